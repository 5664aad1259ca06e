"""The steps a map's runs simulate past their stops, for fixed segments, for segments that end at
each run's marks, and for what the engine declares today. Measures and prints; it passes or fails
nothing.

    python tests/measurements/bench_past_stop.py RUN_DIR [RUN_DIR ...] [--near 0.05] [--record NAME]
    python tests/measurements/bench_past_stop.py --table NAME

RUN_DIR: a `rockbench map` run directory (cells.csv and bisection.csv: every run of the map and of its
located boundary), e.g. a `rockbench run` suite's ``maps/ENGINE-settings=calibrated/B3M-sine-housner``.
A run's stop is its simulated time (``simulated_s``; the loop drops the samples after it); its pulse
ends at one period 2π/ω. The segments of the engine's settings (run.json: ``segment_s``, 0.05 s
without it, at the run's step) are replayed with the loop's own ``_segment_end`` to each run's stop:
fixed (``near_segment_s`` None), ending at the marks with ``--near``, and as the engine's adapter
declares today (its ``near_segment_s``, and its default ``segment_s`` where it has one; an engine whose
solver stops itself inside a segment, Exudyn, declares ``stop_check_steps``, and its run then ends at the
first of those steps at or after the stop, the rule's stops being lasting: an overturn under way, a
trapped block). The fraction is Σ (steps from a stop to the end of its
segment) / Σ (steps to the stops), a batch's worlds counted one at a time; each engine's runs are also
pooled over the directories given. ``--record NAME`` writes the rows as a benchmark record
(tests/measurements/records.py); ``--table NAME`` prints a record's rows as a markdown table.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))   # tests/measurements/: the records module beside this script
from records import load, write_record  # noqa: E402

from rockbench.engines.loop import DEFAULT_SEGMENT_S, _segment_end  # noqa: E402
from rockbench.engines.motion import run_steps  # noqa: E402
from rockbench.engines.registry import adapter_class  # noqa: E402

MEASURES = ("Steps simulated past each run's stop over every run of a located map (its cells and its "
            "boundary's bisection samples), replayed from the map's recorded stops with the loop's own "
            "segment rule: fixed segments, segments ending at each run's marks (near_segment_s), and what "
            "the engine's adapter declares; past_pct = 100 · Σ steps past the stops / Σ steps to them.")


def runs(run_dir: str) -> tuple[dict, list]:
    """The map's engine, settings, block, pulse, step, segment, tail and shortest tail, and ``(stop,
    pulse length)`` [s] of each of its runs."""
    rec = json.load(open(f"{run_dir}/run.json"))
    rs = rec["engine"]["resolved_settings"]
    dt = (rs.get("calibration") or {}).get("step_rule", {}).get("dt_s") or rec["engine"]["dt_s"]
    spec = rec["spec"]
    out = []
    for name in ("cells.csv", "bisection.csv"):
        with open(f"{run_dir}/{name}") as f:
            out += [(float(r["simulated_s"]), 2 * math.pi / float(r["omega_rad_s"])) for r in csv.DictReader(f)
                    if r["status"] == "ok" and r["simulated_s"]]
    info = {"engine": spec["engine"], "settings": (spec.get("engine_settings") or {}).get("settings"),
            "block": spec["block"]["name"], "pulse": spec["pulse"], "dt_s": float(dt),
            "segment_s": float(rs.get("segment_s") or DEFAULT_SEGMENT_S), "tail_s": float(rs["tail_s"]),
            "min_tail_s": float(rs["min_tail_s"])}
    return info, out


def past(dt: float, seg_s: float, tail_s: float, min_tail_s: float, cells: list, near_s: float | None,
         checks=None):
    """``(steps past the stops, steps to them, segments)`` of the runs ``cells`` with these segments;
    ``checks``: the engine's ``stop_check_steps`` (its solver stops itself inside a segment at the first
    of them at or after the stop), or None."""
    seg = max(1, round(seg_s / dt))
    near = None if near_s is None else min(seg, max(1, round(near_s / dt)))
    over = total = segments = 0
    for t_stop, t_pulse in cells:
        steps = run_steps(dt, t_pulse, tail_s, min_tail_s)
        k, n, before = min(round(t_stop / dt), steps[0]), 0, 0
        while n < k:
            before, n = n, _segment_end(n, seg, near, [steps])
            segments += 1
        inside = [c for c in (checks(seg, dt, *steps) if checks else ()) if max(before, k - 1) < c < n]
        n = min(inside, default=n)
        over, total = over + n - k, total + k
    return over, total, segments


def measure(run_dir: str, near_s: float) -> dict:
    """One map's row: its runs and the steps past their stops with each segment rule."""
    info, cells = runs(run_dir)
    cls = adapter_class(info["engine"])
    declared, checks = cls.near_segment_s, getattr(cls, "stop_check_steps", None)
    seg_now = float(cls.SETTINGS.get("segment_s", info["segment_s"]))
    row = {"map": run_dir.rstrip("/").split("/maps/")[-1], **info, "runs": len(cells),
           "mean_simulated_s": sum(c[0] for c in cells) / len(cells), "near_segment_s": declared,
           "segment_s_now": seg_now, "checks_inside": checks is not None}
    for key, near, seg, inside in (("fixed", None, info["segment_s"], None), ("marks", near_s, info["segment_s"], None),
                                   ("now", declared, seg_now, checks)):
        over, total, segments = past(info["dt_s"], seg, info["tail_s"], info["min_tail_s"], cells, near, inside)
        row[key] = {"near_segment_s": near, "steps_past": over, "steps_to_stops": total,
                    "past_pct": 100.0 * over / total, "segments_per_run": segments / len(cells)}
    return row


