"""How much a planted restitution error moves each problem of the default suite (docs/scores.md, "The
suite's power: a planted difference").

For each block of the default suite (B2M, B3M, B6M, B8M) and pulse, the reference solver maps the full
grid (N × N over ω/p 1–16, a₀/(g·tanα) 1–12, default N = 101) at Housner's η, and as the planted
variant (``planted_eta_factor`` = 1 − δ, the production path) at δ = 0.5 %, 1 % and 2 %. It prints the
overturning cells and how many impacts came before each overturn (an overturn before any impact does not
depend on η at all), the cells each δ stops from overturning and those it makes overturn (a smaller η
loses more energy at every impact: few, where the rebound's timing against the pulse changes), the boundary distance of each planted map against η_H's
(the primary metric, on full grids), and the η_H–η_M (average k) reference gap, the physics' own scale.
About two minutes of the reference solver at N = 101.

Run from the repository root: ``python tests/measurements/probes/probe_planted.py [--n N]``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.maps.grid import MapSpec, make_axis
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.scoring.metrics import OVERTURN, score
from rockbench.engines.adapters.reference import PLANTED
from rockbench.reference_solver.restitution import Restitution

BLOCKS = ("B2M", "B3M", "B6M", "B8M")
PULSES = ("sine", "cosine")
DELTAS = (0.005, 0.01, 0.02)


def one_problem(out: Path, block: str, pulse: str, n: int) -> str:
    """One line of the table: a block and pulse, its maps in ``out``."""
    x, y = make_axis("--w-ratio", "w_ratio", 1.0, 16.0, n), make_axis("--a-ratio", "a_ratio", 1.0, 12.0, n)
    pre = get_preset(block)

    def ref_map(name, rest, settings=None):
        spec = MapSpec(pre.block(), pulse, rest, x, y, engine="reference", engine_settings=settings or {})
        return run_map(spec, out / f"{block}-{pulse}-{name}", serial=True)

    h = ref_map("housner", Restitution())
    m = ref_map("modified", pre.restitution("modified-average"))
    over = h.outcome == OVERTURN
    by_impacts = np.bincount(np.minimum(h.n_impacts[over].astype(int), 1), minlength=2)
    parts = [f"{block} {pulse:6} overturn {int(over.sum()):5d} (before an impact {by_impacts[0]}, after "
             f"{by_impacts[1]}); gap η_M {score(m, h)['boundary_mean']:.4f}"]
    for d in DELTAS:
        p = ref_map(f"planted-{d}", Restitution(), {PLANTED: round(1 - d, 12)})
        lost, gained = int((over & (p.outcome != OVERTURN)).sum()), int((~over & (p.outcome == OVERTURN)).sum())
        parts.append(f"δ {100 * d:g} %: lost {lost}, gained {gained}, distance {score(p, h)['boundary_mean']:.4f}")
    return "; ".join(parts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=101, help="values per axis (default 101)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        print(f"reference solver, {args.n} × {args.n} over ω/p 1–16, a0/(g·tanα) 1–12, full grids")
        for block in BLOCKS:
            for pulse in PULSES:
                print(one_problem(Path(tmp), block, pulse, args.n), flush=True)


if __name__ == "__main__":
    main()
