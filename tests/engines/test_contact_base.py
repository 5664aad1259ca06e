"""The contact engines' shared base (engines/contact.py): one η measurement, one time-step resolver,
one overturn-is-certain rule, one resolution of the settings. No engine needed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.contract import uplift_tol_rad
from rockbench.engines.calibration.knobs import Knob
from rockbench.engines.contact import ContactEngine
from rockbench.engines.calibration.free_rocking import free_rocking_etas
from rockbench.engines.calibration.time_step import step_for
from rockbench.reference_solver.classify import FLAT_ANGLE_RAD, decision_index, overturn_certain
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.pulses import RecordPulse
from rockbench.reference_solver.solver import solve


def _free_rocking(block, eta, theta0, dt, n_impacts=4):
    quiet = RecordPulse(np.array([0.0, 0.01]), np.array([0.0, 0.0]))
    quarter = math.acosh(1.0 / (1.0 - theta0 / block.alpha_rad)) / block.p_rad_s
    sol = solve(block, quiet, eta, dt_s=dt, mode="to-rest", history=True,
                t_max_s=quarter * (2 * n_impacts + 1) * 1.2, theta0_rad=theta0)
    return sol


@pytest.mark.parametrize("name,eta", [("B3M", 0.9), ("B6M", 0.95), ("B3M", 0.7)])
def test_peak_ratio_eta_equals_the_eta_the_rigid_model_applies(name, eta):
    # the reference solver applies θ̇⁺ = η θ̇⁻ exactly at every impact: the shared measurement,
    # reading only θ(t), must give that η back at each impact (to the sampling of the peaks)
    block = get_preset(name).block()
    th0 = 0.5 * block.alpha_rad
    sol = _free_rocking(block, eta, th0, 1e-4)
    etas, peaks = free_rocking_etas(sol.theta_rad, block.alpha_rad, th0, uplift_tol_rad(block), 4)
    assert len(etas) == 4
    assert peaks[0] == pytest.approx(th0)
    np.testing.assert_allclose(etas, eta, rtol=2e-4)


def test_peak_ratio_is_robust_to_a_coarse_step():
    # a peak is where θ̇ = 0: sampling it coarsely errs only to second order, so the measurement
    # stays within 0.1 % at Δt = 2 ms (20 times the step above)
    block = get_preset("B3M").block()
    th0 = 0.5 * block.alpha_rad
    sol = _free_rocking(block, 0.9, th0, 2e-3)
    etas, _ = free_rocking_etas(sol.theta_rad, block.alpha_rad, th0, uplift_tol_rad(block), 4)
    np.testing.assert_allclose(etas, 0.9, rtol=1e-3)


def test_peak_ratio_reads_known_peaks_exactly():
    # synthetic swings with chosen peaks: η = sqrt of the ratio of cos(α − θ_peak) − cos α
    block = get_preset("B3M").block()
    al = block.alpha_rad
    peaks = [0.5 * al, 0.4 * al, 0.3 * al, 0.22 * al]
    x = np.linspace(0.0, np.pi, 401)[:-1]
    release = peaks[0] * np.cos(x[x < np.pi / 2])          # from rest at θ0 down to the first impact
    th = np.concatenate([release] + [(-1) ** k * pk * np.sin(x) for k, pk in enumerate(peaks[1:], start=1)])
    etas, got = free_rocking_etas(th, al, peaks[0], uplift_tol_rad(block), 4)
    ke = np.cos(al - np.array(peaks)) - math.cos(al)
    np.testing.assert_allclose(got, peaks, rtol=1e-4)
    np.testing.assert_allclose(etas, np.sqrt(ke[1:] / ke[:-1]), rtol=1e-4)


def test_no_rocking_gives_no_eta():
    block = get_preset("B3M").block()
    etas, peaks = free_rocking_etas(np.zeros(100), block.alpha_rad, 0.0, uplift_tol_rad(block), 4)
    assert etas == []


def test_overturn_certain_is_the_classifiers_rule_on_arrays_and_floats():
    alpha, te = 0.2, 1.0
    t = np.array([0.5, 0.5, 1.5, 1.5, 1.5, 0.5])
    th = np.array([0.3, FLAT_ANGLE_RAD, 0.3, 0.3, -0.3, -FLAT_ANGLE_RAD])
    thd = np.array([1.0, 0.0, 1.0, -1.0, -1.0, 0.0])
    want = [False, True, True, False, True, True]
    assert overturn_certain(t, th, thd, alpha_rad=alpha, t_pulse_end_s=te).tolist() == want
    got = [overturn_certain(float(a), float(b), float(c), alpha_rad=alpha, t_pulse_end_s=te)
           for a, b, c in zip(t, th, thd)]
    assert got == want and all(isinstance(g, bool) for g in got)
    assert decision_index(t[2:4], th[2:4], thd[2:4], alpha_rad=alpha, t_pulse_end_s=te) == (0, True)


class _Toy(ContactEngine):
    CONTRACT_VERSION = 2
    name = "toy"
    SETTINGS = {"segment_s": 0.1}
    SHIPPED = {"stiffness_n_m": 1e6, "damping_n_s_m": None}
    MODE_DEFAULTS = {"iterations": (50, 30)}
    KNOBS = (Knob("stiffness_n_m", "N/m", (1e5, 1e6), start=2e6), Knob("damping_n_s_m", "N s/m", (1.0, 2.0)))
    own_dt_s = 1e-3


def test_shared_settings_are_checked_once_for_every_contact_engine():
    a = _Toy(planar="false")
    assert a.settings["planar"] is False
    for bad, msg in ((dict(settings="rigid"), "'settings' must be one of calibrated, shipped"),
                     (dict(drive="mocap"), "'drive' must be one of inertial, table"),
                     (dict(planar="maybe"), "'planar' must be true or false"),
                     (dict(friction=-1), "'friction' must be a finite number > 0"),
                     (dict(friction=True), "'friction' must be a finite number > 0"),
                     (dict(min_tail_s=5.0), "'min_tail_s' (5 s) must not exceed 'tail_s'"),
                     (dict(segment_s=0), "'segment_s' must be a finite number > 0")):
        with pytest.raises(ConfigError, match=msg.replace("(", r"\(").replace(")", r"\)")):
            _Toy(**bad)


def test_the_settings_are_the_shared_ones_the_shipped_contact_and_the_engine_s_own():
    assert set(_Toy.SETTINGS) == {"settings", "drive", "planar", "friction", "tail_s", "min_tail_s", "calibrate_on",
                                  "planted_eta_factor",
                                  "segment_s", "stiffness_n_m", "damping_n_s_m", "iterations"}
    assert all(_Toy.SETTINGS[k] is None for k in ("stiffness_n_m", "damping_n_s_m", "iterations"))
    with pytest.raises(TypeError, match="'stiffness_n_m' a default"):
        type("Stiff", (ContactEngine,), {"SETTINGS": {"stiffness_n_m": 1e6}, "SHIPPED": {"stiffness_n_m": 2e6}})


def test_one_resolution_of_the_settings():
    """As shipped: the shipped contact and the modes' shipped values; calibrated: the calibrated
    values, the calibration's contact; a contact given: a knob left out at its start."""
    shipped = _Toy(settings="shipped").settings_with()
    assert (shipped["stiffness_n_m"], shipped["damping_n_s_m"], shipped["iterations"]) == (1e6, None, 50)
    cal = _Toy().settings_with({"stiffness_n_m": 1e5, "damping_n_s_m": 2.0, "not_a_setting": 1})
    assert (cal["stiffness_n_m"], cal["damping_n_s_m"], cal["iterations"]) == (1e5, 2.0, 30) and "not_a_setting" not in cal
    given = _Toy(damping_n_s_m=3.0)
    assert given.explicit_contact() and not given.calibrated()
    assert (given.settings_with()["stiffness_n_m"], given.settings_with()["damping_n_s_m"]) == (2e6, 3.0)
    assert not _Toy().explicit_contact() and _Toy().calibrated()


