"""Locating the overturning boundary below the cell: the one bisection rule of every map.

After a map's cells are known (simulated, or inferred by the adaptive fill), every edge between two
4-neighbour cells with an outcome whose *overturn regime* differs is bisected along its own direction
``depth`` times: an edge between ``(i, j)`` and ``(i, j + 1)`` (axis :data:`ALONG_W`) in ω/p at the
row's a₀/(g·tanα), one between ``(i, j)`` and ``(i + 1, j)`` (axis :data:`ALONG_A`) in a₀/(g·tanα) at
the column's ω/p. A sample's position is ``t`` in [0, 1] along its edge (0 at ``(i, j)``); after
``depth`` rounds each located crossing lies inside an interval of ``1/2**depth`` of the edge, and is
given as that interval's midpoint. Depth 0 is the cell-level boundary: the edge midpoints.

The *overturn regime* (:func:`overturn_regime`) is :data:`STANDING` (rest or rocking, one class) or
``1 + n`` for an overturn after ``n`` impacts (``n`` capped as in
:func:`~rockbench.benchmark.maps.adaptive.regime_key`). Two kinds of edges:

- **standing | overturn**: each round keeps the half whose ends differ in overturn-or-not; one crossing.
- **overturn(n) | overturn(m)**, n ≠ m: where the thin safe band of the sine maps hides. Each round keeps
  the half whose ends differ in regime; a *standing* sample splits the edge into two intervals
  (overturn → standing → overturn) bisected on, two crossings. An edge where no standing sample is ever
  found has no located crossing (a band there is thinner than the tolerance).

An edge whose sample matches neither end of its interval (islands, tongues inside one edge) is flagged
:data:`MULTIPLE`; one whose sample failed (engine error, timeout) :data:`FAILED_EDGE`; either stops the
edge's bisection, and its crossings are the midpoints of the intervals it had reached (those whose ends
differ in overturn-or-not). A sample that is not available (a map read back before its bisection
finished) stops the edge the same way, flagged :data:`UNFINISHED`.

Each round asks for the midpoints of all edges' intervals at once (one batch, so engines keep their
parallel batches and worker pools). The rule is deterministic given its samples, so resuming is
replaying it with the stored samples as a memo (:func:`bisect`'s ``sample`` looks them up first), and
the loader derives a stored map's boundary by the same function.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from rockbench.reference_solver.classify import OUTCOME_CODES, Outcome
from rockbench.benchmark.maps.adaptive import MAX_REGIME_IMPACTS, regime_key

#: Overturn regime of a standing cell (rest or rocking); an overturn after n impacts is ``1 + min(n, 3)``.
STANDING = 0

#: Overturn regime of a cell or sample without an outcome (failed, missing).
NO_REGIME = -1

#: Regime a replay gets for a sample that was never stored (an unfinished bisection).
UNSAMPLED = -2

#: The two edge directions: along ω/p (cells ``(i, j)``, ``(i, j + 1)``) and along a₀/(g·tanα)
#: (cells ``(i, j)``, ``(i + 1, j)``); bisection.csv writes them ``w`` and ``a``.
ALONG_W, ALONG_A = 0, 1
AXIS_NAMES = ("w", "a")

#: Edge flags: none, more than the crossings the rule follows, a failed sample, an unstored sample.
CLEAN, MULTIPLE, FAILED_EDGE, UNFINISHED = "", "multiple", "failed", "unfinished"

#: Rounds of bisection of a map's boundary edges unless told otherwise (docs/scores.md, "The grid's
#: resolution": the probe that chose it).
DEFAULT_DEPTH = 5

#: Largest bisection depth a map accepts (a tolerance of 2**-12 of a step, far below any engine's
#: own precision).
MAX_DEPTH = 12


def overturn_regime(key) -> np.ndarray:
    """The overturn regime of cells from their :func:`~rockbench.benchmark.maps.adaptive.regime_key`
    codes (vectorised): :data:`STANDING`, ``1 + n`` (overturn after n impacts), :data:`NO_REGIME`."""
    k = np.asarray(key).astype(np.int16)
    return np.where(k < 0, NO_REGIME, np.where(k >= 2, 1 + (k - 2) // 10, STANDING)).astype(np.int16)


def regime_of(outcome, n_impacts) -> np.ndarray:
    """The overturn regime of outcome codes (0 rest, 1 rocking, 2 overturn, negative: none) and impacts."""
    return overturn_regime(regime_key(outcome, np.clip(np.asarray(n_impacts), 0, MAX_REGIME_IMPACTS)))


def sample_regime(status: str, outcome, n_impacts) -> int:
    """The overturn regime of one sample: its outcome's (``rest``, ``rocking``, ``overturn`` or the
    code) after ``n_impacts`` impacts, :data:`NO_REGIME` when it failed."""
    if status != "ok" or outcome in (None, ""):
        return NO_REGIME
    code = outcome if isinstance(outcome, (int, np.integer)) else OUTCOME_CODES[Outcome(outcome)]
    return int(regime_of(code, int(n_impacts)))


def edges_between(regime: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(i, j, axis)`` of every 4-neighbour edge between two cells with a regime whose regimes differ,
    along ω/p first, then along a₀/(g·tanα), each in row-major order."""
    r = np.asarray(regime)
    has = r >= 0
    out = []
    for axis, (a, b) in ((ALONG_W, (np.s_[:, :-1], np.s_[:, 1:])), (ALONG_A, (np.s_[:-1, :], np.s_[1:, :]))):
        i, j = np.nonzero(has[a] & has[b] & (r[a] != r[b]))
        out.append((i, j, np.full(i.size, axis)))
    return tuple(np.concatenate([o[k] for o in out]).astype(np.int64) for k in range(3))


