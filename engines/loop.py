"""The one stepping loop of every contact engine, and the trajectory it makes of a run.

:func:`run_worlds` runs a batch of worlds (one pulse each, or free rocking from a release angle)
through an engine's four methods (:class:`~rockbench.engines.contact.ContactEngine`): ``build`` the
scene, ``start`` the worlds, ``advance`` them segment by segment, ``read`` their motion. After each
segment every running world's new samples are tested with floor 1's end-of-run rule
(:func:`~rockbench.reference_solver.classify.run_end`: diverged, overturn certain, or trapped below
the barrier after ``min_tail_s``), else the run ends ``tail_s`` after the pulse; the samples after a
world's stop are dropped. The segments are ``segment_s`` long (:data:`DEFAULT_SEGMENT_S` where an
engine has no such setting); an adapter whose steps do not depend on where a segment starts declares
``near_segment_s`` [s], and its segments then end at each run's marks (its pulse's end, where an
overturn is most often certain; the trapped rule's first step; its last step) and last at most
``near_segment_s`` after its pulse, so that fewer steps run past a stop (docs/speed.md, "Work past
the stop and repeated work"). An engine whose solver is re-entered at each segment (Exudyn) keeps
the fixed segments: where they end moves its results, so they are those of its segment length. An engine with its own
sampling reports each sample's time (``Motion.t_s``): the rule then counts the samples it got, each
at its own step (:func:`~rockbench.engines.motion.steps_of_times`). An engine that stops by itself
raises :class:`EngineHalted` with the rows it has; the run ends there (``ended_by`` ``"halted"``).
:func:`trajectory` turns a world's rows into the :class:`~rockbench.engines.contract.Trajectory` the
judge reads: θ, θ̇, both bottom corners relative to the table, the block's own energy, diagnostics.
"""

from __future__ import annotations

import math
import time

import numpy as np

from rockbench.reference_solver.classify import run_end
from rockbench.reference_solver.model import Block
from rockbench.reference_solver.validity import uplift_tol_rad
from rockbench.engines import progress
from rockbench.engines.contract import Trajectory
from rockbench.engines.motion import Motion, body_energy_j_kg, corners, run_steps, steps_of_times

__all__ = ["EngineHalted", "run_worlds", "trajectory", "segment_steps", "DEFAULT_SEGMENT_S"]

#: The segment between end-of-run tests of an engine without a ``segment_s`` setting [s]
DEFAULT_SEGMENT_S = 0.05


class EngineHalted(Exception):
    """Raised by an engine's ``advance`` when the engine stopped by itself inside the segment (its
    solver failed): ``rows`` are the samples it has, ``(W, n, k)``; the message says why."""

    def __init__(self, message: str, rows):
        super().__init__(message)
        self.rows = rows


def segment_steps(s: dict, dt_s: float) -> int:
    """The steps of a fixed segment: the settings' ``segment_s`` (:data:`DEFAULT_SEGMENT_S` without it)
    at step ``dt_s`` [s], at least one."""
    return max(1, int(round(float(s.get("segment_s", DEFAULT_SEGMENT_S)) / dt_s)))


def _segment_end(n_done: int, seg: int, near: int | None, running: list[tuple]) -> int:
    """The step the next segment ends at, after step ``n_done``, for the running worlds' steps
    ``(n_w, n_pulse, n_min)`` each (:func:`~rockbench.engines.motion.run_steps`). ``near`` None: ``seg``
    steps on, at most the last world's last step. Otherwise at every world's next mark (its pulse's
    end, its trapped rule's first step, its last step), where its run most often ends; within ``seg``
    steps before its pulse's end (only a flat block or a diverged run ends it there), within ``near``
    steps after it (an overturn or the trapped rule may end it at any sample)."""
    if near is None:
        return min(max(n_w for n_w, _, _ in running), n_done + seg)
    ends = []
    for n_w, n_pulse, n_min in running:
        marks = [m for m in (n_pulse, n_min, n_w) if n_done < m < math.inf]
        ends.append(min([n_done + (seg if n_done < n_pulse else near)] + marks))
    return int(min(ends))


def _advance(ad, scene, n_from: int, n_to: int, n_worlds: int) -> tuple[np.ndarray, str | None]:
    """One segment's rows ``(W, n, k)`` and, where the engine halted in it, why."""
    try:
        return np.asarray(ad.advance(scene, n_from, n_to), dtype=float), None
    except EngineHalted as e:
        rows = np.asarray(e.rows, dtype=float)
        return (rows if rows.ndim == 3 else rows.reshape(n_worlds, 0, -1)), str(e)


