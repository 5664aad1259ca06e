"""The one outcome classifier: any trajectory, from any engine, judged by the same rule.

Rules (``tol`` is the one uplift tolerance, :data:`UPLIFT_TOL_FRAC` of α, for the reference and every
engine alike):

1. **rest**: ``|θ|`` never exceeds ``tol`` (the block never lifted off) and the block did not
   overturn. A soft contact tilts a standing block by a few tenths of a milliradian, and the rigid
   reference lifts by a hair in the first cells above the uplift threshold; one tolerance judges both,
   so rest against rocking is decided by the same rule on every map.
2. **overturn**: at some sample the block is flat on its side (``|θ| ≥ π/2 − 0.01``), or, once the
   excitation has ended, ``|θ| > α`` while moving outward (``θ·θ̇ > 0``): with nothing left to
   pull it back, gravity alone takes it over. If the trajectory ends before either happens and a
   restitution ``eta`` is given, the exact free-rocking decision of
   :func:`~rockbench.reference_solver.energy.free_rocking_fate` is applied to the last state
   (that is how the reference solver's fast mode stops at the end of the pulse).
3. **rocking**: lifted off and did not overturn.

``n_impacts`` counts the crossings of θ from one side to the other, and ``t_uplift_s`` is the first
instant θ leaves the caller's measurement tolerance (``uplift_tol_rad``: 0 for the rigid reference,
whose uplift is exact; :data:`UPLIFT_TOL_FRAC` of α for a soft contact); ``t_overturn_s`` is the
last outward crossing of ``|θ| = α`` before the overturn was certain (None if not overturned, NaN if
decided by energy before θ reached α).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, asdict
from enum import Enum

import numpy as np

from rockbench.reference_solver.energy import ENERGY_GAIN_TOL, free_rocking_fate
from rockbench.reference_solver.model import FLAT_ANGLE_RAD  # noqa: F401 - re-exported: the classifier's flat-on-its-side angle



#: The one uplift tolerance as a fraction of α [-]: a block whose |θ| never exceeds it did not lift
#: off (rule 1), for the reference and every engine. 2 % of α (4 mrad for the h/b = 4.5 blocks) lies
#: above a soft contact's tilt under a horizontal load and far below any rocking worth the name.
UPLIFT_TOL_FRAC = 0.02


def uplift_tol(alpha_rad: float) -> float:
    """The one uplift tolerance of a block with slenderness angle ``alpha_rad`` [rad]."""
    return UPLIFT_TOL_FRAC * alpha_rad


class Outcome(str, Enum):
    """The three fates of a block."""

    REST = "rest"
    ROCKING = "rocking"
    OVERTURN = "overturn"

    def __str__(self) -> str:
        return self.value


#: Integer codes used by compiled kernels and arrays of outcomes.
OUTCOME_CODES = {Outcome.REST: 0, Outcome.ROCKING: 1, Outcome.OVERTURN: 2}
OUTCOME_FROM_CODE = {v: k for k, v in OUTCOME_CODES.items()}


@dataclass(frozen=True)
class Classification:
    """What the classifier says about one trajectory.

    Attributes
    ----------
    outcome : Outcome
        rest, rocking or overturn.
    n_impacts : int
        Impacts (sign changes of θ) up to the decision [-].
    max_abs_theta_rad : float
        Largest |θ| seen [rad] (up to the overturn decision when overturned).
    t_uplift_s : float or None
        First time |θ| exceeds the tolerance [s].
    t_overturn_s : float or None
        See the module docstring [s].
    """

    outcome: Outcome
    n_impacts: int
    max_abs_theta_rad: float
    t_uplift_s: float | None
    t_overturn_s: float | None

    def to_dict(self) -> dict:
        d = asdict(self)
        d["outcome"] = self.outcome.value
        return d


def classify(t_s, theta_rad, theta_dot_rad_s, *, alpha_rad: float, p_rad_s: float,
             t_pulse_end_s: float, eta: float | None = None, linearized: bool = False,
             uplift_tol_rad: float = 0.0) -> Classification:
    """Classify one trajectory (see the module docstring for the rules).

    Parameters
    ----------
    t_s, theta_rad, theta_dot_rad_s : array_like
        Samples of time [s], rotation [rad] and angular velocity [rad/s], same length.
    alpha_rad, p_rad_s : float
        The block's slenderness angle [rad] and frequency parameter [rad/s].
    t_pulse_end_s : float
        When the excitation ended [s].
    eta : float, optional
        Restitution for the exact free-rocking decision at the end of a trajectory that stops
        while still rocking [-]. Leave None for engines: their trajectories decide by themselves.
    linearized : bool
        Use the linearised energy for that decision.
    uplift_tol_rad : float
        |θ| at or below this is "not lifted" for ``t_uplift_s`` and the impacts counted [rad]: 0 for
        the exact reference, :func:`uplift_tol` for soft contacts. Rest against rocking is decided by
        :func:`uplift_tol` for everyone (rule 1); a larger value widens it.
    """
    t = np.asarray(t_s, dtype=float)
    th = np.asarray(theta_rad, dtype=float)
    thd = np.asarray(theta_dot_rad_s, dtype=float)
    if not (t.shape == th.shape == thd.shape) or t.ndim != 1:
        raise ValueError(f"t, theta and theta_dot must be 1-D arrays of one length, got {t.shape}, {th.shape}, {thd.shape}")
    if t.size == 0:
        return Classification(Outcome.REST, 0, 0.0, None, None)
    lifted = np.abs(th) > uplift_tol_rad
    if not lifted.any():
        return Classification(Outcome.REST, 0, float(np.max(np.abs(th))), None, None)
    i_up = int(np.argmax(lifted))

    i_end, overturned = decision_index(t, th, thd, alpha_rad=alpha_rad, t_pulse_end_s=t_pulse_end_s)

    side = np.where(th > uplift_tol_rad, 1, np.where(th < -uplift_tol_rad, -1, 0))[: i_end + 1]
    nz = side[side != 0]
    n_imp = int(np.count_nonzero(np.diff(nz))) if nz.size > 1 else 0
    max_th = float(np.max(np.abs(th[: i_end + 1])))

    t_over = None
    if overturned:
        t_over = _last_outward_alpha_crossing(t[: i_end + 1], th[: i_end + 1], alpha_rad)
    elif eta is not None and t[-1] >= t_pulse_end_s:
        goes, extra = free_rocking_fate(float(th[-1]), float(thd[-1]), alpha_rad, p_rad_s, eta, linearized)
        if goes:
            overturned = True
            n_imp += extra
            t_over = math.nan
    if not overturned and max_th <= max(uplift_tol_rad, uplift_tol(alpha_rad)):
        return Classification(Outcome.REST, 0, max_th, None, None)
    outcome = Outcome.OVERTURN if overturned else Outcome.ROCKING
    return Classification(outcome, n_imp, max_th, float(t[i_up]), t_over)


def overturn_certain(t_s, theta_rad, theta_dot_rad_s, *, alpha_rad: float, t_pulse_end_s: float):
    """Where the overturn is certain (the classifier's rule 2): flat on its side (``|θ| ≥ π/2 − 0.01``)
    at any time, or after the excitation ``|θ| > α`` moving outward.

    Works element by element on arrays (a boolean array) and on plain floats (a bool, no NumPy call:
    adapters test it after every step). Every adapter's early stop and :func:`decision_index` use it.
    """
    a = abs(theta_rad)
    return flat_on_side(a) | ((t_s >= t_pulse_end_s) & (a > alpha_rad) & (theta_rad * theta_dot_rad_s > 0.0))


def flat_on_side(abs_theta_rad):
    """Where the block lies flat on its side, ``|θ| ≥ π/2 − 0.01`` (from ``|θ|`` [rad]): the part of
    :func:`overturn_certain` that holds at any time, before the excitation's end too."""
    return abs_theta_rad >= FLAT_ANGLE_RAD


#: The end-of-run rule's margin under the barrier, as a fraction of the barrier height ``p²(1 − cos α)``
#: (:func:`overturn_impossible`) [-]: the energy gain the validity rule tolerates, so a trapped block
#: could only overturn by gaining more energy than an engine may without the ``energy-gain`` flag.
TRAPPED_MARGIN = ENERGY_GAIN_TOL

#: Why a contact engine's run stopped (:func:`run_end`), besides reaching its longest tail (``"tail"``).
END_REASONS = ("diverged", "flat", "overturn", "trapped")


def overturn_impossible(theta_rad, theta_dot_rad_s, *, alpha_rad: float, p_rad_s: float):
    """Where a freely rocking block can no longer overturn: its ideal free-rocking energy
    ``E = ½θ̇² + p²cos(α − |θ|)`` is below the barrier ``p²`` by more than :data:`TRAPPED_MARGIN` of
    the barrier height ``p²(1 − cos α)``.

    Free rocking only loses energy (docs/physics.md §2), so such a block is trapped; a block at rest
    on its base is the extreme case. The margin keeps a block balancing just under the barrier
    running (the validity rule's ``energy-gain`` check watches for engines that gain energy).
    Element by element on arrays (a boolean array).
    """
    p2 = p_rad_s * p_rad_s
    th = np.asarray(theta_rad, dtype=float)
    om = np.asarray(theta_dot_rad_s, dtype=float)
    return 0.5 * om * om + p2 * np.cos(alpha_rad - np.abs(th)) < trapped_energy(alpha_rad, p_rad_s)


def trapped_energy(alpha_rad: float, p_rad_s: float) -> float:
    """The ideal free-rocking energy below which a block is trapped (:func:`overturn_impossible`):
    the barrier ``p²`` less :data:`TRAPPED_MARGIN` of its height ``p²(1 − cos α)`` [rad²/s²]."""
    p2 = p_rad_s * p_rad_s
    return p2 - TRAPPED_MARGIN * p2 * (1.0 - math.cos(alpha_rad))


def run_end(step, theta_rad, theta_dot_rad_s, *, alpha_rad: float, p_rad_s: float, pulse_end_step: float,
            min_tail_step: float) -> tuple[int, str] | None:
    """Where a contact engine's run may stop, on new samples: the first of them, and why.

    The one end-of-run rule of every contact engine, tested on what the engine measured at each
    sample (its step number ``step`` [-], θ [rad], θ̇ [rad/s]), in this order at a sample:

    1. ``diverged``: θ or θ̇ is not finite;
    2. ``flat`` / ``overturn``: the overturn is certain (:func:`overturn_certain`, the classifier's
       rule: flat on its side, or from step ``pulse_end_step`` on ``|θ| > α`` moving outward);
    3. ``trapped``: from step ``min_tail_step`` on the block can no longer overturn
       (:func:`overturn_impossible`).

    ``pulse_end_step`` and ``min_tail_step`` may be ``math.inf`` (a free-rocking test: only the flat
    rule and divergence stop it). Returns ``(index into the new samples, reason)``, or None when the
    run goes on (until its longest tail, ``"tail"``).
    """
    i = np.asarray(step)
    th = np.asarray(theta_rad, dtype=float)
    om = np.asarray(theta_dot_rad_s, dtype=float)
    bad = ~(np.isfinite(th) & np.isfinite(om))
    last = i.max() if i.size else -math.inf   # samples all before a rule's first step skip its test
    certain = (flat_on_side(np.abs(th)) if last < pulse_end_step
               else overturn_certain(i, th, om, alpha_rad=alpha_rad, t_pulse_end_s=pulse_end_step))
    hit = bad | certain
    if not last < min_tail_step:   # (a step of NaN tests every sample, as the rule does)
        hit |= (i >= min_tail_step) & overturn_impossible(th, om, alpha_rad=alpha_rad, p_rad_s=p_rad_s)
    hit = np.flatnonzero(hit)
    if not hit.size:
        return None
    k = int(hit[0])
    if bad[k]:
        return k, "diverged"
    if certain[k]:
        return k, "flat" if abs(th[k]) >= FLAT_ANGLE_RAD else "overturn"
    return k, "trapped"


def decision_index(t_s, theta_rad, theta_dot_rad_s, *, alpha_rad: float, t_pulse_end_s: float) -> tuple[int, bool]:
    """The sample at which the classifier decides, and whether that decision is an overturn.

    The first sample at which the overturn is certain (rule 2: flat on its side, or after the
    excitation ``|θ| > α`` moving outward), else the last sample. The one validity rule
    (:mod:`~rockbench.reference_solver.validity`) and the rigid model's contact demand
    (:mod:`~rockbench.reference_solver.demand`) judge the motion up to this sample.
    """
    t = np.asarray(t_s, dtype=float)
    th = np.asarray(theta_rad, dtype=float)
    thd = np.asarray(theta_dot_rad_s, dtype=float)
    certain = overturn_certain(t, th, thd, alpha_rad=alpha_rad, t_pulse_end_s=t_pulse_end_s)
    if certain.any():
        return int(np.argmax(certain)), True
    return th.size - 1, False


def _last_outward_alpha_crossing(t, th, alpha):
    a = np.abs(th)
    below = a <= alpha
    idx = np.nonzero(below[:-1] & ~below[1:])[0]
    if idx.size == 0:
        return float(t[0]) if a[0] > alpha else math.nan
    i = int(idx[-1])
    # linear interpolation of the crossing inside the sample interval
    f = (alpha - a[i]) / (a[i + 1] - a[i]) if a[i + 1] != a[i] else 0.0
    return float(t[i] + f * (t[i + 1] - t[i]))
