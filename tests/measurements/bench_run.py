"""Time the main job, ``rockbench run`` (the default suite, ``--quick`` or a suite file,
on the machine it runs on). Prints figures; passes or fails on nothing.

    python tests/measurements/bench_run.py [--quick | SUITE.toml] [--out DIR] [--keep]
    python tests/measurements/bench_run.py --summarize RUN_DIR --wall-s SECONDS

The first form runs ``rockbench run`` as its own process, as a user would, with an empty
calibration cache (``ROCKBENCH_CACHE`` in a fresh folder: the free-rocking measurements and the
calibrations are part of the time), and records the wall time, the exit code, the load average
before and after, and where the time went: per map (from the run's ``suite.json``) summed per
engine variant, the calibration phase and the report. The second form writes the same summary for
a run timed by other means (e.g. ``/usr/bin/time -v rockbench run``), from its output folder.

The figures go to the record ``tests/measurements/results/run-<suite>-suite.json`` (``records.py show`` prints it).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from datetime import datetime, timezone
from pathlib import Path

from records import write_record

MEASURES = ("Wall time of `rockbench run` on the {suite} suite from an empty calibration cache, and where it went "
            "(start-up and calibrations, maps per engine variant with their simulated cells, report).")


def _loadavg() -> list[float]:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return []


def summarize(out_dir: Path, wall_s: float) -> dict:
    """Where the time of a finished run went, from its ``suite.json``."""
    doc = json.loads((out_dir / "suite.json").read_text())
    per = defaultdict(lambda: {"maps": 0, "wall_s": 0.0, "cells": 0})
    for m in doc["maps"]:
        variant = Path(m["dir"]).parent.name
        per[variant]["maps"] += 1
        per[variant]["wall_s"] += m["wall_s"]
        per[variant]["cells"] += m["n_simulated"]
    maps_wall = float(doc.get("maps_wall_s", 0.0))
    report_wall = float(doc.get("report_wall_s", 0.0))
    return {"suite": doc.get("suite_name"), "wall_s": wall_s, "maps_wall_s": maps_wall,
            "report_wall_s": report_wall,
            "before_maps_s": max(0.0, wall_s - maps_wall - report_wall),
            "per_variant": {k: {**v, "wall_s": round(v["wall_s"], 1)} for k, v in sorted(per.items())},
            "n_maps": len(doc["maps"])}


def markdown(rec: dict) -> str:
    s = rec["summary"]
    head = (f"`rockbench run` ({s['suite']} suite) on {rec['machine']['platform']}, "
            f"{rec['machine']['cpus']} cores, {rec['started_utc']}")
    if "returncode" in rec:
        head += (f"; load average before {rec['loadavg_before']} after {rec['loadavg_after']}; "
                 f"exit code {rec['returncode']}")
    else:
        head += f" ({rec['how']})"
    lines = [head, "",
             f"**{s['wall_s'] / 60:.1f} min** wall ({s['wall_s']:.0f} s): start-up, free-rocking η and "
             f"calibrations {s['before_maps_s']:.0f} s, {s['n_maps']} maps {s['maps_wall_s']:.0f} s, "
             f"report {s['report_wall_s']:.0f} s.",
             "",
             "| maps of | maps | simulated cells | wall [s] |",
             "|---|---|---|---|"]
    for k, v in s["per_variant"].items():
        lines.append(f"| {k} | {v['maps']} | {v['cells']} | {v['wall_s']:.0f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("suite", nargs="?", default=None, help="a suite file (default: the default suite)")
    ap.add_argument("--quick", action="store_true", help="the quick suite")
    ap.add_argument("--out", default=None, help="run folder (default: a temporary one)")
    ap.add_argument("--keep", action="store_true", help="keep the temporary run folder")
    ap.add_argument("--summarize", metavar="RUN_DIR", help="summarise a finished run instead of running one")
    ap.add_argument("--wall-s", type=float, help="with --summarize: the measured wall time [s]")
    args = ap.parse_args(argv)
    rec = {"started_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
           "machine": {"platform": platform.platform(), "python": sys.version.split()[0], "cpus": os.cpu_count()}}
    if args.summarize:
        if args.wall_s is None:
            ap.error("--summarize needs --wall-s (the measured wall time)")
        rec["summary"] = summarize(Path(args.summarize), args.wall_s)
        rec["how"] = "summarised from a run timed elsewhere"
    else:
        tmp = Path(tempfile.mkdtemp(prefix="rb-bench-run-"))
        out = Path(args.out) if args.out else tmp / "out"
        env = dict(os.environ, ROCKBENCH_CACHE=str(tmp / "cache"))
        # the rockbench of the environment this script runs in, else the one on PATH
        here = Path(sys.executable).with_name("rockbench")
        cmd = [str(here) if here.is_file() else (shutil.which("rockbench") or "rockbench"), "run", "--out", str(out)]
        cmd += ["--quick"] if args.quick else ([args.suite] if args.suite else [])
        rec["command"] = " ".join(cmd[1:])
        rec["loadavg_before"] = _loadavg()
        t0 = time.perf_counter()
        r = subprocess.run(cmd, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        rec["loadavg_after"] = _loadavg()
        rec["returncode"] = r.returncode
        if r.returncode != 0:
            print(r.stderr[-3000:], file=sys.stderr)
        rec["summary"] = summarize(out, wall) if (out / "suite.json").is_file() else {"wall_s": wall}
        if not args.keep and not args.out:
            shutil.rmtree(tmp, ignore_errors=True)
    suite = rec["summary"].get("suite") or "unknown"
    command = " ".join(["python tests/measurements/bench_run.py", *(sys.argv[1:] if argv is None else argv)])
    path = write_record(f"run-{suite}-suite", MEASURES.format(suite=suite), command, rec)
    print(markdown(rec) if "per_variant" in rec["summary"] else json.dumps(rec, indent=1))
    print("wrote", path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
