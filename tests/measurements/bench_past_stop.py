"""The steps a map's runs simulate past their stops, for fixed segments and for segments that end at
each run's marks. Measures and prints; it passes or fails nothing.

    python tests/measurements/bench_past_stop.py RUN_DIR [RUN_DIR ...] [--near 0.05]

RUN_DIR: a `rockbench map` run directory (cells.csv and bisection.csv: every run of the map and of its
located boundary). A run's stop is its simulated time (``simulated_s``; the loop drops the samples
after it); its pulse ends at one period 2π/ω. The segments of the engine's settings (run.json:
``segment_s``, 0.05 s without it, at the run's step) are replayed with the loop's own
``_segment_end``, fixed (``near_segment_s`` None) and ending at the marks (``--near``), to each run's
stop; the fraction is Σ (steps from a stop to the end of its segment) / Σ (steps to the stops), a
batch's worlds counted one at a time.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys

from rockbench.engines.loop import DEFAULT_SEGMENT_S, _segment_end
from rockbench.engines.motion import run_steps


def runs(run_dir: str) -> tuple[float, float, float, float, list]:
    """The map's step, segment, tail and shortest tail [s], and ``(stop, pulse length)`` [s] of each run."""
    rec = json.load(open(f"{run_dir}/run.json"))
    rs = rec["engine"]["resolved_settings"]
    dt = (rs.get("calibration") or {}).get("step_rule", {}).get("dt_s") or rec["engine"]["dt_s"]
    out = []
    for name in ("cells.csv", "bisection.csv"):
        with open(f"{run_dir}/{name}") as f:
            out += [(float(r["simulated_s"]), 2 * math.pi / float(r["omega_rad_s"])) for r in csv.DictReader(f)
                    if r["status"] == "ok" and r["simulated_s"]]
    return float(dt), float(rs.get("segment_s") or DEFAULT_SEGMENT_S), float(rs["tail_s"]), float(rs["min_tail_s"]), out


def past(dt: float, seg_s: float, tail_s: float, min_tail_s: float, cells: list, near_s: float | None):
    """``(steps past the stops, steps to them, segments)`` of the runs ``cells`` with these segments."""
    seg = max(1, round(seg_s / dt))
    near = None if near_s is None else min(seg, max(1, round(near_s / dt)))
    over = total = segments = 0
    for t_stop, t_pulse in cells:
        steps = run_steps(dt, t_pulse, tail_s, min_tail_s)
        k, n = min(round(t_stop / dt), steps[0]), 0
        while n < k:
            n = _segment_end(n, seg, near, [steps])
            segments += 1
        over, total = over + n - k, total + k
    return over, total, segments


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dirs", nargs="+")
    ap.add_argument("--near", type=float, default=0.05, help="near_segment_s [s] (default 0.05)")
    args = ap.parse_args(argv)
    for d in args.run_dirs:
        dt, seg_s, tail_s, min_tail_s, cells = runs(d)
        shown = []
        for near in (None, args.near):
            over, total, segments = past(dt, seg_s, tail_s, min_tail_s, cells, near)
            shown.append(f"{100 * over / total:.1f} % past ({segments / len(cells):.1f} segments a run)")
        print(f"{d}: step {dt:g} s, segment {seg_s:g} s, {len(cells)} runs, mean {sum(c[0] for c in cells) / len(cells):.3f} s"
              f" simulated | fixed: {shown[0]} | marks, {args.near:g} s: {shown[1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
