"""Time the reference solver: a 200×200 map in both ways of ending a run, and the
event-driven ``solve_ivp`` baseline on a random sample of the same cells.

    python tests/measurements/bench_reference.py [--n 200] [--sample 40] [--repeat 3] [--cold] [--json FILE]

The map: block B3M, one sine wave, ω/p in [1, 12] × a₀/(g·tanα) in [1, 10], modified restitution
with the average k of size M (0.8608), Δt = 1 ms. The first call of each kernel (JIT compile, or
loading numba's cache) is timed apart; ``--cold`` also measures a compile from scratch in a
subprocess with an empty cache. The script measures and prints; it passes or fails nothing.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))   # ivp_baseline: the tests' independent solution


def load() -> str:
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "unknown"


def cold_compile_s() -> float:
    """Seconds for a first call with an empty numba cache (a fresh interpreter)."""
    code = ("import time, numpy as np; t=time.perf_counter();"
            "from rockbench.reference_solver.solver import solve_batch;"
            "solve_batch(0.4, 11.5, 0.8, 'sine', 60.0, 30.0); solve_batch(0.4, 11.5, 0.8, 'sine', 60.0, 30.0, mode='to-rest');"
            "print(time.perf_counter()-t)")
    with tempfile.TemporaryDirectory() as d:
        env = {**os.environ, "NUMBA_CACHE_DIR": d}
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    return float(r.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200, help="cells per axis (default 200)")
    ap.add_argument("--sample", type=int, default=40, help="cells solved by the solve_ivp baseline (default 40)")
    ap.add_argument("--repeat", type=int, default=3, help="timed repetitions of each map; the best is kept")
    ap.add_argument("--cold", action="store_true", help="also time a JIT compile with an empty cache")
    ap.add_argument("--json", default=None, help="write the figures to this JSON file")
    args = ap.parse_args(argv)

    import numba

    from rockbench.benchmark.blocks.presets import get_preset
    from rockbench.reference_solver.model import G
    from rockbench.reference_solver.pulses import SinePulse
    from rockbench.reference_solver.restitution import modified_eta
    from rockbench.reference_solver.solver import solve_batch
    from ivp_baseline import solve_events

    pre = get_preset("B3M")
    blk = pre.block()
    eta = modified_eta(blk.alpha_rad, pre.k_average)
    wr = np.linspace(1.0, 12.0, args.n)
    ar = np.linspace(1.0, 10.0, args.n)
    W, A = np.meshgrid(wr, ar)
    omega = W * blk.p_rad_s
    amp = A * G * math.tan(blk.alpha_rad)
    n_cells = W.size
    res = {"machine": {"cpus": os.cpu_count(), "numba_threads": numba.get_num_threads(),
                       "python": platform.python_version(), "numba": numba.__version__,
                       "platform": platform.platform(), "load_before": load()},
           "grid": {"block": "B3M", "pulse": "sine", "eta": eta, "w_ratio": [1, 12], "a_ratio": [1, 10],
                    "n": args.n, "dt_s": 1e-3}}

    if args.cold:
        res["cold_compile_s"] = cold_compile_s()
    t0 = time.perf_counter()
    solve_batch(blk.alpha_rad, blk.p_rad_s, eta, "sine", omega[:1, :2], amp[:1, :2])
    solve_batch(blk.alpha_rad, blk.p_rad_s, eta, "sine", omega[:1, :2], amp[:1, :2], mode="to-rest")
    res["first_call_s"] = time.perf_counter() - t0  # JIT compile or numba cache load

    maps = {}
    for mode in ("energy", "to-rest"):
        best, cpu = math.inf, math.inf
        for _ in range(args.repeat):
            c0, t0 = time.process_time(), time.perf_counter()
            r = solve_batch(blk.alpha_rad, blk.p_rad_s, eta, "sine", omega, amp, mode=mode)
            wall = time.perf_counter() - t0
            if wall < best:
                best, cpu = wall, time.process_time() - c0
        steps, newton = int(r.n_steps.sum()), int(r.n_newton.sum())
        maps[mode] = r
        res[mode] = {"wall_s": best, "cpu_s": cpu, "per_cell_us": best / n_cells * 1e6, "steps": steps,
                     "newton_iterations": newton, "newton_per_step": newton / steps,
                     "cpu_ns_per_step": cpu / steps * 1e9,
                     "outcomes": {k: int((r.outcome == i).sum()) for i, k in enumerate(("rest", "rocking", "overturn"))}}
    res["modes_disagree_cells"] = int((maps["energy"].outcome != maps["to-rest"].outcome).sum())

    rng = np.random.default_rng(0)
    idx = rng.choice(n_cells, size=min(args.sample, n_cells), replace=False)
    t0 = time.perf_counter()
    agree = 0
    nfev = 0
    for i in idx:
        w, a = omega.flat[i], amp.flat[i]
        e = solve_events(blk.alpha_rad, blk.p_rad_s, eta, SinePulse(a, w))
        nfev += e["nfev"]
        agree += int(("rest", "rocking", "overturn").index(e["outcome"]) == maps["energy"].outcome.flat[i])
    ivp = (time.perf_counter() - t0) / idx.size
    res["solve_ivp"] = {"sample": int(idx.size), "per_sim_s": ivp, "mean_nfev": nfev / idx.size,
                        "outcome_agreement": agree}
    for mode in ("energy", "to-rest"):
        res[mode]["speedup_vs_solve_ivp"] = ivp / (res[mode]["wall_s"] / n_cells)
    res["machine"]["load_after"] = load()

    print(f"reference solver benchmark: {args.n}×{args.n} = {n_cells} cells, B3M sine, η = {eta:.4f}, Δt = 1 ms; "
          f"{res['machine']['numba_threads']} threads on {res['machine']['cpus']} CPUs; "
          f"load {res['machine']['load_before']} → {res['machine']['load_after']}")
    if "cold_compile_s" in res:
        print(f"JIT compile from an empty cache: {res['cold_compile_s']:.1f} s")
    print(f"first call (compile or cache load): {res['first_call_s']:.2f} s")
    print(f"{'':18}{'wall [s]':>9}{'CPU [s]':>9}{'µs/cell':>9}{'steps':>11}{'Newton/step':>12}"
          f"{'CPU ns/step':>12}{'× solve_ivp':>12}")
    for mode in ("energy", "to-rest"):
        m = res[mode]
        print(f"{'map, ' + mode:18}{m['wall_s']:9.3f}{m['cpu_s']:9.3f}{m['per_cell_us']:9.1f}{m['steps']:11d}"
              f"{m['newton_per_step']:12.2f}{m['cpu_ns_per_step']:12.0f}{m['speedup_vs_solve_ivp']:12.0f}")
    s = res["solve_ivp"]
    print(f"{'solve_ivp (DOP853)':18}{'':9}{'':9}{s['per_sim_s'] * 1e6:9.0f}   {s['sample']} cells, "
          f"{s['mean_nfev']:.0f} RHS calls each; outcome agrees with the energy map in {s['outcome_agreement']}")
    print(f"energy and to-rest maps differ in {res['modes_disagree_cells']} cells; outcomes (energy): "
          f"{res['energy']['outcomes']}")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
