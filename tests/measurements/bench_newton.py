"""Benchmark of the Newton adapter: cells per CPU second, one at a time and as the worlds of one model.

Measures and prints; it passes or fails on nothing (timings depend on the machine and its load, so
the CPU time of this process is reported beside the wall time: Warp's CPU device runs its kernels
in this thread).

Usage (from the repository's top folder, in the venv)::

    python tests/measurements/bench_newton.py [--solver xpbd] [--set KEY=VALUE ...] [--worlds 1,16,64,256]

Each batch is a square grid of B3M cells under one sine wave (ω/p from 1 to 10, a₀/(g·tanα) from
0.5 to 8), run with ``run_many`` (one world: ``run``); the line says the cells per CPU second, the
world-steps per CPU second and the outcomes.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.contract import Case
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.model import G
from rockbench.reference_solver.pulses import make_pulse


def _cases(n_cells: int) -> list:
    """``n_cells`` B3M cells of a square grid (ω/p 1–10, a₀/(g·tanα) 0.5–8) under one sine wave."""
    blk = get_preset("B3M").block()
    n = int(math.ceil(math.sqrt(n_cells)))
    cells = [(w, a) for w in np.linspace(1, 10, n) for a in np.linspace(0.5, 8, n)][:n_cells]
    return [Case(blk, make_pulse("sine", a * G * math.tan(blk.alpha_rad), w * blk.p_rad_s)) for w, a in cells]


def time_batches(ad, label: str, worlds: str) -> None:
    """For each batch size of ``worlds`` (comma-separated), run that many cells of :func:`_cases`
    (one: ``run``, more: ``run_many``) and print the CPU and wall time, the cells and world-steps
    per CPU second, the outcomes and how many cells were flagged."""
    for w in (int(x) for x in worlds.split(",")):
        cases = _cases(w)
        c0, t0 = time.process_time(), time.perf_counter()
        res = ad.run_many(cases) if w > 1 else [ad.run(cases[0])]
        cpu, wall = time.process_time() - c0, time.perf_counter() - t0
        steps = sum((r.diagnostics or {}).get("steps", 0) for r in res)
        outcomes = {o: sum(r.outcome == o for r in res) for o in ("rest", "rocking", "overturn")}
        print(f"{label} worlds={w}: CPU {cpu:.1f} s, wall {wall:.1f} s; "
              f"{w / cpu:.2f} cells per CPU s, {steps / cpu:.0f} world-steps per CPU s; {outcomes}, "
              f"{sum(not r.valid for r in res)} flagged", flush=True)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solver", default="xpbd")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="an engine setting (repeatable)")
    ap.add_argument("--worlds", default="1,16,64,256", help="batch sizes, comma-separated")
    args = ap.parse_args(argv)
    extra = dict(kv.split("=", 1) for kv in args.set)
    time_batches(get_adapter("newton", solver=args.solver, **extra), f"newton {args.solver} {extra or ''}", args.worlds)


if __name__ == "__main__":
    main()
