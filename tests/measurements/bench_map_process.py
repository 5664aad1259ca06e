"""A reference map as a whole process: ``rockbench map`` against the batch kernel run
alone in its own process, start-up of the command line, and the threads the map uses.
Measures and prints; it passes or fails nothing.

    python tests/measurements/bench_map_process.py [--sizes 200,1000] [--repeat 3] [--threads 1,2]
                                           [--startup 5] [--json FILE]

1. For each size n: the n×n map of B6M, one sine wave, Housner's η, ω/p and a₀/(g·tanα) from 0.5
   to 10 (the map of ``bench_maps.py``), timed as two processes started from here, in turn:
   the kernel alone (``python -c`` importing :func:`solve_batch`, building the grid and solving it)
   and ``rockbench map ... --out DIR --json`` (drawing ``map.png``, as a user runs it). Each gets its
   wall time, its CPU time (user + system, from ``wait4``), its peak memory (max RSS) and, for the
   map, the size of ``cells.csv``. Rounds alternate the two so a changing load favours neither;
   the best of ``--repeat`` is reported, with the load average.
2. The same two processes with ``NUMBA_NUM_THREADS`` = 1 and 2 (``--threads``) at the first size:
   on N cores the solve should take close to 1/N of the time.
3. ``rockbench --help`` and ``rockbench blocks``: best wall time of ``--startup`` runs.

On a shared machine the wall times carry the neighbours' load: compare the CPU times too.
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

W = A = (0.5, 10.0)

KERNEL = ("import numpy as np; "
          "from rockbench.reference_solver.solver import solve_batch; "
          "from rockbench.benchmark.blocks.presets import get_preset; b = get_preset('B6M').block(); "
          "w = np.linspace({w0}, {w1}, {n}) * b.p_rad_s; "
          "a = np.linspace({a0}, {a1}, {n}) * 9.81 * np.tan(b.alpha_rad); "
          "W, A = np.meshgrid(w, a); "
          "solve_batch(b.alpha_rad, b.p_rad_s, 1 - 1.5 * np.sin(b.alpha_rad) ** 2, 'sine', W, A, dt_s=1e-3)")


def loadavg() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def rockbench_exe() -> str:
    exe = Path(sys.executable).parent / "rockbench"
    return str(exe) if exe.exists() else "rockbench"


def timed(cmd: list[str], env: dict | None = None) -> dict:
    """Run ``cmd``; its wall time [s], CPU time (user + system) [s] and peak memory [MB]."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    err = p.stderr.read().decode(errors="replace")
    p.stderr.close()
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}): {err[-500:]}")
    return {"wall_s": wall, "cpu_s": ru.ru_utime + ru.ru_stime, "max_rss_mb": ru.ru_maxrss / 1024}


def one_round(n: int, tmp: Path, env: dict, plot: bool = True) -> dict:
    kern = timed([sys.executable, "-c", KERNEL.format(w0=W[0], w1=W[1], a0=A[0], a1=A[1], n=n)], env)
    d = tmp / f"map-{n}"
    cmd = [rockbench_exe(), "map", "--block", "B6M", "--w-ratio", f"{W[0]}:{W[1]}:{n}", "--a-ratio",
           f"{A[0]}:{A[1]}:{n}", "--out", str(d), "--json"] + ([] if plot else ["--no-plot"])
    m = timed(cmd, env)
    m["cells_csv_mb"] = (d / "cells.csv").stat().st_size / 2**20
    shutil.rmtree(d)
    return {"kernel": kern, "map": m, "load": loadavg()[0],
            "ratio_wall": m["wall_s"] / kern["wall_s"], "ratio_cpu": m["cpu_s"] / kern["cpu_s"]}


def best(rounds: list[dict]) -> dict:
    """The best (smallest) of each figure over the rounds, and the ratio of the best walls."""
    out = {"rounds": rounds}
    for who in ("kernel", "map"):
        out[who] = {k: min(r[who][k] for r in rounds) for k in rounds[0][who]}
    out["ratio_best_wall"] = out["map"]["wall_s"] / out["kernel"]["wall_s"]
    out["ratio_best_cpu"] = out["map"]["cpu_s"] / out["kernel"]["cpu_s"]
    out["load"] = [r["load"] for r in rounds]
    return out


def startup(repeat: int) -> dict:
    out = {}
    for label, args in (("help", ["--help"]), ("blocks", ["blocks"])):
        ts = [timed([rockbench_exe(), *args])["wall_s"] for _ in range(repeat)]
        out[label] = {"best_s": min(ts), "all_s": ts}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="200,1000", help="map sizes n (n×n cells), comma-separated")
    ap.add_argument("--repeat", type=int, default=3, help="rounds per size; the best is reported")
    ap.add_argument("--threads", default="1,2", help="NUMBA_NUM_THREADS values for part 2 ('' skips it)")
    ap.add_argument("--startup", type=int, default=5, help="runs of --help and blocks (0 skips part 3)")
    ap.add_argument("--no-plot", action="store_true", help="maps without map.png")
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = ap.parse_args(argv)
    sizes = [int(x) for x in args.sizes.split(",") if x]
    res = {"started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "cores": os.cpu_count(), "load_before": loadavg()}
    print(f"{res['started']} cores {res['cores']} load {res['load_before']}", flush=True)
    base_env = dict(os.environ)
    base_env.setdefault("MPLBACKEND", "Agg")
    # warm numba's cache and the file system once, untimed
    subprocess.run([sys.executable, "-c", KERNEL.format(w0=W[0], w1=W[1], a0=A[0], a1=A[1], n=4)], check=True,
                   env=base_env)
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        res["maps"] = {}
        for n in sizes:
            rounds = [one_round(n, tmp, base_env, plot=not args.no_plot) for _ in range(args.repeat)]
            res["maps"][n] = b = best(rounds)
            print(f"1. {n}×{n}: kernel {b['kernel']['wall_s']:.2f} s wall {b['kernel']['cpu_s']:.2f} s CPU "
                  f"{b['kernel']['max_rss_mb']:.0f} MB | map {b['map']['wall_s']:.2f} s wall {b['map']['cpu_s']:.2f} s "
                  f"CPU {b['map']['max_rss_mb']:.0f} MB, cells.csv {b['map']['cells_csv_mb']:.1f} MB | ratio "
                  f"{b['ratio_best_wall']:.2f} (wall), {b['ratio_best_cpu']:.2f} (CPU) | load {b['load']}", flush=True)
        threads = [int(x) for x in args.threads.split(",") if x]
        if threads and sizes:
            res["threads"] = {}
            for k in threads:
                env = dict(base_env, NUMBA_NUM_THREADS=str(k))
                rounds = [one_round(sizes[0], tmp, env, plot=not args.no_plot) for _ in range(args.repeat)]
                res["threads"][k] = b = best(rounds)
                print(f"2. {sizes[0]}×{sizes[0]} on {k} thread(s): kernel {b['kernel']['wall_s']:.2f} s, "
                      f"map {b['map']['wall_s']:.2f} s wall ({b['map']['cpu_s']:.2f} s CPU) | load {b['load']}",
                      flush=True)
    if args.startup:
        res["startup"] = startup(args.startup)
        print(f"3. rockbench --help {res['startup']['help']['best_s']:.3f} s, rockbench blocks "
              f"{res['startup']['blocks']['best_s']:.3f} s (best of {args.startup})", flush=True)
    res["load_after"] = loadavg()
    print(f"load after {res['load_after']}")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
