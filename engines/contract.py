"""The engine contract, version 2: what every adapter implements, and the objects it exchanges.

An adapter turns a :class:`Case` (a block, a table pulse, a restitution law and the time step it runs
at) into a :class:`Trajectory`: what the engine measured (θ(t), θ̇(t), both bottom corners in the
table's frame, the block's energy) and diagnostics. It decides nothing: :meth:`EngineAdapter.judge`
hands the trajectory to the one shared classifier (:func:`rockbench.reference_solver.classify.classify`)
and the one validity rule (:mod:`rockbench.reference_solver.validity`), so every engine is judged by
the same rules.

A contact engine (an engine with a contact model: MuJoCo, PyBullet, ...) derives from
:class:`~rockbench.engines.contact.ContactEngine` and implements four batch-shaped methods there
(``build``, ``start``, ``advance``, ``read``); everything else is the base's. This module is the
contract every adapter shares, for a subclass of :class:`EngineAdapter`:

1. Declare the contract it is written to: ``CONTRACT_VERSION = 2`` (:data:`CONTRACT_VERSION`; the
   registry and ``rockbench check-adapter`` refuse a plugin written to another one, naming what
   changed and how to port it, docs/engines.md "Porting an adapter to contract 2").
2. Set the class attributes ``name`` (the registry key), ``module`` (the engine's Python module,
   imported lazily) and ``install_hint`` (how to get it), and ``own_dt_s``: the engine's own default
   time step [s] (None where it ships none). Import the engine only inside methods.
3. :attr:`SETTINGS` maps each accepted setting to its default; the base rejects names that are not
   there (ConfigError), and the hook ``validate(settings)`` checks values, with the helpers
   :meth:`number_setting`, :meth:`whole_setting` and :meth:`bool_setting`.
4. ``_simulate(case)`` runs one case (its ``dt_s`` already decided, item 8) and returns a
   :class:`Trajectory`. Angles follow one convention: x is the excitation direction, z is up, θ is the
   rotation about +y, so a positive table acceleration starts a negative θ. Samples start at t = 0 and
   cover at least the pulse (``t_pulse_end_s``).
5. A contact engine reports its measurements in the trajectory: ``corner_x_m`` and ``corner_z_m``
   (the bottom corners, ``(n, k)`` with k ≥ 2, relative to the table and above its top) and, where the
   engine gives the body's state, ``energy_j_kg``. It never raises ``slip``, ``jump`` or
   ``energy-gain`` itself; the only flag an adapter may set is ``diverged`` (non-finite state). The
   reference reports instead the rigid model's contact demand (``min_normal_mg``,
   ``max_friction_ratio``), which the judge turns into ``lift-required`` / ``slip-required``.
6. An exception inside the engine is not caught by ``_simulate``: :meth:`EngineAdapter.run_many`
   turns it into a failed :class:`CellResult` (``engine-error``), so sweeps go on.
7. ``_simulate_many(cases)`` may run many cases at once; results must not depend on how cases are
   batched. :attr:`batching` says how: ``"none"``, ``"native"`` or ``"parallel"`` (a native batch
   that uses every core; maps run it in their own process). A native batch that applies the
   classifier's rule itself implements ``_native_verdicts``; a ``parallel`` adapter may offer
   ``solve_grid(...)`` (verdicts of a grid of harmonic cases as :class:`CellColumns`).
8. The time step is decided once, by one resolver, :meth:`EngineAdapter.posed`: the step given,
   else the engine's (here ``own_dt_s``; a contact engine's rule in
   :func:`~rockbench.engines.calibration.time_step.step_for`). :meth:`run_many` poses every case's
   step with it before anything runs, and the case carries it (``Case.dt_s``) from there on.
9. ``resolve(block, restitution, dt_s)`` returns the concrete settings a case will use, recorded in
   run.json; ``measure_restitution`` and ``calibrate`` belong to engines with a contact model.
10. ``version()`` returns the engine's version string (its module's ``__version__``, else the
    version of the distribution that installed it), or raises
    :class:`~rockbench.engines.errors.EngineUnavailableError` with the install hint.
11. ``default_suite_exclusion()`` and ``device_note()`` (optional classmethods) say why suites of
    every engine leave this one out here, and where it runs.

Subclasses implement the hooks, never the public ``run``, ``run_many`` or ``judge``. Every hook a
base class calls is declared there (:func:`rockbench.engines.hooks.required`): one left out raises
:class:`~rockbench.engines.hooks.MissingHook` saying what to implement, and ``rockbench
check-adapter`` lists them before anything runs.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import time
from dataclasses import dataclass, field, asdict
from importlib import metadata
from typing import Any, ClassVar, Iterable, Literal, Mapping

import numpy as np

from rockbench.reference_solver.classify import Classification, classify
from rockbench.reference_solver.errors import ConfigError, check_positive
from rockbench.engines.errors import EngineUnavailableError
from rockbench.reference_solver.model import Block
from rockbench.reference_solver.pulses import Pulse
from rockbench.reference_solver.restitution import Restitution
from rockbench.reference_solver.validity import (DEFAULT_FRICTION, FLAGS, Measurement, contact_flags, judge_measurement,
                                         jump_tol_m, slip_tol_m, uplift_tol_rad)
from rockbench.engines import CONTRACT_VERSION
from rockbench.engines.hooks import missing_hooks, required
from rockbench.engines.support import DISTRIBUTIONS, version_label

__all__ = ["CONTRACT_VERSION", "Case", "Trajectory", "CellResult", "CellColumns", "RestitutionMeasurement",
           "CalibrationResult", "EngineAdapter", "SETTINGS_MODES", "FLAGS", "jump_tol_m", "slip_tol_m",
           "uplift_tol_rad", "DEVICE_NOTED_ENV"]

#: Set (to "1") in the environment once the user has been told where an engine runs
#: (:meth:`EngineAdapter.device_note`): worker processes inherit it and stay quiet.
DEVICE_NOTED_ENV = "ROCKBENCH_DEVICE_NOTED"

_TRUE, _FALSE = ("true", "1"), ("false", "0")


@dataclass(frozen=True)
class Case:
    """One simulation to run.

    Attributes
    ----------
    block : Block
        The block.
    pulse : Pulse
        The table motion.
    restitution : Restitution
        The restitution law: what the reference applies at impacts, and the target η engines are
        calibrated to.
    dt_s : float or None
        The time step the case runs at [s]; None: not posed yet, the engine's one resolver
        (:meth:`EngineAdapter.posed`) decides it when the case runs.
    linearized : bool
        Linearised equation of motion (reference only).
    """

    block: Block
    pulse: Pulse
    restitution: Restitution = field(default_factory=Restitution)
    dt_s: float | None = None
    linearized: bool = False

    @property
    def eta(self) -> float:
        """The restitution coefficient of this case [-]."""
        return self.restitution.eta(self.block.alpha_rad)

    def to_dict(self) -> dict:
        return {"block": self.block.to_dict(), "pulse": self.pulse.to_dict(),
                "restitution": self.restitution.to_dict(), "eta": self.eta, "dt_s": self.dt_s,
                "linearized": self.linearized}


@dataclass
class Trajectory:
    """What an adapter returns for one case.

    Attributes
    ----------
    t_s : ndarray
        Sample times [s], increasing, from 0.
    theta_rad : ndarray
        Rotation about +y [rad] (see the contract for the sign).
    theta_dot_rad_s : ndarray
        Angular velocity [rad/s].
    t_pulse_end_s : float
        When the excitation ended [s].
    flags : list of str
        Only ``"diverged"`` (non-finite state); every other flag comes from the judge.
    diagnostics : dict
        Anything the engine reports along the way (``steps``, impact list, ...), JSON-serialisable.
    eta_for_tail : float or None
        When the trajectory stops while the block still rocks freely and the adapter wants the
        exact free-rocking decision applied (the reference's fast mode), the η to use [-].
    uplift_tol_rad : float
        |θ| below which the classifier counts the block as not lifted [rad].
    theta_ddot_rad_s2 : ndarray or None
        Angular acceleration at the samples [rad/s^2], when the engine provides it (for histories).
    corner_x_m, corner_z_m : ndarray (n, k) or None
        A contact engine's k ≥ 2 bottom corners relative to the table and above its top [m]
        (:class:`~rockbench.reference_solver.validity.Measurement`); None for the reference.
    energy_j_kg : ndarray or None
        The block's mechanical energy per unit mass in the table's frame [J/kg], where the engine
        gives the body's state.
    min_normal_mg, max_friction_ratio : float or None
        The rigid model's contact demand along the trajectory (reference only,
        :mod:`~rockbench.reference_solver.demand`) [-].
    """

    t_s: np.ndarray
    theta_rad: np.ndarray
    theta_dot_rad_s: np.ndarray
    t_pulse_end_s: float
    flags: list = field(default_factory=list)
    diagnostics: dict = field(default_factory=dict)
    eta_for_tail: float | None = None
    uplift_tol_rad: float = 0.0
    theta_ddot_rad_s2: np.ndarray | None = None
    corner_x_m: np.ndarray | None = None
    corner_z_m: np.ndarray | None = None
    energy_j_kg: np.ndarray | None = None
    min_normal_mg: float | None = None
    max_friction_ratio: float | None = None

    def measurement(self) -> Measurement | None:
        """What the engine measured, for the one validity rule (None without corner positions)."""
        if self.corner_x_m is None or self.corner_z_m is None:
            return None
        return Measurement(self.t_s, self.theta_rad, self.theta_dot_rad_s, self.corner_x_m, self.corner_z_m,
                           self.energy_j_kg)


@dataclass
class CellResult:
    """The verdict on one case: the classifier's outcome and the model's validity.

    Attributes
    ----------
    outcome : str or None
        ``rest``, ``rocking``, ``overturn``; None when the cell failed.
    n_impacts : int
        Impacts up to the decision [-].
    max_abs_theta_rad : float
        Largest |θ| [rad].
    t_overturn_s : float or None
        See :mod:`rockbench.reference_solver.classify` [s].
    t_uplift_s : float or None
        First uplift [s].
    valid : bool
        False when the engine broke the model's assumptions (any flag) or failed.
    flags : list of str
        :data:`FLAGS` raised.
    status : str
        ``ok`` or ``failed``.
    message : str
        Why it failed, or empty.
    wall_s : float
        Wall time of the simulation [s].
    diagnostics : dict
        The adapter's diagnostics and the validity rule's figures (``max_slip_m``, ...).
    min_normal_mg, max_friction_ratio : float or None
        The rigid model's contact demand (reference cells only) [-].
    """

    outcome: str | None
    n_impacts: int = 0
    max_abs_theta_rad: float = math.nan
    t_overturn_s: float | None = None
    t_uplift_s: float | None = None
    valid: bool = True
    flags: list = field(default_factory=list)
    status: str = "ok"
    message: str = ""
    wall_s: float = 0.0
    diagnostics: dict = field(default_factory=dict)
    min_normal_mg: float | None = None
    max_friction_ratio: float | None = None

    @classmethod
    def failed(cls, flag: str, message: str, wall_s: float = 0.0) -> "CellResult":
        return cls(outcome=None, valid=False, flags=[flag], status="failed", message=message, wall_s=wall_s)

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class CellColumns:
    """The verdicts on many successful cases as arrays, one entry per case (a columnar
    :class:`CellResult`; ``solve_grid`` in contract item 7).

    Attributes
    ----------
    outcome : ndarray of int8
        :data:`~rockbench.reference_solver.classify.OUTCOME_CODES` (0 rest, 1 rocking, 2 overturn).
    n_impacts : ndarray of int
        Impacts up to the decision [-].
    max_abs_theta_rad : ndarray
        Largest |θ| [rad].
    t_overturn_s : ndarray
        As in :class:`CellResult`, NaN where None [s] (an overturn decided before θ reached α has NaN too).
    t_uplift_s : ndarray
        First uplift, NaN where the block never lifted [s].
    flag_bits : ndarray of int8
        The flags: bit ``2**k`` for ``flag_names[k]``; 0 where valid.
    flag_names : tuple of str
        What the bits stand for.
    min_normal_mg, max_friction_ratio : ndarray
        The rigid model's contact demand [-].
    wall_s : float
        Wall time per case [s] (the batch's time over its size).
    """

    outcome: np.ndarray
    n_impacts: np.ndarray
    max_abs_theta_rad: np.ndarray
    t_overturn_s: np.ndarray
    t_uplift_s: np.ndarray
    flag_bits: np.ndarray
    flag_names: tuple
    min_normal_mg: np.ndarray
    max_friction_ratio: np.ndarray
    wall_s: float = 0.0

    @property
    def valid(self) -> np.ndarray:
        """True where no flag was raised."""
        return self.flag_bits == 0

    def flags_of(self, k: int) -> list[str]:
        """The flags of entry ``k``, in the order a :class:`CellResult` lists them."""
        b = int(self.flag_bits[k])
        return [f for n, f in enumerate(self.flag_names) if b >> n & 1]


@dataclass
class RestitutionMeasurement:
    """The restitution an engine shows in free rocking, impact by impact.

    Attributes
    ----------
    etas : list of float
        ``|θ̇⁺/θ̇⁻|`` of each measured impact [-].
    eta_mean, eta_std : float
        Their mean and standard deviation [-].
    theta0_rad : float
        Release angle [rad].
    dt_s : float
        Time step [s].
    settings : dict
        The engine settings used.
    method : str
        How η was read from the motion (e.g. velocities around θ = 0, or amplitude ratios).
    first_quarter_s : float or None
        Time from the release to the first impact (θ = 0) [s], where the adapter reports it: a
        quarter of the free-rocking period, compared with the rigid model's in the contact price.
    steps_per_s : float or None
        Engine time steps per second of wall time in this measurement (one core), where reported.
    sink_m, hop_m : float or None
        The resting sink and the highest hop of the run's bottom corners [m]
        (:func:`~rockbench.engines.calibration.free_rocking.contact_figures`: what the calibration's pick reads
        beside η); None where not measured.
    """

    etas: list
    eta_mean: float
    eta_std: float
    theta0_rad: float
    dt_s: float
    settings: dict
    method: str = ""
    first_quarter_s: float | None = None
    steps_per_s: float | None = None
    sink_m: float | None = None
    hop_m: float | None = None

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class CalibrationResult:
    """Contact settings searched so that an engine's free-rocking η reaches a target.

    Attributes
    ----------
    eta_target : float
        The η asked for [-].
    eta_measured : float
        The η reached with ``settings`` [-].
    eta_std : float
        Spread of the per-impact η with those settings [-].
    reached : bool
        Whether the one pick reached the target: regular free rocking (no hop, spread within 2 % of
        the target) with ``|eta_measured − eta_target| ≤ 1 %·eta_target`` (:mod:`rockbench.engines.calibration.pick`).
    settings : dict
        The engine settings found.
    note : str
        Why a target could not be reached, or how it was.
    evaluations : int
        Free-rocking runs spent in the search.
    price : dict or None
        What the contact costs (:func:`rockbench.engines.calibration.price.contact_price`): static
        uplift threshold, anti-slip, free-rocking period change, steps per second; None where not
        measured.
    sink_m, hop_m : float or None
        The pick's resting sink and highest hop in free rocking [m] (what the pick reads beside η,
        :func:`~rockbench.engines.calibration.free_rocking.contact_figures`); None where not measured.
    """

    eta_target: float
    eta_measured: float
    eta_std: float
    reached: bool
    settings: dict
    note: str = ""
    evaluations: int = 0
    price: dict | None = None
    sink_m: float | None = None
    hop_m: float | None = None

    @property
    def rel_error(self) -> float:
        """``(eta_measured − eta_target)/eta_target`` [-]."""
        return (self.eta_measured - self.eta_target) / self.eta_target

    def to_dict(self) -> dict:
        d = asdict(self)
        d["rel_error"] = self.rel_error
        return d


#: ``settings`` values of an engine with a contact model: the contact calibrated to the case's η, or
#: the engine as shipped (:meth:`EngineAdapter.as_shipped`)
SETTINGS_MODES = ("calibrated", "shipped")


class EngineAdapter:
    """Base class of every engine adapter; see the module docstring for the contract."""

    #: the engine contract the adapter is written to (:data:`CONTRACT_VERSION`); a plugin declares it
    CONTRACT_VERSION: ClassVar[int] = CONTRACT_VERSION
    #: registry key, e.g. ``"mujoco"``
    name: ClassVar[str] = ""
    #: the engine's Python module, imported lazily (None for pure-Python adapters)
    module: ClassVar[str | None] = None
    #: how to install the engine
    install_hint: ClassVar[str] = ""
    #: accepted settings and their defaults
    SETTINGS: ClassVar[Mapping[str, Any]] = {}
    #: the engine's own default time step [s]: what a case that poses none runs at (a contact engine:
    #: as shipped); None where the engine ships none
    own_dt_s: ClassVar[float | None] = None
    #: how the adapter batches cases (contract item 7): "none", "native" or "parallel"
    batching: ClassVar[Literal["none", "native", "parallel"]] = "none"
    #: settings that choose which of the engine's models runs (an engine with several solvers behind
    #: one API): every variant's name shows them, their default included, and choosing one is not a
    #: hand-set tweak (the verdict still counts the variant as calibrated or as shipped)
    MODEL_SETTINGS: ClassVar[tuple] = ()
    #: a plugin's supported versions of its engine library: ``{distribution: specifier}``, e.g.
    #: ``{"myengine": ">=2.1,<3"}`` (PEP 440); `rockbench engines` and check-adapter show it and say when
    #: the installed version is outside it (:mod:`rockbench.engines.support`). A built-in engine's range
    #: is its extra in pyproject.toml instead
    SUPPORTED_VERSIONS: ClassVar[Mapping[str, str]] = {}

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.batching not in ("none", "native", "parallel"):
            raise TypeError(f"{cls.__name__}.batching must be 'none', 'native' or 'parallel', got {cls.batching!r}")
        if cls.__dict__.get("SUPPORTED_VERSIONS"):
            from packaging.specifiers import InvalidSpecifier, SpecifierSet   # on first use (start-up time)
            for dist, spec in cls.SUPPORTED_VERSIONS.items():
                try:
                    SpecifierSet(spec)
                except (InvalidSpecifier, TypeError):
                    raise TypeError(f"{cls.__name__}.SUPPORTED_VERSIONS[{dist!r}] = {spec!r} is not a version "
                                    "specifier: give one as pip reads it, e.g. '>=2.1,<3'.") from None

    def __init__(self, **settings):
        unknown = sorted(set(settings) - set(self.SETTINGS))
        if unknown:
            known = ", ".join(sorted(self.SETTINGS)) or "none"
            raise ConfigError(f"engine {self.name!r} has no setting {unknown[0]!r}; its settings are: {known}.")
        self.settings = {**self.SETTINGS, **settings}
        self._validate_settings(self.settings)

    # -- settings ------------------------------------------------------------------------------
    def _validate_settings(self, settings: dict) -> None:
        """Check the settings' values (a contact engine checks its shared ones first); the hook."""
        self.validate(settings)

    def validate(self, settings: dict) -> None:
        """Hook: raise ConfigError for a bad value of one of the adapter's own settings, e.g. with
        :meth:`number_setting`, :meth:`whole_setting` and :meth:`bool_setting`, which also store the
        value converted (default: every value passes)."""

    def number_setting(self, settings: dict, key: str, unit: str = "", *, allow_zero: bool = False,
                       allow_none: bool = True, maximum: float | None = None) -> None:
        """Check that ``settings[key]`` is a finite number > 0 and store it as a float, or one
        ConfigError line naming the engine, the setting, its bounds and the value given.

        Parameters
        ----------
        settings : dict
        key : str
        unit : str
            Shown in brackets in the message, e.g. ``"N/m"``; ``""`` for a ratio.
        allow_zero : bool
            Accept 0 (≥ 0 instead of > 0): a coefficient whose shipped value is 0, such as a
            plastic material's restitution, or a damping the engine ships off.
        allow_none : bool
            Accept None ("not given": a contact setting the calibration or the engine fills in).
        maximum : float, optional
            The largest value accepted (inclusive), e.g. 1 for a restitution coefficient.
        """
        _unit_given(self, "number_setting", unit)
        v = settings[key]
        if v is None and allow_none:
            return
        x = _number(v)
        bound = (">= 0" if allow_zero else "> 0") + (f" and <= {maximum:g}" if maximum is not None else "")
        if not math.isfinite(x) or x < 0.0 or (x == 0.0 and not allow_zero) or (maximum is not None and x > maximum):
            in_unit = f" [{unit}]" if unit else ""
            raise ConfigError(f"{self.name} setting {key!r} must be a finite number {bound}{in_unit}, got {v!r}.")
        settings[key] = x

    def whole_setting(self, settings: dict, key: str, unit: str = "", *, minimum: int = 0,
                      maximum: int | None = None, allow_none: bool = True) -> None:
        """Check that ``settings[key]`` is a whole number from ``minimum`` (to ``maximum`` when given),
        given as an int or an integral float (not a bool or a string), and store it as an int; or one
        ConfigError line naming the engine, the setting, its bounds and the value given. The
        arguments are :meth:`number_setting`'s (``unit``, shown in the message, third; the bounds are
        keywords)."""
        _unit_given(self, "whole_setting", unit)
        v = settings[key]
        if v is None and allow_none:
            return
        if (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v != int(v)
                or v < minimum or (maximum is not None and v > maximum)):
            bounds = f">= {minimum}" if maximum is None else f"from {minimum} to {maximum}"
            in_unit = f" [{unit}]" if unit else ""
            raise ConfigError(f"{self.name} setting {key!r} must be a whole number {bounds}{in_unit}, got {v!r}.")
        settings[key] = int(v)

    def bool_setting(self, settings: dict, key: str, *, allow_none: bool = False) -> None:
        """Check that ``settings[key]`` is a bool, or a string true/false/1/0, and store it as a bool;
        or one ConfigError line."""
        v = settings[key]
        if v is None and allow_none:
            return
        if isinstance(v, str) and v.lower() in _TRUE + _FALSE:
            v = v.lower() in _TRUE
        if not isinstance(v, bool):
            raise ConfigError(f"{self.name} setting {key!r} must be true or false, got {settings[key]!r}.")
        settings[key] = v

    def choice_setting(self, settings: dict, key: str, allowed, *, allow_none: bool = True) -> None:
        """Check that ``settings[key]`` is one of ``allowed`` (None passes with ``allow_none``); or one
        ConfigError line."""
        v = settings[key]
        if (v is None and allow_none) or v in allowed:
            return
        raise ConfigError(f"{self.name} setting {key!r} must be one of {', '.join(map(str, allowed))}, got {v!r}.")

    # -- the hooks of contract item 4 and 7 ------------------------------------------------------
    @required("(case) -> Trajectory", "run one case (contract item 4), or derive a contact engine from "
              "ContactEngine and implement build, start, advance and read instead (docs/engines.md)")
    def _simulate(self, case: Case) -> Trajectory:  # pragma: no cover - declared
        ...

    def missing_hooks(self) -> list[str]:
        """One line per hook this adapter must implement and does not, saying what to do (empty when
        none is missing; :mod:`rockbench.engines.hooks`)."""
        return missing_hooks(self)

    def _simulate_many(self, cases: list[Case]) -> list[Trajectory | BaseException]:
        out = []
        for c in cases:
            try:
                out.append(self._simulate(c))
            except Exception as e:  # noqa: BLE001 - recorded per cell, the sweep goes on
                out.append(e)
        return out

    def _native_verdicts(self, cases: list[Case]) -> list[CellResult | None]:
        """Hook: verdicts a native batch reaches by itself with the shared rules (the classifier's
        rule compiled into the batch, floor 1's validity functions), None for every case it leaves
        to :meth:`_simulate_many` and :meth:`judge`. The default leaves them all."""
        return [None] * len(cases)

    # -- the time step (contract item 8) --------------------------------------------------------
    def posed(self, case: Case) -> Case:
        """``case`` with its step decided once, by the one resolver: what runs. ``case.dt_s`` [s] where
        given (a finite number > 0), else the engine's own step (:attr:`own_dt_s`); checked against the
        pulse (:meth:`~rockbench.reference_solver.pulses.Pulse.check_dt`: fine enough to follow it). A
        ConfigError for a bad step. (A contact engine's resolver is
        :func:`~rockbench.engines.calibration.time_step.step_for`.)"""
        if case.dt_s is None and self.own_dt_s is None:
            raise ConfigError(f"engine {self.name!r} has no time step of its own (own_dt_s): give the case one (--dt).")
        dt = check_positive("--dt", case.dt_s if case.dt_s is not None else self.own_dt_s, "s")
        return dataclasses.replace(case, dt_s=dt if case.pulse is None else case.pulse.check_dt(dt))

    # -- the public methods ----------------------------------------------------------------------
    def simulate(self, case: Case) -> Trajectory:
        """Run one case and return its trajectory (exceptions propagate)."""
        return self._simulate(self.posed(case))

    def run(self, case: Case) -> CellResult:
        """Simulate one case and classify it; an engine exception becomes a failed cell."""
        return self.run_many([case])[0]

    def run_many(self, cases: Iterable[Case]) -> list[CellResult]:
        """Simulate and classify many cases; failures are recorded per case.

        Every case's step is decided first (:meth:`posed`); cases the adapter's
        :meth:`_native_verdicts` hook returns verdicts for keep them, the others are simulated
        (:meth:`_simulate_many`) and judged (:meth:`judge`).
        """
        posed, out = [], []
        for c in cases:
            try:
                posed.append(self.posed(c))
                out.append(None)
            except ConfigError:
                raise
            except Exception as e:  # noqa: BLE001 - the step could not be decided: this cell fails
                posed.append(c)
                out.append(CellResult.failed("engine-error", f"{type(e).__name__}: {e}"))
        return self._judged(posed, out)

    def _judged(self, cases: list[Case], out: list | None = None) -> list[CellResult]:
        """The verdicts of posed ``cases`` (their steps decided); ``out`` holds a verdict already
        reached per case, else None."""
        out = list(out or [None] * len(cases))
        todo = [i for i, r in enumerate(out) if r is None]
        for i, r in zip(todo, self._native_verdicts([cases[i] for i in todo])):
            out[i] = r
        todo = [i for i, r in enumerate(out) if r is None]
        if todo:
            t0 = time.perf_counter()
            trajs = self._simulate_many([cases[i] for i in todo])
            wall = (time.perf_counter() - t0) / len(todo)
            for i, tr in zip(todo, trajs):
                out[i] = self.judge(cases[i], tr, wall)
        return out

    @property
    def friction(self) -> float:
        """The friction coefficient μ the contact-demand test uses: the ``friction`` setting, else 10 [-]."""
        mu = self.settings.get("friction")
        return DEFAULT_FRICTION if mu is None else float(mu)

    def judge(self, case: Case, tr, wall_s: float = 0.0) -> CellResult:
        """The verdict on one simulation: the one classifier and the one validity rule.

        ``tr`` is the adapter's :class:`Trajectory`, or the exception it raised (a failed cell).
        """
        if isinstance(tr, BaseException):
            if isinstance(tr, ConfigError):
                raise tr
            return CellResult.failed("engine-error", f"{type(tr).__name__}: {tr}", wall_s)
        if "diverged" in tr.flags or not (np.all(np.isfinite(tr.theta_rad)) and np.all(np.isfinite(tr.theta_dot_rad_s))):
            return CellResult.failed("diverged", "the engine returned non-finite angles", wall_s)
        c: Classification = classify(
            tr.t_s, tr.theta_rad, tr.theta_dot_rad_s, alpha_rad=case.block.alpha_rad,
            p_rad_s=case.block.p_rad_s, t_pulse_end_s=tr.t_pulse_end_s, eta=tr.eta_for_tail,
            linearized=case.linearized, uplift_tol_rad=tr.uplift_tol_rad)
        flags: set[str] = set()
        diag = dict(tr.diagnostics)
        m = tr.measurement()
        if m is not None:
            v = judge_measurement(m, case.block, tr.t_pulse_end_s)
            flags.update(v.flags)
            diag.update(v.diagnostics())
        if tr.min_normal_mg is not None:
            flags.update(contact_flags(tr.min_normal_mg, tr.max_friction_ratio or 0.0, self.friction))
        return CellResult(outcome=c.outcome.value, n_impacts=c.n_impacts,
                          max_abs_theta_rad=c.max_abs_theta_rad, t_overturn_s=c.t_overturn_s,
                          t_uplift_s=c.t_uplift_s, valid=not flags, flags=sorted(flags), status="ok",
                          wall_s=wall_s, diagnostics=diag, min_normal_mg=tr.min_normal_mg,
                          max_friction_ratio=tr.max_friction_ratio)

    def resolve(self, block: Block, restitution: Restitution, dt_s: float | None = None) -> dict:
        """The concrete settings cases of this block, restitution and time step [s] use (for run.json)."""
        return dict(self.settings)

    def as_shipped(self) -> bool:
        """Whether the engine runs as shipped: ``settings="shipped"`` (adapters without that setting
        never do)."""
        return self.settings.get("settings") == "shipped"

    # -- what the engine is -----------------------------------------------------------------------
    @classmethod
    def default_suite_exclusion(cls) -> str | None:
        """Why a suite that runs every available engine (``names = "available"``) leaves this one
        out on this machine, in one line; None (the default) when it takes part. Asked for by name,
        an engine always runs. (MuJoCo Warp, for one, needs a CUDA device to run a whole suite in
        reasonable time.)"""
        return None

    @classmethod
    def device_note(cls) -> str:
        """Where the engine runs on this machine, when a reader should know (``rockbench engines``):
        "" for an engine that runs on the CPU by design; a GPU-first engine without a GPU says
        "CPU only (slow)". A caller that shows the note sets ``os.environ[DEVICE_NOTED_ENV]``, so
        that the engine's own processes do not say it again."""
        return ""

    @classmethod
    def load_engine(cls):
        """Hook: import and return the engine's module (:attr:`module`); an adapter whose engine prints
        or warns when imported overrides it to import it quietly."""
        return importlib.import_module(cls.module)

    @classmethod
    def version(cls) -> str:
        """The engine's version: a built-in engine's distributions (:func:`~rockbench.engines.support.version_label`),
        else its module's ``__version__``, else the version of the distribution that installed the
        module (a module without ``__version__``: ``importlib.metadata``), else "unknown". Raises
        EngineUnavailableError when the engine cannot be imported."""
        if cls.module is None:
            try:
                return metadata.version("rockbench")
            except Exception:  # noqa: BLE001 - running from a source tree
                return "source"
        try:
            mod = cls.load_engine()
        except Exception as e:  # noqa: BLE001 - any import failure means "not available"
            raise EngineUnavailableError(
                f"engine {cls.name!r} is not available: importing {cls.module!r} failed ({e}); {cls.install_hint}") from None
        if cls.name in DISTRIBUTIONS and version_label(cls.name) != "unknown":
            return version_label(cls.name)
        own = getattr(mod, "__version__", None)
        return str(own) if own is not None else _distribution_version(cls)

    def describe(self) -> dict:
        """Name, version, contract, settings and the engine's own step [s], for run.json."""
        return {"engine": self.name, "version": self.version(), "contract": self.CONTRACT_VERSION,
                "settings": dict(self.settings), "own_dt_s": self.own_dt_s}


def _unit_given(ad, helper: str, unit) -> None:
    """A TypeError, for the adapter's author, where a setting helper's third argument is not a unit."""
    if not isinstance(unit, str):
        raise TypeError(f"{type(ad).__name__}: {helper}'s third argument is the unit, a string such as 'N/m' or '' "
                        f"(got {unit!r}); give the bounds as keywords (minimum=, maximum=).")


def _number(v) -> float:
    """``v`` as a float, NaN where it is not a number (a bool is not)."""
    if isinstance(v, bool):
        return math.nan
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _distribution_version(cls) -> str:
    """The version of the distribution that installed ``cls.module`` (the first of
    ``SUPPORTED_VERSIONS``' distributions, else the one that provides the module's top package),
    "unknown" when none is found."""
    names = list(cls.SUPPORTED_VERSIONS) + metadata.packages_distributions().get(cls.module.partition(".")[0], [])
    for dist in names:
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            continue
    return "unknown"