def run_worlds(ad, block: Block, s: dict, dt: float, pulses: list, theta0: float = 0.0,
               duration_s: float | None = None) -> list[tuple[Trajectory, Motion]]:
    """The runs of one batch of worlds (one per pulse, at most the engine's ``max_worlds``), stepped
    together by engine ``ad`` with the resolved settings ``s`` at step ``dt`` [s]: each world's
    trajectory and motion. A pulse run ends by the end-of-run rule (module docstring); a free-rocking
    test (``pulses`` of None, ``duration_s`` [s], release at ``theta0`` [rad]) runs its whole length
    in one segment, stopped early only where θ diverges or the block lies flat."""
    t_end = [p.duration_s if p is not None else 0.0 for p in pulses]
    tail_s, min_tail_s = (float(s[k]) for k in ("tail_s", "min_tail_s"))
    steps = [run_steps(dt, te, tail_s, min_tail_s, duration_s) for te in t_end]
    if duration_s is not None:
        s = {**s, "segment_s": duration_s}
    scene = ad.build(block, s, dt)
    first = np.asarray(ad.start(scene, block, s, dt, pulses, theta0, max(n for n, _, _ in steps)), dtype=float)
    rows, n_rows = [first], first.shape[1]
    stop: list = [None] * len(pulses)          # (row index of the last sample kept, why)
    n_done, seg = 0, segment_steps(s, dt)
    near_s = ad.near_segment_s
    near = None if near_s is None else min(seg, max(1, int(round(near_s / dt))))
    t0, c0 = time.perf_counter(), time.process_time()
    while any(e is None for e in stop):
        n_to = _segment_end(n_done, seg, near, [st for st, e in zip(steps, stop) if e is None])
        new, halted = _advance(ad, scene, n_done, n_to, len(pulses))
        progress.tick()   # a long run inside a calibration or the rule's probes: a line where the throttle allows
        rows.append(new)
        for w, p in enumerate(pulses):
            if stop[w] is None:
                stop[w] = _stop(ad, scene, block, s, dt, p, new[w], n_done, n_to, steps[w], n_rows, halted)
                if stop[w] is not None:
                    ad.retire(scene, w)
        n_rows += new.shape[1]
        n_done = n_to
    run = {"wall_s": (time.perf_counter() - t0) / len(pulses), "cpu_s": (time.process_time() - c0) / len(pulses)}
    data = np.concatenate(rows, axis=1)
    return [trajectory(ad, scene, block, s, dt, p, te, data[w, :k + 1], {**run, "ended_by": why, **extra})
            for w, (p, te, (k, why, extra)) in enumerate(zip(pulses, t_end, stop))]


def _stop(ad, scene, block: Block, s: dict, dt: float, pulse, new: np.ndarray, n_done: int, n_to: int,
          steps: tuple, first: int, halted: str | None) -> tuple[int, str, dict] | None:
    """Where one world's run ends among its new rows ``new`` (rows ``first…`` of the run, after step
    ``n_done``; the engine was asked to step to ``n_to``), why, and what the record adds: floor 1's
    :func:`~rockbench.reference_solver.classify.run_end` on each row at its own step, else the engine's
    own stop, else the tail (the run's last step, ``steps[0]``); None: the run goes on."""
    n_w, n_pulse, n_min = steps
    n_new = new.shape[0]
    m = ad.stop_angles(scene, block, s, new, (first + np.arange(n_new)) * dt, pulse) if n_new else None
    if m is None or m[2] is None:   # a row a step: steps n_done + 1 … n_done + n_new
        k = np.arange(n_done + 1, n_done + n_new + 1, dtype=float)
        j = min(max(min(n_to, n_w) - n_done, 0), n_new)   # rows up to the run's last step
    else:
        k = steps_of_times(m[2], dt)
        j = int(np.searchsorted(k, min(n_to, n_w) + 0.5))
    if m is not None and j:
        end = run_end(k[:j], m[0][:j], m[1][:j], alpha_rad=block.alpha_rad,
                      p_rad_s=block.p_rad_s, pulse_end_step=n_pulse, min_tail_step=n_min)
        if end is not None:
            return first + end[0], end[1], {}
    if halted is not None:
        return first + j - 1, "halted", {"engine_stopped": halted}
    if (k[j - 1] if j else n_done) >= n_w - 0.5:
        return first + j - 1, "tail", {}
    return None


def trajectory(ad, scene, block: Block, s: dict, dt: float, pulse, t_end: float, data: np.ndarray,
               run: dict) -> tuple[Trajectory, Motion]:
    """The trajectory from one world's rows of a run: θ, θ̇, both bottom corners relative to the table,
    the block's own energy, and diagnostics (``run``: wall and CPU time, how it ended)."""
    m = ad.read(scene, block, s, data, np.arange(data.shape[0]) * dt, pulse)
    n = m.theta_rad.size
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
    diag = {"dt_s": dt, "max_penetration_m": float(max(-np.nanmin(corner_z), 0.0)), "steps": int(steps), "wall_s": wall,
            "cpu_s": cpu, "steps_per_s": (steps / wall if wall > 0 else None),
            "steps_per_cpu_s": (steps / cpu if cpu > 0 else None), **run, "drive": s["drive"],
            "planar": bool(s["planar"]), **m.diagnostics}
    flags = [] if np.all(np.isfinite(data)) else ["diverged"]
    traj = Trajectory(t_s=t, theta_rad=m.theta_rad, theta_dot_rad_s=m.theta_dot_rad_s, t_pulse_end_s=t_end,
                      flags=flags, diagnostics=diag, eta_for_tail=None, uplift_tol_rad=uplift_tol_rad(block),
                      corner_x_m=corner_x, corner_z_m=corner_z, energy_j_kg=energy)
    return traj, m