@pytest.mark.parametrize("dt", [0.0, -1e-3, math.nan, "x"])
def test_one_time_step_resolver_refuses_a_bad_step(dt):
    with pytest.raises(ConfigError, match="--dt must be a"):
        step_for(_Toy(), get_preset("B3M").block(), 0.75, dt_s=dt)


def test_the_step_as_shipped_is_the_engine_s_own_never_coarser_than_the_pulse_accepts():
    from rockbench.reference_solver.pulses import make_pulse

    block = get_preset("B3M").block()
    slow, fast = (make_pulse("sine", 5.0, w * block.p_rad_s) for w in (2.0, 60.0))
    toy = _Toy(settings="shipped")
    assert step_for(toy, block, 0.75) == step_for(toy, block, 0.75, slow) == 1e-3
    assert step_for(toy, block, 0.75, fast) == pytest.approx(fast.duration_s / 20)
    assert step_for(toy, block, 0.75, slow, dt_s=2e-4) == 2e-4
    assert step_for(_Toy(stiffness_n_m=1e6), block, 0.75, slow) == _Toy.fixed_dt_s   # a contact given


def _cal(n, eta, reached):
    from rockbench.engines.contract import CalibrationResult
    return CalibrationResult(eta_target=0.8, eta_measured=eta, eta_std=0.0, reached=reached,
                             settings={"contact_points": n}, note=f"η {eta}")


def test_first_reached_stops_at_the_first_count_that_reaches_the_target():
    from rockbench.engines.calibration.routine import first_reached
    asked = []
    results = {9: _cal(9, 0.75, False), 5: _cal(5, 0.801, True), 17: _cal(17, 0.8, True)}

    def calibrate_n(n):
        asked.append(n)
        return results[n]

    assert first_reached(calibrate_n, (9, 5, 17), "points") is results[5]
    assert asked == [9, 5]


