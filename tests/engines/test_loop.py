"""The contact engines' one loop: a batch of worlds gives what one world at a time gives.

A toy engine in NumPy (a planar block on two damped penalty springs at its bottom corners, the
example of docs/engines.md, vectorised over worlds) runs the same cases one at a time
(``max_worlds = 1``) and in batches (``max_worlds = 4``): every verdict and every sample must be
equal bit for bit, whatever the pulses' lengths and wherever each world stops.
"""

from __future__ import annotations

import math

import numpy as np

from rockbench.engines.contract import Case
from end_of_run import assert_ends_by_run_end
from rockbench.engines.contact import ContactEngine
from rockbench.engines.motion import Motion, pivot_pose
from rockbench.reference_solver.model import G, Block
from rockbench.reference_solver.pulses import make_pulse

BLOCK = Block(0.045, 0.10125, mass_kg=0.5444, name="B3M")


class _Toy(ContactEngine):
    """The toy, stepping every world of a batch at once."""

    CONTRACT_VERSION = 2
    name = "toy-batch"
    own_dt_s = 1e-4
    max_worlds = 4
    batching = "native"
    SETTINGS = {"settings": "shipped", "tail_s": 0.5, "min_tail_s": 0.1}
    SHIPPED = {"stiffness_n_m": 1e6}

    def build(self, block, s, dt_s):
        return {"block": block, "k": s["stiffness_n_m"], "mu": s["friction"], "dt": dt_s}

    def start(self, w, block, s, dt_s, pulses, theta0_rad, n_steps):
        x, z = pivot_pose(block, theta0_rad)
        mid = (np.arange(n_steps) + 0.5) * dt_s
        w["acc"] = np.array([np.zeros(n_steps) if p is None else -p.accel(mid) for p in pulses])
        w["state"] = np.tile([x, z, theta0_rad, 0.0, 0.0, 0.0], (len(pulses), 1))
        return w["state"][:, None].copy()

    def advance(self, w, n_from, n_to):
        blk, dt, k = w["block"], w["dt"], w["k"]
        m, inertia = blk.mass_kg, blk.inertia_cm_kg_m2
        c = 2.0 * math.sqrt(k * m)
        rows = []
        for i in range(n_from, n_to):
            x, z, th, vx, vz, om = w["state"].T
            fx, fz, tau = m * w["acc"][:, i], np.full_like(x, -m * G), np.zeros_like(x)
            for side in (1.0, -1.0):
                rx = side * blk.width_m / 2 * np.cos(th) - blk.height_m / 2 * np.sin(th)
                rz = -side * blk.width_m / 2 * np.sin(th) - blk.height_m / 2 * np.cos(th)
                touch = z + rz < 0.0
                n = np.where(touch, np.maximum(0.0, -k * (z + rz) - c * (vz - om * rx)), 0.0)
                t = np.clip(-c * (vx + om * rz), -w["mu"] * n, w["mu"] * n)
                fx, fz, tau = fx + t, fz + n, tau + rz * t - rx * n
            vx, vz, om = vx + dt * fx / m, vz + dt * fz / m, om + dt * tau / inertia
            w["state"] = np.stack([x + dt * vx, z + dt * vz, th + dt * om, vx, vz, om], axis=1)
            rows.append(w["state"])
        return np.stack(rows, axis=1)

    def read(self, w, block, s, rows, t_s, pulse):
        return Motion(x_m=rows[:, 0], z_m=rows[:, 1], theta_rad=rows[:, 2], vx_m_s=rows[:, 3], vz_m_s=rows[:, 4],
                      theta_dot_rad_s=rows[:, 5])


class _OneAtATime(_Toy):
    max_worlds = 1
    batching = "none"


def _cases():
    A = G * BLOCK.width_m / BLOCK.height_m
    p = BLOCK.p_rad_s
    # rest, rocking and overturning cells of different pulse lengths: the worlds of a batch stop apart
    return [Case(BLOCK, make_pulse(kind, a * A, w * p)) for kind, w, a in
            (("sine", 6.0, 0.8), ("sine", 4.0, 2.0), ("cosine", 1.5, 4.0), ("sine", 12.0, 6.0),
             ("cosine", 8.0, 1.6), ("sine", 2.0, 3.0))]


def test_a_batch_of_worlds_equals_one_world_at_a_time():
    cases = _cases()
    batch = _Toy()._simulate_many([_Toy().posed(c) for c in cases])
    single = [_OneAtATime().simulate(c) for c in cases]
    for b, s in zip(batch, single):
        assert b.t_s.size == s.t_s.size and b.diagnostics["ended_by"] == s.diagnostics["ended_by"]
        for f in ("theta_rad", "theta_dot_rad_s", "corner_x_m", "corner_z_m", "energy_j_kg"):
            assert np.array_equal(getattr(b, f), getattr(s, f)), f
    verdicts = {(r.outcome, r.valid, tuple(r.flags), r.n_impacts) for r in _Toy().run_many(cases)}
    assert {"rest", "rocking", "overturn"} <= {v[0] for v in verdicts}
    assert [_verdict(r) for r in _Toy().run_many(cases)] == [_verdict(r) for r in _OneAtATime().run_many(cases)]


def _verdict(cell) -> dict:
    """A cell without its timings."""
    timing = ("wall_s", "cpu_s", "steps_per_s", "steps_per_cpu_s")
    return {**cell.to_dict(), "wall_s": 0.0,
            "diagnostics": {k: v for k, v in cell.diagnostics.items() if k not in timing}}


