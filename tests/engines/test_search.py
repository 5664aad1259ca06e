"""The one bisection of the calibration searches (engines/search.py and Search.bisect /
Search.scan_bisect), on fake η(knob) curves: no engine runs."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from rockbench.engines.search import BISECT_RTOL, bisection, bracket
from rockbench.engines.skeleton import Search


def _search(eta_of, target, std=0.001):
    """A Search whose free-rocking test is ``eta_of(knob)`` (the candidate's only setting)."""
    return Search(lambda extra: SimpleNamespace(eta_mean=eta_of(extra["knob"]), eta_std=std, etas=[0.0] * 4), target)


def _knob(x):
    return {"knob": x}


def _knobs(search):
    return [extra["knob"] for _, _, extra in search.tried]


def test_a_monotone_eta_is_halved_towards_the_target_until_within_the_tolerance():
    """η = 0.5 + 0.4·x on [0, 1], target 0.7123 (x = 0.53075): each midpoint halves the range on the
    side that keeps the target inside, and the first midpoint within 0.25 % ends the bisection."""
    t = 0.7123
    search = _search(lambda x: 0.5 + 0.4 * x, t)
    search.bisect(_knob, 0.0, 1.0, 12, eta_lo=-math.inf)
    assert _knobs(search) == [0.5, 0.75, 0.625, 0.5625, 0.53125]
    assert search.err(search.tried[-1][0]) <= BISECT_RTOL < search.err(search.tried[-2][0])
    eta, _, extra, reached = search.best()
    assert reached and extra == {"knob": 0.53125} and eta == pytest.approx(t, rel=BISECT_RTOL)


@pytest.mark.parametrize("eta_lo", [-math.inf, 0.5])
def test_the_direction_comes_from_eta_at_the_low_end(eta_lo):
    """A rising η: -inf (known direction) or the measured η at lo give the same halvings."""
    search = _search(lambda x: 0.5 + 0.4 * x, 0.81)
    search.bisect(_knob, 0.0, 1.0, 4, eta_lo=eta_lo, tol=0.0)
    assert _knobs(search) == [0.5, 0.75, 0.875, 0.8125]


def test_a_falling_eta_moves_the_other_way_and_steps_bound_the_evaluations():
    """η = 0.9 − 0.4·x (η falls with the knob: eta_lo = +inf), target 0.61 (x = 0.725) within tol 0:
    exactly ``steps`` midpoints, converging on the knob that gives it."""
    search = _search(lambda x: 0.9 - 0.4 * x, 0.61)
    search.bisect(_knob, 0.0, 1.0, 6, eta_lo=math.inf, tol=0.0)
    xs = _knobs(search)
    assert len(xs) == 6 and xs[:3] == [0.5, 0.75, 0.625]
    assert abs(xs[-1] - 0.725) <= 2.0 ** -6


@pytest.mark.parametrize("nonfinite_low, second", [(False, 0.25), (True, 0.75)])
def test_a_nonfinite_eta_counts_on_the_side_the_caller_names(nonfinite_low, second):
    """A NaN at the first midpoint: the next midpoint is below it (default) or above it."""
    search = _search(lambda x: math.nan if x == 0.5 else 0.5 + 0.4 * x, 0.9)
    search.bisect(_knob, 0.0, 1.0, 2, eta_lo=-math.inf, nonfinite_low=nonfinite_low)
    assert _knobs(search) == [0.5, second]


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


def test_scan_bisect_scans_every_knob_then_bisects_between_the_bracketing_neighbours():
    """A non-monotone scan: the first bracketing pair (0.46, 0.5) is refined, the later ones are not."""
    def eta(x):
        return 0.9 - abs(x - 0.52) * 5.0 if x < 0.6 else 0.7 + x / 10

    t = 0.71
    search = _search(eta, t)
    grid = [0.42, 0.46, 0.5, 0.54, 0.58, 0.62, 0.66]
    search.scan_bisect(_knob, grid, 5)
    xs = _knobs(search)
    assert xs[:len(grid)] == grid
    # η(0.46) = 0.6 < t < η(0.5) = 0.8: the bisection starts at their midpoint
    assert xs[len(grid)] == pytest.approx(0.48) and 1 <= len(xs) - len(grid) <= 5
    assert all(0.46 < x < 0.5 for x in xs[len(grid):])


def test_scan_bisect_without_a_bracket_only_scans():
    search = _search(lambda x: 0.5 + 0.1 * x, 0.9)
    search.scan_bisect(_knob, [0.0, 0.5, 1.0], 5)
    assert _knobs(search) == [0.0, 0.5, 1.0]


def test_result_records_the_pick_with_every_contact_key_and_all_evaluations():
    """Search.result: the closest consistent setting, the contact keys it does not set None."""
    search = _search(lambda x: 0.5 + 0.4 * x, 0.7123)
    search.bisect(_knob, 0.0, 1.0, 12, eta_lo=-math.inf)
    res = search.result(("stiffness", "knob"), "a note")
    assert res.settings == {"stiffness": None, "knob": 0.53125} and list(res.settings) == ["stiffness", "knob"]
    assert res.evaluations == 5 and res.reached and res.note == "a note"
    assert res.eta_target == 0.7123 and res.eta_measured == search.tried[-1][0] and res.eta_std == 0.001
