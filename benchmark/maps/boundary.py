"""A map's located overturning boundary in the normalised plane (:class:`LocatedBoundary`): the
crossings its bisection found (:mod:`rockbench.benchmark.maps.bisection`), the chords that join them
into a polyline, and each bisected edge's flag.

The polyline is marching squares on the node lattice (the cells' centres): in each square of four
neighbouring nodes, the crossings on its four sides, taken in perimeter order, are paired into
non-crossing chords: two crossings give one chord; four or more, of the two alternating pairings,
the one of shorter total length, except that a pairing that joins two crossings of one side loses
to one that does not (between two crossings of one edge lies a band the edge's bisection found
standing: a chord along the edge would run through the band instead of along it, and the shorter
pairing would draw a thin band as dashes across it). A square with an odd number of crossings (a
side not judged, or an edge whose bisection stopped) draws no chord; its crossings stay points of
the boundary.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from rockbench.benchmark.maps.bisection import ALONG_A, ALONG_W, MULTIPLE, Bisected, bisect, far_end, regime_of


@dataclass(frozen=True)
class LocatedBoundary:
    """The located boundary of one map.

    Attributes
    ----------
    depth : int
        Rounds of bisection per edge (0: the edge midpoints); the tolerance is a step over ``2**depth``.
    points : ndarray, shape (n, 2)
        The crossings, columns (w_ratio, a_ratio) [-].
    cell_a, cell_b : ndarray of int, shape (n, 2)
        The two cells ``(i, j)`` of each crossing's edge (``cell_a`` at t = 0).
    axis : ndarray of int, shape (n,)
        Each crossing's edge direction (:data:`~rockbench.benchmark.maps.bisection.ALONG_W` or ``ALONG_A``).
    t : ndarray, shape (n,)
        Each crossing's position along its edge [-].
    band : ndarray of bool, shape (n,)
        True for a side of a band thinner than a cell (an overturn(n) | overturn(m) edge).
    valid : ndarray of bool, shape (n,)
        Whether the map's runs on both sides of each crossing (the ends of its last interval: a
        bisection sample, or a cell of its edge) are valid: the map is valid right at its boundary.
    edges : ndarray of int, shape (m, 3)
        Every edge bisected, ``(i, j, axis)``.
    flags : ndarray of str, shape (m,)
        Each bisected edge's flag (``""``, ``multiple``, ``failed``, ``unfinished``).
    n_samples : int
        Off-grid runs the bisection used.
    shape : tuple
        ``(n_a, n_w)``: the grid's nodes (the squares of the polyline lie between them).
    """

    depth: int
    points: np.ndarray
    cell_a: np.ndarray
    cell_b: np.ndarray
    axis: np.ndarray
    t: np.ndarray
    band: np.ndarray
    valid: np.ndarray
    edges: np.ndarray
    flags: np.ndarray
    n_samples: int = 0
    shape: tuple = (0, 0)

    @property
    def n_crossings(self) -> int:
        return int(self.points.shape[0])

    def count(self, flag: str) -> int:
        """Bisected edges with ``flag``."""
        return int(np.count_nonzero(self.flags == flag))

    def flagged_edges(self, flag: str = MULTIPLE) -> np.ndarray:
        """``(i, j, axis)`` of the edges with ``flag``."""
        return self.edges[self.flags == flag]

    def within(self, cells: np.ndarray) -> "LocatedBoundary":
        """The crossings and edges whose two cells are both in the boolean grid ``cells``."""
        keep = cells[tuple(self.cell_a.T)] & cells[tuple(self.cell_b.T)] if self.n_crossings else np.zeros(0, bool)
        ei, ej, ea = self.edges.T if self.edges.size else (np.zeros(0, int),) * 3
        fi, fj = far_end(ei, ej, ea)
        ekeep = cells[ei, ej] & cells[fi, fj] if self.edges.size else np.zeros(0, bool)
        return LocatedBoundary(self.depth, self.points[keep], self.cell_a[keep], self.cell_b[keep], self.axis[keep],
                               self.t[keep], self.band[keep], self.valid[keep], self.edges[ekeep], self.flags[ekeep],
                               self.n_samples, self.shape)

    def chords(self) -> np.ndarray:
        """The polyline's chords, shape (k, 2, 2): ``[[w0, a0], [w1, a1]]`` each (module docstring)."""
        return self._chords

    @cached_property
    def _chords(self) -> np.ndarray:
        return marching_chords(self.points, self.cell_a, self.axis, self.t, self.shape)

    def segments(self) -> np.ndarray:
        """What a distance to this boundary is measured to, shape (k, 2, 2): its chords, and each
        crossing that is the end of no chord as a segment of length 0."""
        ch = self.chords()
        ends = ch.reshape(-1, 2)
        if ends.size:
            alone = ~(np.abs(self.points[:, None, :] - ends[None, :, :]).max(axis=2) == 0).any(axis=1)
        else:
            alone = np.ones(self.n_crossings, bool)
        lone = np.repeat(self.points[alone][:, None, :], 2, axis=1)
        return np.concatenate([ch, lone], axis=0)

    def summary(self) -> dict:
        """Counts for run.json and score.json."""
        return {"locate_depth": self.depth, "located_crossings": self.n_crossings,
                "bisected_edges": int(self.flags.size), "multiple_edges": self.count(MULTIPLE),
                "failed_edges": self.count("failed"), "unfinished_edges": self.count("unfinished"),
                "bisection_samples": self.n_samples}


