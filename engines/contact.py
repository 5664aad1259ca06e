"""The base of every contact engine (MuJoCo, PyBullet, Exudyn, ...): :class:`ContactEngine`.

A contact engine simulates the block touching the table through the engine's own contact model. Its
adapter implements four batch-shaped methods and declares what it ships and what a calibration may
change; this base keeps what every run needs (the settings, a case posed and resolved, the one loop),
and the policies are functions of the engine in :mod:`rockbench.engines.calibration` (the time step,
free rocking, the calibration and its price), the same for every engine:

* **the four methods**: ``build(block, s, dt_s)`` the scene for a block and the resolved settings
  ``s``; ``start(scene, block, s, dt_s, pulses, theta0_rad, n_steps)`` one world per pulse (None: free
  rocking), every block at rest at ``theta0_rad`` on its lower corner (:func:`~rockbench.engines.motion.pivot_pose`),
  the rows of the samples so far ``(W, n, k)``; ``advance(scene, n_from, n_to)`` every world from step
  ``n_from`` to ``n_to`` under its pulse, the new rows ``(W, n, k)``; ``read(scene, block, s, rows, t_s,
  pulse)`` one world's :class:`~rockbench.engines.motion.Motion` from its rows (called on each
  segment's rows and on the whole run's: a function of the rows alone);
* **the declarations**: ``own_dt_s`` (the engine's own step), ``fixed_dt_s`` (the benchmark's step
  where no rule chooses one), ``SETTINGS`` (the engine's own settings; the shared ones are added),
  ``SHIPPED`` (the shipped contact, ``{setting: value}``, None for the engine's own value unstated),
  ``MODE_DEFAULTS`` (settings the benchmark sets by mode: ``{setting: (as shipped, calibrated)}``),
  ``KNOBS`` (:class:`~rockbench.engines.calibration.knobs.Knob`: name, unit, values), and where the
  engine builds a row of contact points along the base, ``CONTACT_ROWS`` and ``ROW_KNOBS``;
* **settings**: the shared settings checked once, and one resolution (:meth:`ContactEngine.settings_with`);
* **the time step**: every case posed once (:meth:`ContactEngine.posed`) by the one resolver, a function
  of the engine (:func:`rockbench.engines.calibration.time_step.step_for`), the time-step rule's step
  calibrated (:mod:`rockbench.engines.calibration.step_rule`);
* **the run**: one stepping loop and one end of a run (:mod:`rockbench.engines.loop`), cases batched
  up to ``max_worlds`` worlds, a run the engine halts retried as ``RETRIES`` says;
* **free rocking**: one test (:func:`rockbench.engines.calibration.free_rocking.measure_restitution`, a
  function of the engine), η read by the one reader; the base's ``measure_many`` hook runs it per setting;
* **the calibration**: one routine (:func:`rockbench.engines.calibration.routine.calibrate`, a function
  of the engine): the knobs searched (or the engine's own ``candidates``), the one pick, the cache; a
  row along the base at a price (:mod:`rockbench.engines.calibration.layout`); the block calibrated on
  (:mod:`rockbench.engines.calibration.held_out`).
"""

from __future__ import annotations

import dataclasses
import json
from typing import Any, ClassVar, Mapping


from rockbench.reference_solver.classify import overturn_certain
from rockbench.reference_solver.errors import ConfigError
from rockbench.engines.errors import EngineError
from rockbench.reference_solver.model import Block
from rockbench.reference_solver.restitution import Restitution
from rockbench.engines import progress
from rockbench.engines.calibration import held_out, knobs, layout, routine, time_step
from rockbench.engines.calibration.free_rocking import free_rocking_run
from rockbench.engines.calibration.routine import POINTS_TRIED
from rockbench.engines.contract import SETTINGS_MODES, CalibrationResult, EngineAdapter
from rockbench.engines.hooks import hook_line, required
from rockbench.engines.loop import run_worlds

__all__ = ["ContactEngine", "SHARED_SETTINGS", "DRIVES", "PLANAR_MODES", "MODES", "CONTACT_LAYOUTS",
           "POINTS_TRIED", "MAX_CONTACT_POINTS", "as_written"]

