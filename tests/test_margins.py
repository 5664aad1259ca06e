"""The fail limit and the held-out margin as rules on the run's η_H–η_M reference gaps
(rockbench.benchmark.scoring.declared: fail_limit, held_out_margin_of), on hand-built values."""

import math

import pytest

from rockbench.benchmark.scoring.declared import (DEFAULTS, HALF_GAP, LARGEST_GAP, Declared, fail_limit,
                                                  held_out_margin_of)
from rockbench.benchmark.scoring.equivalence import held_out_check
from rockbench.benchmark.scoring.scenarios import Scenario, Variant
from rockbench.benchmark.scoring.verdict import verdict
from rockbench.benchmark.report.verdict_words import sentences
from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.scoring.declared import check_fail_distance, check_held_out_margin

GAPS = {("B2M", "sine"): 0.10, ("B3M", "sine"): 0.165, ("B6M", "cosine"): 0.061, ("B8M", "cosine"): 0.039}


def test_the_default_declarations_are_the_rules():
    assert DEFAULTS.fail_distance == LARGEST_GAP and DEFAULTS.held_out_margin == HALF_GAP


def test_the_fail_limit_is_the_largest_gap_and_names_its_scenario():
    lim = fail_limit(DEFAULTS, GAPS)
    assert lim == {"value": 0.165, "rule": LARGEST_GAP, "from": {"block": "B3M", "pulse": "sine", "gap": 0.165}}


def test_a_run_without_gaps_has_no_fail_limit_and_a_number_is_its_own():
    assert fail_limit(DEFAULTS, {})["value"] is None
    assert fail_limit(DEFAULTS, {("B3M", "sine"): math.nan, ("B6M", "sine"): 0.0})["value"] is None
    assert fail_limit(Declared(fail_distance=0.3), GAPS) == {"value": 0.3, "rule": None, "from": None}


def test_the_held_out_margin_is_half_the_mean_gap_over_problems():
    """Two sizes of one problem count once: (0.04 + 0.06)/2 = 0.05 for one problem, 0.03 for the other,
    mean 0.04, half 0.02."""
    gaps = [(0.04, (4.5, "sine")), (0.06, (4.5, "sine")), (0.03, (6.0, "sine"))]
    assert held_out_margin_of(DEFAULTS, gaps) == pytest.approx(0.02)
    assert held_out_margin_of(DEFAULTS, [(math.nan, (4.5, "sine"))]) is None
    assert held_out_margin_of(Declared(held_out_margin=0.05), gaps) == 0.05


@pytest.mark.parametrize("check, rule", [(check_fail_distance, LARGEST_GAP), (check_held_out_margin, HALF_GAP)])
def test_a_rule_or_a_positive_number(check, rule):
    assert check(rule.upper()) == rule and check(0.2) == 0.2
    for bad in (0, -1, "gap", True):
        with pytest.raises(ConfigError, match=f'must be "{rule}" or a number > 0'):
            check(bad)


def _variant(name, values, gaps, sd=0.002, held=False):
    sc = {k: Scenario(v, sd, 0.36, (hb, k[1]), held_out=held, gap=gaps[k])
          for k, v, hb in zip(gaps, values, (1.5, 2.25, 4.5, 6.0))}
    return Variant(name, "e", name, "calibrated", sc)


def test_carries_over_needs_the_interval_inside_the_derived_margin():
    """Twin and held-out differ by 0.015 in two scenarios whose gaps are 0.061 and 0.039: the margin is
    half their mean, 0.025; with a small error the 90 % interval lies inside it (carries over), with a
    large one it does not (not shown), and a declared 0.05 would have passed both."""
    gaps = {("B6M", "cosine"): 0.061, ("B8M", "cosine"): 0.039}
    twin = _variant("own", [0.02, 0.02], gaps)
    for sd, expected in ((0.002, True), (0.012, False)):
        held = _variant("held", [0.035, 0.035], gaps, sd=sd, held=True)
        h = held_out_check(held, twin, DEFAULTS)
        assert h["margin"] == pytest.approx(0.025) and h["margin_rule"] == HALF_GAP
        assert h["difference"] == pytest.approx(0.015) and h["carries_over"] is expected
        assert held_out_check(held, twin, Declared(held_out_margin=0.05))["carries_over"]


def test_no_gap_no_held_out_test():
    gaps = {("B6M", "cosine"): math.nan, ("B8M", "cosine"): math.nan}
    h = held_out_check(_variant("held", [0.03, 0.03], gaps, held=True), _variant("own", [0.02, 0.02], gaps), DEFAULTS)
    assert h["margin"] is None and h["tost"] is None and not h["carries_over"] and h["in_sample"] == pytest.approx(0.02)


def _pair(variant, block, pulse, bm, settings="calibrated"):
    return {"variant": variant, "engine": variant, "label": variant, "settings": settings, "block": block,
            "pulse": pulse, "like_for_like": True, "scores": {"boundary_mean": bm},
            "cells": {"w_step": 0.3, "a_step": 0.2, "boundary_edges": 100}, "cells_in_domain": 2000}


def test_the_verdict_fails_by_the_largest_gap_and_says_where_it_comes_from():
    """A scenario 0.15 off passes under a largest gap of 0.165 and fails when the largest gap is 0.10; the
    limit, its rule and its scenario are in score.json's verdict and its words."""
    pairs = [_pair("m", b, p, 0.15 if (b, p) == ("B2M", "sine") else 0.01) for b, p in GAPS]
    pairs += [_pair("q", b, p, 0.01) for b, p in GAPS]
    gaps = [{"block": b, "pulse": p, "boundary_mean": g} for (b, p), g in GAPS.items()]
    v = verdict({"pairs": pairs, "reference_gaps": gaps})
    assert v["fail_distance"] == 0.165 and v["fail_limit"]["from"]["block"] == "B3M"
    assert not any(r["fails"] for r in v["variants"])
    small = [dict(g, boundary_mean=min(g["boundary_mean"], 0.08 if g["block"] == "B3M" else 0.10)) for g in gaps]
    v = verdict({"pairs": pairs, "reference_gaps": small})
    assert v["fail_distance"] == 0.10 and next(r for r in v["variants"] if r["variant"] == "m")["fails"]
    assert ("Fail (boundary farther than 0.100, the largest η_H–η_M reference gap of the run's scenarios "
            "(B2M sine), from the reference's") in " ".join(sentences(v))
