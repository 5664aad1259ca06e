"""What the contact engines (MuJoCo, PyBullet, Exudyn, ...) share: :class:`ContactEngineAdapter`.

A contact engine simulates the block touching the table through the engine's own contact model,
so it needs the same few things whatever the engine:

* **Shared settings, one naming scheme** (units in names): ``settings`` (``calibrated``: contact
  parameters searched so that free rocking reaches the case's η; ``defaults``: the engine as
  shipped), ``drive`` (``inertial`` or ``table``), ``planar``, ``friction`` [-], ``tail_s`` (the
  longest simulated time after the pulse), ``min_tail_s`` (the shortest) and, for engines that
  step in segments between stop checks, ``segment_s``. They are validated here, once.
* **Old names** of settings (before issue 15) are accepted for one release and mapped to the new
  ones by :data:`RENAMED_SETTINGS`, the one table of them (``--set``, suite TOMLs, run.json files
  and cached calibration records all go through :meth:`ContactEngineAdapter.canonical_settings`).
* **One time-step rule**: :meth:`ContactEngineAdapter.check_dt`.
* **One ``resolve()`` flow**: explicit contact settings, else the engine's defaults, else the
  calibration to the case's η (cached); an adapter only says which contact settings are explicit
  (:meth:`~ContactEngineAdapter.explicit_contact`) and builds its concrete settings
  (:meth:`~ContactEngineAdapter._resolved_settings`).
* **One overturn-is-certain early stop**: :func:`~rockbench.reference_solver.classify.overturn_certain`,
  the classifier's own rule, re-exported here.
* **A free-rocking η measurement**: :func:`free_rocking_etas` (amplitude ratio of successive
  peaks, energy-consistent); see its docstring for why this one. Exudyn uses it; MuJoCo and
  PyBullet keep their own for now, since moving them made their calibrations pick worse settings
  (docs/engines.md says what was measured).
* **The body's energy**: :func:`body_energy_j_kg`.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any, ClassVar, Mapping

import numpy as np

from ..reference_solver.classify import overturn_certain
from ..reference_solver.errors import ConfigError
from ..reference_solver.model import G, Block
from ..reference_solver.restitution import Restitution
from .base import CalibrationResult, Case, EngineAdapter, Trajectory

__all__ = ["ContactEngineAdapter", "RENAMED_SETTINGS", "SETTINGS_MODES", "DRIVES", "FREE_ROCKING_IMPACTS",
           "FREE_ROCKING_METHOD", "body_energy_j_kg", "free_rocking_duration_s", "free_rocking_etas",
           "overturn_certain", "CONTACT_LAYOUTS", "POINTS_TRIED", "MAX_CONTACT_POINTS", "first_reached"]

#: ``settings`` values: contact calibrated to the case's η, or the engine as shipped
SETTINGS_MODES = ("calibrated", "defaults")

#: ``drive`` values: the inertial force −m·ü at the centre of mass, or a table moved along u(t)
DRIVES = ("inertial", "table")

#: Old setting names (before issue 15) → new names, per engine. Accepted for one release with a
#: DeprecationWarning; the one place where a rename is recorded.
RENAMED_SETTINGS: Mapping[str, Mapping[str, str]] = {
    "mujoco": {"timeconst": "timeconst_s"},
    "pybullet": {"contact_stiffness": "contact_stiffness_n_m", "contact_damping": "contact_damping_n_s_m",
                 "contact_breaking_threshold": "contact_breaking_threshold_m"},
    "exudyn": {"chunk_s": "segment_s", "max_tail_s": "tail_s", "stiffness_n_m": "contact_stiffness_n_m",
               "damping_n_s_m": "contact_damping_n_s_m"},
}

#: Impacts a free-rocking test measures (calibrations average their η) [-]
FREE_ROCKING_IMPACTS = 4

#: How :func:`free_rocking_etas` reads η (recorded with every restitution measurement)
FREE_ROCKING_METHOD = ("energy-consistent amplitude ratio of successive peaks: "
                       "η = sqrt[(cos(α − θ_next) − cos α)/(cos(α − θ) − cos α)]")

#: ``contact`` values: the corners alone, a row of points along the base, or the corners unless the
#: target η is above Housner's (then the row); see docs/contact.md
CONTACT_LAYOUTS = ("auto", "corners", "distributed")

#: Points of a contact along the base that a calibration tries in turn when ``contact_points`` is not
#: set (the first is also the default row)
POINTS_TRIED = (9, 5, 17)

#: The most points a contact along the base may have
MAX_CONTACT_POINTS = 101

_TRUE, _FALSE = ("true", "1"), ("false", "0")


class ContactEngineAdapter(EngineAdapter):
    """Base of the adapters of engines with a contact model (see the module docstring).

    A subclass sets :attr:`SETTINGS` to :attr:`SHARED_SETTINGS` (with its own defaults) plus its
    engine's settings, and implements:

    * :meth:`_validate_engine_settings` (its own settings; the shared ones are checked already),
    * :meth:`explicit_contact` (whether the user gave contact settings that replace calibration),
    * :meth:`_resolved_settings` (the concrete settings, given a calibration or None),
    * ``calibrate`` and ``measure_restitution``, and ``_simulate`` (contract items 3, 8).
    """

    #: the settings every contact engine has, with typical defaults (an adapter may change a default)
    SHARED_SETTINGS: ClassVar[Mapping[str, Any]] = {
        "settings": "calibrated",
        "drive": "inertial",
        "planar": True,
        "friction": 10.0,
        "tail_s": 3.0,
        "min_tail_s": 0.5,
    }

    def __init__(self, **settings):
        super().__init__(**self.canonical_settings(settings, warn=True))
        self._resolved: dict = {}

    # -- names --------------------------------------------------------------------------------
    @classmethod
    def canonical_settings(cls, settings: Mapping[str, Any], *, warn: bool = False) -> dict:
        """``settings`` with old names (:data:`RENAMED_SETTINGS`) replaced by the new ones.

        Giving both an old name and its new name is a ConfigError; ``warn`` emits a
        DeprecationWarning per old name (user input; not for cached records).
        """
        renamed = RENAMED_SETTINGS.get(cls.name, {})
        out = dict(settings)
        for old, new in renamed.items():
            if old not in out:
                continue
            if new in out:
                raise ConfigError(f"{cls.name} setting {old!r} is the old name of {new!r}; give only {new!r}.")
            if warn:
                warnings.warn(f"{cls.name} setting {old!r} is now called {new!r}; the old name goes in the next "
                              "release.", DeprecationWarning, stacklevel=3)
            out[new] = out.pop(old)
        return out

    # -- settings -----------------------------------------------------------------------------
    def _validate_settings(self, s: dict) -> None:
        for key, allowed in (("settings", SETTINGS_MODES), ("drive", DRIVES)):
            if s[key] not in allowed:
                raise ConfigError(f"{self.name} setting {key!r} must be {' or '.join(allowed)}, got {s[key]!r}.")
        self._bool_setting(s, "planar")
        self._number_setting(s, "friction", allow_none=False)
        self._number_setting(s, "tail_s", "s", allow_none=False)
        self._number_setting(s, "min_tail_s", "s", allow_zero=True, allow_none=False)
        if s["min_tail_s"] > s["tail_s"]:
            raise ConfigError(f"{self.name} setting 'min_tail_s' ({s['min_tail_s']:g} s) must not exceed "
                              f"'tail_s' ({s['tail_s']:g} s).")
        if "segment_s" in s:
            self._number_setting(s, "segment_s", "s", allow_none=False)
        self._validate_engine_settings(s)

    def _validate_engine_settings(self, s: dict) -> None:
        """Raise ConfigError for a bad value of an engine-specific setting (default: none)."""

    def _contact_layout_settings(self, s: dict) -> None:
        """Check the ``contact`` layout (:data:`CONTACT_LAYOUTS`) and ``contact_points`` (None, or a
        whole number from 3 to :data:`MAX_CONTACT_POINTS`) of an engine that offers a contact along
        the base."""
        if s["contact"] not in CONTACT_LAYOUTS:
            raise ConfigError(f"{self.name} setting 'contact' must be one of {', '.join(CONTACT_LAYOUTS)}, "
                              f"got {s['contact']!r}.")
        self._whole_setting(s, "contact_points", 3, maximum=MAX_CONTACT_POINTS)

    def _bool_setting(self, s: dict, key: str) -> None:
        """Check that ``s[key]`` is a bool, or a string true/false/1/0, and store it as a bool."""
        v = s[key]
        if isinstance(v, str) and v.lower() in _TRUE + _FALSE:
            v = v.lower() in _TRUE
        if not isinstance(v, bool):
            raise ConfigError(f"{self.name} setting {key!r} must be true or false, got {s[key]!r}.")
        s[key] = v

    # -- the time step ------------------------------------------------------------------------
    def check_dt(self, dt_s: float | None) -> float:
        """The time step a run or a calibration uses [s]: ``dt_s``, or the engine's default when
        None; a ConfigError unless it is a finite number > 0."""
        if dt_s is None:
            return float(self.default_dt_s)
        try:
            dt = float(dt_s)
        except (TypeError, ValueError):
            dt = math.nan
        if not (math.isfinite(dt) and dt > 0.0):
            raise ConfigError(f"--dt must be > 0 s, got {dt_s!r}.")
        return dt

    # -- resolve: explicit, or defaults, or calibrated ---------------------------------------
    def explicit_contact(self) -> bool:
        """Whether contact settings were given that replace the calibration (default: none exist)."""
        return False

    def resolve(self, block: Block, restitution: Restitution, dt_s: float | None = None) -> dict:
        """The concrete settings cases of this block, restitution and time step [s] use (for run.json).

        Explicit contact settings, else (``settings="defaults"``) the engine's defaults, else the
        calibration to the restitution's η at this time step (:meth:`calibrate`, cached on disk);
        then :meth:`_resolved_settings` builds the concrete settings. Memoised per block, η and step.
        """
        dt = self.check_dt(dt_s)
        eta = restitution.eta(block.alpha_rad)
        key = (block.width_m, block.height_m, block.depth_m, block.mass_kg, round(eta, 12), dt)
        if key not in self._resolved:
            cal = None
            if not self.explicit_contact() and self.settings["settings"] == "calibrated":
                cal = self.calibrate(block, eta, dt_s=dt)
            out = self._resolved_settings(block, dt, cal)
            if cal is not None:
                out["calibration"] = self._calibration_summary(cal)
            self._resolved[key] = out
        return dict(self._resolved[key])

    def _resolved_settings(self, block: Block, dt: float, cal: CalibrationResult | None) -> dict:
        """The concrete settings for ``block`` at step ``dt`` [s], with the calibration ``cal`` (None:
        explicit or default contact)."""
        raise NotImplementedError  # pragma: no cover - every contact adapter implements it

    # -- simulation ----------------------------------------------------------------------------
    def _simulate(self, case: Case) -> Trajectory:
        """One case with the resolved settings, for engines that run one case at a time through
        ``self._run(block, settings, dt, pulse)`` (PyBullet, Drake); MuJoCo and Exudyn run their own."""
        dt = self.dt_for(case)
        s = self.resolve(case.block, case.restitution, dt)
        tr = self._run(case.block, s, dt, case.pulse)
        tr.diagnostics.update(self._settings_diagnostics(s))
        return tr

    @staticmethod
    def _settings_diagnostics(resolved: dict) -> dict:
        """What a trajectory's diagnostics record of the resolved settings it ran with: the settings'
        name and, calibrated, the calibration's summary."""
        out = {"settings": resolved["settings"]}
        if "calibration" in resolved:
            out["calibration"] = dict(resolved["calibration"])
        return out

    @staticmethod
    def _calibration_summary(cal: CalibrationResult) -> dict:
        """What run.json records of the calibration behind the resolved settings."""
        return {"eta_target": cal.eta_target, "eta_measured": cal.eta_measured, "eta_std": cal.eta_std,
                "reached": cal.reached, "price": cal.price}

    @staticmethod
    def check_target_eta(target_eta) -> float:
        """A calibration target η as a float, or a ConfigError unless it is in (0, 1]."""
        try:
            t = float(target_eta)
        except (TypeError, ValueError):
            t = math.nan
        if not (math.isfinite(t) and 0.0 < t <= 1.0):
            raise ConfigError(f"the target η must be in (0, 1], got {target_eta!r}.")
        return t