#: The settings every contact engine has, with typical defaults (an adapter may change a default in its
#: own ``SETTINGS``): the contact ``calibrated`` to the case's η or the engine as ``shipped``; the drive;
#: the block kept in the x–z plane; the block–table friction [-]; the longest and shortest simulated
#: time after the pulse [s]; the block the calibration is made on (the held-out check)
SHARED_SETTINGS: Mapping[str, Any] = {"settings": "calibrated", "drive": "inertial", "planar": True, "friction": 10.0,
                                      "tail_s": 3.0, "min_tail_s": 0.5, "calibrate_on": None}

#: ``drive`` values: the inertial force −m·ü at the centre of mass, or a table moved along u(t)
DRIVES = ("inertial", "table")
#: ``planar`` values: the block kept in the x–z plane, or a free 3-D body
PLANAR_MODES = (True, False)
#: the settings that choose how the problem is posed, and their values
MODES = {"drive": DRIVES, "planar": PLANAR_MODES}
#: ``contact`` values of an engine with a row along the base: the corners alone, a row of points along
#: the base, or the corners unless the target η is above Housner's (then the row); docs/contact.md
CONTACT_LAYOUTS = ("auto", "corners", "distributed")
#: The most points a row along the base may have
MAX_CONTACT_POINTS = 101

#: What to do about a contact engine without a calibration (its ``settings`` default is ``calibrated``)
CALIBRATION_ADVICE = ("declare KNOBS (the calibration then searches them) or implement candidates; or run the "
                      "engine as shipped: --set settings=shipped, or \"settings\": \"shipped\" in SETTINGS")


