"""The block's energy and the exact fate of free rocking after the pulse (docs/physics.md §2).

Energies here are per unit corner inertia ``I_A`` [rad^2/s^2]:

- nonlinear: ``E = ½θ̇² + p²·cos(α − |θ|)``; the barrier (block balanced on its corner) is
  ``E = p²``, the block at rest on its base has ``E = p²·cos α``;
- linearised: ``E = ½θ̇² − ½p²·(|θ| − α)²``; barrier ``0``, rest ``−½p²α²``.

With no excitation left, E is conserved between impacts and every impact (at θ = 0) multiplies the
kinetic energy there by ``η²``. A block moving outward (``θ·θ̇ > 0``, or leaving the base at
``θ = 0``, i.e. just after an impact) overturns exactly when
``E > barrier``; a block moving inward first hits the base once, so it overturns exactly when the
post-impact energy exceeds the barrier. No later impact can change that, since energy only falls.
"""

from __future__ import annotations

import numpy as np

#: Relative rise of the energy after the pulse, over the barrier height, beyond which a run gained
#: energy (the validity rule's ``energy-gain``) [-]; also the margin under the barrier below which a
#: freely rocking block can no longer overturn (:func:`~rockbench.reference_solver.classify.overturn_impossible`).
ENERGY_GAIN_TOL = 0.05


def energy_rad2_s2(theta_rad, theta_dot_rad_s, alpha_rad: float, p_rad_s: float, linearized: bool = False):
    """Mechanical energy per unit corner inertia [rad^2/s^2] (vectorised)."""
    th = np.abs(np.asarray(theta_rad, dtype=float))
    kin = 0.5 * np.asarray(theta_dot_rad_s, dtype=float) ** 2
    if linearized:
        return kin - 0.5 * p_rad_s**2 * (th - alpha_rad) ** 2
    return kin + p_rad_s**2 * np.cos(alpha_rad - th)


def barrier_energy_rad2_s2(alpha_rad: float, p_rad_s: float, linearized: bool = False) -> float:
    """Energy of the block balanced on its corner (|θ| = α, θ̇ = 0) [rad^2/s^2]."""
    return 0.0 if linearized else p_rad_s**2


def base_energy_rad2_s2(alpha_rad: float, p_rad_s: float, linearized: bool = False) -> float:
    """Potential energy at θ = 0 [rad^2/s^2]."""
    return -0.5 * p_rad_s**2 * alpha_rad**2 if linearized else p_rad_s**2 * np.cos(alpha_rad)


def free_rocking_fate(theta_rad: float, theta_dot_rad_s: float, alpha_rad: float, p_rad_s: float,
                      eta: float, linearized: bool = False) -> tuple[bool, int]:
    """Decide exactly whether a freely rocking block overturns.

    Parameters
    ----------
    theta_rad, theta_dot_rad_s : float
        State when the excitation has ended [rad], [rad/s].
    alpha_rad, p_rad_s : float
        Slenderness angle [rad] and frequency parameter [rad/s].
    eta : float
        Coefficient of restitution applied at the next impact [-].
    linearized : bool
        Use the linearised energy.

    Returns
    -------
    (overturns, impacts_before)
        Whether it overturns, and how many impacts (0 or 1) happen before it does; when it does
        not overturn the count is 0 (the endless decaying series after is not counted here).
    """
    E = float(energy_rad2_s2(theta_rad, theta_dot_rad_s, alpha_rad, p_rad_s, linearized))
    Eb = barrier_energy_rad2_s2(alpha_rad, p_rad_s, linearized)
    if theta_rad == 0.0 and theta_dot_rad_s == 0.0:
        return False, 0
    if abs(theta_rad) > alpha_rad and theta_rad * theta_dot_rad_s >= 0.0:
        return True, 0  # already past the corner's balance point and not returning
    # θ = 0 with θ̇ ≠ 0 is a state just after an impact (or an uplift): the block is leaving the
    # base, so it counts as outward and no further impact is applied
    outward = theta_rad * theta_dot_rad_s > 0.0 or theta_rad == 0.0
    if outward:
        if E > Eb:
            return True, 0
        # falls back, hits the base, then moves out on the other side with less energy
        return False, 0
    if abs(theta_rad) > alpha_rad and E <= Eb:
        return True, 0  # moving inward past the balance point without enough energy to get back over it
    E0 = base_energy_rad2_s2(alpha_rad, p_rad_s, linearized)
    after = E0 + eta**2 * (E - E0)
    return (after > Eb), (1 if after > Eb else 0)
