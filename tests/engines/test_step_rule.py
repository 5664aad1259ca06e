"""The one time-step rule (engines/calibration/step_rule.py): the coarsest step of the ladder at which a calibrated
engine agrees with itself at the finest step, on a fake engine whose answers per step are known."""

from types import SimpleNamespace

import pytest

from rockbench.engines.calibration import step_rule
from rockbench.engines.contract import CellResult
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.reference_solver.restitution import housner_eta

B3M = get_preset("B3M").block()
ETA = housner_eta(B3M.alpha_rad)


class FakeEngine:
    """η and probe outcomes per step: ``etas[dt]``, ``flip[dt]`` (the probes that overturn there
    although the reference rocks), calls counted."""

    def __init__(self, etas, flip=None, reached=None):
        self.etas, self.flip, self.reached = etas, flip or {}, reached or {}
        self.calibrations: list = []

    def calibrate(self, block, eta, dt_s):
        self.calibrations.append(dt_s)
        return SimpleNamespace(eta_measured=self.etas[dt_s], reached=self.reached.get(dt_s, True))

    def run_many(self, cases):
        dt = cases[0].dt_s
        return [CellResult(outcome="overturn" if k in self.flip.get(dt, ()) else "rocking", valid=True)
                for k, _ in enumerate(cases)]


def _converged(eng):
    """The rule on the fake engine: its calibration of B3M to η_H at a step, its verdicts."""
    return step_rule.converged_step(lambda dt: eng.calibrate(B3M, ETA, dt), eng.run_many, B3M, ETA)


@pytest.fixture(autouse=True)
def few_probes(monkeypatch):
    monkeypatch.setattr(step_rule, "probe_cases", lambda block, eta: [("sine", 2.0, 1.5), ("sine", 3.0, 2.0)])


def test_the_coarsest_step_that_agrees_with_the_finest_is_kept():
    eng = FakeEngine({1e-3: ETA * 0.97, 5e-4: ETA, 2e-4: ETA * 1.002, 1e-4: ETA})
    dt, rec = _converged(eng)
    assert dt == 5e-4 and rec["converged"]
    assert [r["agrees"] for r in rec["compared"]] == [False, True]
    assert eng.calibrations == [1e-4, 1e-3, 5e-4]        # the yardstick first, each step calibrated once


def test_two_coarse_steps_that_agree_with_each_other_but_not_the_finest_do_not_count():
    eng = FakeEngine({dt: ETA for dt in step_rule.STEP_LADDER_S}, flip={1e-3: (0,), 5e-4: (0,)})
    dt, rec = _converged(eng)
    assert dt == 2e-4 and [r["agrees"] for r in rec["compared"]] == [False, False, True]


def test_a_probe_that_changes_outcome_keeps_the_finer_step():
    eng = FakeEngine({dt: ETA for dt in step_rule.STEP_LADDER_S}, flip={1e-3: (1,)})
    dt, rec = _converged(eng)
    assert dt == 5e-4 and rec["compared"][0]["probes_differ"] == ["sine ω/p 3 a 2: overturn valid vs rocking valid"]


def test_a_calibration_that_misses_its_target_never_agrees():
    eng = FakeEngine({dt: ETA for dt in step_rule.STEP_LADDER_S}, reached={1e-3: False})
    assert _converged(eng)[0] == 5e-4


def test_no_agreement_anywhere_keeps_the_finest_step_and_says_so():
    eng = FakeEngine({1e-3: 0.70, 5e-4: 0.72, 2e-4: 0.74, 1e-4: 0.76})
    dt, rec = _converged(eng)
    assert dt == step_rule.STEP_LADDER_S[-1] and not rec["converged"] and len(rec["compared"]) == 3


def test_a_finest_step_that_misses_the_target_is_no_yardstick():
    """Drake's case: calibrated at 1, 0.5 and 0.2 ms, not at 0.1 ms; the yardstick is 0.2 ms, and the
    coarsest step that agrees with it is kept, not the uncalibrated finest step."""
    eng = FakeEngine({dt: ETA for dt in step_rule.STEP_LADDER_S}, reached={1e-4: False})
    dt, rec = _converged(eng)
    assert dt == 1e-3 and rec["converged"] and rec["yardstick_dt_s"] == 2e-4
    assert [(r["dt_s"], r["finer_dt_s"]) for r in rec["compared"]] == [(1e-3, 2e-4)]


def test_no_step_that_reaches_the_target_keeps_the_finest_step_and_says_so():
    eng = FakeEngine({dt: ETA for dt in step_rule.STEP_LADDER_S}, reached={dt: False for dt in step_rule.STEP_LADDER_S})
    dt, rec = _converged(eng)
    assert dt == step_rule.STEP_LADDER_S[-1] and not rec["converged"] and rec["yardstick_dt_s"] is None
    assert rec["compared"] == []
