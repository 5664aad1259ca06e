"""The boundary metrics on hand-made located boundaries: straight boundaries bisected to a known
tolerance, shifted by a known distance."""

import math

import numpy as np
import pytest

from rockbench.benchmark.maps.bisection import ALONG_A, ALONG_W, regime_of
from rockbench.benchmark.maps.boundary import locate
from rockbench.benchmark.maps.result import MapResult
from rockbench.benchmark.scoring.metrics import (OVERTURN, ROCKING, boundary_distance, critical_amplitude,
                                               is_perfect, judged_crossings, score)

W = A = np.linspace(0.0, 10.0, 21)   # steps of 0.5
DEPTH = 12                           # a step over 4096: far below the shifts tested


def straight(c0: float, slope: float, valid=None) -> MapResult:
    """A map overturning above a = c0 + slope·w, its boundary located by bisecting the exact line."""
    def over(w, a):
        return a >= c0 + slope * w

    outcome = np.where(over(W[None, :], A[:, None]), OVERTURN, ROCKING)
    m = MapResult.from_outcomes(W, A, outcome, valid=valid)
    regime = regime_of(outcome, np.zeros(outcome.shape, int))

    def sample(i, j, axis, t):
        w = W[j] + t * (W[1] - W[0]) * (axis == ALONG_W)
        a = A[i] + t * (A[1] - A[0]) * (axis == ALONG_A)
        return np.where(over(w, a), 1, 0)

    valid_cells = np.ones(outcome.shape, bool) if valid is None else np.asarray(valid, bool)
    m.located = locate(regime, W, A, DEPTH, sample, lambda i, j, axis, t: np.where(
        t <= 0, valid_cells[i, j], np.where(t >= 1, valid_cells[i + (axis == ALONG_A), j + (axis == ALONG_W)], True)))
    return m


def test_a_boundary_shifted_by_delta_gives_delta():
    delta = 0.137   # a quarter of a step, not a whole one: the cells alone would say 0 or 0.5
    mean, mx = boundary_distance(straight(4.3 + delta, 0.0), straight(4.3, 0.0))
    assert mean == pytest.approx(delta, abs=1e-3) and mx == pytest.approx(delta, abs=1e-3)


def test_a_slanted_boundary_shifted_by_delta_gives_delta_cos_not_the_offset_along_the_grid():
    """Two parallel lines a = 2 + 0.6 w and δ above it lie δ·cos(atan 0.6) apart; the crossings of
    both lie on the same grid lines, so point to point they would read the vertical offset δ (on the
    columns) or δ/0.6 (on the rows). Only the two crossings at the lines' ends, whose feet fall past
    the other line's end, read δ."""
    delta = 0.2
    mean, mx = boundary_distance(straight(2.0 + delta, 0.6), straight(2.0, 0.6))
    want = delta * math.cos(math.atan(0.6))
    assert mean == pytest.approx(want, rel=0.02)
    assert abs(mean - delta) > 0.1 * delta
    assert mx == pytest.approx(delta, abs=1e-3)


@pytest.mark.parametrize("delta", [0.137, -0.137])
def test_a_boundary_shifted_by_delta_gives_that_signed_offset(delta):
    """An engine boundary δ below the reference's (it overturns at a lower amplitude: less stable) gives
    boundary_offset +δ, one above gives −δ; as a share of the reference's critical amplitude 4.3,
    100·δ/4.3 %. The distance is |δ| either way."""
    s = score(straight(4.3 - delta, 0.0), straight(4.3, 0.0))
    assert s["boundary_offset"] == pytest.approx(delta, abs=1e-3)
    assert s["boundary_offset_percent"] == pytest.approx(100 * delta / 4.3, abs=0.03)
    assert s["boundary_mean"] == pytest.approx(abs(delta), abs=1e-3)


def test_a_slanted_boundary_shifted_gives_its_normal_offset_with_its_sign():
    delta = 0.2
    s = score(straight(2.0 - delta, 0.6), straight(2.0, 0.6))
    assert s["boundary_offset"] == pytest.approx(s["boundary_mean"], rel=1e-12)
    assert s["boundary_offset"] == pytest.approx(delta * math.cos(math.atan(0.6)), rel=0.02)
    assert score(straight(2.0 + delta, 0.6), straight(2.0, 0.6))["boundary_offset"] < 0