def far_end(i, j, axis) -> tuple[np.ndarray, np.ndarray]:
    """The cell at ``t = 1`` of edges ``(i, j, axis)``."""
    axis = np.asarray(axis)
    return np.asarray(i) + (axis == ALONG_A), np.asarray(j) + (axis == ALONG_W)


@dataclass(frozen=True)
class Bisected:
    """What the bisection found on its edges (positions as ``t`` along each edge).

    Attributes
    ----------
    depth : int
        Rounds of bisection asked for.
    i, j, axis : ndarray of int, shape (n_edges,)
        The edges bisected.
    flag : ndarray of str, shape (n_edges,)
        :data:`CLEAN`, :data:`MULTIPLE`, :data:`FAILED_EDGE` or :data:`UNFINISHED` per edge.
    edge : ndarray of int, shape (n_crossings,)
        The edge (index into ``i``, ``j``, ``axis``) of each located crossing.
    t : ndarray of float, shape (n_crossings,)
        Each crossing's position along its edge (the midpoint of its last interval) [-].
    band : ndarray of bool, shape (n_crossings,)
        True for a crossing on an overturn(n) | overturn(m) edge (a side of a band thinner than a cell).
    lo, hi : ndarray of float, shape (n_crossings,)
        The ends of each crossing's last interval (0 and 1 are the edge's cells, others samples) [-].
    n_samples : int
        Samples the bisection used.
    """

    depth: int
    i: np.ndarray
    j: np.ndarray
    axis: np.ndarray
    flag: np.ndarray
    edge: np.ndarray
    t: np.ndarray
    band: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    n_samples: int


#: ``sample(i, j, axis, t)``: the overturn regimes at position ``t[k]`` along edge ``(i[k], j[k], axis[k])``,
#: one batch; :data:`NO_REGIME` for a failed sample, :data:`UNSAMPLED` for one not available.
Sampler = Callable[[np.ndarray, np.ndarray], np.ndarray]


