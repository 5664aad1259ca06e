"""A contact engine with a planted restitution error (``planted_eta_factor`` = 1 + δ): calibrated to
η × (1 + δ) with the contact layout and time step of its unplanted calibration, the target in the
calibration's cache key (docs/scores.md, "The suite's power against an engine's own restitution error").
Nothing here simulates: the calibration and the time-step rule are replaced by recorders."""

from __future__ import annotations

import pytest

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines import contact
from rockbench.engines.calibration import planted, routine, time_step
from rockbench.engines.calibration.layout import contact_layout
from rockbench.engines.contract import CalibrationResult
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.restitution import Restitution, housner_eta


@pytest.fixture
def b6m():
    return get_preset("B6M").block()


def test_the_calibration_aims_at_eta_times_the_factor_and_the_layout_stays(b6m):
    eta = housner_eta(b6m.alpha_rad)
    plain, high, low = (get_adapter("mujoco", **kw) for kw in ({}, {"planted_eta_factor": 1.02},
                                                               {"planted_eta_factor": 0.98}))
    assert planted.calibration_target(plain, b6m, Restitution()) == (b6m, eta)
    assert planted.calibration_target(high, b6m, Restitution())[1] == pytest.approx(1.02 * eta, rel=1e-15)
    assert planted.calibration_target(low, b6m, Restitution())[1] == pytest.approx(0.98 * eta, rel=1e-15)
    # 2 % above η_H would be a row along the base for the unplanted engine; a planted error keeps the corners
    assert contact_layout(plain, b6m, 1.02 * eta) == "distributed"
    assert contact_layout(high, b6m, 1.02 * eta) == contact_layout(low, b6m, 0.98 * eta) == "corners"


def test_the_cache_key_holds_the_target_and_not_the_factor(b6m):
    eta = housner_eta(b6m.alpha_rad)
    plain, high = get_adapter("mujoco"), get_adapter("mujoco", planted_eta_factor=1.01)
    key = routine.cache_key(plain, b6m, eta, 5e-4, "corners")
    assert routine.cache_key(high, b6m, eta, 5e-4, "corners") == key          # the factor is no identity of its own
    assert routine.cache_key(high, b6m, 1.01 * eta, 5e-4, "corners") != key   # the target it moves is


def test_resolve_calibrates_to_the_planted_target_at_the_unplanted_step(b6m, monkeypatch):
    eta = housner_eta(b6m.alpha_rad)
    steps, targets = [], []
    monkeypatch.setattr(time_step.step_rule, "converged_step", lambda cal, judged, block, e: steps.append(e) or
                        (None, {"dt_s": 4e-4}))
    monkeypatch.setattr(time_step.cache, "load", lambda key: None)
    monkeypatch.setattr(time_step.cache, "store", lambda key, rec, engine: None)

    def calibrate(ad, block, target, *, dt_s=None, use_cache=True):
        targets.append((target, dt_s, planted.factor(ad)))
        return CalibrationResult(eta_target=target, eta_measured=target, eta_std=0.0, reached=True,
                                 settings={"timeconst_s": 2e-3, "dampratio": 1.0}, note="recorded")
    monkeypatch.setattr(contact.routine, "calibrate", calibrate)
    out = get_adapter("mujoco", planted_eta_factor=1.01).resolve(b6m, Restitution())
    assert steps == [pytest.approx(eta, rel=1e-14)]                  # the step rule at η_H, as the unplanted engine's
    assert targets == [(pytest.approx(1.01 * eta, rel=1e-15), 4e-4, 1.01)]
    assert out["calibration"]["eta_target"] == pytest.approx(1.01 * eta, rel=1e-15)
    assert out["planted_eta_factor"] == 1.01


@pytest.mark.parametrize("settings, words", [
    ({"planted_eta_factor": 1.6}, "must be in [0.5, 1.5] (the calibration aims at η × it), got 1.6"),
    ({"planted_eta_factor": 0.4}, "must be in [0.5, 1.5]"),
    ({"planted_eta_factor": "x"}, "planted_eta_factor"),
    ({"planted_eta_factor": 1.01, "settings": "shipped"}, "needs settings = calibrated"),
])
def test_a_bad_planted_factor_is_one_line(settings, words):
    with pytest.raises(ConfigError) as e:
        get_adapter("mujoco", **settings)
    assert words in str(e.value) and "\n" not in str(e.value)
