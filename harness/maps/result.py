"""A stability map in memory (:class:`MapResult`): an outcome per cell of its grid, with the
simulation's impacts, θ and validity flags, and the codes of cells without an outcome
(:data:`FAILED`, :data:`MISSING`).

It is the one type of a map in memory: what :func:`~rockbench.harness.maps.sweep.run_map` computes,
what :func:`~rockbench.harness.store.loading.load_map` reads back, what the scores compare
(:meth:`MapResult.from_outcomes`, also for a cell table another tool wrote) and what the pictures
draw. A map on disk is a :class:`~rockbench.harness.store.loading.MapEntry` (docs/maps.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...engines.base import CellResult
from ...reference_solver.classify import OUTCOME_CODES, Outcome
from ...reference_solver.validity import LEFT_MODEL_FLAGS
from .grid import MapSpec

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
        :func:`~rockbench.harness.scoring.metrics.from_cells`); 0 for a full grid.
    meta : dict
        Anything describing the map (engine, block, pulse, restitution, eta, missing cells, ...).
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
                "n_resumed": self.n_resumed, "wall_s": self.wall_s}


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


def _put_columns(result: MapResult, ii: np.ndarray, jj: np.ndarray, cols) -> None:
    """Record fresh successful cells ``(ii[k], jj[k])`` from a CellColumns in the grids."""
    result.outcome[ii, jj] = cols.outcome
    result.simulated[ii, jj] = True
    result.n_impacts[ii, jj] = cols.n_impacts
    result.max_abs_theta_rad[ii, jj] = cols.max_abs_theta_rad
    result.valid[ii, jj] = cols.flag_bits == 0
    left = sum(1 << k for k, f in enumerate(cols.flag_names) if f in LEFT_MODEL_FLAGS)
    result.left_model[ii, jj] = (cols.flag_bits & left) != 0


def _put(result: MapResult, i: int, j: int, row: dict) -> None:
    ok = row["status"] == "ok" and row["outcome"] not in ("", None)
    result.outcome[i, j] = OUTCOME_CODES[Outcome(row["outcome"])] if ok else FAILED
    result.simulated[i, j] = True
    result.n_impacts[i, j] = int(row["n_impacts"]) if ok else -1
    result.max_abs_theta_rad[i, j] = float(row["max_abs_theta_rad"]) if ok else math.nan
    result.valid[i, j] = ok and str(row["valid"]).lower() in ("true", "1")
    result.left_model[i, j] = ok and bool(LEFT_MODEL_FLAGS.intersection(str(row["flags"]).split(";")))
