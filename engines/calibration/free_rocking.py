"""The free-rocking test of the contact engines: how long it runs, how η is read from it, and
what else the calibration's pick reads from the run.

A block released from rest at ``θ0 = theta0_frac·α`` rocks freely on the table; the restitution
coefficient η of each impact is read from what the engine measured by the one reader,
:data:`PEAK_RATIO` (the energy-consistent ratio of successive peak amplitudes, from θ(t) alone).
It was chosen over two others (θ̇ read where |θ| crosses 0.1·α around each impact; the ratio of
the body's mechanical energy between impacts) by testing all three on the reference solver's
trajectories, where η is known exactly, sampled at engine steps (tests/engines/test_eta_reader.py):
all three read the rigid model's η to 2e-4 at steps up to 2 ms, but the crossing velocity loses
impacts once the swings no longer reach 0.1·α (two of four for the wide blocks at η_H), and the
energy ratio reads a soft contact's resting sink as kinetic energy (a sink of 0.1 mm biases B6L's
η by 0.3–0.5 %, more at each impact), while the peak ratio needs only θ and is blind to a sink.

:func:`contact_figures` reads, from the same run's bottom corners, the resting sink (how deep the
pivot sits in its contact: the pick's measure of stiffness) and the highest clearance of the lower
corner (a hop: both corners in the air).

An :class:`EtaReader` names the reader, how long its test runs and how it is recorded.

The test itself is a function of the adapter, not a method an adapter inherits:
:func:`measure_restitution` (checked, at the engine's free-rocking step, with the settings in force),
:func:`free_rocking_run` (one run of given settings, unchecked; the base's ``measure_many`` hook runs
it per setting) and :func:`measured` (what a run measured, for an engine that runs its free rocking
its own way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from rockbench.reference_solver.errors import ConfigError, check_positive
from rockbench.reference_solver.model import Block
from rockbench.reference_solver.restitution import Restitution
from rockbench.reference_solver.validity import uplift_tol_rad
from rockbench.engines.contract import RestitutionMeasurement
from rockbench.engines.errors import EngineError

__all__ = ["FREE_ROCKING_IMPACTS", "FREE_ROCKING_METHOD", "EtaReader", "PEAK_RATIO", "free_rocking_duration_s",
           "free_rocking_etas", "first_quarter_s", "swings", "contact_figures", "measure_restitution", "free_rocking_run",
           "measured", "free_rocking_step", "has_contact_model", "require_contact"]

#: Impacts a free-rocking test measures (calibrations average their η) [-]
FREE_ROCKING_IMPACTS = 4

#: How :func:`free_rocking_etas` reads η (recorded with every restitution measurement)
FREE_ROCKING_METHOD = ("energy-consistent amplitude ratio of successive peaks: "
                       "η = sqrt[(cos(α − θ_next) − cos α)/(cos(α − θ) − cos α)]")

@dataclass(frozen=True)
class EtaReader:
    """One way of reading η from a free-rocking test.

    Attributes
    ----------
    name : str
        Short name (``peak-ratio``).
    method : str
        What :class:`~rockbench.engines.contract.RestitutionMeasurement` records as its ``method``.
    duration_s : callable
        ``duration_s(block, theta0_frac)``: how long the test runs [s].
    etas : callable
        ``etas(block, theta_rad, theta0_rad)``: η per impact [-] from the run's θ samples [rad].
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
    peaks. Of the three ways tried for reading η this is the most robust for a rigid-like contact:

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


def first_quarter_s(t_s, theta_rad) -> float | None:
    """Time of the first sign change of θ (the first impact of a release), interpolated [s]; None
    when θ never changes sign."""
    th = np.asarray(theta_rad)
    zc = np.nonzero(np.sign(th[1:]) != np.sign(th[:-1]))[0]
    if not zc.size:
        return None
    i = int(zc[0])
    return float(t_s[i] + (t_s[i + 1] - t_s[i]) * th[i] / (th[i] - th[i + 1]))


def contact_figures(block: Block, theta_rad, corner_z_m) -> tuple[float, float]:
    """The resting sink and the highest hop of a free-rocking run, from its bottom corners.

    Parameters
    ----------
    block : Block
    theta_rad : array_like
        θ samples from the release [rad].
    corner_z_m : array_like
        ``(n, c)`` clearances of the bottom contact points above the table top [m] (negative: in
        the contact).

    Returns
    -------
    sink_m : float
        The pivot's median penetration over the release swing (release to first impact), the
        lowest point's depth below the table top [m]; NaN when the run has no swing.
    hop_m : float
        The highest clearance of the lowest contact point over the run [m]: above zero, every
        point is off the table at once.
    """
    z = np.asarray(corner_z_m, dtype=float)
    low = np.min(z, axis=1)
    sw = swings(theta_rad, uplift_tol_rad(block))
    sink = float(np.median(np.maximum(-low[: sw[0][1]], 0.0))) if sw else math.nan
    hop = float(np.nanmax(low)) if low.size else math.nan
    return sink, hop


def _peak_ratio(block: Block, theta_rad, theta0_rad: float) -> list:
    return free_rocking_etas(theta_rad, block.alpha_rad, theta0_rad, uplift_tol_rad(block),
                             FREE_ROCKING_IMPACTS)[0]


