"""CPU time per cell of single cells through ``run_many`` on a warm adapter. Measures and prints; it
passes or fails nothing.

    python tests/measurements/bench_cell_cpu.py [ENGINE ...] [--repeats 5]

For each engine (default: mujoco, dart, exudyn, pybullet), calibrated and as shipped, 16 cells of
B3M under a sine pulse (ω/p 2, 4.5, 7, 9.5 × a₀/(g·tanα) 1.5, 3, 4.5, 6) at the engine's own step
(the time-step rule's, calibrated): the adapter warmed by one pass over the cells (its calibration
cached beforehand), then each cell alone through ``run_many([case])``, ``--repeats`` passes; the
least CPU time of a pass (``time.process_time``: a machine shared with other jobs adds to a pass,
never takes away) over 16 cells. Run it with the code before and after a change, on one machine.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from cells import cell_case  # noqa: E402  tests/cells.py

from rockbench.engines.registry import get_adapter  # noqa: E402

CELLS = [("B3M", "sine", w, a) for w in (2.0, 4.5, 7.0, 9.5) for a in (1.5, 3.0, 4.5, 6.0)]


def per_cell_cpu_s(engine: str, variant: str, repeats: int) -> float:
    """The least CPU time per cell [s] of ``repeats`` passes over :data:`CELLS`, one cell a call."""
    ad = get_adapter(engine, settings=variant)
    cases = [cell_case(*c) for c in CELLS]
    ad.run_many(cases)   # warm: calibration, models, step rule
    best = float("inf")
    for _ in range(repeats):
        c0 = time.process_time()
        for c in cases:
            ad.run_many([c])
        best = min(best, time.process_time() - c0)
    return best / len(cases)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("engines", nargs="*", default=["mujoco", "dart", "exudyn", "pybullet"])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    for e in args.engines:
        for variant in ("calibrated", "shipped"):
            print(f"{e:9s} {variant:10s} {1e3 * per_cell_cpu_s(e, variant, args.repeats):8.2f} ms CPU per cell", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
