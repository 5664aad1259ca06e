"""What the contact engines (MuJoCo, PyBullet, Exudyn, ...) share: :class:`ContactEngineAdapter`.

A contact engine simulates the block touching the table through the engine's own contact model,
so it needs the same few things whatever the engine:

* **Shared settings, one naming scheme** (units in names): ``settings`` (``calibrated``: contact
  parameters searched so that free rocking reaches the case's η; ``shipped``: the engine as
  shipped), ``drive`` (``inertial`` or ``table``), ``planar``, ``friction`` [-], ``tail_s`` (the
  longest simulated time after the pulse), ``min_tail_s`` (the shortest) and, for engines that
  step in segments between stop checks, ``segment_s``; ``calibrate_on`` (another block, of the same
  slenderness or another, that the calibration runs on: the held-out check, :mod:`rockbench.engines.held_out`).
  They are validated here, once.
* **Old names** of settings and of their values are accepted for one release and mapped to the new
  ones by :mod:`rockbench.engines.renamed` (``--set``, suite TOMLs, stored runs and cached calibration
  records all go through its :func:`~rockbench.engines.renamed.canonical_settings`).
* **One time-step rule**: :meth:`ContactEngineAdapter.time_step_s` (not to be confused with
  :meth:`~rockbench.reference_solver.pulses.Pulse.check_dt`, which checks a step against a pulse).
* **One ``resolve()`` flow**: explicit contact settings, else the engine's defaults, else the
  calibration to the case's η (cached); an adapter only says which contact settings are explicit
  (:meth:`~ContactEngineAdapter.explicit_contact`) and builds its concrete settings
  (:meth:`~ContactEngineAdapter._resolved_settings`).
* **One overturn-is-certain early stop**: :func:`~rockbench.reference_solver.classify.overturn_certain`,
  the classifier's own rule, re-exported here (the whole end-of-run rule is
  :func:`~rockbench.reference_solver.classify.run_end`).
* **The body's energy**: :func:`body_energy_j_kg`.

The stepping loop, the read-out, the free-rocking test and the calibration frame are the
skeleton's (:class:`~rockbench.engines.skeleton.SteppedContactAdapter`); the one way η is read from
free rocking is in :mod:`rockbench.engines.free_rocking`, the one calibration pick in
:mod:`rockbench.engines.pick`.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar, Mapping

from ..reference_solver.classify import overturn_certain
from ..reference_solver.errors import ConfigError
from ..reference_solver.model import G, Block
from ..reference_solver.restitution import Restitution, housner_eta
from ..reference_solver.rules import RULES_VERSION
from . import calibration, held_out, step_rule
from .base import SETTINGS_MODES, CalibrationResult, EngineAdapter
from .hooks import required
from .renamed import RENAMED_SETTINGS, RENAMED_VALUES, canonical_changes, canonical_settings, warn_renamed

__all__ = ["ContactEngineAdapter", "RENAMED_SETTINGS", "RENAMED_VALUES", "canonical_settings", "SETTINGS_MODES",
           "DRIVES", "body_energy_j_kg", "overturn_certain", "CONTACT_LAYOUTS", "POINTS_TRIED", "MAX_CONTACT_POINTS",
           "first_reached", "PLANAR_MODES", "MODES"]

#: ``drive`` values: the inertial force −m·ü at the centre of mass, or a table moved along u(t)
DRIVES = ("inertial", "table")

#: ``planar`` values: the block kept in the x–z plane, or a free 3-D body
PLANAR_MODES = (True, False)

#: the settings that choose how the problem is posed, and their values (an adapter may run fewer:
#: :attr:`ContactEngineAdapter.SUPPORTED_MODES`)
MODES = {"drive": DRIVES, "planar": PLANAR_MODES}

#: ``contact`` values: the corners alone, a row of points along the base, or the corners unless the
#: target η is above Housner's (then the row); see docs/contact.md
CONTACT_LAYOUTS = ("auto", "corners", "distributed")

#: Points of a contact along the base that a calibration tries in turn when ``contact_points`` is not
#: set (the first is also the default row)
POINTS_TRIED = (9, 5, 17)

#: The most points a contact along the base may have
MAX_CONTACT_POINTS = 101

_TRUE, _FALSE = ("true", "1"), ("false", "0")

#: What to do about a contact engine without a calibration (the ``settings`` default is ``calibrated``)
CALIBRATION_ADVICE = ("the contact calibrated to the target η: declare CALIBRATION_KNOBS (the skeleton then "
                      "searches them) or implement this hook; or run the engine as shipped: --set settings=shipped, "
                      "or \"settings\": \"shipped\" in SETTINGS")


class ContactEngineAdapter(EngineAdapter):
    """Base of the adapters of engines with a contact model (see the module docstring).

    A subclass sets :attr:`SETTINGS` to :attr:`SHARED_SETTINGS` (with its own defaults) plus its
    engine's settings, and implements:

    * :meth:`_validate_engine_settings` (its own settings; the shared ones are checked already),
    * :meth:`explicit_contact` (whether the user gave contact settings that replace calibration),
    * :meth:`_resolved_settings` (the concrete settings, given a calibration or None) and, where a
      setting is filled in by mode, :meth:`_base_settings` (the settings before any calibration),
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
        "calibrate_on": None,
    }

    #: version of the calibration (free-rocking test and search); part of the cache key
    CALIBRATION_VERSION: ClassVar[int] = 1
    #: version of the distributed contact's calibration; part of its cache key
    CALIBRATION_VERSION_DIST: ClassVar[int] = 1
    #: what the engine's shipped settings do in this benchmark, measured, in one sentence that names
    #: the setting (a stand-in where the engine ships none, a setting that fails the problem); run.json
    #: records it with the resolved settings as shipped, and the verdict's failure reason quotes it
    SHIPPED_NOTE: ClassVar[str | None] = None
    #: whether the adapter offers a row of contact points along the base (``contact`` layouts)
    distributed_contact: ClassVar[bool] = False
    #: what a point of the distributed contact is, in calibration notes
    POINT_UNIT: ClassVar[str] = "points"
    #: the ``drive`` and ``planar`` values the adapter runs, e.g. ``{"drive": ("inertial",)}`` (a key left
    #: out: every value of :data:`MODES`); another value is a ConfigError at construction, and
    #: check-adapter skips the check of a mode left out
    SUPPORTED_MODES: ClassVar[Mapping[str, tuple]] = {}

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        # an adapter's own defaults under an old name or value (``"settings": "defaults"``): kept for one release
        own = cls.__dict__.get("SETTINGS")
        if own is not None and canonical_settings(cls.name, own) != dict(own):
            warn_renamed(f"{cls.__name__}.SETTINGS uses an old name or value ({canonical_changes(cls.name, own)}); "
                         "the old spelling goes in the next release.", 2)
            cls.SETTINGS = canonical_settings(cls.name, own)
        for key, values in {**MODES, **cls.SUPPORTED_MODES}.items():
            mine = cls.supported_modes(key)
            if key not in MODES or not mine or set(mine) - set(values) or cls.SETTINGS.get(key, mine[0]) not in mine:
                raise TypeError(f"{cls.__name__}.SUPPORTED_MODES[{key!r}] = {mine}: its keys are drive and planar, "
                                f"each with some of its values {dict(MODES)}, the default in SETTINGS among them.")

    @classmethod
    def supported_modes(cls, key: str) -> tuple:
        """The values of ``key`` (``drive`` or ``planar``) the adapter runs (:attr:`SUPPORTED_MODES`)."""
        return tuple(cls.SUPPORTED_MODES.get(key, MODES.get(key, ())))

    def __init__(self, **settings):
        super().__init__(**self.canonical_settings(settings, warn=True))
        self._resolved: dict = {}
        self._steps: dict = {}
        self._itself: ContactEngineAdapter | None = None

    # -- names --------------------------------------------------------------------------------
    @classmethod
    def canonical_settings(cls, settings: Mapping[str, Any], *, warn: bool = False) -> dict:
        """:func:`canonical_settings` of this engine."""
        return canonical_settings(cls.name, settings, warn=warn, stacklevel=3)

    # -- settings -----------------------------------------------------------------------------
    def _validate_settings(self, s: dict) -> None:
        for key, allowed in (("settings", SETTINGS_MODES), ("drive", DRIVES)):
            if s[key] not in allowed:
                raise ConfigError(f"{self.name} setting {key!r} must be {' or '.join(allowed)}, got {s[key]!r}.")
        self._bool_setting(s, "planar")
        for key in MODES:
            supported = self.supported_modes(key)
            if s[key] not in supported:
                shown = ", ".join(str(v).lower() if isinstance(v, bool) else v for v in supported)
                raise ConfigError(f"{self.name} does not run {key} = {str(s[key]).lower()} (its SUPPORTED_MODES): "
                                  f"use {key} = {shown}, or an engine that runs it (docs/engines.md).")
        self._number_setting(s, "friction", allow_none=False)
        self._number_setting(s, "tail_s", "s", allow_none=False)
        self._number_setting(s, "min_tail_s", "s", allow_zero=True, allow_none=False)
        if s["min_tail_s"] > s["tail_s"]:
            raise ConfigError(f"{self.name} setting 'min_tail_s' ({s['min_tail_s']:g} s) must not exceed "
                              f"'tail_s' ({s['tail_s']:g} s).")
        if "segment_s" in s:
            self._number_setting(s, "segment_s", "s", allow_none=False)
        s["calibrate_on"] = held_out.check_setting(s.get("calibrate_on"), self.name)
        if s["calibrate_on"] and s["settings"] == "shipped":
            raise ConfigError(f"{self.name} setting 'calibrate_on' needs settings = calibrated (as shipped, nothing is "
                              f"calibrated), got calibrate_on = '{s['calibrate_on']}' with settings = shipped.")
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
    def time_step_s(self, dt_s: float | None) -> float:
        """The time step a run or a calibration uses [s]: ``dt_s``, or :meth:`unposed_dt_s` when
        None; a ConfigError unless it is a finite number > 0."""
        if dt_s is None:
            return self.unposed_dt_s()
        try:
            dt = float(dt_s)
        except (TypeError, ValueError):
            dt = math.nan
        if not (math.isfinite(dt) and dt > 0.0):
            raise ConfigError(f"--dt must be > 0 s, got {dt_s!r}.")
        return dt

    # -- the one time-step rule -----------------------------------------------------------------
    def calibrated(self) -> bool:
        """Whether runs use a calibration: ``settings="calibrated"`` and no explicit contact."""
        return not self.explicit_contact() and self.settings["settings"] == "calibrated"

    def calibration_block(self, block: Block) -> Block:
        """The block the calibration of ``block``'s runs is made on: ``block`` itself, or the block the
        ``calibrate_on`` setting names or picks (:func:`~rockbench.engines.held_out.calibration_block`;
        a ConfigError for the mapped block itself, or a rule that finds none)."""
        return held_out.calibration_block(self.settings.get("calibrate_on"), block)

    def calibration_target(self, block: Block, restitution: Restitution) -> tuple[Block, float]:
        """The block the calibration of ``block``'s runs is made on and the η it aims at there [-]
        (:func:`~rockbench.engines.held_out.calibration_target`: the law's η for that block)."""
        return held_out.calibration_target(self.settings.get("calibrate_on"), block, restitution)

    def run_step_s(self, block: Block, eta: float, dt_s: float | None = None) -> float:
        """The step of the runs and the calibration of ``block`` [s]: ``dt_s`` where given; calibrated,
        the one time-step rule's (:meth:`converged_step_s`) on the block the calibration is made on
        (:meth:`calibration_block`) at ``eta``, the η the calibration aims at there
        (:meth:`calibration_target`); else :meth:`unposed_dt_s`."""
        on = self.calibration_block(block)
        if dt_s is not None or not self.calibrated() or self.contact_layout(on, eta) == "distributed":
            return self.time_step_s(dt_s)
        return self.converged_step_s(on, eta)[0]

    def converged_step_s(self, block: Block, eta: float) -> tuple[float, dict]:
        """The step :func:`~rockbench.engines.step_rule.converged_step` chooses for ``block`` at η [s],
        and its record; cached on disk with the calibrations. The search runs on ``block`` itself, with
        ``calibrate_on`` left out (its probe runs are of the block the step is for), so a held-out
        calibration shares the cached step of the block it names."""
        key = calibration.cache_key(**self._cache_identity(), kind="step-rule", rules_version=RULES_VERSION,
                                    block=[block.width_m, block.height_m, block.depth_m, block.mass_kg],
                                    target=round(float(eta), 12), ladder=list(step_rule.STEP_LADDER_S),
                                    probes=[step_rule.PROBE_W_RATIOS, step_rule.PROBE_MARGIN, step_rule.PROBE_DEEP,
                                            step_rule.PROBE_PULSES, step_rule.ETA_STEP_RTOL],
                                    settings=sorted((k, str(v)) for k, v in self.settings.items()
                                                    if k != "calibrate_on"))
        rec = self._steps.get(key) or calibration.load(key)
        if rec is None:
            rec = step_rule.converged_step(self._on_itself(), block, eta)[1]
            calibration.store(key, rec)
        self._steps[key] = rec
        return float(rec["dt_s"]), rec

    def _on_itself(self) -> "ContactEngineAdapter":
        """This adapter, or without ``calibrate_on`` a copy of it that calibrates every block on itself."""
        if not self.settings.get("calibrate_on"):
            return self
        if self._itself is None:
            self._itself = type(self)(**{**self.settings, "calibrate_on": None})
        return self._itself

    def dt_for(self, case) -> float:
        """As :meth:`EngineAdapter.dt_for`; calibrated, a case that poses no step runs at the one
        time-step rule's step, never coarser than its pulse accepts [s]."""
        if case.dt_s is None and self.calibrated():
            eta = self.calibration_target(case.block, case.restitution)[1]
            return case.pulse.check_dt(min(self.run_step_s(case.block, eta), case.pulse.max_dt_s()))
        return super().dt_for(case)

    # -- resolve: explicit, or defaults, or calibrated ---------------------------------------
    def explicit_contact(self) -> bool:
        """Whether contact settings were given that replace the calibration (default: none exist)."""
        return False

    def resolve(self, block: Block, restitution: Restitution, dt_s: float | None = None) -> dict:
        """The concrete settings cases of this block, restitution and time step [s] use (for run.json).

        Explicit contact settings, else (``settings="shipped"``) the engine's defaults, else the
        calibration to the restitution's η at this time step (:meth:`calibrate`, cached on disk), made
        on :meth:`calibration_block` (``block`` itself unless ``calibrate_on`` names another, which the
        record's ``calibrated_on`` then names) and aimed at the law's η for that block
        (:meth:`calibration_target`); then :meth:`_resolved_settings` builds the concrete settings for
        ``block``. Memoised per block, η and step.
        """
        on, eta = self.calibration_target(block, restitution) if self.calibrated() else \
            (block, restitution.eta(block.alpha_rad))
        dt = self.run_step_s(block, eta, dt_s)
        key = (block.width_m, block.height_m, block.depth_m, block.mass_kg, round(eta, 12), dt)
        if key not in self._resolved:
            cal = None
            if self.calibrated():   # by the adapter without calibrate_on: every run inside is of ``on`` itself
                cal = self._on_itself().calibrate(on, eta, dt_s=dt)
            out = self._resolved_settings(block, dt, cal)
            if cal is not None:
                out["calibration"] = self._calibration_summary(cal)
                if self.settings.get("calibrate_on"):
                    out["calibration"]["calibrated_on"] = on.name
                out["calibration"]["equals_shipped"] = self._equals_shipped(block, dt, out)
            if self.as_shipped() and self.SHIPPED_NOTE:
                out["shipped_note"] = self.SHIPPED_NOTE
            self._resolved[key] = out
        out = as_written(self._resolved[key])
        if dt_s is None and out.get("calibration"):   # the step the one time-step rule chose, and why
            out["calibration"] = {**out["calibration"], "step_rule": self.converged_step_s(on, eta)[1]}
        return out

    def describe(self) -> dict:
        """As :meth:`EngineAdapter.describe`, the settings as written (:func:`as_written`)."""
        return {**super().describe(), "settings": as_written(self.settings)}

    def _equals_shipped(self, block: Block, dt: float, resolved: dict) -> bool:
        """Whether calibrated settings ``resolved`` at step ``dt`` [s] are the engine as shipped: the
        same concrete settings at its own step (then the two variants give one answer, which the
        verdict counts once)."""
        shipped = type(self)(**{**self.settings, "settings": "shipped", "calibrate_on": None})
        if shipped.unposed_dt_s() != dt:
            return False
        skip = ("settings", "calibration")
        other = shipped._resolved_settings(block, dt, None)
        return {k: v for k, v in resolved.items() if k not in skip} == {k: v for k, v in other.items() if k not in skip}

    def _base_settings(self) -> dict:
        """The settings before any calibration: what a calibration's candidates start from and what
        its cache key names (default: the settings as given; an adapter that fills in a setting by
        mode, as PyBullet's solver iterations, overrides it)."""
        return dict(self.settings)

    @required("(block, dt_s, calibration) -> dict", "the concrete settings of a case: the settings with "
              "the calibration's (a CalibrationResult, None where explicit or as shipped), e.g. "
              "{**self._base_settings(), **(calibration.settings if calibration else {})}")
    def _resolved_settings(self, block: Block, dt: float, cal: CalibrationResult | None) -> dict:
        """The concrete settings for ``block`` at step ``dt`` [s], with the calibration ``cal`` (None:
        explicit or default contact)."""

    # -- the calibration frame ----------------------------------------------------------------
    def calibrate(self, block: Block, target_eta: float, *, dt_s: float | None = None,
                  use_cache: bool = True) -> CalibrationResult:
        """Contact settings whose free-rocking η reaches ``target_eta`` (1 %), by the ``contact``
        layout where the engine offers one: :meth:`_calibrate_corners`, or a row of points along the
        base (:meth:`_calibrate_distributed_n`, with the set number of points or 9, then 5, then 17
        until one reaches the target at an acceptable price); ``auto``: the corners up to 1 % above
        Housner's η_H (a plastic impact at a corner is Housner's), the row above (the modified η_M).
        A ConfigError with an explicit contact: a given contact replaces the calibration (:meth:`resolve`)."""
        if self.explicit_contact():
            given = [f"{k} = {self.settings[k]!r}" for k in getattr(self, "CALIBRATED_SETTINGS", ())
                     if self.settings.get(k) is not None]
            raise ConfigError(f"{self.name}: {', '.join(given) or 'a contact setting'} is given, and a given contact "
                              "replaces the calibration (in maps as here), so there is nothing to calibrate: leave out "
                              "--target to measure η with it, or leave it out to calibrate.")
        t = self.check_target_eta(target_eta)
        dt = self.time_step_s(dt_s)
        if self.contact_layout(block, t) != "distributed":
            return self._calibrate_corners(block, t, dt, use_cache)
        n_set = self.settings["contact_points"]
        return first_reached(lambda n: self._calibrate_distributed_n(block, t, n, dt, use_cache),
                             (n_set,) if n_set is not None else POINTS_TRIED, self.POINT_UNIT)

    def contact_layout(self, block: Block, target: float) -> str:
        """``corners`` or ``distributed``: the contact a calibration to ``target`` builds (``auto``: the
        corners up to 1 % above Housner's η_H, a row of points along the base above)."""
        kind = self.settings.get("contact") if self.distributed_contact else "corners"
        if kind == "auto":
            kind = "corners" if target <= 1.01 * housner_eta(block.alpha_rad) else "distributed"
        return "distributed" if kind == "distributed" else "corners"

    @required("(block, target, dt_s, use_cache) -> CalibrationResult", CALIBRATION_ADVICE,
              when=lambda ad: ad.calibrated())
    def _calibrate_corners(self, block: Block, target: float, dt: float,
                           use_cache: bool) -> CalibrationResult:  # pragma: no cover - declared
        """The contact at the two bottom corners calibrated to ``target`` at step ``dt`` [s]."""

    @required("(block, target, n, dt_s, use_cache) -> CalibrationResult", "a row of n contact points along "
              "the base calibrated to the target (an engine with distributed_contact = True)",
              when=lambda ad: ad.distributed_contact)
    def _calibrate_distributed_n(self, block: Block, t: float, n: int, dt: float,
                                 use_cache: bool) -> CalibrationResult:  # pragma: no cover - declared
        """A row of ``n`` contact points along the base calibrated to ``t`` at step ``dt`` [s]."""

    def _cache_identity(self) -> dict:
        """What names the engine in the calibration cache key: its name and version (an adapter
        that shares another engine's calibrations names that engine; one with solver settings of
        its own adds them)."""
        return {"engine": self.name, "version": self.version()}

    def _cache_key(self, block: Block, target: float, dt: float, version: int, **identity) -> str:
        """The calibration cache key: engine, its version, the calibration's ``version``, the rule set's
        (:data:`~rockbench.reference_solver.rules.RULES_VERSION`), block,
        target η, step [s] and what else the result depends on (``identity``)."""
        return calibration.cache_key(**self._cache_identity(), calibration_version=version, rules_version=RULES_VERSION,
                                     block=[block.width_m, block.height_m, block.depth_m, block.mass_kg],
                                     target=target, dt=dt, **identity)

    def _cached(self, key: str, use_cache: bool) -> CalibrationResult | None:
        """The cached calibration under ``key``, or None (always None without ``use_cache``); a setting
        the calibration chose, stored under its old name (:data:`RENAMED_SETTINGS`), is read under the
        new one. Other keys stay: Exudyn's records name its model's own parameters, some of which
        share an old setting's name."""
        rec = calibration.load(key) if use_cache else None
        if rec is None or "result" not in rec:
            return None
        res = CalibrationResult(**rec["result"])
        chosen = set(getattr(self, "CALIBRATED_SETTINGS", ()))   # the skeleton's adapters declare them
        renamed = {old: new for old, new in RENAMED_SETTINGS.get(self.name, {}).items() if new in chosen}
        return dataclasses.replace(res, settings={renamed.get(k, k): v for k, v in res.settings.items()})

    @staticmethod
    def _store(key: str, res: CalibrationResult, search: dict) -> None:
        """Cache a calibration: ``{"result": …, "search": …}`` (``search``: what was tried)."""
        calibration.store(key, {"result": {k: v for k, v in res.to_dict().items() if k != "rel_error"},
                                "search": search})

    @staticmethod
    def _settings_diagnostics(resolved: dict) -> dict:
        """What a trajectory's diagnostics record of the resolved settings it ran with: the settings'
        name and, calibrated, the calibration's summary (an explicit contact may resolve it to None)."""
        out = {"settings": resolved["settings"]}
        if resolved.get("calibration") is not None:
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


def as_written(settings: Mapping[str, Any]) -> dict:
    """``settings`` as run.json records them: a ``calibrate_on`` (:class:`~rockbench.engines.held_out.CalibrateOn`)
    as written, ``sibling`` or the block's name."""
    out = dict(settings)
    if out.get("calibrate_on") is not None:
        out["calibrate_on"] = str(out["calibrate_on"])
    return out


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

