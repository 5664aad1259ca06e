"""A stability map in memory (:class:`MapResult`): an outcome per cell of its grid, with the
simulation's impacts, θ and validity flags, and the codes of cells without an outcome
(:data:`FAILED`, :data:`MISSING`).

It is the one type of a map in memory: what :func:`~rockbench.benchmark.sweep.run_map` computes,
what :func:`~rockbench.benchmark.store.loading.load_map` reads back, what the scores compare
(:meth:`MapResult.from_outcomes`, also for a cell table another tool wrote) and what the pictures
draw. A map on disk is a :class:`~rockbench.benchmark.store.loading.MapEntry` (docs/maps.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from rockbench.engines.contract import CellResult
from rockbench.reference_solver.classify import OUTCOME_CODES, Outcome
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.validity import LEFT_MODEL_FLAGS
from rockbench.benchmark.maps.boundary import LocatedBoundary, midpoint_boundary
from rockbench.benchmark.maps.grid import MapSpec

#: The codes of a cell without an outcome, beside the classifier's (0 rest, 1 rocking, 2 overturn):
#: FAILED, the simulation gave none; MISSING, neither simulated nor inferred (an unfinished run).
#: The one definition: scores, the fill rule and the pictures read them from here.
FAILED = -1
MISSING = -2

#: Relative tolerance when deciding two axes are the same [-].
AXIS_RTOL = 1e-9


@dataclass
class MapResult:
    """A map in memory: computed, loaded, or built from outcomes for the scores.

    Attributes
    ----------
    spec : MapSpec or None
        What was computed; None for a map built from outcomes alone (:meth:`from_outcomes`), whose
        axes are ``axes``.
    outcome : ndarray of int8, shape ``spec.shape``
        Outcome codes (:data:`~rockbench.reference_solver.classify.OUTCOME_CODES`: 0 rest,
        1 rocking, 2 overturn), :data:`FAILED` (-1) for a failed cell, :data:`MISSING` (-2) for a
        cell neither simulated nor inferred (an unfinished run).
    simulated : ndarray of bool
        True where the cell was simulated; adaptive maps infer the others.
    n_impacts : ndarray of int32
        Impacts up to the decision [-]; -1 where not simulated.
    max_abs_theta_rad : ndarray of float
        Largest |θ| [rad]; NaN where not simulated.
    valid : ndarray of bool
        False where the run broke the model's assumptions or failed.
    left_model : ndarray of bool
        True where the run left the rigid model through its contact: an engine's ``slip`` or
        ``jump``, the reference's ``lift-required`` or ``slip-required``.
    failures : list of dict
        ``{"i", "j", "flag", "message"}`` of each failed cell.
    adaptive : bool
        Whether unsimulated cells were inferred by adaptive refinement.
    coarse_stride : int
        The adaptive coarse grid's spacing in cells (1 for a full map).
    wall_s : float
        Wall time of the run that produced it [s] (0 when loaded).
    n_resumed : int
        Cells found already done in the run directory when the run started.
    axes : (ndarray, ndarray) or None
        ``(w_ratio, a_ratio)`` of a map without a spec.
    filled : int
        Cells a table had no row for, filled from the nearest computed cell (adaptive maps; see
        :func:`from_cells`); 0 for a full grid.
    meta : dict
        Anything describing the map (engine, block, pulse, restitution, eta, missing cells, ...).
    located : LocatedBoundary or None
        The overturning boundary located below the cell by the map stage's bisection
        (:mod:`rockbench.benchmark.maps.bisection`); None for a map without one (built from outcomes
        alone), whose boundary is the edge midpoints (:meth:`boundary`).
    """

    spec: MapSpec
    outcome: np.ndarray
    simulated: np.ndarray
    n_impacts: np.ndarray
    max_abs_theta_rad: np.ndarray
    valid: np.ndarray
    left_model: np.ndarray | None = None
    failures: list = field(default_factory=list)
    adaptive: bool = False
    coarse_stride: int = 1
    wall_s: float = 0.0
    n_resumed: int = 0
    axes: tuple | None = None
    filled: int = 0
    meta: dict = field(default_factory=dict)
    located: LocatedBoundary | None = None

    def __post_init__(self):
        if self.left_model is None:
            self.left_model = np.zeros(self.outcome.shape, bool)

    @property
    def w_ratio(self) -> np.ndarray:
        """ω/p of each column [-]."""
        return self.spec.w_ratios() if self.spec is not None else self.axes[0]

    @property
    def a_ratio(self) -> np.ndarray:
        """a₀/(g·tanα) of each row [-]."""
        return self.spec.a_ratios() if self.spec is not None else self.axes[1]

    @property
    def n_simulated(self) -> int:
        return int(self.simulated.sum())

    @property
    def fraction_simulated(self) -> float:
        """Simulated cells over all cells [-]."""
        return self.n_simulated / self.outcome.size

    @property
    def complete(self) -> bool:
        return not bool((self.outcome == MISSING).any())

    @property
    def shape(self) -> tuple[int, int]:
        return self.outcome.shape

    @property
    def known(self) -> np.ndarray:
        """Cells with an outcome."""
        return self.outcome >= 0

    @property
    def outside_domain(self) -> np.ndarray:
        """Cells with an outcome that are not valid (for a reference map: lift-/slip-required)."""
        return self.known & ~self.valid

    def boundary(self) -> LocatedBoundary:
        """The located boundary, or for a map without one the depth-0 boundary of its cells (the
        midpoints of the edges between a standing and an overturning cell)."""
        if self.located is not None:
            return self.located
        return midpoint_boundary(self.outcome, self.w_ratio, self.a_ratio, valid=self.valid)

    def same_axes(self, other: "MapResult") -> bool:
        """Whether both maps lie on the same grid (within :data:`AXIS_RTOL`)."""
        return (self.w_ratio.shape == other.w_ratio.shape and self.a_ratio.shape == other.a_ratio.shape
                and np.allclose(self.w_ratio, other.w_ratio, rtol=AXIS_RTOL, atol=0.0)
                and np.allclose(self.a_ratio, other.a_ratio, rtol=AXIS_RTOL, atol=0.0))

    @classmethod
    def from_outcomes(cls, w_ratio, a_ratio, outcome, valid=None, left_model=None, simulated=None, *,
                      filled: int = 0, meta: dict | None = None) -> "MapResult":
        """A map from its axes and outcome codes alone, as the scores compare maps.

        Parameters
        ----------
        w_ratio : array_like, shape (n_w,)
            ω/p of the columns [-], strictly increasing.
        a_ratio : array_like, shape (n_a,)
            a₀/(g·tanα) of the rows [-], strictly increasing.
        outcome : array_like of int, shape (n_a, n_w)
            0 rest, 1 rocking, 2 overturn, :data:`FAILED` for no outcome (no :data:`MISSING` here).
        valid : array_like of bool, optional
            False where the run broke the model's assumptions (default: every cell with an outcome);
            a failed cell is never valid.
        left_model : array_like of bool, optional
            True where the run left the rigid model through its contact (default nowhere); never in a
            failed cell.
        simulated : array_like of bool, optional
            True where the cell was simulated (default everywhere); an adaptive map infers the
            others' outcomes, and knows nothing of their flags.
        filled, meta
            See the attributes.

        Raises
        ------
        ValueError
            Axes that are not finite and strictly increasing, shapes that do not match, unknown codes.
        """
        w = np.asarray(w_ratio, dtype=float)
        a = np.asarray(a_ratio, dtype=float)
        codes = np.asarray(outcome, dtype=int)
        shape = (a.size, w.size)
        if codes.shape != shape:
            raise ValueError(f"codes must have shape (n_a, n_w) = {shape}, got {codes.shape}")
        for name, ax in (("w_ratio", w), ("a_ratio", a)):
            if ax.ndim != 1 or ax.size == 0 or not np.all(np.isfinite(ax)) or np.any(np.diff(ax) <= 0):
                raise ValueError(f"{name} must be a non-empty, finite, strictly increasing 1-D axis")
        if not np.all(np.isin(codes, (FAILED, *OUTCOME_CODES.values()))):
            raise ValueError("codes must be -1 (failed), 0 (rest), 1 (rocking) or 2 (overturn)")
        has = codes != FAILED
        valid = has if valid is None else np.asarray(valid, dtype=bool) & has
        left = np.zeros(shape, dtype=bool) if left_model is None else np.asarray(left_model, dtype=bool) & has
        sim = np.ones(shape, bool) if simulated is None else np.asarray(simulated, dtype=bool)
        for name, arr in (("valid", valid), ("left_model", left), ("simulated", sim)):
            if arr.shape != shape:
                raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
        return cls(None, codes, sim, np.full(shape, -1, np.int32), np.full(shape, np.nan), valid, left,
                   axes=(w, a), filled=filled, meta=dict(meta or {}))

    def counts(self) -> dict:
        """Cells per outcome (``rest``, ``rocking``, ``overturn``, ``failed``, ``missing``)."""
        codes = {o.value: OUTCOME_CODES[o] for o in Outcome}
        codes.update(failed=FAILED, missing=MISSING)
        return {name: int((self.outcome == c).sum()) for name, c in codes.items()}

    def summary(self) -> dict:
        """JSON-ready summary (what ``rockbench map --json`` prints)."""
        return {"engine": self.spec.engine, "block": self.spec.block.name, "pulse": self.spec.pulse,
                "restitution": self.spec.restitution.label, "eta": self.spec.eta,
                "shape": list(self.spec.shape), "n_cells": self.spec.n_cells, "n_simulated": self.n_simulated,
                "fraction_simulated": self.fraction_simulated, "adaptive": self.adaptive,
                "complete": self.complete, "counts": self.counts(), "n_failed": len(self.failures),
                "n_invalid": int(np.count_nonzero(self.simulated & ~self.valid & (self.outcome >= 0))),
                "n_resumed": self.n_resumed, "wall_s": self.wall_s,
                **(self.located.summary() if self.located is not None else {})}


def empty_result(spec: MapSpec) -> MapResult:
    """A result with every cell :data:`MISSING`."""
    shape = spec.shape
    return MapResult(spec, np.full(shape, MISSING, np.int8), np.zeros(shape, bool), np.full(shape, -1, np.int32),
                     np.full(shape, np.nan), np.zeros(shape, bool))


# -- helpers ----------------------------------------------------------------------------------
_CODES = {o.value: c for o, c in OUTCOME_CODES.items()}


def record_result(result: MapResult, i: int, j: int, r: CellResult) -> int:
    """Record a fresh cell result in the grids; returns its outcome code."""
    ok = r.status == "ok" and r.outcome
    code = _CODES[r.outcome] if ok else FAILED
    result.outcome[i, j] = code
    result.simulated[i, j] = True
    result.n_impacts[i, j] = int(r.n_impacts) if ok else -1
    result.max_abs_theta_rad[i, j] = float(r.max_abs_theta_rad) if ok else math.nan
    result.valid[i, j] = bool(ok and r.valid)
    result.left_model[i, j] = bool(ok and LEFT_MODEL_FLAGS.intersection(r.flags))
    return code


def put_columns(result: MapResult, ii: np.ndarray, jj: np.ndarray, cols) -> None:
    """Record fresh successful cells ``(ii[k], jj[k])`` from a CellColumns in the grids."""
    result.outcome[ii, jj] = cols.outcome
    result.simulated[ii, jj] = True
    result.n_impacts[ii, jj] = cols.n_impacts
    result.max_abs_theta_rad[ii, jj] = cols.max_abs_theta_rad
    result.valid[ii, jj] = cols.flag_bits == 0
    left = sum(1 << k for k, f in enumerate(cols.flag_names) if f in LEFT_MODEL_FLAGS)
    result.left_model[ii, jj] = (cols.flag_bits & left) != 0


def put_row(result: MapResult, i: int, j: int, row: dict) -> None:
    ok = row["status"] == "ok" and row["outcome"] not in ("", None)
    result.outcome[i, j] = OUTCOME_CODES[Outcome(row["outcome"])] if ok else FAILED
    result.simulated[i, j] = True
    result.n_impacts[i, j] = int(row["n_impacts"]) if ok else -1
    result.max_abs_theta_rad[i, j] = float(row["max_abs_theta_rad"]) if ok else math.nan
    result.valid[i, j] = ok and str(row["valid"]).lower() in ("true", "1")
    result.left_model[i, j] = ok and bool(LEFT_MODEL_FLAGS.intersection(str(row["flags"]).split(";")))


def from_cells(w_ratio, a_ratio, outcome, valid=None, *, fill: bool = True, meta: Mapping | None = None,
               decimals: int = 9, flags=None) -> MapResult:
    """Build a :class:`MapResult` from a table of cells, one row per simulation, in any order.

    Parameters
    ----------
    w_ratio, a_ratio : array_like, shape (n,)
        Normalised frequency and amplitude of each row [-].
    outcome : array_like, shape (n,)
        ``"rest"``, ``"rocking"``, ``"overturn"`` or an empty string / None for a failed cell; or
        the integer codes.
    valid : array_like of bool, shape (n,), optional
        Per-row validity (default all valid).
    flags : array_like of str, shape (n,), optional
        Per-row flags as cells.csv writes them (``;``-separated); they give
        :attr:`MapResult.left_model`.
    fill : bool
        Cells of the grid (the product of the distinct ``w_ratio`` and ``a_ratio`` values) without a
        row take the outcome of the nearest computed cell in index space (ties: the lower index),
        which is what an adaptive sweep that skipped uniform regions implies. With False they stay
        :data:`FAILED`.
    meta : mapping, optional
        Stored in :attr:`MapResult.meta`.
    decimals : int
        Axis values are rounded to this many decimals before grouping, so a value written as text
        and read back lands on the same row or column.

    Raises
    ------
    ConfigError
        Two rows for one cell with different outcomes (both with an outcome), or an unknown outcome.
    """
    w = np.round(np.asarray(w_ratio, dtype=float), decimals)
    a = np.round(np.asarray(a_ratio, dtype=float), decimals)
    if w.shape != a.shape or w.ndim != 1:
        raise ValueError("w_ratio and a_ratio must be 1-D arrays of one length")
    codes = _to_codes(outcome, w.size)
    ok = np.ones(w.size, bool) if valid is None else np.asarray(valid, dtype=bool)
    left = np.zeros(w.size, bool) if flags is None else np.array(
        [bool(LEFT_MODEL_FLAGS.intersection(str(f or "").split(";"))) for f in flags], dtype=bool)
    if w.size == 0:
        raise ConfigError("the cell table has no rows: compute the map first (rockbench map ... --out DIR).")
    wu, wi = np.unique(w, return_inverse=True)
    au, ai = np.unique(a, return_inverse=True)
    shape = (au.size, wu.size)
    # Duplicate rows of one cell resolve the same way whatever the row order: a row with an
    # outcome beats a failed one, and the cell is valid when any row with its outcome is.
    # Two rows with different outcomes are an error (a stale row in a hand-edited table).
    has = codes != FAILED
    hi = np.full(shape, FAILED, dtype=int)
    lo = np.full(shape, OUTCOME_CODES[Outcome.OVERTURN] + 1, dtype=int)
    np.maximum.at(hi, (ai[has], wi[has]), codes[has])
    np.minimum.at(lo, (ai[has], wi[has]), codes[has])
    clash = (hi != FAILED) & (lo != hi)
    if clash.any():
        i, j = (int(x[0]) for x in np.nonzero(clash))
        raise ConfigError(f"two rows for the cell w_ratio={wu[j]:g}, a_ratio={au[i]:g} disagree "
                          f"({_name(lo[i, j])} and {_name(hi[i, j])}); remove the stale row from cells.csv.")
    grid = hi
    gvalid = np.zeros(shape, dtype=bool)
    np.logical_or.at(gvalid, (ai[has], wi[has]), ok[has])
    gleft = np.zeros(shape, dtype=bool)
    np.logical_or.at(gleft, (ai[has], wi[has]), left[has])
    seen = np.zeros(shape, dtype=bool)
    seen[ai, wi] = True
    filled = 0
    if fill and not seen.all():
        ii, jj = np.nonzero(seen)
        mi, mj = np.nonzero(~seen)
        filled = mi.size
        src_i = np.empty(mi.size, int)
        src_j = np.empty(mi.size, int)
        for s in range(0, mi.size, 512):  # chunks keep the distance matrix small
            d = (mi[s:s + 512, None] - ii[None, :]) ** 2 + (mj[s:s + 512, None] - jj[None, :]) ** 2
            k = np.argmin(d, axis=1)
            src_i[s:s + 512], src_j[s:s + 512] = ii[k], jj[k]
        grid[mi, mj] = grid[src_i, src_j]
        gvalid[mi, mj] = gvalid[src_i, src_j]
        gleft[mi, mj] = False   # an inferred cell's outcome is known, its flags are not
    return MapResult.from_outcomes(wu, au, grid, gvalid, gleft, seen, filled=filled, meta=dict(meta or {}))


def _name(code: int) -> str:
    return "failed" if code == FAILED else [o.value for o, c in OUTCOME_CODES.items() if c == code][0]


def _to_codes(outcome, n: int) -> np.ndarray:
    arr = np.asarray(outcome, dtype=object) if not isinstance(outcome, np.ndarray) else outcome
    if arr.shape != (n,):
        raise ValueError(f"outcome must have shape ({n},), got {arr.shape}")
    if arr.dtype.kind in "iu":
        return arr.astype(int)
    names = {o.value: c for o, c in OUTCOME_CODES.items()}
    names.update({"": FAILED, "none": FAILED, "failed": FAILED, "nan": FAILED})
    # distinct texts are few (three outcomes and the empty one): map each once
    text = np.array(["" if v is None else str(v).strip().lower() for v in arr], dtype=object)
    uniq, inv = np.unique(text.astype(str), return_inverse=True)
    for u in uniq:
        if u not in names:
            raise ConfigError(f"unknown outcome {u!r} in the cell table; expected rest, rocking, overturn "
                              "or empty for a failed cell.")
    return np.array([names[u] for u in uniq], dtype=int)[inv]