def first_reached(calibrate_n, counts, unit: str) -> CalibrationResult:
    """Calibrate a contact along the base with each number of points in ``counts`` in turn
    (``calibrate_n(n)`` → :class:`CalibrationResult`) and return the first that reaches its target
    at an acceptable price; when none does, the closest (finite η first), its note listing every
    count tried (``"9 points: …"``, ``unit`` naming what the points are)."""
    tried = []
    for n in counts:
        c = calibrate_n(n)
        if c.reached:
            return c
        tried.append(c)
    if len(tried) == 1:
        return tried[0]
    best = min(tried, key=lambda c: abs(c.rel_error) if math.isfinite(c.rel_error) else math.inf)
    return dataclasses.replace(best, note=" | ".join(f"{c.settings['contact_points']} {unit}: {c.note}" for c in tried))


def body_energy_j_kg(block: Block, vx_m_s, vz_m_s, omega_rad_s, zc_m):
    """The block's own mechanical energy per unit mass in the table's frame [J/kg]:
    ``½(v_x² + v_z²) + ½(I_c/m)ω² + g·z_c`` from its centre of mass's velocity relative to the table
    [m/s], its angular velocity about y [rad/s] and its height above the table top [m]. Unlike the
    rigid model's ``½θ̇² + p²cos(α − |θ|)`` it sees a hop after an impact (the energy-gain check)."""
    return 0.5 * (vx_m_s**2 + vz_m_s**2) + 0.5 * block.inertia_cm_kg_m2 / block.mass_kg * omega_rad_s**2 + G * zc_m