def test_first_reached_without_success_gives_the_closest_finite_eta_and_lists_every_count():
    from rockbench.engines.calibration.routine import first_reached
    results = {9: _cal(9, math.nan, False), 5: _cal(5, 0.70, False), 17: _cal(17, 0.77, False)}
    best = first_reached(results.__getitem__, (9, 5, 17), "spheres")
    assert best.settings["contact_points"] == 17 and best.eta_measured == 0.77
    assert best.note == "9 spheres: η nan | 5 spheres: η 0.7 | 17 spheres: η 0.77"
    only = first_reached(results.__getitem__, (9,), "spheres")
    assert only is results[9]       # one count tried: its own result, note untouched


@pytest.mark.parametrize("value", [2, 102, 9.5, True, "nine"])
def test_contact_points_must_be_a_whole_number_from_3_to_101(value):
    from rockbench.engines.registry import adapter_class
    for name in ("mujoco", "pybullet", "exudyn"):
        with pytest.raises(ConfigError, match=rf"{name} setting 'contact_points' must be a whole number from 3 to 101"):
            adapter_class(name)(contact_points=value)


def test_run_end_skipping_a_rule_no_sample_reaches_gives_the_full_rule_s_answer():
    """run_end tests a rule only where a sample reaches its first step: on random segments before,
    across and after each mark (NaNs, flat angles and fractional steps among them) it answers as every
    rule tested at every sample does."""
    from rockbench.reference_solver.classify import overturn_impossible, run_end

    alpha, p, n_pulse, n_min = 0.25, 3.0, 40, 60
    rng = np.random.default_rng(7)
    for start in range(0, 90):
        k = start + np.sort(rng.uniform(0.5, 12.0, 8)) if start % 2 else np.arange(start + 1, start + 9, dtype=float)
        th = rng.choice([-1.0, 1.0], 8) * rng.choice([0.0, 0.01, 0.2, 0.3, FLAT_ANGLE_RAD, np.nan], 8,
                                                     p=[0.2, 0.2, 0.25, 0.3, 0.03, 0.02])
        om = rng.normal(0.0, 2.0, 8)
        bad = ~(np.isfinite(th) & np.isfinite(om))
        certain = overturn_certain(k, th, om, alpha_rad=alpha, t_pulse_end_s=n_pulse)
        trapped = (k >= n_min) & overturn_impossible(th, om, alpha_rad=alpha, p_rad_s=p)
        hit = np.flatnonzero(bad | certain | trapped)
        full = None if not hit.size else (int(hit[0]), "diverged" if bad[hit[0]] else (
            ("flat" if abs(th[hit[0]]) >= FLAT_ANGLE_RAD else "overturn") if certain[hit[0]] else "trapped"))
        assert run_end(k, th, om, alpha_rad=alpha, p_rad_s=p, pulse_end_step=n_pulse, min_tail_step=n_min) == full


def test_run_end_is_one_rule_in_order_diverged_overturn_trapped():
    from rockbench.reference_solver.classify import TRAPPED_MARGIN, overturn_impossible, run_end

    alpha, p = 0.25, 3.0
    kw = dict(alpha_rad=alpha, p_rad_s=p, pulse_end_step=10, min_tail_step=20)
    steps = np.arange(5, 9)
    # during the pulse, rocking freely: nothing stops it (trapped waits for min_tail_step)
    assert run_end(steps, [0.01, 0.02, 0.01, 0.0], [0.1, 0.0, -0.1, -0.2], **kw) is None
    assert run_end(steps, [0.01, np.nan, 0.01, 0.0], [0.1, 0.0, -0.1, -0.2], **kw) == (1, "diverged")
    assert run_end(steps, [0.01, FLAT_ANGLE_RAD, 0.01, 0.0], [0.1, 0.0, -0.1, -0.2], **kw) == (1, "flat")
    # past α moving outward counts only from the pulse's end on
    assert run_end(np.arange(8, 12), [0.3, 0.3, 0.3, 0.3], [1.0] * 4, **kw) == (2, "overturn")
    # at rest on the base: trapped from min_tail_step on
    assert run_end(np.arange(18, 22), [0.0] * 4, [0.0] * 4, **kw) == (2, "trapped")
    # the margin: just below the barrier is not trapped, 5 % of its height below it is
    e_trap = p * p - TRAPPED_MARGIN * p * p * (1.0 - np.cos(alpha))
    om = np.sqrt(2.0 * (np.array([e_trap * 1.001, e_trap * 0.999]) - p * p * np.cos(alpha)))
    assert overturn_impossible([0.0, 0.0], om, alpha_rad=alpha, p_rad_s=p).tolist() == [False, True]
