"""Small adapters for the harness tests, importable by worker processes (they get this folder on
their ``sys.path`` from the executor).

:class:`AnalyticAdapter` classifies by a known analytic picture in normalised coordinates
(ω/p, a₀/(g·tanα)): rest below a = 1, overturn above the line a = 1 + 0.8·(ω/p), with two thin
features the adaptive sweep must not miss: a safe band of half-width 0.05 inside the overturn
region (a = 2.5 + 0.8·ω/p ± 0.05) and an overturning tongue of half-width 0.06 inside the rocking
region (a = 1.5 ± 0.06 for ω/p < 6). It returns a synthetic trajectory that the shared classifier
turns into exactly that outcome, with the contract's sign (a positive table acceleration starts a
negative θ), so it is mirror-symmetric and deterministic.

The others misbehave on purpose for cells with ω/p above the ``bad_above`` setting.
"""

from __future__ import annotations

import ctypes
import math
import os
import time

import numpy as np

from rockbench.engines.contract import EngineAdapter, Trajectory
from rockbench.reference_solver.model import G


def analytic_outcome(w: float, a: float) -> str:
    """The known outcome of the analytic map at ω/p = w, a₀/(g·tanα) = a."""
    if a <= 1.0:
        return "rest"
    if abs(a - (2.5 + 0.8 * w)) < 0.05:
        return "rocking"
    if a > 1.0 + 0.8 * w:
        return "overturn"
    if abs(a - 1.5) < 0.06 and w < 6.0:
        return "overturn"
    return "rocking"


def analytic_grid(w_values, a_values) -> np.ndarray:
    codes = {"rest": 0, "rocking": 1, "overturn": 2}
    return np.array([[codes[analytic_outcome(w, a)] for w in w_values] for a in a_values], dtype=np.int8)


def ideal_corners(block, th):
    """Both bottom corners of a block rocking without slip or jump (the pivot stays put): x, z ``(n, 2)``."""
    b = block.width_m
    xs, zs = [], []
    for sx in (1.0, -1.0):
        piv = np.where(th > 0, 1.0, np.where(th < 0, -1.0, sx)) * b / 2
        dx = sx * b / 2 - piv
        xs.append(piv + dx * np.cos(th))
        zs.append(-dx * np.sin(th))
    return np.stack(xs, 1), np.stack(zs, 1)


class AnalyticAdapter(EngineAdapter):
    CONTRACT_VERSION = 2
    name = "analytic"
    module = None
    SETTINGS = {"sleep_s": 0.0, "bad_above": math.inf}
    own_dt_s = 1e-3

    def _ratios(self, case):
        b = case.block
        w = case.pulse.omega_rad_s / b.p_rad_s
        a = abs(case.pulse.amplitude_mps2) / (G * math.tan(b.alpha_rad))
        return round(w, 9), round(a, 9)   # the analytic picture, not round-off, decides a cell on a line

    def _simulate(self, case):   # its step posed (a bad one was the user's error: a ConfigError in run_many)
        if self.settings["sleep_s"]:
            time.sleep(self.settings["sleep_s"])
        w, a = self._ratios(case)
        self._misbehave(w)
        alpha = case.block.alpha_rad
        T = case.pulse.duration_s
        t = np.linspace(0.0, 1.5 * T, 61)
        sgn = -math.copysign(1.0, case.pulse.amplitude_mps2)
        out = analytic_outcome(w, a)
        if out == "rest":
            th = np.zeros_like(t)
        elif out == "rocking":
            th = sgn * 0.5 * alpha * np.sin(np.pi * t / (1.5 * T))
        else:
            th = sgn * (0.5 * np.pi) * (t / t[-1]) ** 2
        thd = np.gradient(th, t)
        cx, cz = ideal_corners(case.block, th)
        return Trajectory(t, th, thd, T, corner_x_m=cx, corner_z_m=cz)

    def _misbehave(self, w):
        pass


class BatchAnalyticAdapter(AnalyticAdapter):
    """The same picture through a native batch (``_simulate_many``)."""

    name = "analytic-batch"
    batching = "native"

    def _simulate_many(self, cases):
        return [self._simulate(c) for c in cases]


class RaisingAdapter(AnalyticAdapter):
    name = "raising"

    def _misbehave(self, w):
        if w > self.settings["bad_above"]:
            raise RuntimeError(f"engine exploded at w={w:.3f}")


class CrashingAdapter(AnalyticAdapter):
    name = "crashing"

    def _misbehave(self, w):
        if w > self.settings["bad_above"]:
            ctypes.string_at(0)   # segfault: the whole process dies


class HangingAdapter(AnalyticAdapter):
    name = "hanging"

    def _misbehave(self, w):
        if w > self.settings["bad_above"]:
            time.sleep(3600)


class HangingStartAdapter(AnalyticAdapter):
    """Never gets going in a worker: it hangs while setting up the engine in any process but the
    one named by ``RB_TEST_PARENT_PID`` (the test's own, which builds an adapter for run.json)."""

    name = "hanging-start"

    def __init__(self, **settings):
        if str(os.getpid()) != os.environ.get("RB_TEST_PARENT_PID"):
            time.sleep(3600)
        super().__init__(**settings)


class DivergingAdapter(AnalyticAdapter):
    name = "diverging"

    def _simulate(self, case):
        tr = super()._simulate(case)
        w, _ = self._ratios(case)
        if w > self.settings["bad_above"]:
            tr.theta_rad[5:] = np.nan
        return tr


