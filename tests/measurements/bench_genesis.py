"""Benchmark of the Genesis adapter: cells per CPU second, one at a time and as the environments of
one scene.

Measures and prints; it passes or fails on nothing (timings depend on the machine and its load, so
the CPU time of this process is reported beside the wall time).

Usage (from the repository's top folder, in the venv)::

    python tests/measurements/bench_genesis.py [--set KEY=VALUE ...] [--worlds 1,16,64,256]

Each batch is a square grid of B3M cells under one sine wave (ω/p from 1 to 10, a₀/(g·tanα) from
0.5 to 8), run with ``run_many`` (one world: ``run``) after one warm-up run that builds the scene
of one environment; the line says the cells per CPU second, the world-steps per CPU second (a
world-step of Δt = 0.5 ms is 1/2000 world-s) and the outcomes.
"""

from __future__ import annotations

import argparse

from rockbench.engines.registry import get_adapter

from bench_newton import _cases, time_batches


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="an engine setting (repeatable)")
    ap.add_argument("--worlds", default="1,16,64,256", help="batch sizes, comma-separated")
    args = ap.parse_args(argv)
    extra = dict(kv.split("=", 1) for kv in args.set)
    ad = get_adapter("genesis", **extra)
    ad.run(_cases(1)[0])  # the kernels loaded and one scene built before the clock starts
    time_batches(ad, f"genesis {extra or ''}", args.worlds)


if __name__ == "__main__":
    main()
