"""Energy, the exact post-pulse decision (docs/physics.md §2) and the shared classifier."""

import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from rockbench.reference_solver.classify import Outcome, classify
from rockbench.reference_solver.energy import barrier_energy_rad2_s2, base_energy_rad2_s2, energy_rad2_s2, free_rocking_fate

ALPHA, P = 0.4182, 11.524


def test_energy_levels():
    assert energy_rad2_s2(0.0, 0.0, ALPHA, P) == pytest.approx(base_energy_rad2_s2(ALPHA, P))
    assert energy_rad2_s2(ALPHA, 0.0, ALPHA, P) == pytest.approx(barrier_energy_rad2_s2(ALPHA, P))
    assert energy_rad2_s2(-ALPHA, 0.0, ALPHA, P, linearized=True) == pytest.approx(0.0)


def test_outward_fate_is_the_barrier():
    # from θ = 0 moving out with kinetic energy just above / below the barrier height
    need = math.sqrt(2 * P**2 * (1 - math.cos(ALPHA)))
    assert free_rocking_fate(1e-12, need * 1.0001, ALPHA, P, 0.8) == (True, 0)
    assert free_rocking_fate(1e-12, need * 0.9999, ALPHA, P, 0.8) == (False, 0)


def test_inward_fate_after_one_impact():
    need = math.sqrt(2 * P**2 * (1 - math.cos(ALPHA)))  # |θ̇| at θ = 0 that just reaches the barrier
    eta = 0.8
    # moving inward at θ → 0⁺: after the impact the speed is η·|θ̇|
    assert free_rocking_fate(1e-12, -need / eta * 1.001, ALPHA, P, eta) == (True, 1)
    assert free_rocking_fate(1e-12, -need / eta * 0.999, ALPHA, P, eta) == (False, 0)


def test_linearised_fate():
    need = P * ALPHA   # ½θ̇² = ½p²α²
    assert free_rocking_fate(-1e-12, -need * 1.001, ALPHA, P, 0.9, linearized=True)[0]
    assert not free_rocking_fate(-1e-12, -need * 0.999, ALPHA, P, 0.9, linearized=True)[0]


def test_past_the_balance_point():
    assert free_rocking_fate(ALPHA * 1.01, 0.0, ALPHA, P, 0.9) == (True, 0)
    assert free_rocking_fate(-ALPHA * 1.01, -0.1, ALPHA, P, 0.9) == (True, 0)


@given(st.floats(-0.4, 0.4), st.floats(-20, 20), st.floats(0.05, 1.0))
def test_fate_is_mirror_symmetric(th, thd, eta):
    assert free_rocking_fate(th, thd, ALPHA, P, eta) == free_rocking_fate(-th, -thd, ALPHA, P, eta)


def _traj(theta, t_end=1.0):
    t = np.linspace(0, t_end, len(theta))
    th = np.asarray(theta, float)
    return t, th, np.gradient(th, t)


def test_classify_rest_rocking_overturn():
    t, th, thd = _traj(np.zeros(50))
    assert classify(t, th, thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=0.5).outcome is Outcome.REST
    t, th, thd = _traj(0.1 * np.sin(np.linspace(0, 4 * np.pi, 400)))
    c = classify(t, th, thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=0.5)
    assert c.outcome is Outcome.ROCKING and c.n_impacts == 3 and c.max_abs_theta_rad == pytest.approx(0.1, rel=1e-3)
    t, th, thd = _traj(np.linspace(0, 1.5, 300))
    c = classify(t, th, thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=0.5)
    assert c.outcome is Outcome.OVERTURN
    assert c.t_overturn_s == pytest.approx(ALPHA / 1.5, abs=2e-3)


def test_classify_ignores_excursions_past_alpha_during_the_pulse():
    th = np.concatenate([np.linspace(0, 0.5, 100), np.linspace(0.5, 0.0, 100), np.zeros(100)])
    t, th, thd = _traj(th)
    c = classify(t, th, thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=0.7)
    assert c.outcome is Outcome.ROCKING


def test_classify_uses_energy_only_when_eta_given():
    need = math.sqrt(2 * P**2 * (1 - math.cos(ALPHA)))
    t = np.array([0.0, 0.1, 0.2])
    th = np.array([0.0, 0.05, 1e-9])
    thd = np.array([0.0, 1.0, need * 1.01])
    assert classify(t, th, thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=0.2).outcome is Outcome.ROCKING
    c = classify(t, th, thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=0.2, eta=0.9)
    assert c.outcome is Outcome.OVERTURN and math.isnan(c.t_overturn_s)


def test_a_caller_may_only_widen_the_uplift_tolerance():
    t, th, thd = _traj(0.03 * ALPHA * np.sin(np.linspace(0, 8, 100)))
    assert classify(t, th, thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=1,
                    uplift_tol_rad=0.05 * ALPHA).outcome is Outcome.REST
    assert classify(t, th, thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=1).outcome is Outcome.ROCKING


@given(st.lists(st.floats(-1.5, 1.5), min_size=2, max_size=60))
def test_classify_mirror_symmetric(values):
    t, th, thd = _traj(values)
    a = classify(t, th, thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=0.5, eta=0.9)
    b = classify(t, -th, -thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=0.5, eta=0.9)
    assert a == b


def test_fate_at_theta_zero_is_post_impact():
    # a sample exactly at θ = 0 carries the post-impact velocity: no second η
    need = math.sqrt(2 * P**2 * (1 - math.cos(ALPHA)))
    assert free_rocking_fate(0.0, -need * 1.001, ALPHA, P, 0.5) == (True, 0)
    assert free_rocking_fate(0.0, need * 0.999, ALPHA, P, 0.5) == (False, 0)


def test_one_uplift_tolerance_for_the_reference_and_every_engine():
    """Rest against rocking is decided by 2 % of α for everyone: a trajectory that lifts by 1 % of α is
    rest whether the caller measures uplift exactly (the reference, tolerance 0) or not (an engine);
    one that lifts by 3 % of α rocks for both. The exact caller keeps its exact uplift instant."""
    from rockbench.reference_solver.classify import uplift_tol
    for frac, expected in ((0.01, Outcome.REST), (0.03, Outcome.ROCKING)):
        t, th, thd = _traj(frac * ALPHA * np.sin(np.linspace(0, 8, 100)))
        for tol in (0.0, uplift_tol(ALPHA)):
            c = classify(t, th, thd, alpha_rad=ALPHA, p_rad_s=P, t_pulse_end_s=1, uplift_tol_rad=tol)
            assert c.outcome is expected
            assert (c.t_uplift_s is None) == (expected is Outcome.REST)
