"""The free-rocking test of the contact engines: how long it runs and how η is read from it.

A block released from rest at ``θ0 = theta0_frac·α`` rocks freely on the table; the restitution
coefficient η of each impact is read from what the engine measured. There is one reader,
:data:`PEAK_RATIO` (the energy-consistent ratio of successive peak amplitudes, from θ(t) alone);
two engines keep their own, because their calibrations were tuned with them and the peak ratio
made them pick worse settings (measured, docs/engines.md):

* :data:`ENERGY_RATIO` (PyBullet): the ratio of the body's mechanical energy between impacts;
* :func:`crossing_velocity_etas` (MuJoCo, MuJoCo Warp): ``|θ̇|`` read where ``|θ|`` crosses a small
  angle around each impact, carried to θ = 0 with the free-rocking energy.

An :class:`EtaReader` names a reader, how long its test runs and how it is recorded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..reference_solver.model import G, Block
from .base import uplift_tol_rad

__all__ = ["FREE_ROCKING_IMPACTS", "FREE_ROCKING_METHOD", "ETA_READ_FRAC", "EtaReader", "PEAK_RATIO", "ENERGY_RATIO",
           "free_rocking_duration_s", "free_rocking_etas", "energy_ratio_etas", "crossing_velocity_etas",
           "first_quarter_s", "swings"]

#: Impacts a free-rocking test measures (calibrations average their η) [-]
FREE_ROCKING_IMPACTS = 4

#: How :func:`free_rocking_etas` reads η (recorded with every restitution measurement)
FREE_ROCKING_METHOD = ("energy-consistent amplitude ratio of successive peaks: "
                       "η = sqrt[(cos(α − θ_next) − cos α)/(cos(α − θ) − cos α)]")

#: |θ| at which :func:`crossing_velocity_etas` reads η on the way into and out of an impact, as a
#: fraction of α [-]
ETA_READ_FRAC = 0.1


@dataclass(frozen=True)
class EtaReader:
    """One way of reading η from a free-rocking test.

    Attributes
    ----------
    name : str
        Short name (``peak-ratio``, ``energy-ratio``).
    method : str
        What :class:`~rockbench.engines.base.RestitutionMeasurement` records as its ``method``.
    duration_s : callable
        ``duration_s(block, theta0_frac)``: how long the test runs [s].
    etas : callable
        ``etas(block, motion, theta0_rad)``: η per impact [-] from the run's
        :class:`~rockbench.engines.skeleton.Motion`.
    """

    name: str
    method: str
    duration_s: Callable[[Block, float], float]
    etas: Callable[..., list]


def free_rocking_duration_s(block: Block, theta0_frac: float, n_impacts: int = FREE_ROCKING_IMPACTS) -> float:
    """How long a free-rocking test from rest at ``theta0_frac·α`` runs to see ``n_impacts`` whole
    swings [s]: ``2n + 1`` quarter periods of the linearised rocking from θ0 (later swings are only
    shorter, docs/physics.md §7), ``T/4 = arcosh(1/(1 − θ0/α))/p``, with 20 % and 0.05 s to spare."""
    quarter = math.acosh(1.0 / (1.0 - float(theta0_frac))) / block.p_rad_s
    return quarter * (2 * n_impacts + 1) * 1.2 + 0.05


def swings(theta_rad, uplift_tol_rad: float) -> list[tuple[int, int]]:
    """The swings of a rocking θ(t): maximal runs of samples on one side of the base (``|θ|`` above
    the tolerance [rad]), each ``(first, last + 1)``; an impact separates two swings of opposite
    sides, samples standing on the base between them belong to neither."""
    th = np.asarray(theta_rad, dtype=float)
    side = np.where(th > uplift_tol_rad, 1, np.where(th < -uplift_tol_rad, -1, 0))
    idx = np.flatnonzero(side != 0)
    if idx.size == 0:
        return []
    out = []
    start = idx[0]
    for a, b in zip(idx[:-1], idx[1:]):
        if side[b] != side[a]:
            out.append((int(start), int(a) + 1))
            start = b
    out.append((int(start), int(idx[-1]) + 1))
    return out


def free_rocking_etas(theta_rad, alpha_rad: float, theta0_rad: float, uplift_tol_rad: float,
                      n_impacts: int) -> tuple[list[float], list[float]]:
    """η of the first impacts of a block released at rest from ``theta0_rad``, from its θ(t) alone.

    Between impacts a freely rocking rigid block keeps ``E = ½θ̇² + p²cos(α − |θ|)``, so the
    kinetic energy at θ = 0 just before the impact that ends a swing of peak ``|θ|`` is
    ``p²(cos(α − θ_peak) − cos α)``; η, the ratio of angular velocities at θ = 0 after and before
    an impact, is then ``√[(cos(α − θ_{i+1}) − cos α)/(cos(α − θ_i) − cos α)]`` for successive
    peaks. Of the three ways the engines read η this is the most robust for a rigid-like contact:

    * it needs only θ(t), which every engine reports (no body velocities, no energy bookkeeping);
    * a peak is where θ̇ = 0, so reading it from samples errs by O((θ̇Δt)²) only, and the few
      steps over which a soft contact spreads an impact do not enter (a velocity ratio read near
      θ = 0, where θ̇ is largest and the contact is still acting, depends on where one samples);
    * it is exact for the rigid model (tested against the reference solver, which applies η
      exactly at every impact).

    Parameters
    ----------
    theta_rad : array_like
        θ samples from the release [rad].
    alpha_rad : float
        The block's α [rad].
    theta0_rad : float
        Release angle [rad] (the first peak).
    uplift_tol_rad : float
        |θ| below which the block counts as standing on its base (separates the swings) [rad].
    n_impacts : int
        Impacts measured at most [-].

    Returns
    -------
    etas : list of float
        η per impact [-] (fewer than ``n_impacts`` when the rocking dies out or the samples end).
    peaks : list of float
        The peak amplitudes |θ| used, the release angle first [rad].
    """
    th = np.asarray(theta_rad, dtype=float)
    peaks = [abs(float(theta0_rad))] + [float(np.max(np.abs(th[a:b]))) for a, b in swings(th, uplift_tol_rad)]
    # the first swing is the release itself (its peak is θ0): keep θ0 once
    peaks = [peaks[0]] + peaks[2:]
    ke = np.cos(alpha_rad - np.asarray(peaks)) - math.cos(alpha_rad)
    etas: list[float] = []
    for i in range(min(len(ke) - 1, n_impacts)):
        if ke[i] <= 0 or ke[i + 1] <= 0:
            break
        etas.append(float(math.sqrt(ke[i + 1] / ke[i])))
    return etas, peaks[: n_impacts + 1]


def energy_ratio_etas(block: Block, motion, n_impacts: int = FREE_ROCKING_IMPACTS) -> list[float]:
    """η of the first ``n_impacts`` impacts of a free-rocking run from the body's energy (PyBullet's reader).

    Between impacts the block's mechanical energy ``E = ½m(ẋ² + ż²) + ½I_c θ̇² + m g z_c`` is
    constant and its excess over standing at rest, ``K = E − m g h/2``, is the kinetic energy at
    θ = 0; so ``η_i = √(K_{i+1}/K_i)``, with ``K`` the median over the middle half of each swing
    (the last swing, perhaps cut by the end of the run, is not used; a swing shorter than 8 samples
    ends the measurement). Robust to the step in which an impact falls; the peak ratio scatters by
    ±0.03 between the impacts of Bullet's compliant contact, which its calibration then refuses.
    """
    m, h = block.mass_kg, block.height_m
    vx, vz, om = motion.vx_m_s, motion.vz_m_s, motion.theta_dot_rad_s
    E = 0.5 * m * (vx * vx + vz * vz) + 0.5 * block.inertia_cm_kg_m2 * om * om + m * G * motion.z_m
    K = E - m * G * h / 2
    Ks = []
    for a, b in swings(motion.theta_rad, uplift_tol_rad(block))[:-1]:
        if b - a < 8:
            break
        Ks.append(float(np.median(K[a + (b - a) // 4: a + 3 * (b - a) // 4])))
    etas = []
    for k0, k1 in zip(Ks[:-1], Ks[1:]):
        if k0 <= 0 or k1 < 0 or len(etas) >= n_impacts:
            break
        etas.append(math.sqrt(k1 / k0))
    return etas


def crossing_velocity_etas(theta_rad, theta_dot_rad_s, alpha_rad: float, p_rad_s: float,
                            read_frac: float = ETA_READ_FRAC) -> list[float]:
    """η of each impact of a freely rocking block from θ̇ read near each impact (MuJoCo's reader).

    A soft contact spreads an impact over several steps, so velocities are not read at θ = 0
    itself but where ``|θ|`` crosses ``θc = read_frac·α`` on the way in (the last crossing before
    the sign change) and on the way out (the first after it), both carried to θ = 0 with the
    rigid block's free-rocking energy ``½θ̇² + p²cos(α − |θ|)`` (paper eqs (1)–(2)):
    ``θ̇₀² = θ̇c² + 2p²(cos(α − θc) − cos α)``. An excursion that does not reach ``θc`` ends
    the measurement.

    Parameters
    ----------
    theta_rad, theta_dot_rad_s : array_like
        Samples of θ [rad] and θ̇ [rad/s].
    alpha_rad, p_rad_s : float
        The block's α [rad] and p [rad/s].
    read_frac : float
        ``θc/α`` [-].

    Returns
    -------
    list of float
        ``θ̇₀⁺/θ̇₀⁻`` per impact [-].
    """
    th = np.asarray(theta_rad, dtype=float)
    thd = np.asarray(theta_dot_rad_s, dtype=float)
    thc = read_frac * alpha_rad
    a = np.abs(th)
    inward = np.nonzero((a[:-1] > thc) & (a[1:] <= thc))[0]
    outward = np.nonzero((a[:-1] < thc) & (a[1:] >= thc))[0]
    add = 2.0 * p_rad_s**2 * (math.cos(alpha_rad - thc) - math.cos(alpha_rad))

    def v0(i):
        f = (a[i] - thc) / (a[i] - a[i + 1])
        v = thd[i] + f * (thd[i + 1] - thd[i])
        return math.sqrt(v * v + add)

    etas = []
    for i in inward:
        later = outward[outward > i]
        if later.size == 0:
            break
        j = int(later[0])
        if np.sign(th[j + 1]) == np.sign(th[i]):
            break  # it came back out on the same side: no impact, the rocking has died out
        etas.append(v0(j) / v0(i))
    return etas


def first_quarter_s(t_s, theta_rad) -> float | None:
    """Time of the first sign change of θ (the first impact of a release), interpolated [s]; None
    when θ never changes sign."""
    th = np.asarray(theta_rad)
    zc = np.nonzero(np.sign(th[1:]) != np.sign(th[:-1]))[0]
    if not zc.size:
        return None
    i = int(zc[0])
    return float(t_s[i] + (t_s[i + 1] - t_s[i]) * th[i] / (th[i] - th[i + 1]))


def _peak_ratio(block: Block, motion, theta0_rad: float) -> list:
    return free_rocking_etas(motion.theta_rad, block.alpha_rad, theta0_rad, uplift_tol_rad(block),
                             FREE_ROCKING_IMPACTS)[0]


def _energy_ratio_duration_s(block: Block, theta0_frac: float) -> float:
    # each swing lasts at most half the linearised period from the release angle,
    # T = (4/p)·arcosh(1/(1 − θ0/α)) (docs/physics.md §7); n + 2 swings with 20 % to spare
    period = 4.0 / block.p_rad_s * math.acosh(1.0 / (1.0 - float(theta0_frac)))
    return 1.2 * (FREE_ROCKING_IMPACTS + 2) * period / 2.0


#: The shared reader: the energy-consistent peak ratio (:func:`free_rocking_etas`)
PEAK_RATIO = EtaReader("peak-ratio", FREE_ROCKING_METHOD,
                       lambda block, frac: free_rocking_duration_s(block, frac, FREE_ROCKING_IMPACTS), _peak_ratio)

#: PyBullet's reader: the body's energy between impacts (:func:`energy_ratio_etas`)
ENERGY_RATIO = EtaReader("energy-ratio",
                         f"energy ratio of the first {FREE_ROCKING_IMPACTS} impacts: "
                         "sqrt(K_next/K), K = mechanical energy above rest between impacts",
                         _energy_ratio_duration_s,
                         lambda block, motion, theta0_rad: energy_ratio_etas(block, motion, FREE_ROCKING_IMPACTS))
