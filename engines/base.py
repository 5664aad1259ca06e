"""The contract every engine adapter implements, and the objects it exchanges.

An adapter turns a :class:`Case` (a block, a table pulse, a restitution law, a time step and
engine settings) into a :class:`Trajectory`: what the engine measured (θ(t), θ̇(t), both bottom
corners in the table's frame, the block's energy) and diagnostics. It decides nothing:
:meth:`EngineAdapter.judge` hands the trajectory to the one shared classifier
(:func:`rockbench.reference_solver.classify.classify`) and the one validity rule
(:mod:`rockbench.reference_solver.validity`), so every engine is judged by the same rules.

The contract, for a subclass of :class:`EngineAdapter`:

1. Set the class attributes ``name`` (the registry key), ``module`` (the Python module of the
   engine, imported lazily) and ``install_hint`` (how to get it). Import the engine only inside
   methods, never at module import time.
2. ``__init__(**settings)`` validates its settings and raises
   :class:`~rockbench.reference_solver.errors.ConfigError` on an unknown name or bad value
   (negative time step, stiffness, ...). :attr:`SETTINGS` maps each accepted setting to its default;
   the base class rejects names that are not there.
3. ``_simulate(case)`` runs one case and returns a :class:`Trajectory`. Angles follow one convention:
   x is the excitation direction, z is up, θ is the rotation about +y, so a positive table
   acceleration starts a negative θ. Samples start at t = 0 and cover at least the pulse
   (``t_pulse_end_s``); the run ends by a documented rule (overturn certain, rest, or a bounded
   tail after the pulse).
4. A contact engine reports its measurements in the trajectory: ``corner_x_m`` and ``corner_z_m``
   (the bottom corners, ``(n, k)`` with k ≥ 2, relative to the table and above its top) and, where the
   engine gives the body's state, ``energy_j_kg`` (see
   :class:`~rockbench.reference_solver.validity.Measurement`). It never raises ``slip``, ``jump``
   or ``energy-gain`` itself: :meth:`EngineAdapter.judge` applies the one rule. The only flag an
   adapter may set is ``diverged`` (non-finite state). The reference reports instead the rigid
   model's contact demand (``min_normal_mg``, ``max_friction_ratio``), which the judge turns into
   ``lift-required`` / ``slip-required`` with the friction coefficient of the adapter's
   ``friction`` setting (:data:`~rockbench.reference_solver.validity.DEFAULT_FRICTION` without one).
   A flagged trajectory is not valid.
5. An exception inside the engine is not caught by ``_simulate``: :meth:`EngineAdapter.run`
   turns it into a failed :class:`CellResult` with the ``engine-error`` flag, so sweeps go on.
6. ``_simulate_many(cases)`` may run many cases at once (native batches); the default loops over
   :meth:`_simulate`. Results must not depend on how cases are batched. The adapter declares how
   it batches in :attr:`batching`: ``"none"`` (one case at a time; maps hand it small batches),
   ``"native"`` (its ``_simulate_many`` runs a batch natively: maps hand it big batches) or
   ``"parallel"`` (a native batch that already uses every core: maps run it in one call in their
   own process instead of spreading it over worker processes). A native batch that also applies
   the classifier's rule itself (compiled, as the reference's kernel) implements the hook
   :meth:`_native_verdicts`; :meth:`run_many` judges every other case. A ``parallel`` adapter may also
   offer ``solve_grid(block, pulse_kind, restitution, omega_rad_s, amplitude_mps2, dt_s=None,
   linearized=False)``: the verdicts of many harmonic-pulse cases as :class:`CellColumns` (arrays,
   no object per case), equal to what :meth:`run_many` gives for the same cases; maps run in this
   process use it from the grid to the file (the reference does). Subclasses implement the
   hooks (``_simulate``, ``_simulate_many``, ``_native_verdicts``, ``_validate_settings``), never the
   public ``run``, ``run_many`` or ``judge``.
7. ``resolve(block, restitution, dt_s)`` returns the concrete settings a case will use (for example contact
   parameters calibrated to reach the restitution's η); they are recorded in run.json.
8. ``measure_restitution(block, settings)`` and ``calibrate(block, target_eta)`` are optional
   (engines with a contact model implement them; the reference solver does not need them).
9. ``version()`` returns the engine's version string, or raises
   :class:`~rockbench.reference_solver.errors.EngineUnavailableError` with an install hint.
10. ``default_suite_exclusion()`` (optional) says in one line why suites that run every available
   engine leave this one out on this machine (None: they include it); named explicitly, it runs.

Every hook a base class calls is declared there (:func:`rockbench.engines.hooks.required`): one
left out raises :class:`~rockbench.engines.hooks.MissingHook` saying what to implement, and
:meth:`EngineAdapter.missing_hooks` lists them before anything runs.

``rockbench check-adapter NAME`` runs a conformance suite on any registered adapter
(:mod:`rockbench.engines.checker`), missing hooks first. Engines with a contact model derive from
:class:`~rockbench.engines.contact.ContactEngineAdapter`, which owns their shared settings.
"""

