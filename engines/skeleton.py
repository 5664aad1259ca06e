"""The contact-engine skeleton: one stepping loop, one end of a run, one free-rocking test, one
calibration frame; an engine adapter fills in a few hooks.

:class:`SteppedContactAdapter` owns everything a contact engine shares beyond its settings
(:class:`~rockbench.engines.contact.ContactEngineAdapter`):

* **the run** (:meth:`~SteppedContactAdapter._trajectory`): the pulse is simulated whole, then the run
  stops at the first sample where floor 1's end-of-run rule
  (:func:`~rockbench.reference_solver.classify.run_end`: diverged, overturn certain, or trapped
  below the barrier after ``min_tail_s``) says so, else ``tail_s`` after the pulse. The engine
  advances in segments (``segment_s``, or :attr:`~SteppedContactAdapter.default_segment_s`) and the
  rule is tested on each segment's samples; samples after the stop are dropped, so the result does
  not depend on the segment length. An engine with its own sampling (more or fewer rows than steps
  in a segment) gives each row's step number (:meth:`~SteppedContactAdapter._sample_steps`): the
  rule counts the rows it got, each at its own time;
* **the read-out** (:meth:`~SteppedContactAdapter._record`): both bottom corners relative to the
  table (:func:`corners`), the block's own energy
  (:func:`~rockbench.engines.contact.body_energy_j_kg`), penetration, steps and speed, from the
  block's pose and velocity that the engine reports (a :class:`Motion`);
* **the free-rocking test** (:meth:`~SteppedContactAdapter.measure_restitution`): a release from
  rest at ``theta0_frac·α`` pivoting on the +x corner, η read by the one reader
  (:data:`~rockbench.engines.free_rocking.PEAK_RATIO`), the resting sink and the hop read from the
  run's corners (:func:`~rockbench.engines.free_rocking.contact_figures`);
* **the calibration frame**: the target and step checks, the layout dispatch (corners, or a row of
  points along the base tried with 9, 5, 17 points), one cache record shape
  (:meth:`~SteppedContactAdapter._cached` / :meth:`~SteppedContactAdapter._store`), the one search
  of the declared knobs (:meth:`~SteppedContactAdapter._calibrate_knobs`,
  :func:`~rockbench.engines.knobs.search`), the one pick (:func:`~rockbench.engines.pick.pick`) and
  the distributed contact's search at a price (:meth:`~SteppedContactAdapter._calibrate_distributed_n`).

The hooks an adapter implements (besides the settings hooks of ``ContactEngineAdapter``):

``_world(block, s, dt_s) -> world``
    Build (or reuse) the scene for the block and the resolved settings ``s``, contact parameters set.
``_start(world, block, s, dt_s, pulse, theta0_rad, n_steps) -> ndarray (1, k)``
    Put the block at rest at ``theta0_rad`` pivoting on its lower corner (:func:`pivot_pose`), the
    table at rest at x = 0, load the drive of ``pulse`` (None: free rocking) for ``n_steps``
    steps of ``dt_s``; return the state of sample 0 as one row of the engine's choice.
``_advance(world, n_from, n_to) -> ndarray (n_to − n_from, k)``
    Step from step ``n_from`` to ``n_to``; the states of samples ``n_from + 1 … n_to``.
``_angles(world, rows) -> (θ [rad], θ̇ [rad/s])``
    The rotation about +y and its rate from state rows.
``_motion(world, block, s, data, t_s, pulse) -> Motion``
    The block's centre of mass (x, height above the table top, velocities), θ, θ̇ and the table's
    position and velocity from all the state rows of a run, plus engine diagnostics.

and, for the calibration, ``CALIBRATION_KNOBS`` (its contact knobs, :mod:`rockbench.engines.knobs`:
the skeleton then runs the one search, and the one pick, :mod:`rockbench.engines.pick`, chooses among
its candidates); where it offers a row of points along the base, ``_distributed_grid`` (or, for an
engine that measures its candidates itself, ``_distributed_rows``).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ..reference_solver.classify import run_end
from ..reference_solver.errors import ConfigError
from ..reference_solver.model import Block
from ..reference_solver.restitution import Restitution
from .base import CalibrationResult, RestitutionMeasurement, Trajectory, uplift_tol_rad
from .contact import CALIBRATION_ADVICE, ContactEngineAdapter, body_energy_j_kg
from .free_rocking import PEAK_RATIO, contact_figures, first_quarter_s
from .hooks import MissingHook, hook_line, required
from .knobs import search as search_knobs
from . import price as pricing
from .pick import ETA_RESOLUTION, Candidate, pick, ranked, regular
from .renamed import adopt_renamed_methods, warn_renamed

__all__ = ["SteppedContactAdapter", "Motion", "corners", "pivot_pose", "run_steps", "MAX_PRICE_TRIES"]

#: How many reached candidates the distributed contact's search prices at most.
MAX_PRICE_TRIES = 8


@dataclass
class Motion:
    """The block's state over a run, sample by sample, as the engine reports it (``(n,)`` arrays).

    Attributes
    ----------
    x_m, z_m : ndarray
        Centre of mass: x in the world, height above the table top [m].
    theta_rad, theta_dot_rad_s : ndarray
        Rotation about +y [rad] and its rate [rad/s].
    vx_m_s, vz_m_s : ndarray
        Velocity of the centre of mass in the world [m/s].
    table_x_m, table_vx_m_s : ndarray or None
        The table's position and velocity along x [m], [m/s]; None: at rest at 0.
    diagnostics : dict
        The engine's own figures for the trajectory (lateral drift, table tracking, ...).
    t_s : ndarray or None
        The samples' times as the engine reports them [s]; None: step number × step.
    corner_x_m, corner_z_m : ndarray or None
        ``(n, c)`` bottom contact points as the engine measures them: x relative to the table and
        clearance above its top [m]; None: :func:`corners` of the centre of mass and θ.
    energy_j_kg : ndarray or None
        The block's own energy as the engine computes it [J/kg]; None:
        :func:`~rockbench.engines.contact.body_energy_j_kg`.
    """

    x_m: np.ndarray
    z_m: np.ndarray
    theta_rad: np.ndarray
    vx_m_s: np.ndarray
    vz_m_s: np.ndarray
    theta_dot_rad_s: np.ndarray
    table_x_m: np.ndarray | None = None
    table_vx_m_s: np.ndarray | None = None
    diagnostics: dict = field(default_factory=dict)
    t_s: np.ndarray | None = None
    corner_x_m: np.ndarray | None = None
    corner_z_m: np.ndarray | None = None
    energy_j_kg: np.ndarray | None = None


def corners(block: Block, xc, zc, th, u_tab):
    """The (+x, −x) bottom corners relative to the table: x and height above its top, ``(n, 2)`` each
    [m], from the centre of mass (x, height) [m], θ [rad] and the table's x [m]."""
    b, h = block.width_m, block.height_m
    c, s = np.cos(th), np.sin(th)
    xs, zs = [], []
    for side in (1.0, -1.0):
        # rotation about +y by θ: body (x, z) -> (x cosθ + z sinθ, −x sinθ + z cosθ)
        xs.append(xc + side * b / 2 * c - h / 2 * s - u_tab)
        zs.append(zc - side * b / 2 * s - h / 2 * c)
    return np.stack(xs, axis=1), np.stack(zs, axis=1)


