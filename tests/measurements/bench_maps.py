"""Speed of the maps harness. Measures and prints; it passes or fails nothing.

1. A 200×200 reference map through ``rockbench map`` (the whole process, started from the shell)
   against the batch solver alone (``solve_batch`` on the same 40 000 cells, warm, in-process).
2. The adaptive fraction of simulations (200×200) for each Table 1 block, pulse and restitution,
   checked cell for cell against the full grid.
3. A 60×60 map of a deliberately slow adapter (the reference plus a per-cell sleep) with 1 and 2
   local worker processes and on a 2-worker Dask LocalCluster.

Usage: ``python tests/measurements/bench_maps.py [--quick] [--json OUT.json]`` (``--quick``: smaller maps).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from rockbench.benchmark.maps.executors import make_executor  # noqa: E402
from rockbench.benchmark.maps.grid import MapSpec, make_axis  # noqa: E402
from rockbench.benchmark.sweep import run_map  # noqa: E402
from rockbench.benchmark.blocks.presets import PRESETS, get_preset  # noqa: E402
from rockbench.engines import registry  # noqa: E402
from rockbench.engines.adapters.reference import ReferenceAdapter  # noqa: E402
from rockbench.reference_solver.restitution import Restitution  # noqa: E402
from rockbench.reference_solver.solver import solve_batch  # noqa: E402

W, A = (0.5, 10.0), (0.5, 10.0)


class SleepyReference(ReferenceAdapter):
    """The reference solver with a fixed sleep per cell: a stand-in for a slow engine."""

    name = "sleepy-reference"
    SETTINGS = {**ReferenceAdapter.SETTINGS, "sleep_s": 0.01}

    def run_many(self, cases):
        cases = list(cases)
        # the sleep stands for engine time (a few thousand engine steps per cell); the physics comes
        # from one batch call, so what is measured is how the harness spreads cells over workers
        time.sleep(self.settings["sleep_s"] * len(cases))
        return super().run_many(cases)


def spec(block, pulse, rest, n, engine="reference", **settings):
    return MapSpec(get_preset(block).block(), pulse, rest, make_axis("--w-ratio", "w_ratio", *W, n),
                   make_axis("--a-ratio", "a_ratio", *A, n), engine=engine, engine_settings=settings)


def rockbench_exe() -> str:
    exe = Path(sys.executable).parent / "rockbench"
    return str(exe) if exe.exists() else "rockbench"


def bench_full_map(n: int, tmp: Path, repeat: int = 3) -> dict:
    """``repeat`` rounds, each timing in turn: the batch solver warm in-process, the batch solver as
    a process of its own, ``rockbench map`` as a process (default executor) and with ``--jobs 2``.
    Interleaving the four keeps a changing machine load from favouring one of them; ratios are
    taken within a round, and the medians reported."""
    s = spec("B6M", "sine", Restitution(), n)
    om, am = np.meshgrid(s.omegas(), s.amplitudes())
    args = (s.block.alpha_rad, s.block.p_rad_s, s.eta, "sine", om, am)
    solve_batch(*(np.ravel(a)[:4] if isinstance(a, np.ndarray) else a for a in args), dt_s=1e-3)   # load the kernel
    code = ("import time, numpy as np; "
            "from rockbench.reference_solver.solver import solve_batch; "
            "from rockbench.benchmark.blocks.presets import get_preset; b = get_preset('B6M').block(); "
            f"w = np.linspace({W[0]}, {W[1]}, {n}) * b.p_rad_s; a = np.linspace({A[0]}, {A[1]}, {n}) * 9.81 * np.tan(b.alpha_rad); "
            "W, A = np.meshgrid(w, a); solve_batch(b.alpha_rad, b.p_rad_s, 1 - 1.5 * np.sin(b.alpha_rad) ** 2, 'sine', W, A, dt_s=1e-3)")
    rounds = []
    for rep in range(repeat):
        r = {"load": os.getloadavg()[0]}
        t0 = time.perf_counter()
        solve_batch(*args, dt_s=1e-3)
        r["batch_solver_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True)
        r["batch_solver_process_s"] = time.perf_counter() - t0
        for label, extra in [("map_default_s", []), ("map_jobs2_s", ["--jobs", "2"])]:
            d = tmp / f"{label}-{rep}"
            cmd = [rockbench_exe(), "map", "--block", "B6M", "--w-ratio", f"{W[0]}:{W[1]}:{n}", "--a-ratio",
                   f"{A[0]}:{A[1]}:{n}", "--out", str(d), "--json", *extra]
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            r[label] = time.perf_counter() - t0
            shutil.rmtree(d)
            r[label[:-2] + "_ratio"] = r[label] / r["batch_solver_s"]
            r[label[:-2] + "_ratio_to_process"] = r[label] / r["batch_solver_process_s"]
        rounds.append(r)
        print("  round " + json.dumps({k: round(v, 3) for k, v in r.items()}), flush=True)
    out = {"cells": n * n, "rounds": rounds}
    for k in rounds[0]:
        out[k] = float(np.median([r[k] for r in rounds]))
    return out


def bench_adaptive(n: int, tmp: Path) -> list:
    rows = []
    for block, pre in PRESETS.items():
        for pulse in ("sine", "cosine"):
            for rest in (Restitution(), Restitution("modified", k=pre.k_average)):
                s = spec(block, pulse, rest, n)
                om, am = np.meshgrid(s.omegas(), s.amplitudes())
                full = solve_batch(s.block.alpha_rad, s.block.p_rad_s, s.eta, pulse, om, am, dt_s=1e-3).outcome
                d = tmp / f"ad-{block}-{pulse}-{rest.kind}"
                r = run_map(s, d, serial=True, adaptive=True)
                rows.append({"block": block, "pulse": pulse, "restitution": rest.label,
                             "fraction": r.fraction_simulated, "equal_to_full": bool(np.array_equal(r.outcome, full))})
                print(f"  adaptive {block} {pulse:6} {rest.label:18} {100 * r.fraction_simulated:5.1f} % "
                      f"{'equal' if rows[-1]['equal_to_full'] else 'DIFFERENT'}", flush=True)
                shutil.rmtree(d)
    return rows


def bench_scaling(n: int, sleep_s: float, tmp: Path) -> dict:
    """Wall time of an n×n map whose cells each cost ``sleep_s``: 1 and 2 local worker processes
    (each run starts its own workers: cold, as a user sees it) and a 2-worker Dask LocalCluster
    (started once; its start and the first, warming map are timed apart from the measured map)."""
    import logging

    from dask.distributed import LocalCluster

    registry.register("sleepy-reference", "bench_maps:SleepyReference")
    s = spec("B3M", "sine", Restitution(), n, engine="sleepy-reference", sleep_s=sleep_s)
    out = {"cells": n * n, "sleep_s": sleep_s, "sleep_total_s": n * n * sleep_s}
    ref = None

    def timed(label, **kw):
        nonlocal ref
        t0 = time.perf_counter()
        r = run_map(s, tmp / label, **kw)
        out[label + "_s"] = time.perf_counter() - t0
        ref = r.outcome if ref is None else ref
        out[label + "_same_map"] = bool(np.array_equal(r.outcome, ref))
        print(f"  {label}: {out[label + '_s']:.1f} s", flush=True)

    timed("processes_1", jobs=1)
    timed("processes_2", jobs=2)
    # the same with workers already started (run_map(executor=...)): the harness's own scaling
    # without the one-off start of the engine in each worker
    warm = spec("B3M", "sine", Restitution(), 4, engine="sleepy-reference", sleep_s=sleep_s)
    for jobs in (1, 2):
        ex = make_executor("sleepy-reference", {"sleep_s": sleep_s}, jobs=jobs)
        try:
            t0 = time.perf_counter()
            run_map(warm, tmp / f"warm-{jobs}", executor=ex)
            out[f"processes_{jobs}_worker_start_s"] = time.perf_counter() - t0
            timed(f"processes_{jobs}_warm", executor=ex)
        finally:
            ex.close()
    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=":0", silence_logs=logging.ERROR)
    out["dask_cluster_start_s"] = time.perf_counter() - t0
    try:
        warm = spec("B3M", "sine", Restitution(), 4, engine="sleepy-reference", sleep_s=sleep_s)
        t0 = time.perf_counter()
        run_map(warm, tmp / "dask-warm", scheduler=cluster.scheduler_address)
        out["dask_worker_warmup_s"] = time.perf_counter() - t0
        timed("dask_local_2", scheduler=cluster.scheduler_address)
    finally:
        cluster.close()
    out["speedup_processes_2"] = out["processes_1_s"] / out["processes_2_s"]
    out["speedup_processes_2_warm"] = out["processes_1_warm_s"] / out["processes_2_warm_s"]
    out["speedup_dask_2_vs_processes_1_warm"] = out["processes_1_warm_s"] / out["dask_local_2_s"]
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller maps (a smoke run)")
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    ap.add_argument("--parts", default="1,2,3", help="which measurements to run (default 1,2,3)")
    args = ap.parse_args()
    parts = {int(x) for x in args.parts.split(",")}
    n_full, n_ad, n_sc = (60, 60, 20) if args.quick else (200, 200, 60)
    load = os.getloadavg()
    print(f"{time.strftime('%Y-%m-%d %H:%M:%S')} cores {os.cpu_count()} load {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    res = {"started": time.strftime("%Y-%m-%dT%H:%M:%S"), "load_before": load}
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        if 1 in parts:
            print(f"1. {n_full}×{n_full} reference map (B6M, sine, Housner):", flush=True)
            res["full_map"] = bench_full_map(n_full, tmp)
            print("  " + json.dumps(res["full_map"]), flush=True)
        if 2 in parts:
            print(f"2. adaptive fraction at {n_ad}×{n_ad}:", flush=True)
            res["adaptive"] = bench_adaptive(n_ad, tmp)
        if 3 in parts:
            print(f"3. {n_sc}×{n_sc} map of a slow adapter (reference + 10 ms per cell):", flush=True)
            res["scaling"] = bench_scaling(n_sc, 0.01, tmp)
            print("  " + json.dumps(res["scaling"]), flush=True)
    res["load_after"] = os.getloadavg()
    print(f"load after {res['load_after'][0]:.2f} {res['load_after'][1]:.2f} {res['load_after'][2]:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