class CrashingBatchAdapter(BatchAnalyticAdapter):
    """A native batch that segfaults when any of its cells is bad (the executor must isolate it)."""

    name = "crashing-batch"

    def _misbehave(self, w):
        if w > self.settings["bad_above"]:
            ctypes.string_at(0)


class WrongAdapter(AnalyticAdapter):
    """Breaks the contract: θ in degrees, the wrong sign, and noise (not deterministic) above the one
    uplift tolerance (2 % of α), so that a block below the uplift threshold seems to rock."""

    name = "wrong"

    def _simulate(self, case):
        tr = super()._simulate(case)
        rng = np.random.default_rng()
        tr.theta_rad = -np.degrees(tr.theta_rad) + 2e-2 * rng.standard_normal(tr.theta_rad.size)
        return tr


class EtaAnalyticAdapter(AnalyticAdapter):
    """The analytic picture with a free-rocking η of its own: a function of the block and the
    ``sleep_s`` setting (so two variants measure two values), deterministic, slow enough (``work_s``)
    that measurements run side by side; each measurement appends a line to ``log_path``."""

    name = "analytic-eta"
    SETTINGS = {**AnalyticAdapter.SETTINGS, "work_s": 0.0, "log_path": ""}

    def measure_restitution(self, block, *, theta0_frac=0.5, dt_s=None):
        from rockbench.engines.contract import RestitutionMeasurement
        time.sleep(self.settings["work_s"])
        if self.settings["log_path"]:
            with open(self.settings["log_path"], "a") as f:
                f.write(f"{block.name} {self.settings['sleep_s']} {os.getpid()}\n")
        eta = 0.8 + 0.1 * block.alpha_rad + 100.0 * self.settings["sleep_s"]
        return RestitutionMeasurement([eta, eta], eta, 0.0, theta0_frac * block.alpha_rad, dt_s or 1e-3,
                                      dict(self.settings), "analytic")


class BrokenAdapter(AnalyticAdapter):
    """An engine version that cannot simulate: every cell fails with one and the same error (what
    Exudyn 1.9.0 does with rockbench's adapter)."""

    name = "broken"

    def _misbehave(self, w):
        raise TypeError("ObjectRigidBody2D.__init__() got an unexpected keyword argument 'mass'")

    def measure_restitution(self, block, *, theta0_frac=0.5, dt_s=None):
        self._misbehave(0.0)


class UnstartableAdapter(AnalyticAdapter):
    """Cannot be set up in a worker process (its start-up fails there); in the process named by
    ``RB_TEST_PARENT_PID`` it builds, as run.json needs."""

    name = "unstartable"

    def __init__(self, **settings):
        if str(os.getpid()) != os.environ.get("RB_TEST_PARENT_PID"):
            raise RuntimeError("the engine's library could not load its solver")
        super().__init__(**settings)


class StepCostAdapter(AnalyticAdapter):
    """A toy engine whose error and cost are known, for the speed stage (a "calibrated" variant that takes
    any time step): rest below a = 1, overturn above the line a = 1 + 0.8·ω/p + ``shift_per_s``·Δt, rocking
    between, so its boundary lies ``shift_per_s``·Δt above the same line without the shift (0.781 times that
    across it); it simulates 1.5 waves (:attr:`SPAN_WAVES`) and burns ``cpu_per_step_s`` of CPU per step of
    that span, so its cost is ``cpu_per_step_s``/Δt CPU seconds per simulated second (plus Python's own)."""

    name = "analytic-step"
    SETTINGS = {**AnalyticAdapter.SETTINGS, "settings": "calibrated", "shift_per_s": 100.0, "cpu_per_step_s": 2e-5}
    SPAN_WAVES = 1.5

    def _simulate(self, case):
        dt = case.dt_s   # posed: the step decided (posed)
        w, a = self._ratios(case)
        line = 1.0 + 0.8 * w + self.settings["shift_per_s"] * dt
        out = "rest" if a <= 1.0 else ("overturn" if a > line else "rocking")
        T = case.pulse.duration_s
        span = self.SPAN_WAVES * T
        until = time.process_time() + self.settings["cpu_per_step_s"] * span / dt
        while time.process_time() < until:
            pass
        t = np.linspace(0.0, span, 61)
        alpha = case.block.alpha_rad
        sgn = -math.copysign(1.0, case.pulse.amplitude_mps2)
        if out == "rest":
            th = np.zeros_like(t)
        elif out == "rocking":
            th = sgn * 0.5 * alpha * np.sin(np.pi * t / span)
        else:
            th = sgn * (0.5 * np.pi) * (t / t[-1]) ** 2
        cx, cz = ideal_corners(case.block, th)
        return Trajectory(t, th, np.gradient(th, t), T, corner_x_m=cx, corner_z_m=cz)


ALL = {c.name: c for c in (AnalyticAdapter, BatchAnalyticAdapter, RaisingAdapter, CrashingAdapter,
                           HangingAdapter, HangingStartAdapter, DivergingAdapter, CrashingBatchAdapter,
                           WrongAdapter, EtaAnalyticAdapter, BrokenAdapter, UnstartableAdapter, StepCostAdapter)}


def register_all():
    from rockbench.engines import registry
    for name, cls in ALL.items():
        registry.register(name, f"{cls.__module__}:{cls.__qualname__}")