def test_the_offset_is_nan_without_a_boundary_and_judged_by_its_size():
    from rockbench.benchmark.scoring.metrics import METRICS, check_gate
    none = MapResult.from_outcomes(W, A, np.full((A.size, W.size), ROCKING))
    assert math.isnan(score(none, straight(4.3, 0.0))["boundary_offset"])
    m = METRICS["boundary_offset"]
    assert m.worse(-0.05, 0.01) and not m.worse(-0.01, 0.02, tol=0.0)
    assert check_gate({"boundary_offset": -0.2}, {"boundary_offset": 0.1})


def test_the_location_error_is_measured_from_the_bisection_intervals():
    """Each crossing lies uniformly in its last interval (a step over 2**depth): the pair's error is
    √(w_e²/12 + w_r²/12), at depth 12 a step/4096 over √6, at depth 0 (edge midpoints) a step over √6."""
    from rockbench.benchmark.scoring.metrics import location_sd, located_counts
    step = 0.5
    a, b = straight(4.3, 0.0), straight(4.4, 0.0)
    assert location_sd(a, b) == pytest.approx(step / 2 ** DEPTH / math.sqrt(6))
    cells_a, cells_b = MapResult.from_outcomes(W, A, a.outcome), MapResult.from_outcomes(W, A, b.outcome)
    assert located_counts(cells_a, cells_b)["location_sd"] == pytest.approx(step / math.sqrt(6))
    none = MapResult.from_outcomes(W, A, np.full((A.size, W.size), ROCKING))
    assert located_counts(none, b)["location_sd"] is None


def test_symmetric_and_perfect_against_itself():
    a, b = straight(2.0, 0.6), straight(2.3, 0.45)
    assert boundary_distance(a, b) == pytest.approx(boundary_distance(b, a), rel=1e-12)
    assert is_perfect(score(a, a)) and score(a, a)["boundary_mean"] == 0.0


def test_critical_amplitude_is_the_located_crossing():
    m = straight(4.3, 0.0)
    np.testing.assert_allclose(critical_amplitude(m), 4.3, atol=0.5 * 0.5 / 2 ** DEPTH)
    s = score(straight(4.5, 0.0), m)
    assert s["critical_error_mean"] == pytest.approx(0.2, abs=1e-3)


def test_domain_counts_a_crossing_where_the_reference_is_valid_at_the_boundary():
    """Reference cells invalid above the line (an overturn that needs lift-off) but its runs valid right
    at the boundary: the cells alone would judge no crossing; the located domain judges them all."""
    valid = A[:, None] < 4.3 + 0 * W[None, :]
    ref = straight(4.3, 0.0, valid=valid)
    ref.located.valid[:] = True      # its bisection's last samples on both sides are valid
    eng = straight(4.4, 0.0)
    ce, cr = judged_crossings(eng, ref)
    assert cr.all() and ce.all()
    ref.located.valid[:] = False     # invalid right above the boundary too: nothing is judged
    ce, cr = judged_crossings(eng, ref)
    assert not cr.any() and not ce.any()


def test_resolution_error_by_locate_depth():
    """A scenario's own error is the measured share of its cell diagonal at its pair's bisection depth:
    0.1 known to the cell (depth 0, and the unmeasured 1–3), 0.01 located at depth 4 and more."""
    from rockbench.benchmark.scoring.scenarios import resolution_sd, scenario_of

    assert resolution_sd(0.372) == pytest.approx(0.0372) and resolution_sd(0.372, 3) == pytest.approx(0.0372)
    assert resolution_sd(0.372, 4) == pytest.approx(0.00372) and resolution_sd(0.372, 9) == pytest.approx(0.00372)
    pair = {"block": "B3M", "pulse": "sine", "scores": {"boundary_mean": 0.01},
            "cells": {"w_step": 0.3, "a_step": 0.22, "locate_depth": 5}}
    assert scenario_of(pair).sd == pytest.approx(0.01 * math.hypot(0.3, 0.22))
