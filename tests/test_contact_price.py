"""The contact price without an engine: the rigid free-rocking quarter period against an
independent integration, the ramp, the price's one-line summary, suite variants with their own
restitution, and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.benchmark.suites.model import load_suite
from rockbench.benchmark.suites.plan import plan, variant_restitution, variant_settings
from rockbench.engines.calibration import price as P
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import G, Block


def _quarter_ivp(block: Block, frac: float) -> float:
    """Release at frac·α, nonlinear equation of motion (docs/physics.md §1), until θ = 0."""
    a, p = block.alpha_rad, block.p_rad_s

    def f(t, y):
        return [y[1], -p * p * math.sin(a - y[0])]

    def hit(t, y):
        return y[0]
    hit.terminal, hit.direction = True, -1
    sol = solve_ivp(f, (0.0, 5.0), [frac * a, 0.0], events=hit, rtol=1e-11, atol=1e-13)
    return float(sol.t_events[0][0])


@pytest.mark.parametrize("name", ["B3M", "B6M", "B3L", "B6L"])
@pytest.mark.parametrize("frac", [0.2, 0.5, 0.8])
def test_rigid_quarter_period_matches_an_independent_integration(name, frac):
    b = PRESETS[name].block()
    assert P.rigid_first_quarter_s(b, frac) == pytest.approx(_quarter_ivp(b, frac), rel=2e-5)


def test_rigid_quarter_period_domain_value():
    # docs/physics.md §7: B3M, θ0 = α/2, nonlinear full period 0.45947 s (four quarters)
    assert 4 * P.rigid_first_quarter_s(PRESETS["B3M"].block(), 0.5) == pytest.approx(0.45947, abs=2e-5)


def test_rigid_quarter_period_tends_to_the_linearised_one_for_slender_blocks():
    # linearised: T/4 = arcosh(1/(1 − θ0/α))/p; a slender block (α small) approaches it from above
    b = Block(0.01, 1.0)
    lin = math.acosh(2.0) / b.p_rad_s
    q = P.rigid_first_quarter_s(b, 0.5)
    assert q > lin and q == pytest.approx(lin, rel=1e-4)


def test_ramp_goes_through_the_threshold_slowly():
    b = PRESETS["B3M"].block()
    A = G * math.tan(b.alpha_rad)
    r = P.ramp_pulse(b)
    t = np.array([0.0, P.RAMP_LEAD_S, P.RAMP_LEAD_S + P.RAMP_S / 2, P.RAMP_LEAD_S + P.RAMP_S])
    assert np.allclose(r.accel(t) / A, [0.0, P.RAMP_FROM, 0.5 * (P.RAMP_FROM + P.RAMP_TO), P.RAMP_TO])
    # slow: the threshold band of ±2 % takes seconds to cross
    assert 0.04 * P.RAMP_S / (P.RAMP_TO - P.RAMP_FROM) >= 1.0


def test_price_line_says_within_or_not():
    price = {"uplift": {"ratio": 0.97, "within": False, "rocks_below": False},
             "anti_slip": {"n_slip": 1, "n_jump": 0, "cells": 27}, "period_change": -0.005, "steps_per_s": 1e5}
    line = P.price_line(price)
    assert "0.9700·g·tanα (NOT within 2 %)" in line and "1 slip / 0 jump in 27" in line and "-0.50 %" in line
    assert P.price_line(None) == "price: not measured"


def test_an_uplift_already_measured_is_not_measured_again(monkeypatch):
    def no_ramp(*args):
        raise AssertionError("the uplift ramp ran again")

    monkeypatch.setattr(P, "uplift_threshold", no_ramp)
    up = {"ratio": 1.004, "within": True, "rocks_below": False}
    price = P.contact_price(None, PRESETS["B3M"].block(), None, 1e-3, first_quarter_s=None, slip_cells=(), uplift=up)
    assert price["uplift"] is up and price["counts"] and price["anti_slip"] is None


def _suite(tmp_path, variants: str):
    p = tmp_path / "s.toml"
    p.write_text(f"""
[grid]
w_ratio = "2:4:3"
a_ratio = "2:4:3"
[cases]
blocks = ["B3M"]
pulses = ["sine"]
[reference]
restitutions = ["housner", "modified-average"]
[engines]
names = ["mujoco", "pybullet"]
variants = {variants}
""")
    return load_suite(str(p))


def test_a_variant_with_its_own_restitution_runs_against_it(tmp_path):
    s = _suite(tmp_path, '[{ settings = "calibrated" }, { contact = "distributed", restitution = "modified-average", '
                         'engines = ["mujoco"] }]')
    v = s.engines.variants[1]
    assert variant_settings(v) == {"contact": "distributed"}
    assert variant_restitution(s, v) == "modified-average"
    jobs = [j for j in plan(s, ["mujoco", "pybullet"]) if j.engine != "reference"]
    # pybullet: one variant only (the other names its engines); mujoco: both
    assert sorted((j.engine, j.restitution.label) for j in jobs) == [
        ("mujoco", "housner"), ("mujoco", "modified(k=0.8608)"), ("pybullet", "housner")]
    for j in jobs:
        assert "restitution" not in j.settings and "engines" not in j.settings


@pytest.mark.parametrize("variants,words", [
    ('[{ restitution = "modfied-average" }]', "engines.variants[0].restitution"),
    ('[{ restitution = true }]', "engines.variants[0].restitution must be a text or a number"),
    ('[{ engines = "mujoco" }]', "engines.variants[0].engines must be a non-empty list"),
])
def test_bad_variant_keys_are_one_line(tmp_path, variants, words):
    with pytest.raises(ConfigError) as e:
        _suite(tmp_path, variants)
    assert words in str(e.value) and "\n" not in str(e.value)
