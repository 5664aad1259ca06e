"""What a suite's grid can resolve, measured with planted restitutions before the suite has them
(docs/scores.md, "Every tie states its scale").

The reference solver maps B3M and B6M, sine and cosine, with Housner's η and with η_H × (1 − δ) for
δ = 0, 0.5 %, 1 %, 2 % on one grid (full, not adaptive: the reference costs milliseconds a cell); the
planted maps are scored against the η_H maps as planted variants (``planted_eta_factor``) of a score
document, through the verdict's own code (:func:`rockbench.benchmark.scoring.verdict.verdict`). Prints,
per δ, the distance from the reference, the difference from δ = 0 with its error, and whether it is
resolved by the critical value of one comparison and of a class of six variants (the default suite's
calibrated class), and the class's minimal detectable difference at that error.

Run from the repository root: ``python tests/measurements/probes/probe_planted_power.py OUT_DIR
[--w-ratio 1:16:51] [--a-ratio 1:12:51]`` (about a minute of the reference solver on 2 cores for the
default grid; the maps stay in OUT_DIR and are reused).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import subprocess
from pathlib import Path

from rockbench.benchmark.scoring.score_runs import score_entries
from rockbench.benchmark.scoring.statistics import detectable, dunnett_critical
from rockbench.benchmark.store.loading import load_entry

ETA_H = {"B3M": 0.7526, "B6M": 0.9294}
DELTAS = (0.0, 0.005, 0.01, 0.02)


def one_map(out: Path, block: str, pulse: str, delta: float, w: str, a: str) -> Path:
    d = out / f"{block}-{pulse}-{delta}"
    if not (d / "cells.csv").exists():
        eta = "housner" if delta is None else str(round(ETA_H[block] * (1 - delta), 6))
        subprocess.run(["rockbench", "map", "--block", block, "--pulse", pulse, "--restitution", eta, "--w-ratio", w,
                        "--a-ratio", a, "--no-plot", "--out", str(d)], check=True, stdout=subprocess.DEVNULL)
    return d


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--w-ratio", default="1:16:51")
    ap.add_argument("--a-ratio", default="1:12:51")
    args = ap.parse_args(argv)
    refs, cands = [], []
    for block in ETA_H:
        for pulse in ("sine", "cosine"):
            refs.append(load_entry(one_map(args.out, block, pulse, None, args.w_ratio, args.a_ratio)))
            for delta in DELTAS:
                e = load_entry(one_map(args.out, block, pulse, delta, args.w_ratio, args.a_ratio))
                f = round(1 - delta, 6)
                # as the suite's planted variant: the reference solver as an engine, judged against η_H
                cands.append(dataclasses.replace(e, variant=f"reference[planted_eta_factor={f:g}]",
                                                 settings={"planted_eta_factor": f}, restitution="housner"))
    doc = score_entries(cands, refs).to_json()
    p = doc["verdict"]["power"]
    q6 = dunnett_critical([math.sqrt(0.5)] * 5)
    print(f"grid {args.w_ratio} × {args.a_ratio}; 4 problems (B3M, B6M × sine, cosine); critical value: one "
          f"comparison {p['critical']:.3f}, a class of six {q6:.3f}")
    print("δ        distance  difference ± se      resolved (q 1.645)  resolved (q 2.234)")
    for r in p["planted"]:
        se = r["se"] or 0.0
        print(f"{100 * r['delta']:>4.1f} %   {r['distance']:.4f}    {r['difference']:+.4f} ± {se:.4f}      "
              f"{str(r['resolved']):<18}  {se > 0 and r['difference'] > q6 * se}")
    se = next(r["se"] for r in p["planted"] if r["se"])
    print(f"minimal detectable difference at 80 % power: one comparison {detectable(p['critical'], se):.4f}, "
          f"a class of six {detectable(q6, se):.4f} (paired se {se:.4f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