def free_rocking_duration_s(block: Block, theta0_frac: float, n_impacts: int = FREE_ROCKING_IMPACTS) -> float:
    """How long a free-rocking test from rest at ``theta0_frac·α`` runs to see ``n_impacts`` whole
    swings [s]: ``2n + 1`` quarter periods of the linearised rocking from θ0 (later swings are only
    shorter, docs/physics.md §7), ``T/4 = arcosh(1/(1 − θ0/α))/p``, with 20 % and 0.05 s to spare."""
    quarter = math.acosh(1.0 / (1.0 - float(theta0_frac))) / block.p_rad_s
    return quarter * (2 * n_impacts + 1) * 1.2 + 0.05


def free_rocking_etas(theta_rad, alpha_rad: float, theta0_rad: float, uplift_tol_rad: float,
                      n_impacts: int) -> tuple[list[float], list[float]]:
    """η of the first impacts of a block released at rest from ``theta0_rad``, from its θ(t) alone.

    Between impacts a freely rocking rigid block keeps ``E = ½θ̇² + p²cos(α − |θ|)``, so the
    kinetic energy at θ = 0 just before the impact that ends a swing of peak ``|θ|`` is
    ``p²(cos(α − θ_peak) − cos α)``; η, the ratio of angular velocities at θ = 0 after and before
    an impact, is then ``√[(cos(α − θ_{i+1}) − cos α)/(cos(α − θ_i) − cos α)]`` for successive
    peaks. Of the three ways the engines read η this is the most robust for a rigid-like contact
    (the others: |θ̇| read near θ = 0, MuJoCo; the ratio of the body's energy between impacts,
    PyBullet):

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
    side = np.where(th > uplift_tol_rad, 1, np.where(th < -uplift_tol_rad, -1, 0))
    nz = np.nonzero(side)[0]
    peaks = [abs(float(theta0_rad))]
    if nz.size:
        start = nz[0]
        for a, b in zip(nz[:-1], nz[1:]):
            if side[b] != side[a]:
                peaks.append(float(np.max(np.abs(th[start:a + 1]))))
                start = b
        peaks.append(float(np.max(np.abs(th[start:]))))
    # the first swing is the release itself (its peak is θ0): keep θ0 once
    peaks = [peaks[0]] + peaks[2:]
    ke = np.cos(alpha_rad - np.asarray(peaks)) - math.cos(alpha_rad)
    etas: list[float] = []
    for i in range(min(len(ke) - 1, n_impacts)):
        if ke[i] <= 0 or ke[i + 1] <= 0:
            break
        etas.append(float(math.sqrt(ke[i + 1] / ke[i])))
    return etas, peaks[: n_impacts + 1]