class _OwnSampling(_OneAtATime):
    """The toy stepping at half the step it is given and returning every half step's row, its time in
    the row: an engine with its own sampling (two rows per step), which says when each row is
    (``Motion.t_s``)."""

    def build(self, block, s, dt_s):
        return super().build(block, s, dt_s / 2)

    def start(self, w, block, s, dt_s, pulses, theta0_rad, n_steps):
        rows = super().start(w, block, s, dt_s / 2, pulses, theta0_rad, 2 * n_steps)
        return np.concatenate([rows, np.zeros(rows.shape[:2] + (1,))], axis=2)

    def advance(self, w, n_from, n_to):
        rows = super().advance(w, 2 * n_from, 2 * n_to)
        t = (2 * n_from + 1 + np.arange(rows.shape[1])) * w["dt"]
        return np.concatenate([rows, np.broadcast_to(t[None, :, None], rows.shape[:2] + (1,))], axis=2)

    def read(self, w, block, s, rows, t_s, pulse):
        m = super().read(w, block, s, rows, t_s, pulse)
        m.t_s = rows[:, 6]
        return m


def test_an_engines_own_sampling_is_counted_row_by_row():
    """Rows are counted as rows: the run ends at the row floor 1's rule names, at that row's own time
    (not one row early, as counting rows as steps would), and matches the same engine run at the
    half step with one row per step up to the rule's step rounding."""
    dt = 1e-4
    ad, fine_ad = _OwnSampling(), _OneAtATime()
    ended = set()
    for c in _cases():
        own = ad.run_worlds(BLOCK, ad.settings_with(), dt, [c.pulse])[0][0]
        fine = fine_ad.run_worlds(BLOCK, fine_ad.settings_with(), dt / 2, [c.pulse])[0][0]
        n = min(own.t_s.size, fine.t_s.size)
        assert np.array_equal(own.theta_rad[:n], fine.theta_rad[:n]) and np.array_equal(own.t_s[:n], fine.t_s[:n])
        why = own.diagnostics["ended_by"]
        assert why == fine.diagnostics["ended_by"] and abs(own.t_s.size - fine.t_s.size) <= 2
        assert_ends_by_run_end(own, c, dt, ad.settings["tail_s"], ad.settings["min_tail_s"],
                               steps=np.arange(1, own.t_s.size) / 2.0)    # the rows' own step numbers
        ended.add(why)
    assert "trapped" in ended and ended & {"flat", "overturn"}


class _Counted(_Toy):
    """The toy counting the steps it was asked for and where its segments end."""

    def advance(self, w, n_from, n_to):
        self.ends.append(n_to)
        self.stepped += len(w["state"]) * (n_to - n_from)
        return super().advance(w, n_from, n_to)


class _Near(_Counted):
    """The toy with segments that end at each run's marks (``near_segment_s``)."""

    near_segment_s = 0.01


def test_segments_that_end_at_the_marks_change_no_run_and_step_less_past_the_stop():
    """An engine whose step does not depend on where a segment starts gives the same runs with the
    segments ending at each run's marks; a segment ends at the pulse's end of each run still going then,
    and the engine steps less
    than with fixed segments."""
    cases = _cases()
    runs = {}
    for ad in (_Near(), _Counted()):
        ad.ends, ad.stepped = [], 0
        runs[ad.name, type(ad)] = (ad, ad._simulate_many([ad.posed(c) for c in cases]))
    (near, a_runs), (fixed, b_runs) = runs.values()
    for a, b in zip(a_runs, b_runs):
        assert a.t_s.size == b.t_s.size and a.diagnostics["ended_by"] == b.diagnostics["ended_by"]
        assert np.array_equal(a.theta_rad, b.theta_rad) and np.array_equal(a.theta_dot_rad_s, b.theta_dot_rad_s)
    dt = near.own_dt_s
    pulse_ends = {int(math.ceil(c.pulse.duration_s / dt - 1e-9)) for c, a in zip(cases, a_runs)
                  if a.t_s[-1] >= c.pulse.duration_s}   # the runs still going at their pulse's end
    assert len(pulse_ends) >= 3 and pulse_ends <= set(near.ends)
    assert near.stepped < fixed.stepped

def test_a_segment_ends_at_each_running_worlds_next_mark():
    from rockbench.engines.loop import _segment_end

    running = [(5000, 1200, 2200), (3000, 700, 1700)]   # (last step, pulse's end, trapped rule's first step)
    assert _segment_end(0, 500, None, running) == 500                  # fixed segments: no marks
    assert _segment_end(4800, 500, None, running) == 5000              # at most the last world's last step
    assert _segment_end(0, 500, 100, running) == 500                   # before the pulses' ends: long segments
    assert _segment_end(500, 500, 100, running) == 700                 # a pulse's end
    assert _segment_end(700, 500, 100, running) == 800                 # after it: short segments
    assert _segment_end(1150, 500, 100, running) == 1200               # the other world's pulse's end
    assert _segment_end(1650, 500, 100, running) == 1700               # the trapped rule's first step
    assert _segment_end(2950, 500, 100, running[1:]) == 3000           # the last step
    free = [(4000, math.inf, math.inf)]                                # free rocking: one segment
    assert _segment_end(0, 4000, 100, free) == 4000