def pooled(rows: list[dict]) -> dict:
    """Per engine: the steps past the stops today over all its maps given, as a percentage."""
    out: dict = {}
    for r in rows:
        o = out.setdefault(r["engine"], {"maps": 0, "runs": 0, "steps_past": 0, "steps_to_stops": 0})
        o["maps"], o["runs"] = o["maps"] + 1, o["runs"] + r["runs"]
        o["steps_past"] += r["now"]["steps_past"]
        o["steps_to_stops"] += r["now"]["steps_to_stops"]
    for o in out.values():
        o["past_pct"] = 100.0 * o["steps_past"] / o["steps_to_stops"]
    return out


def markdown_table(figures: dict) -> str:
    """The record's rows as a Markdown table, one row per map (docs/speed.md quotes the pooled figures)."""
    near = figures["near_s"]
    lines = ["| engine | block | step | runs | mean simulated | fixed segments: past (segments a run) "
             f"| at the marks, {near:g} s: past (segments a run) | today | past today |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in figures["rows"]:
        today = "fixed" if r["near_segment_s"] is None else f"at the marks ({r['near_segment_s']:g} s)"
        today += ", stopped inside at checks" if r.get("checks_inside") else ""
        lines.append(f"| {r['engine']} | {r['block']} | {1e3 * r['dt_s']:g} ms | {r['runs']} | "
                     f"{r['mean_simulated_s']:.3f} s | {r['fixed']['past_pct']:.1f} % ({r['fixed']['segments_per_run']:.1f}) | "
                     f"{r['marks']['past_pct']:.1f} % ({r['marks']['segments_per_run']:.1f}) | {today} | "
                     f"{r['now']['past_pct']:.1f} % |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dirs", nargs="*")
    ap.add_argument("--near", type=float, default=0.05, help="near_segment_s [s] of the 'marks' column (default 0.05)")
    ap.add_argument("--record", help="write the rows as this benchmark record (tests/measurements/records.py)")
    ap.add_argument("--notes", help="the record's notes: where the maps come from")
    ap.add_argument("--table", metavar="NAME", help="print the record NAME's rows as a markdown table and stop")
    args = ap.parse_args(argv)
    if args.table:
        print(markdown_table(load(args.table)["figures"]), end="")
        return 0
    if not args.run_dirs:
        ap.error("give one or more map run directories, or --table NAME")
    rows = [measure(d, args.near) for d in args.run_dirs]
    for r in rows:
        f, m, n = r["fixed"], r["marks"], r["now"]
        print(f"{r['map']}: step {r['dt_s']:g} s, segment {r['segment_s']:g} s, {r['runs']} runs, mean "
              f"{r['mean_simulated_s']:.3f} s simulated | fixed: {f['past_pct']:.1f} % past ({f['segments_per_run']:.1f} "
              f"segments a run) | marks, {args.near:g} s: {m['past_pct']:.1f} % ({m['segments_per_run']:.1f}) | "
              f"today ({r['near_segment_s']}): {n['past_pct']:.1f} %")
    pool = pooled(rows)
    for e, o in pool.items():
        print(f"{e}, pooled over {o['maps']} maps ({o['runs']} runs): {o['past_pct']:.1f} % past today")
    if args.record:
        write_record(args.record, MEASURES, "python tests/measurements/bench_past_stop.py " + " ".join(argv or sys.argv[1:]),
                     {"near_s": args.near, "rows": rows, "pooled": pool}, notes=args.notes)
    return 0


if __name__ == "__main__":
    sys.exit(main())
