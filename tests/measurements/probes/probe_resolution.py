"""How well a 51 × 51 map knows its boundary distance, and what locating the boundary below the cell
would cost (docs/scores.md, "The grid's resolution: a boundary known to its cell").

``truth`` maps B3M and B6M, sine and cosine, with the reference solver on a grid eight times finer
than the default one (401 × 401 over ω/p 1–16, a₀/(g·tanα) 1–12), for η_H and for a restitution
0.5 % and 2 % below it; the default grid is every eighth row and column, at 64 phases. It prints the
fine grid's distance (the truth), the default grid's bias and root mean square error over the phases
(also in cell diagonals), the error version 4 assumed (d/√(6E)) and the error the verdict now
assigns (``RESOLUTION_SD_CELLS`` of the diagonal), and the share of phases whose error lies within
1.96 times each. About a minute of the reference solver (adaptive fine maps, 4,000–23,000 cells each).

``cost RUN_DIR`` counts, over a run's engine maps, the simulated cells and the boundary edges: the
edges between rows (one per column and crossing), the lowest crossing of each column, and the edges
between columns; three more runs per located edge give an eighth of a cell.

Run from the repository root: ``python tests/measurements/probes/probe_resolution.py truth OUT_DIR`` or
``python tests/measurements/probes/probe_resolution.py cost RUN_DIR``.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

from rockbench.benchmark.maps.result import FAILED, MapResult
from rockbench.benchmark.scoring.metrics import OVERTURN, boundary_edges, score
from rockbench.benchmark.scoring.scenarios import resolution_sd
from rockbench.benchmark.store.loading import load_entry, load_map

ETA_H = {"B3M": 0.7526, "B6M": 0.9294}
OFF = (0.0, 0.005, 0.02)       # restitution below η_H, as a share of it
FINE = 8                       # fine cells per default cell along each axis


def fine_map(out: Path, block: str, pulse: str, off: float) -> MapResult:
    d = out / f"{block}-{pulse}-{off}"
    if not (d / "cells.csv").exists():
        eta = round(ETA_H[block] * (1 - off), 5)
        subprocess.run(["rockbench", "map", "--block", block, "--pulse", pulse, "--restitution", str(eta),
                        "--w-ratio", "1:16:401", "--a-ratio", "1:12:401", "--adaptive", "--serial",
                        "--out", str(d)], check=True, stdout=subprocess.DEVNULL)
    return load_entry(d).map    # as the scores read it: an inferred (adaptive) cell counts as valid


def coarse(m: MapResult, oi: int, oj: int) -> MapResult:
    """Every :data:`FINE`-th row and column of ``m`` from row ``oi`` and column ``oj``."""
    ii, jj = np.arange(oi, m.a_ratio.size, FINE), np.arange(oj, m.w_ratio.size, FINE)
    s = np.ix_(ii, jj)
    return MapResult.from_outcomes(m.w_ratio[jj], m.a_ratio[ii], m.outcome[s], m.valid[s], m.left_model[s])


def truth(out: Path) -> None:
    for block in ETA_H:
        for pulse in ("sine", "cosine"):
            ref = fine_map(out, block, pulse, OFF[0])
            for off in OFF[1:]:
                eng = fine_map(out, block, pulse, off)
                true = score(eng, ref)["boundary_mean"]
                err, old = [], []
                for oi in range(FINE):
                    for oj in range(FINE):
                        e, r = coarse(eng, oi, oj), coarse(ref, oi, oj)
                        cell = math.hypot(e.w_ratio[1] - e.w_ratio[0], e.a_ratio[1] - e.a_ratio[0])
                        err.append(score(e, r)["boundary_mean"] - true)
                        old.append(cell / math.sqrt(6 * max(boundary_edges(e, r), 1)))
                err, old, new = np.array(err), np.array(old), resolution_sd(cell)
                rms = float(np.sqrt(np.mean(err ** 2)))
                print(f"{block} {pulse:6s} η {100 * off:.1f} % off: truth {true:.4f}, bias {err.mean():+.4f}, "
                      f"rms {rms:.4f} ({rms / cell:.2f} diagonal); version 4's error {old.mean():.4f} holds "
                      f"{np.mean(np.abs(err) <= 1.96 * old):.0%}, now {new:.4f} holds "
                      f"{np.mean(np.abs(err) <= 1.96 * new):.0%}", flush=True)


def cost(run_dir: Path) -> None:
    sim = cols = rows = across = 0
    for cells in sorted(run_dir.glob("maps/*/*/cells.csv")):
        if cells.parent.parent.name == "reference":
            continue
        m = load_map(cells.parent)
        known, ov = m.outcome != FAILED, m.outcome == OVERTURN
        between_rows = known[:-1] & known[1:] & (ov[:-1] != ov[1:])
        sim += int(m.simulated.sum())
        cols += int(between_rows.any(axis=0).sum())
        rows += int(between_rows.sum())
        across += int((known[:, :-1] & known[:, 1:] & (ov[:, :-1] != ov[:, 1:])).sum())
    print(f"engine cells simulated {sim}; boundary edges between rows {rows}, between columns {across}; "
          f"columns with a crossing {cols}")
    print(f"three runs per lowest crossing: +{300 * cols / sim:.1f} % runs for {cols / (rows + across):.0%} of the "
          f"edges; per edge: +{300 * (rows + across) / sim:.1f} %")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("truth", "cost"), help="truth: the fine-grid truth and the grid's error; "
                    "cost: what locating the boundary below the cell would cost on a run's maps")
    ap.add_argument("path", type=Path, help="truth: the output folder; cost: a run folder of the default suite")
    a = ap.parse_args(argv)
    {"truth": truth, "cost": cost}[a.what](a.path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