def from_bisection(b: Bisected, w_ratio: np.ndarray, a_ratio: np.ndarray, valid_at=None) -> LocatedBoundary:
    """The boundary of a :class:`~rockbench.benchmark.maps.bisection.Bisected` on the axes ``w_ratio``
    (columns) and ``a_ratio`` (rows) [-]; ``valid_at(i, j, axis, t)`` says whether the runs at
    positions ``t`` along edges ``(i, j, axis)`` are valid (``t`` 0 and 1 are the edge's cells; None:
    nothing is known to be valid)."""
    i, j, ax = b.i[b.edge], b.j[b.edge], b.axis[b.edge]
    fi, fj = far_end(i, j, ax)
    valid = np.zeros(i.size, bool) if valid_at is None or not i.size else \
        np.asarray(valid_at(i, j, ax, b.lo), bool) & np.asarray(valid_at(i, j, ax, b.hi), bool)
    w, a = np.asarray(w_ratio, float), np.asarray(a_ratio, float)
    pw = np.where(ax == ALONG_W, w[j] + b.t * (w[fj] - w[j]), w[j])
    pa = np.where(ax == ALONG_A, a[i] + b.t * (a[fi] - a[i]), a[i])
    edges = np.column_stack([b.i, b.j, b.axis]).astype(np.int64).reshape(-1, 3)
    return LocatedBoundary(b.depth, np.column_stack([pw, pa]).reshape(-1, 2), np.column_stack([i, j]).reshape(-1, 2),
                           np.column_stack([fi, fj]).reshape(-1, 2), ax.astype(np.int64), b.t.astype(float),
                           b.band.astype(bool), valid, edges, np.asarray(b.flag, dtype=str).reshape(-1), b.n_samples,
                           (len(a), len(w)))


def midpoint_boundary(outcome: np.ndarray, w_ratio, a_ratio, n_impacts=None, valid=None) -> LocatedBoundary:
    """The depth-0 boundary of a map without bisection samples: the midpoints of the edges between a
    standing and an overturning cell (every overturn one regime when ``n_impacts`` is not given), valid
    where both cells are (``valid``, default every cell with an outcome)."""
    o = np.asarray(outcome)
    n = np.zeros(o.shape, int) if n_impacts is None else np.asarray(n_impacts)
    ok = o >= 0 if valid is None else np.asarray(valid, bool)
    return from_bisection(bisect(regime_of(o, n), 0, _no_samples), w_ratio, a_ratio, cell_validity(ok, {}))


