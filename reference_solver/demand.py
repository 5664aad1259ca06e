"""What the rigid rocking model asks of the table: the pivot's normal and friction force (docs/physics.md §9).

The rigid model assumes the pivot corner neither lifts nor slides. Along a trajectory the pivot must
then supply, in the table's frame, with ``φ = α·s − θ`` (``s`` the side it pivots on) and the centre
of mass at ``(x, z) = (−R·sinφ, R·cosφ)`` from the pivot::

    z̈_cm = R·(sinφ·θ̈ − cosφ·θ̇²)        ẍ_cm = R·(sinφ·θ̇² + cosφ·θ̈)
    N = m·(g + z̈_cm)                      F = m·(ü + ẍ_cm)

Divided by ``m·g`` and with ``R/g = 3/(4p²)`` (since ``p² = 3g/(4R)``) both need only α and p::

    N/(m·g) = 1 + 3/(4p²)·(sinφ·θ̈ − cosφ·θ̇²)
    F/(m·g) = ü/g + 3/(4p²)·(sinφ·θ̇² + cosφ·θ̈)

Where ``N < 0`` the model needs the table to pull the block down (a real block, and any engine,
lifts off: ``lift-required``); where ``|F|/N > μ`` it must slide (``slip-required``). Near ``N → 0``
the ratio depends on the time step; the sign of N is the robust criterion.

**The window** is the motion the classifier judges: from the first uplift to its decision, the first
sample at which the outcome is certain (the block lies on its side, ``|θ| ≥ π/2 − 0.01``, or the
excitation has ended and ``|θ| > α`` moving outward), or the end of the run. A block past α while
the table still shakes is not yet decided (the table may push it back, or, where ``N < 0``, throw
it), so that stretch is in; the free fall after the pulse is not. The one validity rule
(:mod:`.validity`) judges an engine's slip and jump over the same window. A block resting on its
base (before uplift, or put to rest by a Zeno series) needs ``N = m·g`` and
``|F|/N = |ü|/g < tanα``: never a violation, so rest samples are skipped.

**Impacts.** An impact is an impulse, not a force: the samples just before and just after it are
in the window, the impulse itself is not. For Housner's impact (the impulse at the new pivot
corner, the block sticking there) the impulse's own friction demand is ``|J_x|/J_z =
(h/b)·(1 − η)/(1 + η)`` (:func:`impact_friction_ratio`): 0.32 for B3M and 0.16 for B6M, far below
any anti-slip friction used here, and ``J_z > 0`` always (the block lands). So impacts never need
the table to pull or the corner to slide, and leaving them out loses nothing; soft-contact engines
spread the same impulse over a few steps, which their own slip/jump checks see.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rockbench.reference_solver.model import G


@njit(cache=True)
def demand_point(th, thd, thdd, u_g, s, alpha, p2):
    """``(N/(m·g), F/(m·g))`` of one state on side ``s`` (see the module docstring) [-].

    Parameters: rotation [rad], angular velocity [rad/s], angular acceleration [rad/s^2], table
    acceleration over g [-], side (±1), slenderness angle [rad], p² [rad^2/s^2].
    """
    phi = alpha * s - th
    sp = math.sin(phi)
    cp = math.cos(phi)
    k = 0.75 / p2
    n = 1.0 + k * (sp * thdd - cp * thd * thd)
    f = u_g + k * (sp * thd * thd + cp * thdd)
    return n, f


def contact_demand(theta_rad, theta_dot_rad_s, theta_ddot_rad_s2, table_acc_mps2, alpha_rad: float,
                   p_rad_s: float, side=None):
    """Normal and friction force the pivot must supply, over ``m·g``, at each sample (vectorised).

    Parameters
    ----------
    theta_rad, theta_dot_rad_s, theta_ddot_rad_s2 : array_like
        The samples [rad], [rad/s], [rad/s^2].
    table_acc_mps2 : array_like
        The table's acceleration ``ü`` at the samples [m/s^2].
    alpha_rad, p_rad_s : float
        Slenderness angle [rad] and frequency parameter [rad/s].
    side : array_like, optional
        Pivot side ±1 per sample (0: resting on the base); default ``sgn θ``.

    Returns
    -------
    normal_mg, friction_mg : ndarray
        ``N/(m·g)`` and ``F/(m·g)`` [-]; NaN where the block rests (side 0).
    """
    th = np.asarray(theta_rad, dtype=float)
    thd = np.asarray(theta_dot_rad_s, dtype=float)
    thdd = np.asarray(theta_ddot_rad_s2, dtype=float)
    s = np.sign(th) if side is None else np.asarray(side, dtype=float)
    phi = alpha_rad * s - th
    k = 0.75 / p_rad_s**2
    n = 1.0 + k * (np.sin(phi) * thdd - np.cos(phi) * thd**2)
    f = np.asarray(table_acc_mps2, dtype=float) / G + k * (np.sin(phi) * thd**2 + np.cos(phi) * thdd)
    rest = s == 0
    return np.where(rest, np.nan, n), np.where(rest, np.nan, f)


def impact_friction_ratio(width_m: float, height_m: float, eta: float) -> float:
    """``|J_x|/J_z`` of Housner's impact impulse at the new pivot corner [-] (module docstring).

    Before the impact the block turns about one corner with ``θ̇⁻``, after it about the other with
    ``η·θ̇⁻``; the centre of mass's velocity change is ``((h/2)(η − 1)θ̇⁻, ±(b/2)(η + 1)θ̇⁻)``.
    """
    return (height_m / width_m) * (1.0 - eta) / (1.0 + eta)


#: indices of the running-demand vector used by the solver's kernels
D_MIN_N, D_MAX_F = range(2)
N_DEMAND = 2


@njit(cache=True)
def demand_start():
    """A running demand with no sample yet: ``[1, 0]`` (``N = m·g`` and no friction: never lifted)."""
    dm = np.zeros(N_DEMAND)
    dm[D_MIN_N] = 1.0
    return dm


@njit(cache=True)
def demand_update(dm, th, thd, thdd, u_g, s, alpha, p2):
    """Add one sample on side ``s`` (0: at rest, skipped) to a running demand ``dm``
    (``[min N/(m·g), max |F|/N]``, from :func:`demand_start`); ``|F|/N`` counts where ``N > 0``."""
    if s == 0.0:
        return
    n, f = demand_point(th, thd, thdd, u_g, s, alpha, p2)
    if n < dm[D_MIN_N]:
        dm[D_MIN_N] = n
    if n > 0.0 and abs(f) / n > dm[D_MAX_F]:
        dm[D_MAX_F] = abs(f) / n