class ContactEngine(EngineAdapter):
    """Base of the adapters of engines with a contact model (module docstring)."""

    #: the benchmark's step where no rule chooses one (a contact given by hand, a row along the base,
    #: as shipped where the engine has no step of its own) [s]
    fixed_dt_s: ClassVar[float] = 5e-4
    #: the engine's shipped contact: ``{setting: value}``; each is a setting (default None, "not given":
    #: given, it replaces the calibration), its value filled in from here where nothing else sets it
    #: (None: the engine's own, unstated)
    SHIPPED: ClassVar[Mapping[str, Any]] = {}
    #: settings the benchmark sets by mode where not given: ``{setting: (as shipped, calibrated)}``
    MODE_DEFAULTS: ClassVar[Mapping[str, tuple]] = {}
    #: the calibration's knobs (:class:`~rockbench.engines.calibration.knobs.Knob`) at the corners
    KNOBS: ClassVar[tuple] = ()
    #: what a point of a row along the base is, in notes (``"points"``, ``"spheres"``): the engine builds
    #: such a row (the settings ``contact`` and ``contact_points``); None: the corners only
    CONTACT_ROWS: ClassVar[str | None] = None
    #: the calibration's knobs of a row along the base (or the engine's own ``candidates``)
    ROW_KNOBS: ClassVar[tuple] = ()
    #: the shipped contact measured first and kept within this fraction of the target [-] (None: not)
    START_KEEP_RTOL: ClassVar[float | None] = None
    #: what to try, in turn, when the engine halts a run before the overturn is certain:
    #: ``(step factor, settings added)`` each; none left, the case fails with the engine's reason
    RETRIES: ClassVar[tuple] = ()
    #: worlds an engine steps together (1: one case at a time); more: cases of one block, settings and
    #: step run in batches (``batching = "native"``)
    max_worlds: ClassVar[int] = 1
    #: the loop's segments end at each run's marks and last at most this after its pulse [s]
    #: (:mod:`rockbench.engines.loop`), for an engine whose steps do not depend on where a segment
    #: starts; None: fixed segments of ``segment_s``
    near_segment_s: ClassVar[float | None] = None
    #: the ``drive`` and ``planar`` values the adapter runs, e.g. ``{"drive": ("inertial",)}`` (a key left
    #: out: every value of :data:`MODES`); another is a ConfigError at construction
    SUPPORTED_MODES: ClassVar[Mapping[str, tuple]] = {}
    #: what the engine's shipped settings do in this benchmark, measured, in one sentence (run.json records
    #: it as shipped, the verdict's failure reason quotes it)
    SHIPPED_NOTE: ClassVar[str | None] = None
    #: version of the calibration's search; part of the cache key (raise it when the search changes)
    CALIBRATION_VERSION: ClassVar[int] = 1

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if any(k in cls.__dict__ for k in ("SETTINGS", "SHIPPED", "MODE_DEFAULTS", "CONTACT_ROWS")):
            rows = {"contact": "auto", "contact_points": None} if cls.CONTACT_ROWS else {}
            given = {k: None for k in (*cls.SHIPPED, *cls.MODE_DEFAULTS)}
            cls.SETTINGS = {**SHARED_SETTINGS, **given, **rows, **cls.__dict__.get("SETTINGS", cls.SETTINGS)}
        set_ = [k for k in (*cls.SHIPPED, *cls.MODE_DEFAULTS) if cls.SETTINGS.get(k) is not None]
        if set_:
            raise TypeError(f"{cls.__name__}.SETTINGS gives {set_[0]!r} a default ({cls.SETTINGS[set_[0]]!r}): a "
                            "setting of SHIPPED or MODE_DEFAULTS defaults to None (not given), and its value there "
                            "fills it in.")
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
        super().__init__(**settings)
        #: the adapter's own store of what it builds (scenes, compiled models), kept for its life
        self.scenes: dict = {}
        self._resolved: dict = {}
        self._itself: ContactEngine | None = None

    # -- settings -----------------------------------------------------------------------------
    def _validate_settings(self, s: dict) -> None:
        self.choice_setting(s, "settings", SETTINGS_MODES, allow_none=False)
        self.choice_setting(s, "drive", DRIVES, allow_none=False)
        self.bool_setting(s, "planar")
        for key in MODES:
            supported = self.supported_modes(key)
            if s[key] not in supported:
                shown = ", ".join(str(v).lower() if isinstance(v, bool) else v for v in supported)
                raise ConfigError(f"{self.name} does not run {key} = {str(s[key]).lower()} (its SUPPORTED_MODES): "
                                  f"use {key} = {shown}, or an engine that runs it (docs/engines.md).")
        self.number_setting(s, "friction", allow_none=False)
        self.number_setting(s, "tail_s", "s", allow_none=False)
        self.number_setting(s, "min_tail_s", "s", allow_zero=True, allow_none=False)
        if s["min_tail_s"] > s["tail_s"]:
            raise ConfigError(f"{self.name} setting 'min_tail_s' ({s['min_tail_s']:g} s) must not exceed "
                              f"'tail_s' ({s['tail_s']:g} s).")
        if "segment_s" in s:
            self.number_setting(s, "segment_s", "s", allow_none=False)
        if self.CONTACT_ROWS:
            self.choice_setting(s, "contact", CONTACT_LAYOUTS, allow_none=False)
            self.whole_setting(s, "contact_points", minimum=3, maximum=MAX_CONTACT_POINTS)
        s["calibrate_on"] = held_out.check_setting(s.get("calibrate_on"), self.name)
        if s["calibrate_on"] and s["settings"] == "shipped":
            raise ConfigError(f"{self.name} setting 'calibrate_on' needs settings = calibrated (as shipped, nothing is "
                              f"calibrated), got calibrate_on = '{s['calibrate_on']}' with settings = shipped.")
        self.validate(s)

    def explicit_contact(self) -> bool:
        """Whether a contact setting (one of :attr:`SHIPPED`) was given: it replaces the calibration."""
        return any(self.settings[k] is not None for k in self.SHIPPED)

    def calibrated(self) -> bool:
        """Whether runs use a calibration: ``settings="calibrated"`` and no contact given."""
        return not self.explicit_contact() and self.settings["settings"] == "calibrated"

    def settings_with(self, contact: Mapping | None = None, points: int | None = None) -> dict:
        """The one resolution of the settings a run uses: the settings given; where ``settings`` is
        ``calibrated``, :attr:`MODE_DEFAULTS`' calibrated values (else their shipped ones); the
        ``contact`` (a calibration's settings, or a candidate's: its values that are not None; a row
        of ``points`` along the base); with a contact given or chosen, a contact setting left out at
        its knob's ``start``; every setting still None at its :attr:`SHIPPED` value; a row along the
        base without ``contact_points``, :data:`POINTS_TRIED`'s first."""
        s = dict(self.settings)
        mode = 1 if s["settings"] == "calibrated" else 0
        s.update({k: pair[mode] for k, pair in self.MODE_DEFAULTS.items() if s[k] is None})
        s.update({k: v for k, v in (contact or {}).items() if v is not None and k in self.SETTINGS})
        if points is not None:
            s.update(contact="distributed", contact_points=points)
        if contact or self.explicit_contact():
            s.update({k.name: k.start for k in self.KNOBS if k.start is not None and s.get(k.name) is None})
        s.update({k: v for k, v in self.SHIPPED.items() if s[k] is None})
        if self.CONTACT_ROWS and s["contact"] == "distributed" and s["contact_points"] is None:
            s["contact_points"] = POINTS_TRIED[0]
        return s

    def _on_itself(self) -> "ContactEngine":
        """This adapter, or without ``calibrate_on`` a copy of it that calibrates every block on itself."""
        if not self.settings.get("calibrate_on"):
            return self
        if self._itself is None:
            self._itself = type(self)(**{**self.settings, "calibrate_on": None})
        return self._itself

    # -- the time step ------------------------------------------------------------------------
    def posed(self, case):
        """``case`` with its step decided once, by the one resolver of a contact engine
        (:func:`~rockbench.engines.calibration.time_step.step_for`): what runs."""
        return dataclasses.replace(case, dt_s=time_step.step_for(self, case.block, case.eta, case.pulse, case.dt_s,
                                                                 restitution=case.restitution))

    # -- resolve: a contact given, or as shipped, or calibrated -----------------------------------
    def resolve(self, block: Block, restitution: Restitution, dt_s: float | None = None) -> dict:
        """The concrete settings cases of this block, restitution and step [s] use (for run.json; the
        step where none is given: :func:`~rockbench.engines.calibration.time_step.step_for`, and the
        time-step rule's record with it).

        A contact given, else as shipped the engine's, else the calibration to the restitution's η
        at this step (:func:`~rockbench.engines.calibration.routine.calibrate`, cached) made on the block
        ``calibrate_on`` names (the record's ``calibrated_on`` names it) and aimed at the law's η for
        that block (:func:`~rockbench.engines.calibration.held_out.calibration_target`);
        :meth:`settings_with` resolves them. Memoised."""
        on, eta = (held_out.calibration_target(self.settings["calibrate_on"], block, restitution) if self.calibrated()
                   else (block, restitution.eta(block.alpha_rad)))
        dt = time_step.step_for(self, block, restitution.eta(block.alpha_rad), dt_s=dt_s, restitution=restitution)
        key = (block.width_m, block.height_m, block.depth_m, block.mass_kg, round(eta, 12), dt)
        if key not in self._resolved:
            cal = routine.calibrate(self._on_itself(), on, eta, dt_s=dt) if self.calibrated() else None
            out = self.settings_with(cal.settings if cal else None)
            if cal is not None:
                out["calibration"] = _summary(cal) | ({"calibrated_on": on.name} if self.settings["calibrate_on"] else {})
                out["calibration"]["equals_shipped"] = self._equals_shipped(block, eta, dt, out)
            if self.as_shipped() and self.SHIPPED_NOTE:
                out["shipped_note"] = self.SHIPPED_NOTE
            self._resolved[key] = out
        out = as_written(self._resolved[key])
        if dt_s is None and out.get("calibration") and layout.contact_layout(self, on, eta) == "corners":
            out["calibration"] = {**out["calibration"], "step_rule": time_step.rule_step(self, on, eta)[1]}
        return out

    def _equals_shipped(self, block: Block, eta: float, dt: float, resolved: dict) -> bool:
        """Whether calibrated settings ``resolved`` at step ``dt`` [s] are the engine as shipped: the
        same settings at its own step (then the two variants give one answer, counted once)."""
        shipped = type(self)(**{**self.settings, "settings": "shipped", "calibrate_on": None})
        if time_step.step_for(shipped, block, eta) != dt:
            return False
        skip = ("settings", "calibration")
        other = shipped.settings_with()
        return {k: v for k, v in resolved.items() if k not in skip} == {k: v for k, v in other.items() if k not in skip}

    def describe(self) -> dict:
        """As :meth:`EngineAdapter.describe`, the settings as written (:func:`as_written`)."""
        return {**super().describe(), "settings": as_written(self.settings), "fixed_dt_s": self.fixed_dt_s}

    # -- the four methods ---------------------------------------------------------------------
    @required("(block, s, dt_s) -> scene", "build (or reuse) the engine's scene for the block and the resolved "
              "settings s (a dict), contact parameters set")
    def build(self, block: Block, s: dict, dt_s: float) -> Any:  # pragma: no cover - declared
        """The engine's scene for ``block`` and the resolved settings ``s`` at step ``dt_s`` [s]."""

    @required("(scene, block, s, dt_s, pulses, theta0_rad, n_steps) -> ndarray (W, n, k)", "one world per pulse "
              "(None: free rocking), every block at rest at theta0_rad on its lower corner (pivot_pose), each drive "
              "loaded for n_steps steps; return the rows of the samples so far (sample 0: n = 1)")
    def start(self, scene, block: Block, s: dict, dt_s: float, pulses: list, theta0_rad: float,
              n_steps: int):  # pragma: no cover - declared
        """The rows of the samples so far, ``(W, n, k)`` (sample 0 of every world: n = 1)."""

    @required("(scene, n_from, n_to) -> ndarray (W, n_to - n_from, k)", "step every world from step n_from to "
              "n_to under its pulse; return the rows after each step")
    def advance(self, scene, n_from: int, n_to: int):  # pragma: no cover - declared
        """The rows of samples ``n_from + 1 … n_to`` of every world, ``(W, n, k)``."""

    @required("(scene, block, s, rows, t_s, pulse) -> Motion", "one world's centre of mass (x, height above the "
              "table top, velocities), theta, theta rate and the table's x from its rows (t_s: step × dt)")
    def read(self, scene, block: Block, s: dict, rows, t_s, pulse):  # pragma: no cover - declared
        """One world's :class:`~rockbench.engines.motion.Motion` from its rows ``(n, k)``."""

    def stop_angles(self, scene, block: Block, s: dict, rows, t_s, pulse) -> tuple:
        """Hook: what the loop's end-of-run test reads of one world's new rows: ``(θ [rad], θ̇ [rad/s],
        the rows' own times [s] or None)``, as :meth:`read` gives them (the default reads them from it);
        an engine whose ``read`` does more than these overrides it to test a segment for less."""
        m = self.read(scene, block, s, rows, t_s, pulse)
        return m.theta_rad, m.theta_dot_rad_s, m.t_s

    def retire(self, scene, w: int) -> None:
        """Hook: world ``w`` has stopped; a batch engine that can may stop stepping it (its later rows
        are dropped whatever they hold). Default: nothing."""

    def missing_hooks(self) -> list[str]:
        """As :meth:`EngineAdapter.missing_hooks`, and the calibration: calibrated runs need
        :attr:`KNOBS` or the engine's own ``candidates``."""
        out = super().missing_hooks()
        own = type(self).candidates is not ContactEngine.candidates
        if self.calibrated() and not (self.KNOBS or own):
            out.append(hook_line(type(self), "KNOBS", " (or candidates)", CALIBRATION_ADVICE))
        return out

    # -- the runs -----------------------------------------------------------------------------
    def run_worlds(self, block: Block, s: dict, dt: float, pulses: list, theta0: float = 0.0,
                   duration_s: float | None = None) -> list:
        """One batch of worlds through the one loop (:func:`rockbench.engines.loop.run_worlds`): each
        world's ``(Trajectory, Motion)``. An engine that runs the whole loop on its device replaces it."""
        return run_worlds(self, block, s, dt, pulses, theta0, duration_s)

    def _pulse_runs(self, block: Block, s: dict, dt: float, pulses: list) -> list:
        """The trajectories of pulse runs (one batch): a run the engine halted before the overturn was
        certain retried as :attr:`RETRIES` says; still halted, an EngineError; a run the engine found
        no measurement (``Motion.error``), an EngineError."""
        out = []
        for p, (tr, m) in zip(pulses, self.run_worlds(block, s, dt, pulses)):
            for factor, extra in self.RETRIES if _halted(tr, block) else ():
                tried = tr.diagnostics["engine_stopped"]
                tr, m = self.run_worlds(block, {**s, **extra}, dt * factor, [p])[0]
                tr.diagnostics.update(retried_at_dt_s=dt * factor, retried_with=extra, earlier_attempt=tried)
                if not _halted(tr, block):
                    break
            out.append(EngineError(tr.diagnostics["engine_stopped"]) if _halted(tr, block) else
                       EngineError(m.error) if m.error else tr)
        return out

    def _simulate(self, case) -> Any:
        out = self._simulate_many([case])[0]
        if isinstance(out, BaseException):
            raise out
        return out

    def worlds_per_batch(self, s: dict) -> int:
        """How many worlds one batch of the resolved settings ``s`` holds: :attr:`max_worlds`; an engine
        whose answer moves with its batch-mates under some settings returns 1 for those (a hook)."""
        return self.max_worlds

    def _simulate_many(self, cases: list) -> list:
        """Cases whose steps are set, in batches of up to :meth:`worlds_per_batch` worlds of one block,
        resolved settings and step; an engine exception fails its case (its whole batch)."""
        out: list = [None] * len(cases)
        groups: dict = {}
        for i, c in enumerate(cases):
            try:
                s = self.resolve(c.block, c.restitution, c.dt_s)
            except ConfigError:
                raise
            except Exception as e:  # noqa: BLE001 - recorded per cell, the sweep goes on
                out[i] = e
                continue
            key = (json.dumps(c.block.to_dict(), sort_keys=True), c.dt_s, json.dumps(s, sort_keys=True, default=str))
            groups.setdefault(key, (c.block, s, c.dt_s, []))[3].append(i)
        for block, s, dt, idx in groups.values():
            n_worlds = self.worlds_per_batch(s)
            for k in range(0, len(idx), n_worlds):
                part = idx[k:k + n_worlds]
                try:
                    runs = self._pulse_runs(block, s, dt, [cases[i].pulse for i in part])
                except Exception as e:  # noqa: BLE001 - the batch failed inside the engine
                    runs = [e] * len(part)
                progress.advance(len(part))
                for i, tr in zip(part, runs):
                    if not isinstance(tr, BaseException):
                        tr.diagnostics.update(_settings_diagnostics(s))
                    out[i] = tr
        return out

    # -- free rocking: the batch hook (the test is engines/calibration/free_rocking.py's) ----------
    def measure_many(self, block: Block, settings: list[dict], dt: float, theta0_frac: float = 0.5) -> list:
        """Free rocking of each of ``settings`` (resolved settings) at step ``dt`` [s]: a
        :class:`~rockbench.engines.contract.RestitutionMeasurement` each, or the exception it raised."""
        out = []
        for s in settings:
            try:
                out.append(free_rocking_run(self, block, s, dt, theta0_frac))
            except Exception as e:  # noqa: BLE001 - a setting the engine fails on is recorded, the search goes on
                out.append(e)
            progress.advance()
        return out

    # -- the calibration ----------------------------------------------------------------------
    def candidates(self, block: Block, target: float, dt_s: float, points: int | None, measure) -> list[dict]:
        """Hook: the candidates a calibration measures, in order, each a row of ``measure(candidates)``
        (contact settings in, rows with what the pick reads out): at the corners (``points`` None) the
        one search of :attr:`KNOBS`, the shipped contact first where :attr:`START_KEEP_RTOL` is set; a
        row of ``points`` along the base, of :attr:`ROW_KNOBS`. An engine with a search of its own
        replaces it."""
        if points is None:
            return knobs.search(self.KNOBS, block, target, dt_s, measure, self.START_KEEP_RTOL, self.SHIPPED)
        return knobs.search(self.ROW_KNOBS, block, target, dt_s, measure)


