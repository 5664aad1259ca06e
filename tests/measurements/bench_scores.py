"""Speed of scoring and reporting (prints figures; passes or fails on nothing).

    python tests/measurements/bench_scores.py

Measures, on synthetic maps shaped like real ones (an overturn region at low ω/p with a ragged
boundary, a safe band and a one-impact tongue):

1. ``score(engine, reference)`` for square grids of 50² to 400² cells;
2. ``from_cells`` building a 200×200 map from a shuffled cell table;
3. ``rockbench score`` and ``rockbench report --no-trajectories`` on the default suite's shape
   (4 blocks × 2 pulses, 3 reference maps and 2 engine maps each, 76 × 56 cells).

Figures go to docs/scores.md with the machine load (``uptime``) at the time.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))   # tests/: mapdirs

from rockbench.benchmark.report.build import build_report  # noqa: E402
from rockbench.benchmark.maps.result import MapResult  # noqa: E402
from rockbench.benchmark.maps.result import from_cells  # noqa: E402
from rockbench.benchmark.scoring.metrics import score  # noqa: E402
from rockbench.benchmark.scoring.score_runs import score_dirs  # noqa: E402
from rockbench.reference_solver.restitution import Restitution  # noqa: E402

from mapdirs import write_map  # noqa: E402


def synthetic(n_a, n_w, shift=0.0, seed=0):
    """Outcome codes with a curved boundary a_crit(w), a safe band and a tongue."""
    rng = np.random.default_rng(seed)
    w = np.linspace(1, 16, n_w)
    a = np.linspace(1, 12, n_a)
    W, A = np.meshgrid(w, a)
    crit = 1.5 + 0.12 * (W - 1) ** 1.6 + shift + 0.05 * rng.standard_normal(W.shape)
    c = np.where(A >= crit, 2, np.where(A >= 1.0 + 0.05 * W, 1, 0))
    band = (A >= crit + 0.8) & (A < crit + 1.0)
    c[band] = 1
    tongue = (A > crit - 1.5) & (A < crit - 1.2) & (W > 5) & (W < 7)
    c[tongue] = 2
    return MapResult.from_outcomes(w, a, c)


def best_of(f, repeat=5):
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return min(ts)


def main():
    print(f"load: {os.getloadavg()}, cpus: {os.cpu_count()}")
    print("\n1. score(engine, reference)")
    for n in (50, 100, 200, 400):
        ref, eng = synthetic(n, n), synthetic(n, n, shift=0.3, seed=1)
        t = best_of(lambda: score(eng, ref), 3 if n >= 400 else 5)
        print(f"   {n:4d} x {n:<4d} cells: {1e3 * t:8.1f} ms")

    print("\n2. from_cells, 200 x 200 shuffled cell table")
    m = synthetic(200, 200)
    W, A = np.meshgrid(m.w_ratio, m.a_ratio)
    names = np.array(["rest", "rocking", "overturn"])[m.outcome.ravel()]
    perm = np.random.default_rng(0).permutation(names.size)
    t = best_of(lambda: from_cells(W.ravel()[perm], A.ravel()[perm], names[perm]), 3)
    print(f"   {1e3 * t:8.1f} ms")

    print("\n3. default-suite-shaped results: 4 blocks x 2 pulses x (3 references + 2 engines), 76 x 56")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "run"
        t0 = time.perf_counter()
        for block in ("B3M", "B6M", "B3L", "B6L"):
            for pulse in ("sine", "cosine"):
                for k, rest in enumerate([Restitution(), Restitution("modified", k=0.8), Restitution("modified", k=0.75)]):
                    write_map(root / f"ref-{block}-{pulse}-{k}", synthetic(56, 76, shift=0.2 * k).outcome,
                              block=block, pulse=pulse, restitution=rest, w=(1, 16), a=(1, 12))
                for e, eng in enumerate(("mujoco", "pybullet")):
                    write_map(root / f"{eng}-{block}-{pulse}", synthetic(56, 76, shift=0.1 + 0.2 * e, seed=e + 2).outcome,
                              engine=eng, block=block, pulse=pulse, w=(1, 16), a=(1, 12))
        print(f"   writing 40 map directories: {time.perf_counter() - t0:.2f} s")
        t = best_of(lambda: score_dirs([root]), 3)
        print(f"   score (load 40 maps, 48 pairs): {t:.2f} s")
        t0 = time.perf_counter()
        build_report([root], Path(tmp) / "report", trajectories=False, log=lambda m: None)
        print(f"   report without θ(t) (8 stability graphs): {time.perf_counter() - t0:.2f} s")


if __name__ == "__main__":
    main()
