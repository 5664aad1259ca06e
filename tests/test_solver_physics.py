"""Physics of the reference solver against closed forms, invariants and an independent solution.

docs/physics.md §7 ("What must hold"). The independent event-driven solution lives in
``tests/ivp_baseline.py`` (SciPy ``solve_ivp`` with events); it shares nothing with the
Newmark kernels but the pulses' ``ü(t)``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st
from scipy.integrate import quad

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.reference_solver.energy import energy_rad2_s2
from rockbench.reference_solver.model import G, Block
from rockbench.reference_solver.pulses import CosinePulse, RecordPulse, SinePulse, make_pulse
from rockbench.reference_solver.restitution import housner_eta, modified_eta
from rockbench.reference_solver.solver import solve, solve_batch

from ivp_baseline import critical_amplitude, solve_events

B3M = get_preset("B3M").block()
B6M = get_preset("B6M").block()
CODE = {"rest": 0, "rocking": 1, "overturn": 2}


def quiet(duration_s=0.01):
    """No excitation: a record of zeros (the block rocks freely from its initial state)."""
    return RecordPulse(np.array([0.0, duration_s]), np.array([0.0, 0.0]))


def free_impacts(block, theta0, dt, linearized=False, periods=3.0):
    T_guess = 4.0 / block.p_rad_s * math.acosh(1.0 / (1.0 - theta0 / block.alpha_rad))
    sol = solve(block, quiet(), 1.0, dt_s=dt, linearized=linearized, mode="to-rest", history=False,
                t_max_s=periods * T_guess, theta0_rad=theta0)
    return sol.impacts


def period_from_impacts(imp):
    # from rest at θ0 the impacts fall at T/4 + k·T/2
    t = imp[:, 0]
    k = np.arange(t.size)
    slope, icpt = np.polyfit(k, t, 1)
    return 2.0 * slope


def linear_period(block, theta0):
    """docs/physics.md §7: T = (4/p)·arcosh(1/(1 − θ0/α))."""
    return 4.0 / block.p_rad_s * math.acosh(1.0 / (1.0 - theta0 / block.alpha_rad))


def nonlinear_period(block, theta0):
    """Four times the quarter period ∫ dθ/θ̇ from θ0 to 0, θ̇² = 2p²(cos(α−θ) − cos(α−θ0)).

    With θ = θ0(1 − u²) the endpoint singularity goes away.
    """
    a, p2 = block.alpha_rad, block.p_rad_s**2

    def f(u):
        th = theta0 * (1.0 - u * u)
        v2 = 2.0 * p2 * (math.cos(a - theta0) - math.cos(a - th))
        if u == 0.0:  # the limit u → 0
            return 2.0 * theta0 / math.sqrt(2.0 * p2 * theta0 * math.sin(a - theta0))
        return 2.0 * theta0 * u / math.sqrt(v2)
    q, _ = quad(f, 0.0, 1.0, epsabs=1e-14, epsrel=1e-13, limit=200)
    return 4.0 * q


# -- free rocking ---------------------------------------------------------------------------------
def test_closed_form_periods_match_domain_numbers():
    th0 = 0.5 * B3M.alpha_rad
    # docs/physics.md §7 gives five digits; the last one may differ by one with p from the exact sizes
    assert linear_period(B3M, th0) == pytest.approx(0.45712, abs=1.5e-5)
    assert nonlinear_period(B3M, th0) == pytest.approx(0.45947, abs=1.5e-5)


@pytest.mark.parametrize("linearized", [True, False])
def test_free_rocking_period(linearized):
    th0 = 0.5 * B3M.alpha_rad
    exact = linear_period(B3M, th0) if linearized else nonlinear_period(B3M, th0)
    T = period_from_impacts(free_impacts(B3M, th0, 1e-4, linearized))
    assert T == pytest.approx(exact, rel=2e-5)


@pytest.mark.parametrize("linearized", [True, False])
def test_free_rocking_error_shrinks_as_dt_squared(linearized):
    th0 = 0.5 * B3M.alpha_rad
    exact = linear_period(B3M, th0) if linearized else nonlinear_period(B3M, th0)
    dts = np.array([4e-3, 2e-3, 1e-3, 5e-4])
    err = np.array([abs(period_from_impacts(free_impacts(B3M, th0, dt, linearized)) - exact) for dt in dts])
    order = np.polyfit(np.log(dts), np.log(err), 1)[0]
    assert order == pytest.approx(2.0, abs=0.3), (order, err)


def test_free_rocking_with_eta_one_keeps_its_amplitude():
    th0 = 0.3 * B6M.alpha_rad
    sol = solve(B6M, quiet(), 1.0, dt_s=1e-3, mode="to-rest", t_max_s=3.0, theta0_rad=th0)
    assert sol.max_abs_theta_rad == pytest.approx(th0, rel=1e-4)
    assert sol.outcome.value == "rocking"


# -- impacts and energy -----------------------------------------------------------------------------
def test_every_impact_multiplies_kinetic_energy_by_eta_squared():
    eta = modified_eta(B3M.alpha_rad, 0.8608)
    pulse = SinePulse(5.0 * G * math.tan(B3M.alpha_rad), 6.0 * B3M.p_rad_s)
    sol = solve(B3M, pulse, eta, mode="to-rest")
    assert sol.outcome.value == "rocking" and sol.impacts.shape[0] >= 10
    ratio = (sol.impacts[:, 2] / sol.impacts[:, 1]) ** 2
    np.testing.assert_allclose(ratio, eta**2, rtol=0, atol=1e-9)
    # the samples show it too: at each impact time θ = 0 and θ̇ is the post-impact velocity
    i = np.searchsorted(sol.t_s, sol.impacts[:, 0])
    on = sol.t_s[np.minimum(i, sol.t_s.size - 1)] == sol.impacts[:, 0]
    assert on.all()
    np.testing.assert_array_equal(sol.theta_rad[i], 0.0)
    moving = sol.theta_dot_rad_s[i] != 0.0  # not where the Zeno rule put the block to rest
    assert moving.sum() >= sol.impacts.shape[0] - 1
    np.testing.assert_array_equal(sol.theta_dot_rad_s[i][moving], sol.impacts[moving, 2])


def test_energy_is_conserved_between_impacts_after_the_pulse():
    # free rocking after a pulse at Δt = 1 ms: between two impacts E drifts by < 1e-5 of E
    eta = housner_eta(B3M.alpha_rad)
    pulse = SinePulse(5.0 * G * math.tan(B3M.alpha_rad), 6.0 * B3M.p_rad_s)
    sol = solve(B3M, pulse, eta, dt_s=1e-3, mode="to-rest")
    assert sol.outcome.value == "rocking"
    t_imp = sol.impacts[:, 0]
    after = t_imp[t_imp > sol.t_pulse_end_s]
    assert after.size >= 5
    E = energy_rad2_s2(sol.theta_rad, sol.theta_dot_rad_s, B3M.alpha_rad, B3M.p_rad_s)
    worst = 0.0
    bounds = np.concatenate([[sol.t_pulse_end_s], after])
    for a, b in zip(bounds[:-1], bounds[1:]):
        m = (sol.t_s > a) & (sol.t_s < b)
        if m.sum() < 3:
            continue
        worst = max(worst, float((E[m].max() - E[m].min()) / E[m].mean()))
    assert worst < 1e-5, worst


# -- threshold and symmetry ---------------------------------------------------------------------------
def fine_dt(pulse):
    """1 ms, or finer when the pulse is too short for it."""
    return min(1e-3, pulse.max_dt_s())


blocks = st.builds(lambda b, r: Block(b, b * r), st.floats(0.02, 0.5), st.floats(1.2, 8.0))
kinds = st.sampled_from(["sine", "cosine", "half-sine"])


@settings(max_examples=60, deadline=None)
@given(block=blocks, kind=kinds, frac=st.floats(0.05, 0.999), w_ratio=st.floats(0.5, 15.0),
       sign=st.sampled_from([-1.0, 1.0]), linearized=st.booleans())
def test_no_uplift_below_threshold(block, kind, frac, w_ratio, sign, linearized):
    a0 = sign * frac * block.uplift_acceleration(linearized)
    pulse = make_pulse(kind, a0, w_ratio * block.p_rad_s)
    sol = solve(block, pulse, 0.9, linearized=linearized, dt_s=fine_dt(pulse))
    assert sol.outcome.value == "rest"
    assert sol.max_abs_theta_rad == 0.0 and sol.uplifts.size == 0


@settings(max_examples=40, deadline=None)
@given(block=blocks, kind=kinds, ratio=st.floats(1.001, 1.5), w_ratio=st.floats(0.5, 15.0),
       linearized=st.booleans())
def test_uplift_at_the_exact_instant_opposite_to_the_acceleration(block, kind, ratio, w_ratio, linearized):
    a0 = ratio * block.uplift_acceleration(linearized)
    w = w_ratio * block.p_rad_s
    pulse = make_pulse(kind, a0, w)
    dt = fine_dt(pulse)
    sol = solve(block, pulse, 0.9, linearized=linearized, dt_s=dt)
    r = 1.0 / ratio
    t_exact = 0.0 if kind == "cosine" else math.asin(r) / w
    assert sol.uplifts.size >= 1
    assert sol.uplifts[0] == pytest.approx(t_exact, abs=1e-12)
    # a positive ü tips the block to θ < 0, seen once |ü| stays above the threshold for 3 steps
    above = (math.acos(r) if kind == "cosine" else math.pi - 2.0 * math.asin(r)) / w
    assume(above > 3 * dt)
    first = sol.theta_rad[np.nonzero(sol.theta_rad)[0][0]]
    assert first < 0.0


@settings(max_examples=40, deadline=None)
@given(block=blocks, kind=kinds, a_ratio=st.floats(1.0, 12.0), w_ratio=st.floats(0.5, 15.0),
       eta=st.floats(0.5, 1.0), linearized=st.booleans(), mode=st.sampled_from(["energy", "to-rest"]))
def test_mirror_symmetry(block, kind, a_ratio, w_ratio, eta, linearized, mode):
    a0 = a_ratio * G * math.tan(block.alpha_rad)
    w = w_ratio * block.p_rad_s
    dt = fine_dt(make_pulse(kind, a0, w))
    s1 = solve(block, make_pulse(kind, a0, w), eta, linearized=linearized, mode=mode, dt_s=dt)
    s2 = solve(block, make_pulse(kind, -a0, w), eta, linearized=linearized, mode=mode, dt_s=dt)
    assert s1.outcome == s2.outcome and s1.n_impacts == s2.n_impacts
    np.testing.assert_array_equal(s1.t_s, s2.t_s)
    np.testing.assert_allclose(s2.theta_rad, -s1.theta_rad, rtol=0, atol=1e-12)
    np.testing.assert_allclose(s2.theta_dot_rad_s, -s1.theta_dot_rad_s, rtol=0, atol=1e-10)


# -- maps: the two ends of a run, and Δt -------------------------------------------------------------
def _map(block, eta, n, mode, dt=1e-3, kind="sine", w=(1.0, 12.0), a=(1.0, 10.0)):
    W, A = np.meshgrid(np.linspace(*w, n), np.linspace(*a, n))
    r = solve_batch(block.alpha_rad, block.p_rad_s, eta, kind, W * block.p_rad_s,
                    A * G * math.tan(block.alpha_rad), dt_s=dt, mode=mode)
    return r.outcome


def _touches_boundary(m):
    """Cells with a neighbour (8-neighbourhood) of another outcome."""
    pad = np.pad(m, 1, mode="edge")
    out = np.zeros(m.shape, bool)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            out |= pad[1 + di:1 + di + m.shape[0], 1 + dj:1 + dj + m.shape[1]] != m
    return out


@pytest.mark.parametrize("kind", ["sine", "cosine"])
def test_energy_and_to_rest_maps_agree_off_the_boundary(kind):
    eta = modified_eta(B3M.alpha_rad, 0.8608)
    e = _map(B3M, eta, 60, "energy", kind=kind)
    r = _map(B3M, eta, 60, "to-rest", kind=kind)
    differ = e != r
    assert (CODE["overturn"] == e).sum() > 100 and (CODE["rocking"] == e).sum() > 100
    assert not np.any(differ & ~_touches_boundary(e))


@pytest.mark.slow
def test_halving_dt_changes_the_map_only_on_the_boundary():
    eta = modified_eta(B6M.alpha_rad, 0.8608)
    m1 = _map(B6M, eta, 60, "energy", dt=1e-3)
    m2 = _map(B6M, eta, 60, "energy", dt=5e-4)
    assert not np.any((m1 != m2) & ~_touches_boundary(m1))


# -- literature cases ----------------------------------------------------------------------------------
def makris_block():
    """p = 2 rad/s, α = 15° (Makris & Konstantinidis 2003): R = 3g/(4p²), b = 2R·sinα, h = 2R·cosα."""
    R = 3.0 * G / (4.0 * 2.0**2)
    a = math.radians(15.0)
    return Block(2.0 * R * math.sin(a), 2.0 * R * math.cos(a))


@pytest.mark.parametrize("factor, outcome", [(1.01, "overturn"), (0.99, "rocking")])
def test_makris_konstantinidis_one_cosine_pulse(factor, outcome):
    blk = makris_block()
    assert blk.p_rad_s == pytest.approx(2.0, rel=1e-12)
    pulse = CosinePulse(factor * 0.3150 * G, math.pi)
    assert pulse.duration_s == pytest.approx(2.0)
    sol = solve(blk, pulse, housner_eta(blk.alpha_rad))
    assert sol.outcome.value == outcome


@pytest.mark.parametrize("mode", ["energy", "to-rest"])
def test_paper_fig17_pair(mode):
    a0 = 6.1 * G * math.tan(B3M.alpha_rad)
    pulse = SinePulse(a0, 6.0 * B3M.p_rad_s)
    over = solve(B3M, pulse, modified_eta(B3M.alpha_rad, 0.7595), mode=mode)
    rock = solve(B3M, pulse, modified_eta(B3M.alpha_rad, 0.8608), mode=mode)
    assert over.outcome.value == "overturn" and rock.outcome.value == "rocking"
    # the decisive impact comes after the pulse (0.091 s), near 0.14 s: the paper says "just before
    # 0.14 s"; this model (and the independent solution) put it at 0.1466 s
    t_imp = over.impacts[0, 0]
    assert 0.13 < t_imp < 0.15
    assert over.impacts[0, 0] == rock.impacts[0, 0] if mode == "to-rest" else True


# -- an independent solution ---------------------------------------------------------------------------
def _random_cases(n, seed):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        blk = Block(rng.uniform(0.03, 0.3), 1.0)
        blk = Block(blk.width_m, blk.width_m * rng.uniform(1.5, 6.0))
        kind = str(rng.choice(["sine", "cosine", "half-sine"]))
        w = rng.uniform(1.0, 12.0) * blk.p_rad_s
        a = rng.uniform(1.0, 10.0) * G * math.tan(blk.alpha_rad)
        eta = float(rng.uniform(0.6, 1.0))
        lin = bool(rng.random() < 0.2)
        out.append((blk, kind, w, a, eta, lin))
    return out


def _agreement(cases, delta=5e-3):
    checked = 0
    for blk, kind, w, a, eta, lin in cases:
        outs = [solve(blk, make_pulse(kind, a * f, w), eta, linearized=lin, history=False).outcome.value
                for f in (1.0 - delta, 1.0, 1.0 + delta)]
        if len(set(outs)) > 1:
            continue  # within δ of the boundary: Newmark's O(Δt²) error may decide it either way
        ref = solve_events(blk.alpha_rad, blk.p_rad_s, eta, make_pulse(kind, a, w), linearized=lin)
        if abs(ref["max_abs_theta"] / (0.02 * blk.alpha_rad) - 1.0) < 0.25:
            continue  # a hair's rocking near the one uplift tolerance: Newmark's error in max|θ| decides it
        assert ref["outcome"] == outs[1], (blk, kind, w, a, eta, lin, ref["outcome"], outs)
        checked += 1
    return checked


def test_outcomes_agree_with_event_driven_solution():
    cases = _random_cases(40, seed=2)
    assert _agreement(cases) >= 30


@pytest.mark.slow
def test_outcomes_agree_with_event_driven_solution_many():
    cases = _random_cases(300, seed=3)
    assert _agreement(cases) >= 250


@pytest.mark.parametrize("kind, w_ratio", [("sine", 2.0), ("sine", 5.0), ("cosine", 3.0)])
def test_critical_amplitude_agrees_with_event_driven_solution(kind, w_ratio):
    eta = modified_eta(B3M.alpha_rad, 0.8608)
    w = w_ratio * B3M.p_rad_s
    scale = G * math.tan(B3M.alpha_rad)
    # bracket the lowest overturning amplitude with a batch scan
    a_grid = np.linspace(1.0, 15.0, 281) * scale
    out = solve_batch(B3M.alpha_rad, B3M.p_rad_s, eta, kind, w, a_grid).outcome
    i = int(np.argmax(out == CODE["overturn"]))
    assert out[i] == CODE["overturn"] and i > 0
    lo, hi = a_grid[i - 1], a_grid[i]

    def newmark(a):
        return solve(B3M, make_pulse(kind, a, w), eta, history=False).outcome.value

    def events(a):
        return solve_events(B3M.alpha_rad, B3M.p_rad_s, eta, make_pulse(kind, a, w))["outcome"]

    lo2, hi2 = 0.9 * lo, 1.1 * hi
    a_n = critical_amplitude(newmark, lo2, hi2)
    a_e = critical_amplitude(events, lo2, hi2)
    assert a_n == pytest.approx(a_e, rel=5e-3)
