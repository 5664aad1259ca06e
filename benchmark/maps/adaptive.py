"""Adaptive refinement of a map: spend simulations only where the outcome changes.

The grid is cut into *blocks* by a coarse grid of every ``stride``-th row and column (the last row
and column always belong to it). The algorithm:

1. simulate the coarse nodes (the blocks' corners);
2. a block whose four corners disagree is *refined*: every cell in it, borders included, is
   simulated;
3. a block not refined takes its corners' outcome for every cell, *unless* a simulated cell on its
   border or in the ring of cells just outside it (eight-neighbourhood) has another outcome: then
   it is refined too. Step 3 repeats until no block changes.

At the end every simulated cell whose outcome differs from a neighbour's has all its neighbours
simulated, so every boundary that touches a simulated cell is followed to its ends, through blocks
whose corners happen to agree (the thin safe band, the tip of the one-impact overturning tongue).
What it cannot see is a feature that touches no simulated cell at all: an island or a band that
fits between coarse nodes along its whole length. A coarse stride of 4 cells (1/50 of a 200-point
axis) is well below the width and length of the features of the paper's maps; the tests check the
result equals the full grid on the four Table 1 blocks × sine/cosine × Housner/modified.

Refinement follows *regimes*, not only outcomes (:func:`regime_key`): an overturn after no impact
and an overturn after one impact are different regimes. The thin safe band of the sine-wave maps
lies exactly on the boundary between those two overturn regimes and is often thinner than a grid
cell, so on the grid it is a dotted diagonal of single rocking cells that an outcome-only tracer
loses between its dots; the regime boundary beside it is a long unbroken line that coarse nodes
always straddle, and following it simulates every cell of the band.

Failed cells (code :data:`~rockbench.benchmark.maps.result.FAILED`) count as one more outcome, so the
cells around a failure are simulated rather than guessed.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

#: Default coarse spacing in cells.
DEFAULT_STRIDE = 4



#: Impacts before an overturn beyond which regimes are not told apart.
MAX_REGIME_IMPACTS = 3


def regime_key(outcome, n_impacts):
    """The regime of cells (vectorised): the outcome code, and for an overturn (code 2) also the
    number of impacts before it, capped at :data:`MAX_REGIME_IMPACTS`: ``2 + 10·min(n, 3)``."""
    o = np.asarray(outcome).astype(np.int16)
    n = np.clip(np.asarray(n_impacts), 0, MAX_REGIME_IMPACTS).astype(np.int16)
    return np.where(o == 2, 2 + 10 * n, o)


def coarse_index(n: int, stride: int) -> np.ndarray:
    """Indices of the coarse lines along an axis of ``n`` cells: ``0, s, 2s, …`` and ``n − 1``."""
    idx = np.arange(0, n, stride)
    if idx[-1] != n - 1:
        idx = np.append(idx, n - 1)
    return idx


def refine(outcome: np.ndarray, simulated: np.ndarray, evaluate: Callable[[list], None],
           stride: int = DEFAULT_STRIDE) -> int:
    """Simulate the cells adaptive refinement needs; returns the number of refinement rounds.

    Parameters
    ----------
    outcome : ndarray of int, shape (ny, nx)
        What neighbours must agree on, updated in place by ``evaluate``: the regime keys
        (:func:`regime_key`) of the simulated cells (cells already simulated, e.g. from a resumed
        run, are used as they are).
    simulated : ndarray of bool, shape (ny, nx)
        True where ``outcome`` holds a simulated cell; updated in place by ``evaluate``.
    evaluate : callable
        ``evaluate([(i, j), ...])`` simulates those cells and writes ``outcome`` and
        ``simulated``; it may be given cells already simulated (it skips them), never the same
        cell twice in one call.
    stride : int
        Coarse spacing in cells (≥ 1; 1 simulates everything).

    Notes
    -----
    Unsimulated cells are left as they are; call :func:`fill` on the outcome grid afterwards for
    the inferred grid (a block left unrefined has corners of one regime, hence of one outcome).
    """
    ny, nx = outcome.shape
    ri, rj = coarse_index(ny, stride), coarse_index(nx, stride)
    if stride <= 1 or ri.size < 2 or rj.size < 2:
        evaluate([(i, j) for i in range(ny) for j in range(nx)])
        return 1
    evaluate([(int(i), int(j)) for i in ri for j in rj])
    nbi, nbj = ri.size - 1, rj.size - 1
    refined = np.zeros((nbi, nbj), bool)
    corners = np.stack([outcome[np.ix_(ri[:-1], rj[:-1])], outcome[np.ix_(ri[:-1], rj[1:])],
                        outcome[np.ix_(ri[1:], rj[:-1])], outcome[np.ix_(ri[1:], rj[1:])]])
    todo = ~(corners == corners[0]).all(axis=0)
    rounds = 1
    while todo.any():
        cells = []
        for bi, bj in zip(*np.nonzero(todo)):
            i0, i1, j0, j1 = ri[bi], ri[bi + 1], rj[bj], rj[bj + 1]
            sub = simulated[i0:i1 + 1, j0:j1 + 1]
            ii, jj = np.nonzero(~sub)
            cells.extend(zip((ii + i0).tolist(), (jj + j0).tolist()))
        refined |= todo
        # neighbouring blocks share their border cells: hand each cell over once
        evaluate(list(dict.fromkeys(cells)))
        rounds += 1
        todo = np.zeros_like(refined)
        for bi, bj in zip(*np.nonzero(~refined)):
            i0, i1, j0, j1 = ri[bi], ri[bi + 1], rj[bj], rj[bj + 1]
            v = outcome[i0, j0]
            a, b = max(i0 - 1, 0), min(i1 + 2, ny)
            c, d = max(j0 - 1, 0), min(j1 + 2, nx)
            win_sim = simulated[a:b, c:d]
            if (outcome[a:b, c:d][win_sim] != v).any():
                todo[bi, bj] = True
    return rounds


def fill(outcome: np.ndarray, simulated: np.ndarray, stride: int) -> None:
    """Give every unsimulated cell its block's outcome, in place (the corners of such a block agree).

    Cells of blocks whose corners are not all simulated, or disagree, stay as they are (an
    unfinished run).
    """
    ny, nx = outcome.shape
    if stride <= 1:
        return
    ri, rj = coarse_index(ny, stride), coarse_index(nx, stride)
    if ri.size < 2 or rj.size < 2:
        return
    for bi in range(ri.size - 1):
        for bj in range(rj.size - 1):
            i0, i1, j0, j1 = ri[bi], ri[bi + 1], rj[bj], rj[bj + 1]
            cs = [(i0, j0), (i0, j1), (i1, j0), (i1, j1)]
            if not all(simulated[c] for c in cs):
                continue
            v = outcome[i0, j0]
            if any(outcome[c] != v for c in cs):
                continue
            sub = outcome[i0:i1 + 1, j0:j1 + 1]
            sub[~simulated[i0:i1 + 1, j0:j1 + 1]] = v
