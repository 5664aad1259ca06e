"""Probe: can Exudyn reach the modified restitution η_M in free rocking?

The adapter's planar block (``ObjectRigidBody2D``) with ``ObjectContactSphereTriangle`` contacts,
Δt = 1e-4 s, friction 10, free rocking from rest at α/2, η by the adapter's energy-consistent
peak-ratio method (the adapter's free-rocking test, the one its calibration uses). Searched:

* ``corners`` (2 spheres): Hertz exponent 1 and 1.5 with the impact models 0 (linear damping)
  and 2 (Gonthier hysteretic damping with a restitution coefficient), over stiffness and damping;
* ``distributed``: a row of ``n`` spheres along the base (outer ones under the corners), the
  same models, over per-point stiffness, damping / restitution coefficient and exponent.

Run: ``python tests/measurements/probes/probe_eta_m_exudyn.py [--quick]``; writes
the record ``tests/measurements/results/probe-eta-m-exudyn.json``.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import sys
import time
from pathlib import Path

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.adapters.exudyn import ExudynAdapter, default_stiffness_n_m
from rockbench.reference_solver.restitution import housner_eta, modified_eta
from rockbench.reference_solver.validity import Measurement, judge_measurement

# tests/measurements/ holds the one records writer
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from records import write_record  # noqa: E402

MEASURES = "Can Exudyn reach the modified restitution η_M in free rocking: η per block, per contact and contact setting."


def run_one(ad, block, contact):
    """Free rocking with ``contact`` (the adapter's calibration test): η, its spread, the largest jump."""
    t0 = time.perf_counter()
    try:
        m, tr = ad._measure_free_rocking(block, {**ad.settings, **contact}, ad.default_dt_s)
    except Exception as e:  # noqa: BLE001
        return {"error": f"{type(e).__name__}: {e}"[:200], "wall_s": time.perf_counter() - t0}
    jump = judge_measurement(Measurement(tr.t_s, tr.theta_rad, tr.theta_dot_rad_s, tr.corner_x_m, tr.corner_z_m),
                             block, t_pulse_end_s=0.0).max_jump_m
    return {"eta": m.eta_mean, "eta_std": m.eta_std, "etas": m.etas, "max_jump_m": jump,
            "steps": len(tr.t_s) - 1, "wall_s": time.perf_counter() - t0}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--blocks", default="B3M,B6M")
    args = ap.parse_args()
    ad = ExudynAdapter()
    out = {"engine": "exudyn", "version": ad.version(), "dt_s": ad.default_dt_s, "date": str(_dt.date.today()),
           "method": "free rocking from α/2, η from successive peak amplitudes (energy-consistent), up to 4 impacts",
           "blocks": {}}
    for name in args.blocks.split(","):
        pr = get_preset(name)
        block = pr.block()
        a = block.alpha_rad
        targets = {"housner": housner_eta(a), "modified_average": modified_eta(a, pr.k_average),
                   "modified_exact": modified_eta(a, pr.k_exact)}
        k0 = default_stiffness_n_m(block)
        base = ad._contact(block, 0.1)
        rows = []
        grid = []
        # per-point stiffness as a multiple of the default corner stiffness (k0 for 2 points)
        kf = (0.01, 0.03, 0.1, 0.3, 1.0) if not args.quick else (0.03, 0.3)
        for n in ((2, 9) if not args.quick else (9,)):
            for expo in (1.0, 1.5):
                for f in kf:
                    # Hertz exponent 1.5: the stiffness is per m^1.5; scaled to give the same static
                    # penetration δ0 under the block's weight as the linear one
                    k_lin = f * k0 * 2.0 / n
                    delta0 = block.mass_kg * 9.81 / (n * k_lin)
                    k = k_lin if expo == 1.0 else k_lin * delta0 ** -0.5
                    for e in (0.05, 0.2, 0.5, 0.8):
                        grid.append({"contact_points": n, "stiffness_exponent": expo, "stiffness_n_m": k,
                                     "stiffness_factor": f, "impact_model": 2, "restitution_coefficient": e,
                                     "damping_n_s_m": 0.0})
                    # linear damping (impact model 0): a damping ratio ζ of one point's mass share
                    for zeta in (0.3, 1.0, 3.0):
                        c = 2 * zeta * math.sqrt(k_lin * block.mass_kg / n)
                        grid.append({"contact_points": n, "stiffness_exponent": expo, "stiffness_n_m": k,
                                     "stiffness_factor": f, "impact_model": 0, "restitution_coefficient": 1.0,
                                     "damping_n_s_m": c, "zeta": zeta})
        t0 = time.perf_counter()
        for g in grid:
            contact = {**base, **{k: v for k, v in g.items() if k in base or k in ("contact_points", "stiffness_exponent")}}
            r = run_one(ad, block, contact)
            rows.append({**g, **r})
            print(name, {k: (round(v, 4) if isinstance(v, float) else v) for k, v in rows[-1].items() if k != "etas"},
                  flush=True)
        wall = time.perf_counter() - t0
        ok = [r for r in rows if math.isfinite(r.get("eta", math.nan)) and len(r.get("etas", [])) >= 2]
        best = {}
        for tname, tv in targets.items():
            for n in sorted({r["contact_points"] for r in ok}):
                cand = [r for r in ok if r["contact_points"] == n and r["max_jump_m"] <= 0.005 * block.width_m]
                if cand:
                    rb = min(cand, key=lambda r: abs(r["eta"] - tv))
                    best[f"{tname}/n={n}"] = {**{k: v for k, v in rb.items() if k != "etas"}, "target": tv,
                                              "rel_error": rb["eta"] / tv - 1.0}
        etas = [r["eta"] for r in ok]
        out["blocks"][name] = {"targets": targets, "eta_span": [min(etas), max(etas)] if etas else None,
                               "wall_s": wall, "best": best, "rows": rows}
        print(name, "span", out["blocks"][name]["eta_span"], flush=True)
        for k, v in best.items():
            print("  ", k, round(v["eta"], 4), f"{100 * v['rel_error']:+.2f} %", flush=True)
    p = write_record("probe-eta-m-exudyn", MEASURES, "python tests/measurements/probes/probe_eta_m_exudyn.py " + " ".join(sys.argv[1:]),
                     out, packages=("exudyn",))
    print("wrote", p)


if __name__ == "__main__":
    main()
