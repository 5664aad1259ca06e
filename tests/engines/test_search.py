"""The one bisection of the calibration searches (engines/calibration/search.py), alone and as the search of a
declared knob runs it after its ladder, on fake η(knob) curves: no engine runs."""

from __future__ import annotations

import math

import pytest

from rockbench.engines.calibration.knobs import Knob, search
from rockbench.engines.calibration.search import BISECT_RTOL, bisection, bracket
from rockbench.benchmark.blocks.presets import get_preset

BLOCK = get_preset("B3M").block()


def _bisect(eta_of, target, lo, hi, steps, *, eta_lo, tol=BISECT_RTOL, nonfinite_low=False):
    """The knob values :func:`bisection` measures on ``eta_of(knob)``, in order."""
    seen = []

    def measure(x):
        seen.append(x)
        return eta_of(x)

    bisection(measure, lo, hi, steps, target=target, eta_lo=eta_lo, done=lambda e: abs(e - target) <= tol * target,
              nonfinite_low=nonfinite_low)
    return seen


def _scanned(eta_of, target, ladder, steps):
    """The knob values the search of one declared knob measures: its ladder, then the bisection
    between the first neighbours that bracket the target (every finite η counts)."""
    knob = Knob("knob", "", values=lambda b, dt: tuple(ladder), bisect_steps=steps, bisect_regular=False)
    rows = search((knob,), BLOCK, target, 1e-3, lambda cands: [{**c, "eta": eta_of(c["knob"]), "eta_std": 0.001,
                                                               "n": 4} for c in cands])
    return [r["knob"] for r in rows]


def test_a_monotone_eta_is_halved_towards_the_target_until_within_the_tolerance():
    """η = 0.5 + 0.4·x on [0, 1], target 0.7123 (x = 0.53075): each midpoint halves the range on the
    side that keeps the target inside, and the first midpoint within 0.25 % ends the bisection."""
    t = 0.7123
    xs = _bisect(lambda x: 0.5 + 0.4 * x, t, 0.0, 1.0, 12, eta_lo=-math.inf)
    assert xs == [0.5, 0.75, 0.625, 0.5625, 0.53125]
    err = [abs(0.5 + 0.4 * x - t) / t for x in xs[-2:]]
    assert err[1] <= BISECT_RTOL < err[0]


@pytest.mark.parametrize("eta_lo", [-math.inf, 0.5])
def test_the_direction_comes_from_eta_at_the_low_end(eta_lo):
    """A rising η: -inf (known direction) or the measured η at lo give the same halvings."""
    assert _bisect(lambda x: 0.5 + 0.4 * x, 0.81, 0.0, 1.0, 4, eta_lo=eta_lo, tol=0.0) == [0.5, 0.75, 0.875, 0.8125]


def test_a_falling_eta_moves_the_other_way_and_steps_bound_the_evaluations():
    """η = 0.9 − 0.4·x (η falls with the knob: eta_lo = +inf), target 0.61 (x = 0.725) within tol 0:
    exactly ``steps`` midpoints, converging on the knob that gives it."""
    xs = _bisect(lambda x: 0.9 - 0.4 * x, 0.61, 0.0, 1.0, 6, eta_lo=math.inf, tol=0.0)
    assert len(xs) == 6 and xs[:3] == [0.5, 0.75, 0.625]
    assert abs(xs[-1] - 0.725) <= 2.0 ** -6


@pytest.mark.parametrize("nonfinite_low, second", [(False, 0.25), (True, 0.75)])
def test_a_nonfinite_eta_counts_on_the_side_the_caller_names(nonfinite_low, second):
    """A NaN at the first midpoint: the next midpoint is below it (default) or above it."""
    assert _bisect(lambda x: math.nan if x == 0.5 else 0.5 + 0.4 * x, 0.9, 0.0, 1.0, 2, eta_lo=-math.inf,
                   nonfinite_low=nonfinite_low) == [0.5, second]


def test_an_unusable_midpoint_ends_the_bisection():
    """``measure`` returning None (Exudyn: an irregular free rocking) stops at once."""
    seen = []

    def measure(x):
        seen.append(x)
        return None if len(seen) == 2 else 0.5 + 0.4 * x

    bisection(measure, 0.0, 1.0, 10, target=0.8, eta_lo=0.5, done=lambda e: False)
    assert seen == [0.5, 0.75]


def test_bracket_takes_the_first_strict_pair_of_finite_neighbours():
    t = 0.7
    assert bracket([(0, 0.6), (1, 0.65), (2, 0.75), (3, 0.6)], t) == (1, 0.65, 2)
    assert bracket([(0, 0.6), (1, math.nan), (2, 0.75)], t) is None  # a NaN between breaks the pair
    assert bracket([(0, 0.6), (1, math.inf)], t) is None
    assert bracket([(0, 0.7), (1, 0.75)], t) is None  # touching is not bracketing
    assert bracket([(0, 0.75)], t) is None


def test_a_ladder_is_scanned_then_bisected_between_the_first_bracketing_neighbours():
    """A non-monotone scan: the first bracketing pair (0.46, 0.5) is refined, the later ones are not."""
    def eta(x):
        return 0.9 - abs(x - 0.52) * 5.0 if x < 0.6 else 0.7 + x / 10

    t = 0.71
    grid = [0.42, 0.46, 0.5, 0.54, 0.58, 0.62, 0.66]
    xs = _scanned(eta, t, grid, 5)
    assert xs[:len(grid)] == grid
    # η(0.46) = 0.6 < t < η(0.5) = 0.8: the bisection starts at their midpoint
    assert xs[len(grid)] == pytest.approx(0.48) and 1 <= len(xs) - len(grid) <= 5
    assert all(0.46 < x < 0.5 for x in xs[len(grid):])


def test_a_ladder_without_a_bracket_is_only_scanned():
    assert _scanned(lambda x: 0.5 + 0.1 * x, 0.9, [0.0, 0.5, 1.0], 5) == [0.0, 0.5, 1.0]
