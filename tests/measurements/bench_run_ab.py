"""Two versions of rockbench on one suite, in turn on the same machine: wall and CPU time
of ``rockbench run`` from an empty calibration cache, and the maps of both compared cell for cell.
Measures and prints; it passes or fails nothing.

    python tests/measurements/bench_run_ab.py OLD_CHECKOUT NEW_CHECKOUT [SUITE.toml | --quick] [--rounds N] [--cold]
                                      [--json FILE]

Each checkout needs its own ``.venv`` with rockbench installed (``pip install -e '.[all]'``).
Rounds alternate old and new so that a changing load favours neither; each run gets a fresh
``ROCKBENCH_CACHE``, runs ``rockbench run SUITE --out DIR --no-report`` (``--quick`` runs the quick
suite with its report), and is timed with ``wait4`` (wall, and user + system CPU of the whole
process tree). Afterwards every ``cells.csv`` of the last rounds is compared (all columns but
``wall_s``), and so is ``score.json`` (paths and times aside). On a machine other agents share,
compare the CPU times too: equal work, different wall, is what better scheduling looks like.
``--cold`` also gives each run an empty numba cache (``NUMBA_CACHE_DIR``), as on a fresh install:
the compiled kernels' first compile is then part of the time.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def loadavg() -> float:
    return round(os.getloadavg()[0], 2)


def run_once(checkout: Path, suite: str | None, quick: bool, out: Path, cold: bool = False) -> dict:
    exe = checkout / ".venv" / "bin" / "rockbench"
    cmd = [str(exe), "run", "--out", str(out)] + (["--quick"] if quick else [suite, "--no-report"])
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, ROCKBENCH_CACHE=cache, MPLBACKEND="Agg")
        if cold:
            env["NUMBA_CACHE_DIR"] = str(Path(cache) / "numba")
        before = loadavg()
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, cwd=checkout, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        _, status, ru = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        err = p.stderr.read().decode(errors="replace")
        p.stderr.close()
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        print(err[-2000:], file=sys.stderr)
    return {"wall_s": wall, "cpu_s": ru.ru_utime + ru.ru_stime, "exit": code, "load_before": before,
            "load_after": loadavg()}


def cells(d: Path) -> dict:
    with open(d / "cells.csv", newline="") as f:
        return {(r["i"], r["j"]): {k: v for k, v in r.items() if k != "wall_s"} for r in csv.DictReader(f)}


def compare(a: Path, b: Path) -> dict:
    maps = differ = 0
    notes = []
    for ca in sorted(a.glob("maps/*/*/cells.csv")):
        rel = ca.parent.relative_to(a)
        if not (b / rel / "cells.csv").is_file():
            notes.append(f"{rel}: only in the first")
            continue
        maps += 1
        if cells(ca.parent) != cells(b / rel):
            differ += 1
            notes.append(f"{rel}: cells differ")

    def score(d):
        p = d / "score.json"
        if not p.is_file():
            return None
        # the run folders' own paths aside ("run": ".../maps", "dir": ".../maps/...")
        doc = json.loads(re.sub(r'"/[^"]*?/maps(?=[/"])', '"maps', p.read_text()))
        doc.pop("created_utc", None)
        return doc

    return {"maps": maps, "maps_differing": differ, "notes": notes, "scores_equal": score(a) == score(b)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("suite", nargs="?", default=None, help="a suite file (default: --quick)")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--cold", action="store_true", help="an empty numba cache for every run (a fresh install)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    quick = args.quick or args.suite is None
    suite = None if quick else str(Path(args.suite).resolve())
    res = {"started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "suite": "quick" if quick else suite, "cold": args.cold,
           "runs": []}
    tmp = Path(tempfile.mkdtemp(prefix="rb-ab-"))
    try:
        for rnd in range(1, args.rounds + 1):
            for who, checkout in (("old", args.old), ("new", args.new)):
                out = tmp / who
                shutil.rmtree(out, ignore_errors=True)
                r = {"who": who, "round": rnd, **run_once(checkout.resolve(), suite, quick, out, args.cold)}
                res["runs"].append(r)
                print(f"{who} round {rnd}: {r['wall_s']:.1f} s wall, {r['cpu_s']:.1f} s CPU, exit {r['exit']} "
                      f"(load {r['load_before']} → {r['load_after']})", flush=True)
        res["comparison"] = c = compare(tmp / "new", tmp / "old")
        print(f"{c['maps']} maps compared, {c['maps_differing']} differ; scores equal: {c['scores_equal']}")
        for n in c["notes"]:
            print("  " + n)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
