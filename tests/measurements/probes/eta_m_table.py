"""Which restitution targets each engine reaches, with which contact, at what price.

For every engine with a contact calibration (MuJoCo, PyBullet, Exudyn) and every Table 1 block,
the calibration to η_H, η_M with the size's average k and η_M with the block's exact k (cached
calibrations are reused; a missing one is computed, which takes about a minute per Exudyn block),
with the price of the contact found (:func:`rockbench.engines.calibration.price.contact_price`; measured for the
η_H corner calibrations too, for comparison).

Run: ``python tests/measurements/probes/eta_m_table.py [--engines mujoco,pybullet,exudyn] [--blocks B3M,...]``;
writes the record ``tests/measurements/results/eta-m-table.json`` (or ``--out NAME``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.engines.calibration.price import UPLIFT_RTOL
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.restitution import Restitution, effective_k
from rockbench.engines.calibration.price import calibration_price
from rockbench.engines.calibration.routine import calibrate

# tests/measurements/ holds the one records writer
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from records import write_record  # noqa: E402

MEASURES = ("Which restitution target (η_H, η_M with average or exact k) each engine reaches for every Table 1 block, "
            "with which contact, at what price (uplift threshold, slip/jump cells, period change, steps/s).")


def contact_words(st: dict) -> str:
    st = {{"contact_stiffness": "contact_stiffness_n_m", "contact_damping": "contact_damping_n_s_m"}.get(k, k): v
          for k, v in st.items()}
    n = st.get("contact_points")
    if n and int(n) > 2:
        if "solimp_d" in st:
            return f"{n} points, solref ({st['timeconst']:.3g} s, {st['dampratio']:.3g}), solimp d {st['solimp_d']:.2f}"
        if "restitution_coefficient" in st:
            return f"{n} spheres, impact model 2, e = {st['restitution_coefficient']:.3g}"
        return f"{n} spheres, k = {st['contact_stiffness_n_m']:.3g} N/m, c = {st['contact_damping_n_s_m']:.3g} N s/m"
    if "timeconst" in st:
        return f"corners, solref ({st['timeconst']:.3g} s, {st['dampratio']:.3g})"
    if "restitution_coefficient" in st:
        return f"corners, impact model {st.get('impact_model')}, e = {st['restitution_coefficient']:.3g}"
    if st.get("contact_stiffness_n_m"):
        return f"corners, k = {st['contact_stiffness_n_m']:.3g} N/m"
    return "corners, Bullet's rigid contact"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engines", default="mujoco,pybullet,exudyn")
    ap.add_argument("--blocks", default="B3M,B6M,B3L,B6L")
    ap.add_argument("--targets", default="housner,average,exact", help="of housner, average, exact")
    ap.add_argument("--out", default=None, help="record name (default eta-m-table, in tests/measurements/results)")
    args = ap.parse_args()
    wanted = set(args.targets.split(","))
    rows = []
    for eng in args.engines.split(","):
        for bname in args.blocks.split(","):
            pr = PRESETS[bname]
            b = pr.block()
            for tag, label, rest in (("housner", "η_H", Restitution("housner")),
                                     ("average", "η_M avg k", Restitution("modified", k=pr.k_average)),
                                     ("exact", "η_M exact k", Restitution("modified", k=pr.k_exact))):
                if tag not in wanted:
                    continue
                ad = get_adapter(eng)
                t0 = time.perf_counter()
                c = calibrate(ad, b, rest.eta(b.alpha_rad))
                if c.price is None:
                    c.price = calibration_price(ad, b, c)
                p = c.price
                rows.append({"engine": eng, "block": bname, "target": label, "eta_target": c.eta_target,
                             "eta_measured": c.eta_measured, "eta_std": c.eta_std, "rel_error": c.rel_error,
                             "k_effective": effective_k(b.alpha_rad, c.eta_measured),
                             "reached": bool(c.reached), "counts": bool(p and p["counts"]),
                             "contact": contact_words(c.settings), "settings": c.settings, "note": c.note,
                             "price": p, "wall_s": time.perf_counter() - t0})
                r = rows[-1]
                print(eng, bname, label, f"{c.eta_measured:.4f} ({100 * c.rel_error:+.2f} %)", c.reached,
                      r["contact"], f"uplift {p['uplift'].get('ratio', math.nan):.4f}", flush=True)
    lines = ["| engine | block | target | η target | η measured (± spread) | error | k of the measured η | reached | contact | "
             "uplift / g·tanα | slip / jump (cells) | quarter period vs rigid | steps/s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        p = r["price"] or {}
        up, sl = p.get("uplift") or {}, p.get("anti_slip") or {}
        ok = "yes" if r["reached"] and r["counts"] else "**no**"
        pc = p.get("period_change")
        lines.append(f"| {r['engine']} | {r['block']} | {r['target']} | {r['eta_target']:.4f} | "
                     f"{r['eta_measured']:.4f} ± {r['eta_std']:.4f} | {100 * r['rel_error']:+.2f} % | {r['k_effective']:.3f} | {ok} | "
                     f"{r['contact']} | "
                     f"{up.get('ratio', math.nan):.4f}{'' if up.get('within') else f' (outside {100 * UPLIFT_RTOL:g} %)'} | "
                     f"{sl.get('n_slip', '–')} / {sl.get('n_jump', '–')} ({sl.get('cells', '–')}) | "
                     f"{'–' if pc is None else f'{100 * pc:+.2f} %'} | "
                     f"{format(p['steps_per_s'], '.3g') if p.get('steps_per_s') else '–'} |")
    out = write_record(args.out or "eta-m-table", MEASURES, "python tests/measurements/probes/eta_m_table.py " + " ".join(sys.argv[1:]),
                       {"rows": rows, "table_md": "\n".join(lines) + "\n"},
                       packages=("mujoco", "pybullet", "exudyn"))
    print("\n".join(lines))
    print("wrote", out)


if __name__ == "__main__":
    main()