from __future__ import annotations

import importlib
import math
import time
from importlib import metadata
from dataclasses import dataclass, field, asdict
from typing import Any, ClassVar, Iterable, Literal, Mapping

import numpy as np

from ..reference_solver.classify import Classification, classify
from ..reference_solver.errors import ConfigError, EngineUnavailableError
from ..reference_solver.model import Block
from ..reference_solver.pulses import Pulse
from ..reference_solver.restitution import Restitution
from ..reference_solver.validity import (DEFAULT_FRICTION, FLAGS, Measurement, contact_flags, judge_measurement,
                                         jump_tol_m, slip_tol_m, uplift_tol_rad)
from .hooks import missing_hooks, required
from .renamed import adopt_renamed_methods, warn_renamed

__all__ = ["Case", "Trajectory", "CellResult", "CellColumns", "RestitutionMeasurement", "CalibrationResult",
           "EngineAdapter", "SETTINGS_MODES", "FLAGS", "jump_tol_m", "slip_tol_m", "uplift_tol_rad", "DEVICE_NOTED_ENV"]

#: Set (to "1") in the environment once the user has been told where an engine runs
#: (:meth:`EngineAdapter.device_note`): worker processes inherit it and stay quiet.
DEVICE_NOTED_ENV = "ROCKBENCH_DEVICE_NOTED"


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
        Time step [s]; None takes the engine's default.
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
    :class:`CellResult`; ``solve_grid`` in contract item 6).

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
        (:func:`~rockbench.engines.free_rocking.contact_figures`: what the calibration's pick reads
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
        the target) with ``|eta_measured − eta_target| ≤ 1 %·eta_target`` (:mod:`rockbench.engines.pick`).
    settings : dict
        The engine settings found.
    note : str
        Why a target could not be reached, or how it was.
    evaluations : int
        Free-rocking runs spent in the search.
    price : dict or None
        What the contact costs (:func:`rockbench.engines.price.contact_price`): static uplift
        threshold, anti-slip, free-rocking period change, steps per second; None where not measured.
    """

    eta_target: float
    eta_measured: float
    eta_std: float
    reached: bool
    settings: dict
    note: str = ""
    evaluations: int = 0
    price: dict | None = None

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

    #: registry key, e.g. ``"mujoco"``
    name: ClassVar[str] = ""
    #: the engine's Python module, imported lazily (None for pure-Python adapters)
    module: ClassVar[str | None] = None
    #: how to install the engine
    install_hint: ClassVar[str] = ""
    #: accepted settings and their defaults
    SETTINGS: ClassVar[Mapping[str, Any]] = {}
    #: the benchmark's time step for this engine, where a case poses none and the engine does not
    #: run as shipped (calibrated, or explicit settings) [s]
    default_dt_s: ClassVar[float] = 1e-3
    #: the engine's own default time step, what it runs at as shipped (``settings="shipped"``) where a
    #: case poses none [s]; None where the engine has no default step (``default_dt_s`` stands in)
    shipped_dt_s: ClassVar[float | None] = None
    #: how the adapter batches cases (contract item 6): "none", "native" or "parallel"
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
        adopt_renamed_methods(cls, "EngineAdapter")   # ``_run_native``, ``run_grid``: kept for one release
        # ``parallel_batch = True`` (the attribute's old name) is ``batching = "parallel"``: kept for one release
        if cls.__dict__.get("parallel_batch") is True and "batching" not in cls.__dict__:
            warn_renamed(f"{cls.__name__}.parallel_batch is now batching = 'parallel'; the old attribute goes in "
                         "the next release.", 2)
            cls.batching = "parallel"
        if cls.batching not in ("none", "native", "parallel"):
            raise TypeError(f"{cls.__name__}.batching must be 'none', 'native' or 'parallel', got {cls.batching!r}")
        if cls.__dict__.get("SUPPORTED_VERSIONS"):
            from packaging.specifiers import InvalidSpecifier, SpecifierSet
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

    # -- to override -------------------------------------------------------------------------
    def _validate_settings(self, settings: dict) -> None:
        """Raise ConfigError for a bad setting value (the default accepts everything)."""

    # -- for adapters' _validate_settings ------------------------------------------------------
    def _number_setting(self, settings: dict, key: str, unit: str = "", *, allow_zero: bool = False,
                        allow_none: bool = True) -> None:
        """Check that ``settings[key]`` is a finite number > 0 (≥ 0 with ``allow_zero``; None passes
        with ``allow_none``) and store it as a float; otherwise one ConfigError line naming the
        engine, the setting, the bound and the value given."""
        v = settings[key]
        if v is None and allow_none:
            return
        in_unit = f" [{unit}]" if unit else ""
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise ConfigError(f"{self.name} setting {key!r} must be a number{in_unit}, got {v!r}.") from None
        if not math.isfinite(x) or x < 0.0 or (x == 0.0 and not allow_zero):
            bound = ">= 0" if allow_zero else "> 0"
            raise ConfigError(f"{self.name} setting {key!r} must be a finite number {bound}{in_unit}, got {v!r}.")
        settings[key] = x

    def _whole_setting(self, settings: dict, key: str, minimum: int, *, allow_none: bool = True,
                       maximum: int | None = None) -> None:
        """Check that ``settings[key]`` is a whole number ≥ ``minimum`` (and ≤ ``maximum`` when given)
        given as an int or an integral float (not a bool or a string; None passes with
        ``allow_none``) and store it as an int; otherwise one ConfigError line naming the engine, the
        setting, the bounds and the value given."""
        v = settings[key]
        if v is None and allow_none:
            return
        if (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v != int(v)
                or v < minimum or (maximum is not None and v > maximum)):
            bounds = f">= {minimum}" if maximum is None else f"from {minimum} to {maximum}"
            raise ConfigError(f"{self.name} setting {key!r} must be a whole number {bounds}, got {v!r}.")
        settings[key] = int(v)

    @required("(case) -> Trajectory", "run one case (contract item 3), or derive a contact engine from "
              "SteppedContactAdapter and implement its hooks instead (docs/engines.md)")
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

    def resolve(self, block: Block, restitution: Restitution, dt_s: float | None = None) -> dict:
        """The concrete settings cases of this block, restitution and time step [s] will use (for run.json).

        ``dt_s`` None means the engine's default step; calibrated settings depend on it.
        """
        return dict(self.settings)

    def measure_restitution(self, block: Block, *, theta0_frac: float = 0.5,
                            dt_s: float | None = None) -> RestitutionMeasurement:
        """Free rocking from rest at ``theta0_frac·α``, no excitation: η impact by impact."""
        raise ConfigError(f"engine {self.name!r} has no contact model to calibrate; "
                          "calibrate applies to engines such as mujoco, pybullet, exudyn.")

    def calibrate(self, block: Block, target_eta: float, *, dt_s: float | None = None,
                  use_cache: bool = True) -> CalibrationResult:
        """Search the engine's contact settings so its free-rocking η reaches ``target_eta`` (1 %)."""
        raise ConfigError(f"engine {self.name!r} has no contact model to calibrate; "
                          "calibrate applies to engines such as mujoco, pybullet, exudyn.")

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
    def version(cls) -> str:
        """The engine's version; raises EngineUnavailableError when it cannot be imported."""
        if cls.module is None:
            try:
                return metadata.version("rockbench")
            except Exception:  # noqa: BLE001 - running from a source tree
                return "source"
        try:
            mod = importlib.import_module(cls.module)
        except Exception as e:  # noqa: BLE001 - any import failure means "not available"
            raise EngineUnavailableError(
                f"engine {cls.name!r} is not available: importing {cls.module!r} failed ({e}); {cls.install_hint}") from None
        return str(getattr(mod, "__version__", getattr(mod, "version", "unknown")))

    # -- provided ----------------------------------------------------------------------------
    def as_shipped(self) -> bool:
        """Whether the engine runs as shipped: ``settings="shipped"`` (adapters without that setting
        never do)."""
        return self.settings.get("settings") == "shipped"

    def unposed_dt_s(self, pulse=None) -> float:
        """The time step where a case poses none [s]: as shipped the engine's own default step
        (:attr:`shipped_dt_s`), but never coarser than ``pulse`` accepts (the benchmark poses the
        pulse, and a step coarser than 1/20 of its wave does not follow it); otherwise, or where the
        engine has no default step, :attr:`default_dt_s`."""
        if not (self.as_shipped() and self.shipped_dt_s is not None):
            return float(self.default_dt_s)
        return float(self.shipped_dt_s) if pulse is None else min(float(self.shipped_dt_s), pulse.max_dt_s())

    def calibration_block(self, block: Block) -> Block:
        """The block whose geometry the calibration behind runs of ``block`` is made on: ``block``
        itself (a contact engine's ``calibrate_on`` names another block); a
        ConfigError for one it cannot run ``block`` with, before anything runs."""
        return block

    def dt_for(self, case: Case) -> float:
        """The time step a case runs with: its own, else :meth:`unposed_dt_s`, checked against the
        pulse [s]."""
        dt = case.dt_s if case.dt_s is not None else self.unposed_dt_s(case.pulse)
        return case.pulse.check_dt(dt)

    def simulate(self, case: Case) -> Trajectory:
        """Run one case and return its trajectory (exceptions propagate)."""
        return self._simulate(case)

    def run(self, case: Case) -> CellResult:
        """Simulate one case and classify it; an engine exception becomes a failed cell."""
        return self.run_many([case])[0]

    def run_many(self, cases: Iterable[Case]) -> list[CellResult]:
        """Simulate and classify many cases; failures are recorded per case.

        Cases the adapter's :meth:`_native_verdicts` hook returns verdicts for keep them; the others are
        simulated (:meth:`_simulate_many`) and judged (:meth:`judge`).
        """
        cases = list(cases)
        out = list(self._native_verdicts(cases))
        todo = [i for i, r in enumerate(out) if r is None]
        if todo:
            t0 = time.perf_counter()
            trajs = self._simulate_many([cases[i] for i in todo])
            wall = (time.perf_counter() - t0) / len(todo)
            for i, tr in zip(todo, trajs):
                out[i] = self.judge(cases[i], tr, wall)
        return out

    def _native_verdicts(self, cases: list[Case]) -> list[CellResult | None]:
        """Hook: verdicts a native batch reaches by itself with the shared rules (the classifier's
        rule compiled into the batch, floor 1's validity functions), None for every case it leaves
        to :meth:`_simulate_many` and :meth:`judge`. The default leaves them all."""
        return [None] * len(cases)

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

    def describe(self) -> dict:
        """Name, version, settings and the step where a case poses none [s], for run.json."""
        return {"engine": self.name, "version": self.version(), "settings": dict(self.settings),
                "unposed_dt_s": self.unposed_dt_s()}

