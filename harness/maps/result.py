"""A stability map in memory (:class:`MapResult`): an outcome per cell of its grid, with the
simulation's impacts, θ and validity flags, and the codes of cells without an outcome
(:data:`FAILED`, :data:`MISSING`).
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


@dataclass
class MapResult:
    """A computed (or loaded) map.

    Attributes
    ----------
    spec : MapSpec
        What was computed.
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

    def __post_init__(self):
        if self.left_model is None:
            self.left_model = np.zeros(self.outcome.shape, bool)

    @property
    def w_ratio(self) -> np.ndarray:
        """ω/p of each column [-]."""
        return self.spec.w_ratios()

    @property
    def a_ratio(self) -> np.ndarray:
        """a₀/(g·tanα) of each row [-]."""
        return self.spec.a_ratios()

    @property
    def n_simulated(self) -> int:
        return int(self.simulated.sum())

    @property
    def fraction_simulated(self) -> float:
        """Simulated cells over all cells [-]."""
        return self.n_simulated / self.spec.n_cells

    @property
    def complete(self) -> bool:
        return not bool((self.outcome == MISSING).any())

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
