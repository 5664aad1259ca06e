"""What one engine costs in a suite: its calibrations and its maps, in CPU time, sampled on
one block and one pulse and projected to the whole suite. Measures and prints; it passes or fails nothing.

    python tests/measurements/bench_engine_cost.py ENGINE [ENGINE ...] --cells-from RUN_DIR [--suite default]
                                           [--block B3M] [--pulse sine] [--sample 40] [--record NAME]
                                           [--dt-s DT] [--append-path DIR] [--work DIR]

For each engine, from an empty calibration cache (``ROCKBENCH_CACHE`` in a fresh folder):

1. *preparation*: ``rockbench run`` on a copy of the suite reduced to the block, the pulse, this
   engine by name and a 2 × 2 grid (not adaptive), ``--jobs 1 --no-report``, timed with ``wait4``
   (user + system CPU of the whole process tree, which a machine shared with other jobs does not
   distort): each variant's calibration on the block (the time-step rule's search included), its
   free-rocking η and four cells per map;
2. *cells*: for each of the suite's variants, in a process of its own, the calibration now cached,
   a sample of the cells an adaptive map of this scenario simulates: every k-th cell of the first
   engine map of RUN_DIR for the block and pulse (``--sample`` cells, the default suite's grid), run
   through the adapter's ``run_many`` (its batch where it has one); CPU time of the process
   (``time.process_time``, every thread) around that call.

Projected: preparation × blocks + Σ over variants (CPU per cell × the mean cells per engine map of
RUN_DIR) × blocks × pulses. Engines asked for by name run even where a suite of every available engine
would leave them out (Newton and MuJoCo Warp on a CPU). Warp's and Genesis's kernel caches are not
emptied: a new install compiles them once more.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from records import write_record  # tests/measurements/, on the path when the script runs

ROOT = Path(__file__).resolve().parents[2]
MEASURES = ("what each engine costs in a suite, in CPU time: its calibrations on one block from an empty cache "
            "(the time-step rule's search included) and a sample of the cells an adaptive map simulates, "
            "projected to the suite's blocks, pulses and variants")


#: folders appended to the path of every Python started here (``--append-path``)
EXTRA_PATH: list[str] = []


def _python(code: str) -> list[str]:
    """This Python running ``code``, with :data:`EXTRA_PATH` appended to its path (a library found
    only in another environment, e.g. Genesis and torch, after this environment's own)."""
    return [sys.executable, "-c", f"import sys; sys.path.extend({EXTRA_PATH!r}); {code}"]


def _rockbench(*args: str) -> list[str]:
    return _python("from rockbench.benchmark.cli.main import main; sys.argv[0] = 'rockbench'; sys.exit(main())") + list(args)


def _suite_text(suite: str) -> str:
    out = subprocess.run(_rockbench("run", "--show-suite", suite), capture_output=True, text=True, check=True)
    return out.stdout


def _probe_suite(text: str, engine: str, block: str, pulse: str, tiny: bool) -> str:
    """The suite's text with one block, one pulse, one engine by name, the tiny grid if asked."""
    text = re.sub(r"(?m)^blocks = .*$", f'blocks = ["{block}"]', text)
    text = re.sub(r"(?m)^pulses = .*$", f'pulses = ["{pulse}"]', text)
    text = re.sub(r"(?m)^names = .*$", f'names = ["{engine}"]', text)
    text = re.sub(r"(?m)^(exclude|include) = .*$", "", text)
    if tiny:
        text = re.sub(r'(?m)^w_ratio = .*$', 'w_ratio = "1:16:2"', text)
        text = re.sub(r'(?m)^a_ratio = .*$', 'a_ratio = "1:12:2"', text)
        text = re.sub(r"(?m)^adaptive = .*$", "adaptive = false", text)
    return text


def _timed(cmd: list[str], env: dict, log: Path) -> dict:
    """Run ``cmd``; its wall time and the CPU time of its process tree [s]."""
    t0 = time.perf_counter()
    with open(log, "w") as f:
        p = subprocess.Popen(cmd, env=env, stdout=f, stderr=subprocess.STDOUT, cwd=ROOT)
        _, status, ru = os.wait4(p.pid, 0)
    return {"wall_s": round(time.perf_counter() - t0, 1), "cpu_s": round(ru.ru_utime + ru.ru_stime, 1),
            "rc": os.waitstatus_to_exitcode(status), "log": str(log)}


def _map_cells(run_dir: Path, block: str, pulse: str) -> tuple[list, float]:
    """The (row, column) cells one engine map of RUN_DIR simulated for the block and pulse (the first
    engine variant's, by name), and the mean cells simulated per engine map of RUN_DIR."""
    maps = sorted(f for f in run_dir.glob("maps/*/*/cells.csv") if f.parts[-3] != "reference")
    sizes = []
    for f in maps:
        with open(f) as fh:
            sizes.append(sum(1 for _ in fh) - 1)
    first = next(f for f in maps if f.parts[-2].startswith(f"{block}-{pulse}-"))
    with open(first) as fh:
        cells = [(int(r["i"]), int(r["j"])) for r in csv.DictReader(fh)]
    return cells, sum(sizes) / len(sizes)


def _sample_child(engine: str, settings: dict, block: str, pulse: str, w_ratio: str, a_ratio: str,
                  cells: list, dt_s: float | None = None) -> dict:
    """In a child process: the cells' CPU time through the adapter's run_many [s]."""
    from rockbench.engines.registry import get_adapter
    from rockbench.benchmark.blocks.presets import get_preset
    from rockbench.benchmark.maps.grid import MapSpec, parse_range
    from rockbench.benchmark.suites.model import restitution_for

    spec = MapSpec(get_preset(block).block(), pulse, restitution_for("housner", block),
                   parse_range("w", w_ratio, "w_ratio"), parse_range("a", a_ratio, "a_ratio"), engine=engine,
                   engine_settings=dict(settings), dt_s=dt_s)
    adapter = get_adapter(engine, **settings)
    adapter.resolve(spec.block, spec.restitution, dt_s=dt_s)   # the cached calibration, before the clock starts
    t0 = time.process_time()
    results = adapter.run_many(spec.cases(cells))
    return {"cpu_s": time.process_time() - t0, "cells": len(cells),
            "failed": sum(1 for r in results if r.status != "ok")}


def measure(engine: str, suite: str, block: str, pulse: str, work: Path, run_dir: Path, n_sample: int,
            dt_s: float | None = None, preparation: bool = True) -> dict:
    text = _suite_text(suite)
    env = dict(os.environ, ROCKBENCH_CACHE=str(work / f"cache-{engine}"), MPLBACKEND="Agg")
    row: dict = {"engine": engine, "suite": suite, "block": block, "pulse": pulse, "cells_dt_s": dt_s,
                 "loadavg_before": list(os.getloadavg())}
    path = work / f"{engine}-preparation.toml"
    path.write_text(_probe_suite(text, engine, block, pulse, tiny=True))
    cmd = _rockbench("run", str(path), "--jobs", "1", "--no-report", "--out", str(work / f"out-{engine}-preparation"))
    row["preparation"] = (_timed(cmd, env, work / f"{engine}-preparation.log") if preparation
                          else {"cpu_s": 0.0, "wall_s": 0.0, "rc": None})
    cells, per_map = _map_cells(run_dir, block, pulse)
    sample = cells[::max(1, len(cells) // n_sample)][:n_sample]
    grid = {k: re.search(rf'(?m)^{k} = "(.*)"$', text).group(1) for k in ("w_ratio", "a_ratio")}
    row["variants"] = []
    blocks = len(re.search(r"(?m)^blocks = \[(.*)\]$", text).group(1).split(","))
    pulses = len(re.search(r"(?m)^pulses = \[(.*)\]$", text).group(1).split(","))
    projected = row["preparation"]["cpu_s"] * blocks
    for settings in _variants(text):
        code = (f"import json; sys.path.insert(0, {str(Path(__file__).parent)!r}); import bench_engine_cost as b; "
                f"print(json.dumps(b._sample_child({engine!r}, {settings!r}, {block!r}, {pulse!r}, "
                f"{grid['w_ratio']!r}, {grid['a_ratio']!r}, {sample!r}, {dt_s!r})))")
        out = subprocess.run(_python(code), env=env, capture_output=True, text=True, cwd=ROOT)
        if out.returncode != 0:
            row["variants"].append({"settings": settings, "error": out.stderr[-2000:]})
            continue
        v = json.loads(out.stdout.strip().splitlines()[-1]) | {"settings": settings}
        v["cpu_per_cell_s"] = v["cpu_s"] / v["cells"]
        v["projected_maps_cpu_s"] = round(v["cpu_per_cell_s"] * per_map * blocks * pulses, 0)
        projected += v["projected_maps_cpu_s"]
        row["variants"].append(v)
    row["mean_cells_per_map"] = round(per_map, 1)
    row["projected_suite_cpu_s"] = round(projected, 0)
    row["loadavg_after"] = list(os.getloadavg())
    return row


def _variants(text: str) -> list[dict]:
    """The suite's engine variants' settings (``{ settings = "..." }`` entries of ``variants``)."""
    return [{"settings": s} for s in re.findall(r'\{ settings = "([a-z]+)" \}', text)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("engines", nargs="+")
    ap.add_argument("--suite", default="default")
    ap.add_argument("--block", default="B3M")
    ap.add_argument("--pulse", default="sine")
    ap.add_argument("--record", help="write the rows as this benchmark record (tests/measurements/records.py)")
    ap.add_argument("--cells-from", type=Path, required=True,
                    help="a run folder of the suite (rockbench run) whose engine maps give the cells sampled")
    ap.add_argument("--sample", type=int, default=40, help="cells sampled per variant")
    ap.add_argument("--dt-s", type=float, default=None, help="run the sampled cells at this step [s] instead of "
                    "each variant's own (the time-step rule's, or the engine's shipped step)")
    ap.add_argument("--no-preparation", action="store_true",
                    help="skip phase 1 (the cells then calibrate at --dt-s alone, uncounted): per-cell costs only")
    ap.add_argument("--append-path", action="append", default=[],
                    help="a folder appended to the path of the Pythons started (e.g. another environment's "
                    "site-packages holding Genesis and torch)")
    ap.add_argument("--work", type=Path, help="folder for the runs (default: a fresh temporary one)")
    a = ap.parse_args(argv)
    EXTRA_PATH[:] = a.append_path
    work = a.work or Path(tempfile.mkdtemp(prefix="rockbench-engine-cost-"))
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for e in a.engines:
        row = measure(e, a.suite, a.block, a.pulse, work, a.cells_from, a.sample, a.dt_s, not a.no_preparation)
        rows.append(row)
        cells = "; ".join(f"{v['settings']['settings']} " + (f"{1e3 * v['cpu_per_cell_s']:.0f} ms a cell "
                                                               f"({v['failed']} of {v['cells']} failed) → "
                                                               f"{v['projected_maps_cpu_s']:.0f} s"
                                                               if "error" not in v else "error")
                          for v in row["variants"])
        print(f"{e}: preparation {row['preparation']['cpu_s']} s CPU ({row['preparation']['wall_s']} s wall, "
              f"rc {row['preparation']['rc']}); cells: {cells}; projected {a.suite} suite "
              f"{row['projected_suite_cpu_s']:.0f} s CPU", flush=True)
        if a.record:   # rewritten after each engine, so a stopped run keeps what it measured
            write_record(a.record, MEASURES, "python tests/measurements/bench_engine_cost.py " + " ".join(argv or sys.argv[1:]),
                         {"rows": rows}, packages=a.engines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
