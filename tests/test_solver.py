"""The reference solver's API and its internal consistency: batch = per case = the classifier."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.contract import Case
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.classify import OUTCOME_CODES, classify
from rockbench.reference_solver.energy import free_rocking_fate
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import G
from rockbench.reference_solver.pulses import RecordPulse, SinePulse, make_pulse
from rockbench.reference_solver.restitution import Restitution, modified_eta
from rockbench.reference_solver.solver import _fate, solve, solve_batch

B3M = get_preset("B3M").block()
B6L = get_preset("B6L").block()


def random_cases(n, seed):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        blk = B3M if rng.random() < 0.5 else B6L
        kind = str(rng.choice(["sine", "cosine", "half-sine"]))
        w = rng.uniform(0.8, 12.0) * blk.p_rad_s
        a = rng.uniform(0.5, 10.0) * G * math.tan(blk.alpha_rad) * rng.choice([-1.0, 1.0])
        yield blk, kind, w, a, float(rng.uniform(0.6, 1.0)), bool(rng.random() < 0.25)


def same_float(x, y):
    if x is None or y is None:
        return x is None and y is None
    return (math.isnan(x) and math.isnan(y)) or abs(x - y) <= 1e-12


@pytest.mark.parametrize("mode", ["energy", "to-rest"])
def test_batch_equals_classified_history(mode):
    cases = list(random_cases(80, seed=11))
    for kind in ("sine", "cosine", "half-sine"):
        for lin in (False, True):
            sel = [c for c in cases if c[1] == kind and c[5] == lin]
            if not sel:
                continue
            r = solve_batch([c[0].alpha_rad for c in sel], [c[0].p_rad_s for c in sel], [c[4] for c in sel], kind,
                            [c[2] for c in sel], [c[3] for c in sel], linearized=lin, mode=mode)
            for j, (blk, _, w, a, eta, _) in enumerate(sel):
                sol = solve(blk, make_pulse(kind, a, w), eta, linearized=lin, mode=mode)
                c = classify(sol.t_s, sol.theta_rad, sol.theta_dot_rad_s, alpha_rad=blk.alpha_rad,
                             p_rad_s=blk.p_rad_s, t_pulse_end_s=sol.t_pulse_end_s,
                             eta=eta if mode == "energy" else None, linearized=lin)
                assert OUTCOME_CODES[c.outcome] == r.outcome[j]
                assert c.n_impacts == r.n_impacts[j]
                assert c.max_abs_theta_rad == pytest.approx(r.max_abs_theta_rad[j], abs=1e-12)
                assert same_float(c.t_uplift_s, None if math.isnan(r.t_uplift_s[j]) else float(r.t_uplift_s[j]))
                t_over = float(r.t_overturn_s[j]) if r.outcome[j] == 2 else None
                assert same_float(c.t_overturn_s, t_over)
                # and the Solution carries exactly that classification
                assert sol.outcome == c.outcome and sol.n_impacts == c.n_impacts


def test_history_off_gives_the_same_answer():
    for blk, kind, w, a, eta, lin in random_cases(30, seed=5):
        p = make_pulse(kind, a, w)
        s1 = solve(blk, p, eta, linearized=lin)
        s2 = solve(blk, p, eta, linearized=lin, history=False)
        assert s2.t_s is None and s2.theta_ddot_rad_s2 is None
        assert (s1.outcome, s1.n_impacts) == (s2.outcome, s2.n_impacts)
        assert same_float(s1.t_overturn_s, s2.t_overturn_s)
        np.testing.assert_array_equal(s1.impacts, s2.impacts)


def test_batch_broadcasts_and_returns_the_documented_arrays():
    W, A = np.meshgrid(np.linspace(1, 12, 7), np.linspace(0.5, 10, 5))
    r = solve_batch(B3M.alpha_rad, B3M.p_rad_s, 0.8, "sine", W * B3M.p_rad_s, A * G * math.tan(B3M.alpha_rad))
    assert r.outcome.shape == (5, 7) and r.outcome.dtype == np.int8
    assert np.all(r.outcome[0] == OUTCOME_CODES["rest"])  # a0 below g·tanα: never lifts
    assert np.all(np.isnan(r.t_uplift_s[0])) and np.all(r.max_abs_theta_rad[0] == 0)
    over = r.outcome == 2
    assert over.any() and np.all(np.isnan(r.t_overturn_s[~over]))
    assert set(r.outcomes().ravel()) <= {"rest", "rocking", "overturn"}


def test_compiled_fate_equals_the_energy_module():
    rng = np.random.default_rng(0)
    for _ in range(3000):
        alpha = rng.uniform(0.05, 0.7)
        p = rng.uniform(1, 20)
        th = rng.uniform(-1.3, 1.3) * alpha * rng.choice([1, 1, 0])
        thd = rng.normal() * p * alpha * 1.5
        eta = rng.uniform(0.5, 1.0)
        lin = bool(rng.random() < 0.3)
        assert tuple(_fate(th, thd, alpha, p * p, eta, lin)) == free_rocking_fate(th, thd, alpha, p, eta, lin)


def test_adapter_batch_path_equals_per_case_path():
    rest = Restitution("modified", k=0.8608)
    cases = [Case(blk, make_pulse(kind, a, w), rest, None, lin) for blk, kind, w, a, _, lin in random_cases(60, 7)]
    rec = RecordPulse(np.linspace(0, 0.3, 301), 6.0 * np.sin(np.linspace(0, 0.3, 301) * 40.0))
    cases.append(Case(B3M, rec, rest))
    for mode in ("energy", "to-rest"):
        ad = get_adapter("reference", mode=mode)
        fast = ad.run_many(cases)
        slow = [ad.judge(c, ad.simulate(c)) for c in cases]  # the per-case path: simulate, then the one judge
        for f, s in zip(fast, slow):
            assert (f.outcome, f.n_impacts, f.valid, f.flags, f.status) == (s.outcome, s.n_impacts, s.valid, s.flags,
                                                                            s.status)
            assert f.max_abs_theta_rad == pytest.approx(s.max_abs_theta_rad, abs=1e-12)
            assert same_float(f.t_uplift_s, s.t_uplift_s) and same_float(f.t_overturn_s, s.t_overturn_s)
        assert "impacts" in slow[0].diagnostics


def test_adapter_basics():
    ad = get_adapter("reference")
    assert ad.name == "reference" and ad.own_dt_s == 1e-3
    assert ad.settings == {"mode": "energy", "friction": 10.0, "planted_eta_factor": 1.0}
    with pytest.raises(ConfigError):
        get_adapter("reference", mode="forever")
    with pytest.raises(ConfigError):
        get_adapter("reference", stiffness=1.0)
    a0 = 6.1 * G * math.tan(B3M.alpha_rad)
    case = Case(B3M, SinePulse(a0, 6 * B3M.p_rad_s), Restitution("modified", k=0.7595))
    tr = ad.simulate(case)
    assert tr.eta_for_tail == pytest.approx(modified_eta(B3M.alpha_rad, 0.7595))
    assert tr.diagnostics["impacts"] and ad.run(case).outcome == "overturn"
    assert get_adapter("reference", mode="to-rest").simulate(case).eta_for_tail is None
    with pytest.raises(ConfigError):  # a step too coarse for the pulse
        ad.run(Case(B3M, SinePulse(a0, 6 * B3M.p_rad_s), Restitution(), dt_s=0.02))


def test_record_uplift_is_exact_on_the_linear_segment():
    # ü rises linearly from 0 to 8 m/s² over 0.1 s: it reaches g·tanα at t = 0.1·g·tanα/8
    rec = RecordPulse(np.array([0.0, 0.1, 0.2]), np.array([0.0, 8.0, 0.0]))
    sol = solve(B3M, rec, 0.8)
    assert sol.uplifts[0] == pytest.approx(0.1 * G * math.tan(B3M.alpha_rad) / 8.0, abs=1e-14)
    assert solve(B3M, rec, 0.8, linearized=True).uplifts[0] == pytest.approx(0.1 * G * B3M.alpha_rad / 8.0,
                                                                           abs=1e-14)


def test_block_comes_back_to_rest_and_lifts_again():
    # just above the threshold the block rocks a little in each half-wave, settles, and lifts again
    # the other way in the second half-wave; it never leaves the one uplift tolerance (2 % of α), so
    # the classifier calls it rest, as it would an engine's, while the solver's uplifts stay exact
    a0 = 1.05 * G * math.tan(B3M.alpha_rad)
    sol = solve(B3M, SinePulse(a0, 2.0 * B3M.p_rad_s), 0.8, mode="to-rest")
    assert sol.uplifts.size >= 2
    assert 0 < sol.max_abs_theta_rad <= 0.02 * B3M.alpha_rad and sol.outcome.value == "rest"
    i = np.searchsorted(sol.t_s, sol.uplifts[1])
    assert sol.theta_rad[i - 1] == 0.0 and sol.theta_dot_rad_s[i - 1] == 0.0
    assert np.any(sol.theta_rad < 0) and np.any(sol.theta_rad > 0)
    # the run ends at rest, after the pulse, before the cap
    assert sol.theta_rad[-1] == 0.0 and sol.theta_dot_rad_s[-1] == 0.0
    assert sol.t_pulse_end_s <= sol.t_s[-1] < sol.t_pulse_end_s + 20 * 2 * math.pi / B3M.p_rad_s


def test_energy_mode_continues_an_overturn_to_the_alpha_crossing():
    a0 = 6.1 * G * math.tan(B3M.alpha_rad)
    sol = solve(B3M, SinePulse(a0, 6 * B3M.p_rad_s), modified_eta(B3M.alpha_rad, 0.7595))
    assert sol.outcome.value == "overturn"
    assert sol.t_s[-1] > sol.t_pulse_end_s and abs(sol.theta_rad[-1]) > B3M.alpha_rad
    assert sol.t_pulse_end_s < sol.t_overturn_s <= sol.t_s[-1]


@pytest.mark.parametrize("kwargs", [dict(mode="sideways"), dict(dt_s=-1e-3), dict(dt_s=float("nan")),
                                    dict(dt_s=0.05), dict(t_max_s=0.01), dict(theta0_rad=2.0)])
def test_bad_arguments_raise_config_error(kwargs):
    with pytest.raises(ConfigError):
        solve(B3M, SinePulse(5.0, 30.0), 0.8, **kwargs)


@pytest.mark.parametrize("eta", [0.0, 1.5, float("nan"), "x"])
def test_bad_eta(eta):
    with pytest.raises(ConfigError):
        solve(B3M, SinePulse(5.0, 30.0), eta)


def test_bad_batch_arguments():
    ok = dict(alpha_rad=0.4, p_rad_s=10.0, eta=0.8, pulse_kind="sine", omega_rad_s=30.0, amplitude_mps2=5.0)
    for bad in (dict(pulse_kind="record"), dict(eta=0.0), dict(omega_rad_s=-1.0), dict(amplitude_mps2=0.0),
                dict(p_rad_s=float("inf")), dict(alpha_rad=2.0)):
        with pytest.raises(ConfigError):
            solve_batch(**{**ok, **bad})
    with pytest.raises(ConfigError):
        solve_batch(**ok, dt_s=0.05)
    with pytest.raises(ConfigError):
        solve_batch(**ok, mode="nope")


def test_eta_one_rocks_until_the_cap_in_to_rest_mode():
    # no energy loss: the block never settles, the run ends at t_max_s (and does not hang)
    a0 = 1.5 * G * math.tan(B3M.alpha_rad)
    sol = solve(B3M, SinePulse(a0, 6.0 * B3M.p_rad_s), 1.0, mode="to-rest", t_max_s=2.0)
    assert sol.outcome.value == "rocking"
    assert 2.0 <= sol.t_s[-1] < 2.0 + 2e-3 and sol.impacts.shape[0] > 5
    # energy after the pulse stays put at every impact
    after = sol.impacts[sol.impacts[:, 0] > sol.t_pulse_end_s]
    np.testing.assert_allclose(np.abs(after[:, 2]), abs(after[0, 2]), rtol=1e-6)