def cell_validity(valid_cells: np.ndarray, samples: dict):
    """``valid_at(i, j, axis, t)`` of a map: its cells' validity at ``t`` 0 and 1, its stored bisection
    samples' (``{(i, j, axis, t): row}``, the row's ``valid``) in between; a position with no run is not
    valid."""
    def valid_at(i, j, axis, t):
        fi, fj = far_end(i, j, axis)
        out = np.where(t <= 0, valid_cells[i, j], np.where(t >= 1, valid_cells[fi, fj], False))
        for k in np.nonzero((t > 0) & (t < 1))[0]:
            row = samples.get((int(i[k]), int(j[k]), int(axis[k]), float(t[k])))
            out[k] = row is not None and row["status"] == "ok" and str(row["valid"]).lower() in ("true", "1")
        return out
    return valid_at


def _no_samples(i, j, axis, t):   # depth 0 asks for none
    raise AssertionError("a depth-0 bisection takes no samples")


# -- marching squares ------------------------------------------------------------------------------

def marching_chords(points: np.ndarray, cell_a: np.ndarray, axis: np.ndarray, t: np.ndarray,
                    shape: tuple) -> np.ndarray:
    """The chords of crossings ``points`` on the node lattice of ``shape`` ``(n_a, n_w)`` (module
    docstring), shape (k, 2, 2)."""
    sides: dict = {}
    for k in range(points.shape[0]):
        sides.setdefault((int(cell_a[k, 0]), int(cell_a[k, 1]), int(axis[k])), []).append(k)
    squares = {(i - d, j) for (i, j, a) in sides for d in (0, 1) if a == ALONG_W} | \
              {(i, j - d) for (i, j, a) in sides for d in (0, 1) if a == ALONG_A}
    out = []
    for i, j in sorted(squares):
        if not (0 <= i < shape[0] - 1 and 0 <= j < shape[1] - 1):
            continue   # a side of the grid: no square beyond it
        ring = []
        # counter-clockwise: bottom (row i) left→right, right (column j+1) up, top (row i+1) right→left,
        # left (column j) down
        for side, (key, rev) in enumerate((((i, j, ALONG_W), False), ((i, j + 1, ALONG_A), False),
                                           ((i + 1, j, ALONG_W), True), ((i, j, ALONG_A), True))):
            ks = sorted(sides.get(key, []), key=lambda k: t[k], reverse=rev)
            ring.extend((side, points[k]) for k in ks)
        out.extend(_pair(ring))
    return np.array(out, dtype=float).reshape(-1, 2, 2)


def _pair(ring: list) -> list:
    """Non-crossing chords of an even ring of ``(side, point)``: of the two alternating pairings, one
    that joins no two points of one side, else the shorter (module docstring)."""
    n = len(ring)
    if n < 2 or n % 2:
        return []
    first = [(ring[k], ring[k + 1]) for k in range(0, n, 2)]
    if n == 2:
        return [(p, q) for (_, p), (_, q) in first]
    second = [(ring[k], ring[(k + 1) % n]) for k in range(1, n, 2)]

    def cost(ps):
        along = any(a == b for (a, _), (b, _) in ps)
        return along, sum(float(np.hypot(*(p - q))) for (_, p), (_, q) in ps)

    best = first if cost(first) <= cost(second) else second
    return [(p, q) for (_, p), (_, q) in best]


def locate(regime: np.ndarray, w_ratio, a_ratio, depth: int, sample, valid_at=None) -> LocatedBoundary:
    """Bisect (:func:`~rockbench.benchmark.maps.bisection.bisect`) and place the crossings on the axes;
    ``valid_at`` as in :func:`from_bisection`, called after the bisection."""
    return from_bisection(bisect(regime, depth, sample), w_ratio, a_ratio, valid_at)