def bisect(regime: np.ndarray, depth: int, sample: Sampler) -> Bisected:
    """Locate every crossing of overturn regime between neighbouring cells of ``regime`` (module docstring).

    Parameters
    ----------
    regime : ndarray of int, shape (ny, nx)
        The cells' overturn regimes (:func:`overturn_regime`); :data:`NO_REGIME` where none.
    depth : int
        Rounds of bisection (0: the edge midpoints).
    sample : callable
        See :data:`Sampler`; called once per round with every interval's midpoint.
    """
    i, j, axis = edges_between(regime)
    fi, fj = far_end(i, j, axis)
    # open intervals: edge, lo, hi, regime at lo, regime at hi
    r0, r1 = np.asarray(regime)[i, j].astype(int), np.asarray(regime)[fi, fj].astype(int)
    work = [(k, 0.0, 1.0, int(r0[k]), int(r1[k])) for k in range(i.size)]
    flag = np.full(i.size, CLEAN, dtype=object)
    done: list[tuple] = []
    n_samples = 0
    for _ in range(depth):
        if not work:
            break
        ks = np.array([w[0] for w in work], dtype=np.int64)
        mids = np.array([0.5 * (w[1] + w[2]) for w in work])
        got = np.asarray(sample(i[ks], j[ks], axis[ks], mids)).astype(int)
        n_samples += ks.size
        work = _advance(work, mids, got, flag, done)
    done.extend(work)
    keep = sorted((w for w in done if (w[3] == STANDING) != (w[4] == STANDING)), key=lambda w: (w[0], w[1]))
    edge = np.array([w[0] for w in keep], dtype=np.int64)
    t = np.array([0.5 * (w[1] + w[2]) for w in keep], dtype=float)
    band = (r0[edge] != STANDING) & (r1[edge] != STANDING)
    lo, hi = (np.array([w[k] for w in keep], dtype=float) for k in (1, 2))
    return Bisected(int(depth), i, j, axis, flag.astype(str), edge, t, band, lo, hi, n_samples)


def _advance(work: list, mids: np.ndarray, got: np.ndarray, flag: np.ndarray, done: list) -> list:
    """One round: each edge's intervals split by their samples, or the edge stopped and flagged."""
    by_edge: dict[int, list] = {}
    for w, m, r in zip(work, mids, got):
        by_edge.setdefault(w[0], []).append((w, float(m), int(r)))
    new = []
    for k, items in by_edge.items():
        stop = _stop_flag(items)
        if stop:
            flag[k] = stop
            done.extend(w for w, _, _ in items)
            continue
        for w, m, r in items:
            new.extend(_split(w, m, r))
    return new


def _stop_flag(items: list) -> str:
    """The flag that stops an edge this round, or :data:`CLEAN`: a failed sample, a missing one, or one
    whose regime is neither end's (a standing sample inside an overturn(n) | overturn(m) interval is
    the band the rule looks for, not a surprise)."""
    rs = [r for _, _, r in items]
    if NO_REGIME in rs:
        return FAILED_EDGE
    if UNSAMPLED in rs:
        return UNFINISHED
    for (_, _, _, rl, rh), _, r in items:
        band = rl != STANDING and rh != STANDING and r == STANDING
        if r not in (rl, rh) and not band:
            return MULTIPLE
    return CLEAN


def _split(w: tuple, m: float, r: int) -> list:
    """The halves of interval ``w`` sampled ``r`` at ``m`` that hold a change of regime."""
    k, lo, hi, rl, rh = w
    if (rl == STANDING) != (rh == STANDING):      # one crossing of overturn-or-not: keep the half holding it
        return [(k, m, hi, r, rh)] if (r == STANDING) == (rl == STANDING) else [(k, lo, m, rl, r)]
    if r == STANDING:                               # a band inside an overturn(n) | overturn(m) edge
        return [(k, lo, m, rl, r), (k, m, hi, r, rh)]
    return [(k, m, hi, r, rh)] if r == rl else [(k, lo, m, rl, r)]
