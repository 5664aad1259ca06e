"""Where one cell's ``run_many`` goes, part by part, timed inside it. Measures and prints; it passes or
fails nothing.

    python tests/measurements/bench_run_parts.py [--engine dart] [--settings calibrated]
        [--cells B3M:sine:3:5 B8M:sine:3:1.5] [--runs 300]

For each cell (``BLOCK:PULSE:W_RATIO:A_RATIO``, as in bench_native_floor.py) on a warm adapter, every
part below is wrapped with ``time.process_time`` and ``run_many([case])`` runs ``--runs`` times; the run
of least CPU is printed, each part's CPU in it [µs] (a part's wrapper costs about a µs):

* ``posed``, ``resolve``: the case's step and settings; ``build``, ``start``: the scene and its worlds;
* ``advance``: the engine's steps (with the number of steps run and the number the run keeps);
* ``stop``: the end-of-run tests after each segment (with the number of segments);
* ``trajectory``: the trajectory the judge reads; ``judge``: the classifier and the validity rule;
* ``rest``: ``run_many`` less all of these (the loop's and ``run_many``'s own bookkeeping).

The native loop of bench_native_floor.py for the same cell (least of ``--runs``) is printed beside it.
"""

from __future__ import annotations

import argparse
import functools
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))   # tests/measurements/: the bench beside this script
from bench_native_floor import CELLS, ENGINES, NATIVE, _refuse, case_of, product_history  # noqa: E402

from rockbench.engines import loop  # noqa: E402
from rockbench.engines.registry import get_adapter  # noqa: E402

#: The wrapped parts: (where, attribute, label)
PARTS = (("adapter", "posed", "posed"), ("adapter", "resolve", "resolve"), ("adapter", "build", "build"),
         ("adapter", "start", "start"), ("adapter", "advance", "advance"), ("loop", "_stop", "stop"),
         ("loop", "trajectory", "trajectory"), ("adapter", "judge", "judge"))


def wrapped(ad, spent: dict, counts: dict) -> list:
    """Wrap each of :data:`PARTS` on adapter ``ad`` (its instance) and in the loop module so that its CPU
    adds to ``spent[label]`` [s] and its calls to ``counts[label]``; ``advance`` counts steps instead.
    Returns the loop module's originals, ``(name, function)`` each, to put back."""
    originals = []
    for where, name, label in PARTS:
        owner = ad if where == "adapter" else loop
        orig = getattr(owner, name)
        if owner is loop:
            originals.append((name, orig))

        @functools.wraps(orig)
        def timed(*a, _orig=orig, _label=label, **k):
            t0 = time.process_time()
            out = _orig(*a, **k)
            spent[_label] = spent.get(_label, 0.0) + time.process_time() - t0
            counts[_label] = counts.get(_label, 0) + (a[2] - a[1] if _label == "advance" else 1)
            return out
        setattr(owner, name, timed)
    return originals


def measure(engine: str, settings: str, cell: str, runs: int) -> str:
    """One cell's line: the least-CPU run's parts [µs] and the native loop's least CPU."""
    ad = get_adapter(engine, settings=settings)
    case = case_of(cell)
    posed, s, theta, _ = product_history(ad, case)
    dt, n_kept = posed.dt_s, theta.size - 1
    best, native = None, math.inf
    for _ in range(runs):
        scene = ad.build(case.block, s, dt)
        t0 = time.process_time()
        NATIVE[engine](ad, scene, posed, s, dt, n_kept)
        native = min(native, time.process_time() - t0)
    spent, counts = {}, {}
    originals = wrapped(ad, spent, counts)
    try:
        for _ in range(runs):
            spent.clear()
            counts.clear()
            t0 = time.process_time()
            ad.run_many([case])
            total = time.process_time() - t0
            if best is None or total < best[0]:
                best = (total, dict(spent), dict(counts))
    finally:
        for name, orig in originals:
            setattr(loop, name, orig)
    total, spent, counts = best
    rest = total - sum(spent.values())
    parts = ", ".join(f"{label} {1e6 * spent.get(label, 0.0):.0f}" for _, _, label in PARTS)
    return (f"{engine} {settings} {cell}: run_many {1e6 * total:.0f} µs = {parts}, rest {1e6 * rest:.0f} "
            f"({counts.get('advance', 0)} steps run, {n_kept} kept; {counts.get('stop', 0)} segments); "
            f"native loop {1e6 * native:.0f} µs")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="dart", choices=list(ENGINES))
    ap.add_argument("--settings", default="calibrated", choices=["calibrated", "shipped"])
    ap.add_argument("--cells", nargs="+", default=list(CELLS), help="BLOCK:PULSE:W_RATIO:A_RATIO each")
    ap.add_argument("--runs", type=int, default=300, help="runs of each path; the least CPU counts")
    a = ap.parse_args(argv)
    if a.runs < 1:
        _refuse(f"--runs must be at least 1, got {a.runs}")
    for cell in [c for c in a.cells if case_of(c)]:   # a bad cell stops here, before anything runs
        print(measure(a.engine, a.settings, cell, a.runs), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
