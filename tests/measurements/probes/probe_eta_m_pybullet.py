"""Probe: can PyBullet reach the modified restitution η_M in free rocking?

The adapter's planar block (slide x, slide z, hinge y; friction 10, friction anchors, 30 solver
iterations, Δt = 0.5 ms), free rocking from rest at α/2, η by the adapter's energy method
(:func:`rockbench.engines.calibration.free_rocking.measure_restitution`, the one its calibration uses). Searched:

* ``corners`` (Bullet's box–box contact): compliant contact, stiffness ``k`` from 1e3 N/m to the
  stiffest the step resolves (``m/Δt²``) combined with damping ratios ζ = 0.05–2
  (``c = 2ζ√(k·m)``); the calibration so far tried ζ = 1 only;
* ``distributed``: a row of ``n`` small spheres along the base (``contact_points``), Bullet's
  rigid contact and the same compliant grid.

For the settings closest to each target, the static uplift threshold (slow ramp) and the
anti-slip cells are measured with :func:`rockbench.engines.calibration.price.contact_price`.

Run: ``python tests/measurements/probes/probe_eta_m_pybullet.py``; writes
the record ``tests/measurements/results/probe-eta-m-pybullet.json``.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.calibration import price as P
from rockbench.engines.adapters.pybullet import PybulletAdapter
from rockbench.reference_solver.restitution import Restitution, housner_eta, modified_eta
from rockbench.engines.calibration.free_rocking import measure_restitution

# tests/measurements/ holds the one records writer
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from records import write_record  # noqa: E402

MEASURES = "Can PyBullet reach the modified restitution η_M in free rocking: η per block, per contact and contact setting."


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--blocks", default="B3M,B6M")
    args = ap.parse_args()
    ad = PybulletAdapter()
    dt = ad.fixed_dt_s
    out = {"engine": "pybullet", "version": ad.version(), "dt_s": dt, "date": str(_dt.date.today()),
           "method": "free rocking from α/2, η = sqrt(K_next/K) over the first 4 impacts (the adapter's method)",
           "blocks": {}}
    for name in args.blocks.split(","):
        pr = get_preset(name)
        block = pr.block()
        a = block.alpha_rad
        targets = {"housner": housner_eta(a), "modified_average": modified_eta(a, pr.k_average),
                   "modified_exact": modified_eta(a, pr.k_exact)}
        m = block.mass_kg
        kmax = m / dt**2
        ks = [float(k) for k in np.logspace(3, math.log10(kmax), 6)]
        grid = []
        for pts in (None, 9):
            grid.append({"contact_points": pts})
            for k in ks:
                for z in (0.05, 0.2, 0.5, 1.0, 2.0):
                    grid.append({"contact_points": pts, "contact_stiffness_n_m": k,
                                 "contact_damping_n_s_m": 2 * z * math.sqrt(k * m), "zeta": z})
        rows = []
        t0 = time.perf_counter()
        base = ad.settings_with()
        for g in grid:
            s = {**base, **{k: v for k, v in g.items() if k != "zeta"}}
            try:
                mm = measure_restitution(ad, block, dt_s=dt, settings=s)
                rows.append({**g, "eta": mm.eta_mean, "eta_std": mm.eta_std, "etas": mm.etas})
            except Exception as e:  # noqa: BLE001
                rows.append({**g, "error": f"{type(e).__name__}: {e}"[:200]})
            r = rows[-1]
            print(name, {k: (round(v, 4) if isinstance(v, float) else v) for k, v in r.items() if k != "etas"}, flush=True)
        wall = time.perf_counter() - t0
        ok = [r for r in rows if math.isfinite(r.get("eta", math.nan)) and len(r.get("etas", [])) >= 2
              and r["eta_std"] <= 0.02 * r["eta"]]
        best = {}
        for tname, tv in targets.items():
            for pts in (None, 9):
                cand = [r for r in ok if r["contact_points"] == pts]
                if not cand:
                    continue
                rb = min(cand, key=lambda r: abs(r["eta"] - tv))
                entry = {**{k: v for k, v in rb.items() if k != "etas"}, "target": tv, "rel_error": rb["eta"] / tv - 1.0}
                if tname != "housner" and abs(entry["rel_error"]) <= 0.015:
                    fixed = PybulletAdapter(contact="distributed" if pts else "corners",
                                            **{k: v for k, v in rb.items()
                                               if k in ("contact_points", "contact_stiffness_n_m", "contact_damping_n_s_m")})
                    pr_ = P.contact_price(fixed, block, Restitution("constant", value=tv), dt)
                    entry["price"] = {"uplift": pr_["uplift"], "anti_slip": {k: v for k, v in pr_["anti_slip"].items()},
                                      "counts": pr_["counts"]}
                best[f"{tname}/{'corners' if pts is None else f'n={pts}'}"] = entry
        etas = [r["eta"] for r in ok]
        out["blocks"][name] = {"targets": targets, "stiffness_n_m": ks, "eta_span_regular": [min(etas), max(etas)] if etas else None,
                               "wall_s": wall, "best": best, "rows": rows}
        print(name, "regular span", out["blocks"][name]["eta_span_regular"], flush=True)
        for k, v in best.items():
            print("  ", k, round(v["eta"], 4), f"{100 * v['rel_error']:+.2f} %",
                  {kk: v.get(kk) for kk in ("contact_stiffness_n_m", "zeta")},
                  v.get("price", {}).get("uplift", {}).get("ratio"), v.get("price", {}).get("counts"), flush=True)
    p = write_record("probe-eta-m-pybullet", MEASURES, "python tests/measurements/probes/probe_eta_m_pybullet.py " + " ".join(sys.argv[1:]),
                     out, packages=("pybullet",))
    print("wrote", p)


if __name__ == "__main__":
    main()
