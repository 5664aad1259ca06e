"""Which solref MuJoCo's corner calibration picks for the default suite's blocks (the skeleton_alt experiment).

Runs the corner calibration to Housner's η (no cache) for B3M B6M B3L B6L and prints, per block,
the pick (time constant [s], damping ratio, η, per-impact spread, impacts) and, over all the
settings the search measured, how many lie within 1 % of the target and how many of those keep
their per-impact spread within the skeleton's ``CAL_MAX_SPREAD`` (2 % of the target). Run it on
branch ``main`` and on the branch with the patched pick to compare the two rules::

    python tests/measurements/probes/skeleton_alt/alt_mujoco_picks.py [--json OUT.json]
"""

from __future__ import annotations

import argparse
import json
import math

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.adapters.mujoco import MujocoAdapter
from rockbench.engines.loop import CAL_MAX_SPREAD
from rockbench.reference_solver.restitution import housner_eta
from rockbench.engines.calibration.routine import calibrate

BLOCKS = ("B3M", "B6M", "B3L", "B6L")


def pick_of(name: str) -> dict:
    """The calibration of block ``name`` to η_H and the counts over its searched settings."""
    block = get_preset(name).block()
    target = housner_eta(block.alpha_rad)
    ad = MujocoAdapter(settings="calibrated")
    seen: dict = {}
    ad._store = lambda key, res, search: seen.update(search)  # keep the grid, write no cache
    res = calibrate(ad, block, target, use_cache=False)
    rows = [r for r in seen["grid"] if math.isfinite(r[2])]
    within = [r for r in rows if abs(r[2] - target) <= 0.01 * target]
    steady = [r for r in within if r[3] <= CAL_MAX_SPREAD * target]
    s = res.settings
    return {"block": name, "target": target, "timeconst_s": s["timeconst"], "dampratio": s["dampratio"],
            "eta": res.eta_measured, "eta_std": res.eta_std, "spread_rel": res.eta_std / target,
            "reached": res.reached, "rest_sink_m": s.get("rest_sink_m"), "evaluations": res.evaluations,
            "n_within_1pct": len(within), "n_within_steady": len(steady)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the rows here too")
    args = ap.parse_args()
    out = [pick_of(b) for b in BLOCKS]
    for r in out:
        print(f"{r['block']}: solref ({r['timeconst_s']:.4g} s, {r['dampratio']:.4g})  η {r['eta']:.4f} "
              f"(target {r['target']:.4f}, {100 * (r['eta'] / r['target'] - 1):+.2f} %)  spread {r['eta_std']:.4f} "
              f"({100 * r['spread_rel']:.2f} % of target)  sink {1e3 * r['rest_sink_m']:.3g} mm  "
              f"{r['n_within_1pct']} settings within 1 %, {r['n_within_steady']} of them spread ≤ 2 %; "
              f"{r['evaluations']} evaluated")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)


if __name__ == "__main__":
    main()