#: The shared reader: the energy-consistent peak ratio (:func:`free_rocking_etas`)
PEAK_RATIO = EtaReader("peak-ratio", FREE_ROCKING_METHOD,
                       lambda block, frac: free_rocking_duration_s(block, frac, FREE_ROCKING_IMPACTS), _peak_ratio)


def measure_restitution(ad, block: Block, *, theta0_frac: float = 0.5, dt_s: float | None = None,
                        settings: dict | None = None) -> RestitutionMeasurement:
    """Free rocking of contact engine ``ad`` from rest at ``theta0_frac·α`` on the +x corner, no
    excitation: η impact by impact read by the one reader (:data:`PEAK_RATIO`), the run's resting sink
    and hop (:func:`contact_figures`).

    Parameters
    ----------
    ad : ContactEngine, or an engine without a contact model that has a ``measure_restitution(block,
        theta0_frac=, dt_s=)`` of its own (then that is called)
    block : Block
    theta0_frac : float
        Release angle as a fraction of α [-].
    dt_s : float, optional
        Time step [s] (default: :func:`free_rocking_step`'s: the engine's own as shipped, else its
        ``fixed_dt_s``).
    settings : dict, optional
        Resolved settings to measure (default: those in force, ``ad.resolve`` to Housner's η).
    """
    own = getattr(ad, "measure_restitution", None)
    if callable(own) and not has_contact_model(ad):
        # an engine without a contact model of rockbench's that measures its own free rocking (the one
        # hook of the general contract for it): its measurement, as it makes it
        return own(block, theta0_frac=theta0_frac, dt_s=dt_s)
    require_contact(ad)
    if not 0.0 < float(theta0_frac) < 1.0:
        raise ConfigError(f"theta0_frac must be in (0, 1), got {theta0_frac!r}.")
    dt = free_rocking_step(ad, dt_s)
    if dt > 0.01:
        raise ConfigError(f"--dt must be in (0, 0.01] s for a free-rocking test, got {dt!r}.")
    s = ad.resolve(block, Restitution(), dt_s=dt) if settings is None else settings
    return free_rocking_run(ad, block, s, dt, theta0_frac)


def free_rocking_step(ad, dt_s: float | None = None) -> float:
    """The step of a free-rocking test or a calibration of contact engine ``ad`` asked for without one,
    outside any case (:func:`measure_restitution`,
    :func:`~rockbench.engines.calibration.routine.calibrate`) [s]: ``dt_s`` where given; as shipped the
    engine's own step (``own_dt_s``, else ``fixed_dt_s``); otherwise ``fixed_dt_s``. (A case's step is
    :func:`~rockbench.engines.calibration.time_step.step_for`'s; give ``dt_s=step_for(ad, block, eta)``
    to test at it.)"""
    if dt_s is not None:
        return check_positive("--dt", dt_s, "s")
    return ad.own_dt_s if ad.as_shipped() and ad.own_dt_s is not None else ad.fixed_dt_s


def has_contact_model(ad) -> bool:
    """Whether ``ad`` is a contact engine: one with the contact base's free-rocking hook (``measure_many``)."""
    return callable(getattr(ad, "measure_many", None))


def require_contact(ad) -> None:
    """A ConfigError (exit 2) unless ``ad`` is a contact engine (:func:`has_contact_model`): an engine
    without a contact model (the reference) has nothing to measure or calibrate."""
    if not has_contact_model(ad):
        raise ConfigError(f"engine {ad.name!r} has no contact model to calibrate; "
                          "calibrate applies to engines such as mujoco, pybullet, exudyn.")


def free_rocking_run(ad, block: Block, s: dict, dt: float, theta0_frac: float) -> RestitutionMeasurement:
    """The free-rocking test of :func:`measure_restitution` with resolved settings ``s`` at step ``dt``
    [s], unchecked: one run of ``ad.run_worlds``, :func:`measured`."""
    theta0 = float(theta0_frac) * block.alpha_rad
    tr, motion = ad.run_worlds(block, s, dt, [None], theta0, PEAK_RATIO.duration_s(block, theta0_frac))[0]
    return measured(ad, block, s, dt, theta0, tr, motion)


def measured(ad, block: Block, s: dict, dt: float, theta0: float, tr, motion) -> RestitutionMeasurement:
    """What a free-rocking run of ``ad`` from ``theta0`` [rad] (its trajectory and motion) measured: η
    per impact by the one reader, the resting sink and hop, the first impact's time; an EngineError
    where the engine halted before the impacts were measured."""
    etas = PEAK_RATIO.etas(block, motion.theta_rad, theta0)
    if "engine_stopped" in tr.diagnostics and len(etas) < FREE_ROCKING_IMPACTS:
        raise EngineError(f"free rocking: {tr.diagnostics['engine_stopped']}")
    sink, hop = contact_figures(block, tr.theta_rad, tr.corner_z_m)
    shown = {k: s.get(k) for k in ("friction", "planar", "drive", *ad.SHIPPED, *ad.MODE_DEFAULTS)}
    return RestitutionMeasurement(etas=[float(e) for e in etas],
                                  eta_mean=float(np.mean(etas)) if etas else math.nan,
                                  eta_std=float(np.std(etas)) if etas else math.nan, theta0_rad=theta0, dt_s=dt,
                                  settings=shown, method=PEAK_RATIO.method, sink_m=sink, hop_m=hop,
                                  first_quarter_s=first_quarter_s(tr.t_s, tr.theta_rad))