def pivot_pose(block: Block, theta0_rad: float) -> tuple[float, float]:
    """The centre of mass (x, height above the table) [m] of a block at rest at ``theta0_rad``
    pivoting on its lower corner (x = ±b/2, z = 0)."""
    s = 1.0 if theta0_rad >= 0 else -1.0
    R, alpha = block.half_diagonal_m, block.alpha_rad
    return s * (block.width_m / 2 - R * math.sin(alpha - abs(theta0_rad))), R * math.cos(alpha - abs(theta0_rad))


def _worlds(rows) -> np.ndarray:
    """State rows with a leading world axis: ``(n, k)`` of one world becomes ``(1, n, k)``."""
    rows = np.asarray(rows, dtype=float)
    return rows[None] if rows.ndim == 2 else rows


def run_steps(dt_s: float, t_pulse_end_s: float, tail_s: float, min_tail_s: float,
              duration_s: float | None = None) -> tuple[int, int, float]:
    """Steps of a run: the most, the pulse's and the first at which the trapped rule applies (inf
    for a free-rocking test of ``duration_s`` [s]) [-]."""
    t_stop = (t_pulse_end_s + tail_s) if duration_s is None else duration_s
    n_max = int(math.ceil(t_stop / dt_s - 1e-9))
    n_pulse = int(math.ceil(t_pulse_end_s / dt_s - 1e-9))
    n_min = n_pulse + int(math.ceil(min_tail_s / dt_s - 1e-9)) if duration_s is None else math.inf
    return n_max, n_pulse, n_min


def _skeleton_does(adapter, *methods: str) -> bool:
    """Whether ``adapter`` offers a row of contact points along the base and leaves ``methods`` of
    its search to the skeleton (then the hooks those methods call are needed)."""
    return adapter.distributed_contact and all(
        getattr(type(adapter), m) is getattr(SteppedContactAdapter, m) for m in methods)