def _halted(tr, block: Block) -> bool:
    """Whether the engine halted a run before its overturn was certain."""
    return "engine_stopped" in tr.diagnostics and not overturn_certain(
        tr.t_s, tr.theta_rad, tr.theta_dot_rad_s, alpha_rad=block.alpha_rad, t_pulse_end_s=tr.t_pulse_end_s).any()


def _summary(cal: CalibrationResult) -> dict:
    """What run.json records of the calibration behind the resolved settings."""
    return {"eta_target": cal.eta_target, "eta_measured": cal.eta_measured, "eta_std": cal.eta_std,
            "reached": cal.reached, "price": cal.price, "note": cal.note, "sink_m": cal.sink_m}


def _settings_diagnostics(resolved: dict) -> dict:
    """What a trajectory's diagnostics record of the resolved settings it ran with: the settings'
    name and, calibrated, the calibration's summary."""
    out = {"settings": resolved["settings"]}
    if resolved.get("calibration") is not None:
        out["calibration"] = dict(resolved["calibration"])
    return out


def as_written(settings: Mapping[str, Any]) -> dict:
    """``settings`` as run.json records them: a ``calibrate_on``
    (:class:`~rockbench.engines.calibration.held_out.CalibrateOn`) as written, ``sibling`` or the
    block's name."""
    out = dict(settings)
    if out.get("calibrate_on") is not None:
        out["calibrate_on"] = str(out["calibrate_on"])
    return out