class SteppedContactAdapter(ContactEngineAdapter):
    """A contact engine on the shared skeleton (module docstring): the adapter implements the hooks."""

    #: steps between end-of-run tests, in seconds, for engines without a ``segment_s`` setting [s]
    default_segment_s: ClassVar[float] = 0.05
    #: worlds an engine steps together (1: one case at a time); an engine that steps a batch sets
    #: more, and ``batching = "native"``: cases of one block, settings and step run in batches
    max_worlds: ClassVar[int] = 1
    #: the settings a calibration chooses (contact parameters, or a solver setting it searches); given
    #: explicitly, they replace the calibration, so each defaults to None in :attr:`SETTINGS` ("not given")
    CALIBRATED_SETTINGS: ClassVar[tuple] = ()
    #: the contact knobs a grid calibration searches (:class:`~rockbench.engines.knobs.Knob`); with
    #: knobs declared, :meth:`_calibrate_corners` is the skeleton's :meth:`_calibrate_knobs`
    CALIBRATION_KNOBS: ClassVar[tuple] = ()
    #: with knobs declared: measure the shipped contact (every knob at its ``shipped`` value) first and
    #: keep it when its η is within this fraction of the target [-]; None: the shipped contact is not
    #: measured first
    START_KEEP_RTOL: ClassVar[float | None] = None
    #: settings a restitution measurement records (besides :attr:`CALIBRATED_SETTINGS`)
    MEASURED_SETTINGS: ClassVar[tuple] = ("friction", "planar")

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        adopt_renamed_methods(cls, "SteppedContactAdapter")   # ``_run``, ``_run_worlds``: kept for one release
        # ``CONTACT_KEYS`` is the old name of ``CALIBRATED_SETTINGS``: kept for one release
        if "CONTACT_KEYS" in cls.__dict__ and "CALIBRATED_SETTINGS" not in cls.__dict__:
            warn_renamed(f"{cls.__name__}.CONTACT_KEYS is now called CALIBRATED_SETTINGS; the old name goes in the "
                         "next release.", 2)
            cls.CALIBRATED_SETTINGS = tuple(cls.CONTACT_KEYS)
        given = [k for k in cls.CALIBRATED_SETTINGS if cls.SETTINGS.get(k) is not None]
        if cls.SETTINGS.get("settings") == "calibrated" and given:
            raise TypeError(f"{cls.__name__}.SETTINGS gives {given[0]!r} a default ({cls.SETTINGS[given[0]]!r}), so "
                            "every run would count it as given and never calibrate: a setting of CALIBRATED_SETTINGS "
                            "defaults to None, and _resolved_settings fills in the shipped value.")

    def explicit_contact(self) -> bool:
        """Whether any setting a calibration chooses (:attr:`CALIBRATED_SETTINGS`) was given (then nothing
        is calibrated)."""
        return any(self.settings[k] is not None for k in self.CALIBRATED_SETTINGS)

    # -- hooks --------------------------------------------------------------------------------
    @required("(block, s, dt_s) -> world", "build (or reuse) the engine's scene for the block and the resolved "
              "settings s, contact parameters set")
    def _world(self, block: Block, s: dict, dt_s: float) -> Any:  # pragma: no cover - declared
        """The engine's scene for ``block`` and the resolved settings ``s`` at step ``dt_s`` [s]."""

    @required("(world, block, s, dt_s, pulse, theta0_rad, n_steps) -> ndarray (1, k)", "put the block at rest at "
              "theta0_rad on its lower corner (pivot_pose), load the drive of pulse (None: free rocking) for "
              "n_steps steps; return the state of sample 0 as one row")
    def _start(self, world, block: Block, s: dict, dt_s: float, pulse, theta0_rad: float,
               n_steps: int) -> np.ndarray:  # pragma: no cover - declared
        """The state of sample 0, one row ``(1, k)`` of the engine's choice."""

    @required("(world, n_from, n_to) -> ndarray (n_to - n_from, k)", "step from step n_from to n_to; return "
              "the state rows after each step")
    def _advance(self, world, n_from: int, n_to: int) -> np.ndarray:  # pragma: no cover - declared
        """The state rows of samples ``n_from + 1 … n_to``."""

    @required("(world, rows) -> (theta_rad, theta_dot_rad_s)", "the rotation about +y [rad] and its rate "
              "[rad/s] read from state rows")
    def _angles(self, world, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - declared
        """θ [rad] and θ̇ [rad/s] of state rows."""

    @required("(world, block, s, data, t_s, pulse) -> Motion", "the centre of mass (x, height above the table "
              "top, velocities), θ, θ̇ and the table's x and ẋ from all the state rows of a run")
    def _motion(self, world, block: Block, s: dict, data: np.ndarray, t_s: np.ndarray,
                pulse) -> Motion:  # pragma: no cover - declared
        """The block's :class:`Motion` over a run."""

    def missing_hooks(self) -> list[str]:
        """As :meth:`EngineAdapter.missing_hooks`, and the calibration: calibrated runs need declared
        :attr:`CALIBRATION_KNOBS` or an own ``_calibrate_corners``."""
        out = super().missing_hooks()
        own = type(self)._calibrate_corners is not SteppedContactAdapter._calibrate_corners
        if self.calibrated() and not (self.CALIBRATION_KNOBS or own):
            out.append(hook_line(type(self), "_calibrate_corners", "(block, target, dt_s, use_cache) -> CalibrationResult",
                                 CALIBRATION_ADVICE))
        return out

    def _sample_steps(self, world, rows: np.ndarray, n_done: int) -> np.ndarray:
        """The step numbers of one world's new state rows ``(n, k)``, which follow step ``n_done``
        (floats [-]). Default: one row per step. An engine with its own sampling (Exudyn shortens its
        step where Newton struggles, so a segment may hold more rows than steps) gives each row's
        time over the step."""
        return np.arange(n_done + 1, n_done + rows.shape[0] + 1, dtype=float)

    def _retire(self, world, w: int) -> None:
        """World ``w`` has stopped: an engine that can may stop stepping it (its later rows are
        dropped whatever they hold). Default: nothing."""

    def _halted(self, world) -> bool:
        """Whether the engine stopped inside the last ``_advance`` (its rows end there); the run
        then ends with the rows it has (``ended_by`` ``"halted"``). Default: never."""
        return False

    # -- the run ------------------------------------------------------------------------------
    def _segment_steps(self, s: dict, dt_s: float) -> int:
        seg_s = s.get("segment_s", self.settings.get("segment_s", self.default_segment_s))
        return max(1, int(round(float(seg_s) / dt_s)))

    def _trajectory(self, block: Block, s: dict, dt: float, pulse=None, theta0: float = 0.0,
                    duration_s: float | None = None) -> tuple[Trajectory, Motion]:
        """The trajectory of one run and the block's motion: a pulse, ended by the end-of-run rule, or
        (``duration_s`` [s]) free rocking from rest at ``theta0`` [rad]."""
        return self._step_worlds(block, s, dt, [pulse], theta0, duration_s)[0]

    def _step_worlds(self, block: Block, s: dict, dt: float, pulses: list, theta0: float = 0.0,
                     duration_s: float | None = None) -> list[tuple[Trajectory, Motion]]:
        """The stepping loop: one world per pulse (at most :attr:`max_worlds`), stepped together.

        Every world's new samples are tested with floor 1's end-of-run rule after each segment, up
        to its own longest tail (:meth:`_stop`); a world that has stopped is retired
        (:meth:`_retire`) and stepped on with the others where a batch cannot drop a world, its
        later samples dropped. With :attr:`max_worlds` 1 the hooks see one world (``_start`` gets
        the pulse, ``_advance`` returns ``(n, k)``); with more, ``_start`` gets the list of pulses
        and both return a leading world axis.
        """
        world = self._world(block, s, dt)
        t_end = [p.duration_s if p is not None else 0.0 for p in pulses]
        # the tails: the resolved settings', else the adapter's (resolved settings may leave them out)
        tail_s, min_tail_s = (float(s.get(k, self.settings.get(k))) for k in ("tail_s", "min_tail_s"))
        steps = [run_steps(dt, te, tail_s, min_tail_s, duration_s) for te in t_end]
        if duration_s is not None:  # free rocking: only divergence and the flat rule stop it early
            steps = [(n_w, math.inf, n_min) for n_w, _, n_min in steps]
        one = self.max_worlds == 1
        seg = self._segment_steps(s, dt)
        rows = [_worlds(self._start(world, block, s, dt, pulses[0] if one else pulses, theta0,
                                    max(n for n, _, _ in steps)))]
        n_rows = rows[0].shape[1]
        stop: list = [None] * len(pulses)          # (row index of the last sample kept, why)
        n_done = 0
        t0, c0 = time.perf_counter(), time.process_time()
        while any(e is None for e in stop):
            n_to = min(max(st[0] for st, e in zip(steps, stop) if e is None), n_done + seg)
            new = _worlds(self._advance(world, n_done, n_to))
            rows.append(new)
            first, n_rows = n_rows, n_rows + new.shape[1]   # the row index of the segment's first row
            halted = self._halted(world)
            for w in range(len(pulses)):
                if stop[w] is None:
                    stop[w] = self._stop(world, block, new[w], n_done, n_to, steps[w], first, halted)
                    if stop[w] is not None:
                        self._retire(world, w)
            n_done = n_to
        run = {"wall_s": (time.perf_counter() - t0) / len(pulses), "cpu_s": (time.process_time() - c0) / len(pulses)}
        data = np.concatenate(rows, axis=1)
        return [self._record(world, block, s, dt, p, te, data[w, :k + 1], {**run, "ended_by": why})
                for w, (p, te, (k, why)) in enumerate(zip(pulses, t_end, stop))]

    def _stop(self, world, block: Block, new: np.ndarray, n_done: int, n_to: int, steps: tuple, first: int,
              halted: bool) -> tuple[int, str] | None:
        """Where one world's run ends among its new rows ``new`` (``(n, k)``, rows ``first…`` of the
        run, after step ``n_done``; the engine was asked to step to ``n_to``), and why: floor 1's
        :func:`~rockbench.reference_solver.classify.run_end` on each row at its own step number
        (:meth:`_sample_steps`), else the engine's own stop (:meth:`_halted`), else the tail (the
        run's last step, ``steps[0]``, reached); None: the run goes on."""
        n_w, n_pulse, n_min = steps
        k = self._sample_steps(world, new, n_done)
        m = int(np.searchsorted(k, min(n_to, n_w) + 0.5))   # rows up to the run's last step
        th, om = self._angles(world, new[:m])
        end = run_end(k[:m], th, om, alpha_rad=block.alpha_rad, p_rad_s=block.p_rad_s, pulse_end_step=n_pulse,
                      min_tail_step=n_min)
        if end is not None:
            return first + end[0], end[1]
        if halted or (k[m - 1] if m else n_done) >= n_w - 0.5:
            return first + m - 1, "halted" if halted else "tail"
        return None

    def _record(self, world, block: Block, s: dict, dt: float, pulse, t_end: float, data: np.ndarray,
                run: dict) -> tuple[Trajectory, Motion]:
        """The trajectory from a run's state rows: θ, θ̇, both bottom corners relative to the table,
        the block's own energy, and diagnostics (``run``: wall and CPU time, how it ended)."""
        m = self._motion(world, block, s, data, np.arange(data.shape[0]) * dt, pulse)
        n = m.theta_rad.size  # an engine may cut a diverged run at its first non-finite sample
        t = np.arange(n) * dt if m.t_s is None else m.t_s
        u_tab = np.zeros(n) if m.table_x_m is None else m.table_x_m
        v_tab = np.zeros(n) if m.table_vx_m_s is None else m.table_vx_m_s
        corner_x, corner_z = corners(block, m.x_m, m.z_m, m.theta_rad, u_tab)
        if m.corner_z_m is not None:
            corner_x, corner_z = m.corner_x_m, m.corner_z_m
        energy = (body_energy_j_kg(block, m.vx_m_s - v_tab, m.vz_m_s, m.theta_dot_rad_s, m.z_m)
                  if m.energy_j_kg is None else m.energy_j_kg)
        steps, wall, cpu = n - 1, run["wall_s"], run["cpu_s"]
        # CPU time too: on a shared machine the wall time says more about the neighbours
        diag = {"max_penetration_m": float(max(-np.nanmin(corner_z), 0.0)), "steps": int(steps), "wall_s": wall,
                "cpu_s": cpu, "steps_per_s": (steps / wall if wall > 0 else None),
                "steps_per_cpu_s": (steps / cpu if cpu > 0 else None), "ended_by": run["ended_by"],
                "drive": s["drive"], "planar": bool(s["planar"]), **m.diagnostics}
        flags = [] if np.all(np.isfinite(data)) else ["diverged"]
        traj = Trajectory(t_s=t, theta_rad=m.theta_rad, theta_dot_rad_s=m.theta_dot_rad_s, t_pulse_end_s=t_end,
                          flags=flags, diagnostics=diag, eta_for_tail=None, uplift_tol_rad=uplift_tol_rad(block),
                          corner_x_m=corner_x, corner_z_m=corner_z, energy_j_kg=energy)
        return traj, m

    def _simulate(self, case) -> Trajectory:
        """One case with the resolved settings."""
        dt = self.dt_for(case)
        s = self.resolve(case.block, case.restitution, dt)
        tr, _ = self._trajectory(case.block, s, dt, case.pulse)
        tr.diagnostics.update(self._settings_diagnostics(s))
        return tr

    def _simulate_many(self, cases: list) -> list:
        """Cases one at a time (:attr:`max_worlds` 1), or in batches of worlds grouped by block,
        resolved settings and step; an engine exception fails its case (its whole batch)."""
        if self.max_worlds == 1:
            return super()._simulate_many(cases)
        out: list = [None] * len(cases)
        groups: dict = {}
        for i, c in enumerate(cases):
            try:
                dt = self.dt_for(c)
                s = self.resolve(c.block, c.restitution, dt)
            except ConfigError:
                raise
            except Exception as e:  # noqa: BLE001 - recorded per cell, the sweep goes on
                out[i] = e
                continue
            key = (json.dumps(c.block.to_dict(), sort_keys=True), dt, json.dumps(s, sort_keys=True, default=str))
            groups.setdefault(key, (c.block, s, dt, []))[3].append(i)
        for block, s, dt, idx in groups.values():
            for k in range(0, len(idx), self.max_worlds):
                part = idx[k:k + self.max_worlds]
                try:
                    runs = self._step_worlds(block, s, dt, [cases[i].pulse for i in part])
                except Exception as e:  # noqa: BLE001 - the batch failed inside the engine
                    runs = [(e, None)] * len(part)
                for i, (tr, _) in zip(part, runs):
                    if not isinstance(tr, BaseException):
                        tr.diagnostics.update(self._settings_diagnostics(s))
                    out[i] = tr
        return out

    # -- the free-rocking test ----------------------------------------------------------------
    def _free_rocking_settings(self, block: Block, dt: float) -> dict:
        """The settings a restitution measurement uses when none are given: those in force (for
        ``calibrated`` without explicit contact settings, the calibration to Housner's η)."""
        return self.resolve(block, Restitution(), dt_s=dt)

    def measure_restitution(self, block: Block, *, theta0_frac: float = 0.5, dt_s: float | None = None,
                            settings: dict | None = None) -> RestitutionMeasurement:
        """Free rocking from rest at ``theta0_frac·α`` on the +x corner, no excitation: η impact by
        impact, read by the one reader (:data:`~rockbench.engines.free_rocking.PEAK_RATIO`), and the
        run's resting sink and hop (:func:`~rockbench.engines.free_rocking.contact_figures`).

        Parameters
        ----------
        block : Block
        theta0_frac : float
            Release angle as a fraction of α [-].
        dt_s : float, optional
            Time step [s] (default: the adapter's).
        settings : dict, optional
            Resolved settings to measure (default: :meth:`_free_rocking_settings`).
        """
        if not 0.0 < float(theta0_frac) < 1.0:
            raise ConfigError(f"theta0_frac must be in (0, 1), got {theta0_frac!r}.")
        dt = self.time_step_s(dt_s)
        if dt > 0.01:
            raise ConfigError(f"--dt must be in (0, 0.01] s for a free-rocking test, got {dt_s!r}.")
        s = self._free_rocking_settings(block, dt) if settings is None else settings
        return self._measure_free_rocking(block, s, dt, theta0_frac)[0]

    def _measure_free_rocking(self, block: Block, s: dict, dt: float,
                              theta0_frac: float = 0.5) -> tuple[RestitutionMeasurement, Trajectory]:
        """The free-rocking test of :meth:`measure_restitution` with the resolved settings ``s`` at
        step ``dt`` [s], unchecked: the measurement and the run's trajectory (for an engine whose
        calibration reads more from the run than η)."""
        theta0 = float(theta0_frac) * block.alpha_rad
        reader = PEAK_RATIO
        tr, motion = self._trajectory(block, s, dt, None, theta0=theta0,
                                      duration_s=reader.duration_s(block, theta0_frac))
        etas = reader.etas(block, motion.theta_rad, theta0)
        sink, hop = contact_figures(block, tr.theta_rad, tr.corner_z_m)
        shown = {k: s.get(k) for k in self.MEASURED_SETTINGS + self.CALIBRATED_SETTINGS}
        return RestitutionMeasurement(etas=[float(e) for e in etas],
                                      eta_mean=float(np.mean(etas)) if etas else math.nan,
                                      eta_std=float(np.std(etas)) if etas else math.nan, theta0_rad=theta0,
                                      dt_s=dt, settings=shown, method=reader.method, sink_m=sink, hop_m=hop,
                                      first_quarter_s=first_quarter_s(tr.t_s, tr.theta_rad)), tr

    # -- the grid calibration of declared knobs ------------------------------------------------------
    def _calibrate_corners(self, block: Block, target: float, dt: float, use_cache: bool) -> CalibrationResult:
        """With :attr:`CALIBRATION_KNOBS` declared: :meth:`_calibrate_knobs`."""
        if not self.CALIBRATION_KNOBS:
            raise MissingHook(hook_line(type(self), "_calibrate_corners", "(block, target, dt_s, use_cache) -> "
                                        "CalibrationResult", CALIBRATION_ADVICE))
        return self._calibrate_knobs(block, target, dt, use_cache)

    def _calibrate_knobs(self, block: Block, target: float, dt: float, use_cache: bool) -> CalibrationResult:
        """The search of the declared knobs (:meth:`_knob_rows`), each candidate measured
        (:meth:`_evaluate`); the one pick over all of them, cached as ``{"result", "search": {"tried":
        rows}}``."""
        key = self._knobs_key(block, target, dt)
        cached = self._cached(key, use_cache)
        if cached is not None:
            return cached
        knobs = self.CALIBRATION_KNOBS
        rows = self._knob_rows(block, target, dt, knobs, lambda c: self._evaluate(block, dt, c),
                               keep_rtol=self.START_KEEP_RTOL)
        if not any(math.isfinite(r["eta"]) for r in rows):
            raise ConfigError(f"{self.name} calibration: no contact setting gave a measurable free rocking "
                              "(fewer than two impacts); try a smaller --dt.")
        chosen = pick([Candidate.of_row(r) for r in rows], target, block)
        r = chosen.candidate.knobs
        names = dict.fromkeys(tuple(k.name for k in knobs) + self.CALIBRATED_SETTINGS)
        settings = self._knobs_settings(block, dt, {k: v for k, v in r.items() if k in names})
        res = CalibrationResult(eta_target=target, eta_measured=r["eta"], eta_std=r["eta_std"], reached=chosen.reached,
                                settings=settings, note=self._knobs_note(block, dt, target, chosen, rows, settings),
                                evaluations=len(rows))
        self._store(key, res, {"tried": rows})
        return res

    def _knob_rows(self, block: Block, target: float, dt: float, knobs: tuple, evaluate,
                   keep_rtol: float | None = None) -> list[dict]:
        """The measured candidates of ``knobs`` (``evaluate(candidates) -> rows``), in order: the one
        search of declared knobs, :func:`~rockbench.engines.knobs.search`."""
        return search_knobs(knobs, block, target, dt, evaluate, keep_rtol)

    def _evaluate(self, block: Block, dt: float, candidates: list[dict]) -> list[dict]:
        """Free rocking for each candidate (the knobs' values): one row each, the values with what the
        pick reads (``eta``, ``eta_std``, ``n``, ``sink_m``, ``hop_m``, ``damping_ratio``). Here one by
        one; an engine that measures many in one native batch overrides it."""
        base = self._knobs_base(block, dt)
        rows = []
        for c in candidates:
            m = self.measure_restitution(block, dt_s=dt, settings={**base, **c})
            rows.append({**c, "eta": m.eta_mean, "eta_std": m.eta_std, "n": len(m.etas), "sink_m": m.sink_m,
                         "hop_m": m.hop_m, "damping_ratio": self._damping_ratio(block, {**base, **c})})
        return rows

    def _knobs_base(self, block: Block, dt: float) -> dict:
        """The settings a candidate of the declared knobs updates (default: the base settings, the
        contact keys unset)."""
        return {**self._base_settings(), **{k: None for k in self.CALIBRATED_SETTINGS}}

    def _knobs_key(self, block: Block, target: float, dt: float) -> str:
        """The cache key of a grid calibration (default: the engine, the block, target, step and
        :meth:`_calibration_identity` of the base settings)."""
        return self._cache_key(block, target, dt, self.CALIBRATION_VERSION,
                               **self._calibration_identity(self._base_settings()))

    def _knobs_settings(self, block: Block, dt: float, values: dict) -> dict:
        """What a grid calibration records as its settings (default: the contact keys, the knobs set)."""
        return {k: None for k in self.CALIBRATED_SETTINGS} | values

    def _knobs_note(self, block: Block, dt: float, target: float, chosen, rows: list, settings: dict) -> str:
        """A grid calibration's note (default: the pick and the span of η over the candidates)."""
        finite = [x["eta"] for x in rows if math.isfinite(x["eta"])]
        what = ", ".join(f"{k.name} {settings[k.name]:.4g} {k.unit}".rstrip() for k in self.CALIBRATION_KNOBS)
        return (f"{'reached' if chosen.reached else 'not reached'} ({chosen.why}) with {what}; η over the "
                f"searched settings spans {min(finite):.4f}–{max(finite):.4f}.")

    def _damping_ratio(self, block: Block, s: dict) -> float | None:
        """The damping ratio (1: critical) of the contact settings ``s``, for the pick's tie-break: for a
        spring-dashpot contact (``contact_stiffness_n_m`` k, ``contact_damping_n_s_m`` c) ``c/(2√(k·m))``
        with the block's mass m; None where the contact has no damping knob."""
        k, c = s.get("contact_stiffness_n_m"), s.get("contact_damping_n_s_m")
        return c / (2.0 * math.sqrt(k * block.mass_kg)) if k and c is not None else None

    def _fixed(self, contact: dict) -> "SteppedContactAdapter":
        """A copy of this adapter with explicit contact settings (no calibration behind its runs);
        ``contact`` holds :attr:`CALIBRATED_SETTINGS` and, for a row along the base, ``contact_points``."""
        contact = self.canonical_settings(contact)
        st = {**self.settings, **{k: contact.get(k) for k in self.CALIBRATED_SETTINGS}}
        if self.distributed_contact:
            pts = contact.get("contact_points")
            st.update(contact="distributed" if pts else "corners", contact_points=pts or None)
        return type(self)(**st)

    def contact_price(self, block: Block, c: CalibrationResult, dt_s: float | None = None) -> dict:
        """The price of a calibration's contact (:func:`rockbench.engines.price.contact_price`)."""

        dt = self.time_step_s(dt_s)
        fixed = self._fixed(c.settings)
        m = fixed.measure_restitution(block, dt_s=dt)
        return pricing.contact_price(fixed, block, Restitution("constant", value=c.eta_target), dt,
                                    first_quarter_s=m.first_quarter_s)

    # -- the distributed contact's search -----------------------------------------------------
    @required("(block, dt_s) -> (candidates, phrase)", "the candidates of the search of a row of points along "
              "the base (contact settings) and a phrase naming the range searched; or implement _distributed_rows",
              when=lambda ad: _skeleton_does(ad, "_calibrate_distributed_n", "_distributed_rows"))
    def _distributed_grid(self, block: Block, dt: float) -> tuple[list[dict], str]:  # pragma: no cover - declared
        """The candidates of the distributed search (contact settings, plus keys of the engine's own
        for notes) and a phrase describing the range searched."""

    @required("(row) -> str", "one candidate of the search of a row of points along the base in words, for "
              "the notes", when=lambda ad: _skeleton_does(ad, "_calibrate_distributed_n"))
    def _describe_contact(self, row: dict) -> str:  # pragma: no cover - declared
        """One candidate of the distributed search in words, for the notes."""

    def _distributed_rows(self, block: Block, t: float, n: int, dt: float) -> tuple[list[dict], str]:
        """The measured candidates of the distributed search with ``n`` points for the target ``t``,
        in the order measured, and a phrase describing the range searched.

        Each row holds a candidate's contact settings (and keys of the engine's own, for the notes)
        with ``eta``, ``eta_std``, ``n`` (impacts measured), ``sink_m``, ``hop_m`` and ``damping_ratio``
        (what the pick reads); ``eta`` is NaN where free rocking gave none. Here every candidate of
        :meth:`_distributed_grid` is measured one by one; an engine that measures its own grid (in
        batches, refined around its pick) gives its rows.
        """
        base = self._distributed_base(n)
        grid, searched = self._distributed_grid(block, dt)
        rows = []
        for g in grid:
            s = {**base, **{k: g.get(k) for k in self.CALIBRATED_SETTINGS}}
            try:
                mm = self.measure_restitution(block, dt_s=dt, settings=s)
                rows.append({**g, "eta": mm.eta_mean, "eta_std": mm.eta_std, "n": len(mm.etas), "sink_m": mm.sink_m,
                             "hop_m": mm.hop_m, "damping_ratio": self._damping_ratio(block, s)})
            except Exception as e:  # noqa: BLE001 - a setting that breaks is recorded, the search goes on
                rows.append({**g, "eta": math.nan, "eta_std": math.nan, "n": 0, "error": f"{type(e).__name__}: {e}"})
        return rows, searched

    def _distributed_base(self, n: int) -> dict:
        """The settings of a distributed candidate with ``n`` points before its contact settings."""
        return {**self._base_settings(), **{k: None for k in self.CALIBRATED_SETTINGS}, "contact_points": n}

    def _distributed_key(self, block: Block, t: float, n: int, dt: float) -> str:
        """The cache key of the distributed calibration with ``n`` points to ``t`` at step ``dt``."""

        base = self._distributed_base(n)
        return self._cache_key(block, t, dt, self.CALIBRATION_VERSION_DIST, **self._calibration_identity(base),
                               points=n, price_cells=[list(c) for c in pricing.PRICE_CELLS])

    def _distributed_contact(self, row: dict, n: int) -> dict:
        """A candidate row's contact with ``n`` points, as :meth:`_fixed` takes it."""
        return {k: row.get(k) for k in self.CALIBRATED_SETTINGS} | {"contact_points": n}

    def _distributed_settings(self, block: Block, dt: float, row: dict, n: int) -> dict:
        """The settings a distributed calibration records for its row (here: its contact)."""
        return self._distributed_contact(row, n)

    def _calibrate_distributed_n(self, block: Block, t: float, n: int, dt: float,
                                 use_cache: bool) -> CalibrationResult:
        """A row of ``n`` points along the base, calibrated to ``t`` at a price.

        The candidates are :meth:`_distributed_rows`; those the one pick reaches are tried in its order
        (:func:`~rockbench.engines.pick.ranked`; at most :data:`MAX_PRICE_TRIES`,
        :meth:`_first_that_counts`) until one keeps the static uplift threshold within 2 % of g·tanα
        and raises no ``slip`` flag in the anti-slip cells (:func:`rockbench.engines.price.contact_price`);
        its price is recorded, with its free-rocking period change.
        """

        key = self._distributed_key(block, t, n, dt)
        cached = self._cached(key, use_cache)
        if cached is not None:
            return cached
        rows, searched = self._distributed_rows(block, t, n, dt)
        cands = [Candidate.of_row(r) for r in rows]
        regular_rows = [c.knobs for c in cands if regular(c, t, block)]
        within = [c.knobs for c in ranked(cands, t, block)]
        chosen, price, tried = self._first_that_counts(block, within, n, dt, t)
        lo = min((r["eta"] for r in regular_rows), default=math.nan)
        hi = max((r["eta"] for r in regular_rows), default=math.nan)
        span = f"{searched}: regular free rocking spans η = {lo:.4f}–{hi:.4f}"
        if chosen is not None:
            r = chosen
            m = self._fixed(self._distributed_contact(r, n)).measure_restitution(block, dt_s=dt)
            price["period_change"] = (m.first_quarter_s / price["rigid_first_quarter_s"] - 1.0) if m.first_quarter_s else None
            price["first_quarter_s"] = m.first_quarter_s
            note = (f"reached with {n} {self.POINT_UNIT} along the base, {self._describe_contact(r)}, {r['n']} impacts "
                    f"measured; {pricing.price_line(price)}; {span}.")
        else:
            r = (within[0] if within else
                 min(regular_rows or [x for x in rows if math.isfinite(x["eta"])] or rows,
                     key=lambda r: abs(r["eta"] - t) if math.isfinite(r["eta"]) else math.inf))
            note = (f"not reached with {n} {self.POINT_UNIT} along the base: {self._why_not(r, within, tried, t)}; "
                    f"{span}.")
        res = CalibrationResult(eta_target=t, eta_measured=float(r["eta"]), eta_std=float(r["eta_std"]),
                                reached=chosen is not None, settings=self._distributed_settings(block, dt, r, n),
                                note=note, evaluations=len(rows), price=price)
        self._store(key, res, {"grid": rows, "price_tried": tried})
        return res

    def _first_that_counts(self, block: Block, within: list, n: int, dt: float,
                           t: float) -> tuple[dict | None, dict | None, list]:
        """The first of ``within`` (at most :data:`MAX_PRICE_TRIES`) whose contact counts, its price
        and what was tried. The static uplift threshold comes first: a candidate outside it cannot
        count, so its anti-slip cells are not run."""

        rest = Restitution("constant", value=t)
        tried = []
        for r in within[:MAX_PRICE_TRIES]:
            fixed = self._fixed(self._distributed_contact(r, n))
            up = pricing.uplift_threshold(fixed, block, rest, dt)
            tried.append({**r, "uplift_ratio": up.get("ratio", math.nan)})
            if not up.get("within"):
                continue
            pr = pricing.contact_price(fixed, block, rest, dt, uplift=up)
            tried[-1].update(n_slip=pr["anti_slip"]["n_slip"], n_jump=pr["anti_slip"]["n_jump"])
            if pr["counts"]:
                return r, pr, tried
        return None, None, tried

    def _why_not(self, r: dict, within: list, tried: list, t: float) -> str:
        """Why the distributed search reached nothing, in words."""
        if not within:
            return f"the closest regular η is {r['eta']:.4f} ({100 * (r['eta'] - t) / t:+.2f} %)"
        return (f"{len(within)} settings give η within {100 * ETA_RESOLUTION:g} % with regular impacts, but none "
                f"keeps the static uplift threshold within 2 % of g·tanα without rocking below it and the anti-slip "
                f"cells free of slip "
                f"(tried: " + "; ".join(f"{self._describe_contact(x)}: uplift {x['uplift_ratio']:.3f}"
                                        + (f", {x['n_slip']} slip / {x['n_jump']} jump" if "n_slip" in x else "")
                                        for x in tried) + ")")

    def _calibration_identity(self, base: dict) -> dict:
        """What besides block, target and step a calibration depends on (part of its cache key)."""
        return {"planar": base["planar"], "friction": base["friction"], "drive": base["drive"]}
