"""The verdict: one primary measure with its 95 % interval, ties, failing variants, and the rules that
make it citable (docs/scores.md, "The verdict")."""

import json
import math

import numpy as np
import pytest

from rockbench.harness.scoring.metrics import METRICS, PRIMARY_METRIC
from rockbench.harness.scoring.tables import best_group_marks, ranked_summary, summary_table
from rockbench.harness.scoring.verdict import (AS_SHIPPED, CALIBRATED, Scenario, Variant, mean_interval, paired,
                                               rank, settings_class, variant_interval, verdict)
from test_score_runs import run_cli

SCENARIOS = [(b, p) for b in ("B3M", "B6M", "B3L", "B6L") for p in ("sine", "cosine")]


def _pair(variant, block, pulse, bm, *, agreement=0.97, settings=CALIBRATED, edges=100, **counts):
    scores = {m: METRICS[m].perfect for m in METRICS}
    scores.update(boundary_mean=bm, agreement=agreement)
    return {"variant": variant, "engine": variant.split("[")[0], "label": variant, "settings": settings,
            "block": block, "pulse": pulse, "like_for_like": True, "scores": scores,
            "cells": {"w_step": 0.3, "a_step": 0.2, "boundary_edges": edges},
            "cells_in_domain": 2000, "reference_standing": 1500, "reference_overturn": 500, **counts}


def _doc(values: dict, **kw) -> dict:
    """A score document with one like-for-like pair per scenario and variant, from ``{variant: [bm...]}``."""
    pairs = []
    for v, bms in values.items():
        extra = kw.get(v, {})
        pairs += [_pair(v, b, p, bm, **extra) for (b, p), bm in zip(SCENARIOS, bms)]
    return {"pairs": pairs}


def _variant(name, values, cell=0.36, unit=0.0036):
    return Variant(name, name, name, CALIBRATED, {s: Scenario(v, unit, cell) for s, v in zip(SCENARIOS, values)})


# -- intervals -----------------------------------------------------------------------------------------

def test_interval_is_students_t_over_scenarios():
    vals = [0.01, 0.03, 0.02, 0.04]
    mean, half, basis = mean_interval(vals, [1e-6] * 4, [0.3] * 4)
    sd = np.std(vals, ddof=1)
    assert mean == pytest.approx(0.025)
    assert half == pytest.approx(3.182446305284263 * sd / 2)   # t(0.975, 3)
    assert "Student's t over 4 scenarios" in basis


def test_interval_never_collapses_to_a_point():
    """Equal values (a perfect engine everywhere) give the grid's width, not a zero-width interval."""
    _, half, basis = mean_interval([0.0] * 8, [0.004] * 8, [0.3] * 8)
    assert half > 0 and "floored" in basis
    _, half1, basis1 = mean_interval([0.0], [0.004], [0.3])
    assert half1 == pytest.approx(0.15) and "one scenario" in basis1


def test_interval_is_clipped_at_the_perfect_value():
    v = _variant("x", [0.0, 0.0, 0.5, 0.0])
    value, lo, hi, _ = variant_interval(v)
    assert lo == 0.0 and hi > value > 0


# -- ties ----------------------------------------------------------------------------------------------

def test_two_identical_maps_tie():
    a, b = _variant("a", [0.02, 0.05, 0.01, 0.03]), _variant("b", [0.02, 0.05, 0.01, 0.03])
    assert not paired(a, b)["resolved"] and paired(a, b)["ratio"] == pytest.approx(1.0)
    assert rank([a, b]) == {"a": 1, "b": 1}


def test_a_boundary_shifted_by_several_cells_in_every_scenario_does_not_tie():
    cell = 0.36
    a = _variant("a", [0.02, 0.05, 0.01, 0.03, 0.02, 0.04, 0.01, 0.02])
    b = _variant("b", [x + 3 * cell for x in [0.02, 0.05, 0.01, 0.03, 0.02, 0.04, 0.01, 0.02]])
    res = paired(b, a)
    assert res["resolved"] and res["ratio"] > 10 and res["ci95"][0] > 1
    assert rank([a, b]) == {"a": 1, "b": 2}


def test_noise_sized_differences_tie_and_ranks_follow_the_group_leader():
    a = _variant("a", [0.010, 0.030, 0.020, 0.040])
    b = _variant("b", [0.030, 0.010, 0.040, 0.020])   # same values, other scenarios: not resolved
    c = _variant("c", [2.0, 2.5, 1.5, 3.0])
    assert rank([c, b, a]) == {"a": 1, "b": 1, "c": 3}


def test_one_shared_scenario_is_resolved_only_beyond_half_a_cell():
    a, b = _variant("a", [0.01]), _variant("b", [0.10])
    assert not paired(a, b)["resolved"]
    assert paired(a, _variant("c", [0.5]))["resolved"]


def test_variants_without_a_shared_scenario_are_not_resolved():
    a = Variant("a", "a", "a", CALIBRATED, {("B3M", "sine"): Scenario(0.01, 0.001, 0.3)})
    b = Variant("b", "b", "b", CALIBRATED, {("B6M", "sine"): Scenario(5.0, 0.001, 0.3)})
    assert paired(a, b) == {"other": "b", "scenarios": 0, "ratio": None, "ci95": None, "resolved": False}


# -- the verdict of a score document --------------------------------------------------------------------

def test_primary_order_wins_over_agreement_order():
    """Agreement ranks x first (0.977 against 0.971), the boundary ranks y first by far: the summary,
    the ranks and the highlights follow the boundary."""
    doc = _doc({"x[settings=calibrated]": [0.05, 0.04, 0.06, 0.05, 0.04, 0.05, 0.06, 0.04],
                "y[settings=calibrated]": [0.005, 0.008, 0.006, 0.01, 0.007, 0.009, 0.008, 0.006]},
               **{"x[settings=calibrated]": {"agreement": 0.977}, "y[settings=calibrated]": {"agreement": 0.971}})
    v = verdict(doc)
    assert [r["variant"] for r in v["variants"]] == ["y[settings=calibrated]", "x[settings=calibrated]"]
    assert [r["rank"] for r in v["variants"]] == [1, 2]
    ranked = ranked_summary(doc)
    marks = best_group_marks(ranked)
    assert marks[PRIMARY_METRIC] == [True, False]
    assert "agreement" not in marks          # a lone best group highlights its primary value only
    table = summary_table(doc)
    assert table.index("y[settings=calibrated]") < table.index("x[settings=calibrated]")
    assert "Best achievable" in v["text"][0] and "y[settings=calibrated]" in v["text"][0]


def test_a_secondary_metric_is_highlighted_only_inside_the_best_group():
    """z fails (its boundary is far off) but has the best agreement: it is never highlighted."""
    vals = [0.02, 0.03, 0.02, 0.03, 0.02, 0.03, 0.02, 0.03]
    doc = _doc({"a": vals, "b": list(reversed(vals)), "z": [5.0] * 8},
               a={"agreement": 0.95}, b={"agreement": 0.96}, z={"agreement": 0.99, "settings": AS_SHIPPED})
    ranked = ranked_summary(doc)
    names = [r["variant"] for r, _ in ranked]
    marks = best_group_marks(ranked)
    assert set(names[:2]) == {"a", "b"} and ranked[0][0]["rank"] == ranked[1][0]["rank"] == 1
    assert [names[k] for k, on in enumerate(marks["agreement"]) if on] == ["b"]
    assert not any(flags[names.index("z")] for flags in marks.values())


def test_a_failing_variant_is_named_with_its_reason():
    doc = _doc({"mujoco[settings=defaults]": [18.6] * 8, "pybullet": [0.01] * 8},
               **{"mujoco[settings=defaults]": {"settings": AS_SHIPPED, "overturn_extra": 1500,
                                                "agreement": 0.13}})
    v = verdict(doc)
    bad = next(r for r in v["variants"] if r["variant"].startswith("mujoco"))
    assert bad["fails"] and bad["reasons"] == ["overturns in 100 % of the cells where the reference stays standing"]
    text = " ".join(v["text"])
    assert "Out of the box (engines as shipped): its only variant, mujoco[settings=defaults], fails" in text
    assert "Fail (boundary on average more than 1 grid cell" in text and "overturns in 100 %" in text
    assert "Best achievable (engines calibrated by rockbench): pybullet" in text


def test_verdict_object_in_score_json_shape():
    v = verdict(_doc({"a": [0.01] * 8, "b": [0.01] * 8}))
    assert v["metric"] == PRIMARY_METRIC and v["direction"] == "lower"
    for r in v["variants"]:
        assert {"variant", "engine", "settings", "value", "ci95", "rank", "pairs", "versus"} <= set(r)
        assert r["pairs"] == 8 and r["rank"] == 1
        assert len(r["ci95"]) == 2 and r["ci95"][0] <= r["value"] <= r["ci95"][1]
    assert "tied with b" in v["text"][0]


def test_a_variant_with_nothing_judged_has_no_value_and_fails():
    doc = _doc({"a": [math.nan] * 2, "b": [0.01] * 2})
    row = next(r for r in verdict(doc)["variants"] if r["variant"] == "a")
    assert row["value"] is None and row["rank"] is None and row["fails"]


@pytest.mark.parametrize("settings, expected", [
    ({"settings": "defaults"}, AS_SHIPPED), ({}, CALIBRATED), ({"settings": "calibrated"}, CALIBRATED),
    ({"settings": "calibrated", "contact": "distributed"}, CALIBRATED),
    ({"settings": "defaults", "friction": 1.0}, "v[custom]"), ({"friction": 1.0}, "v[custom]")])
def test_settings_class(settings, expected):
    assert settings_class(settings, "v[custom]") == expected


def test_the_choice_of_an_engines_model_is_not_a_tweak():
    """Newton's solver picks which of its models runs: calibrated VBD is calibrated, as shipped
    semi-implicit as shipped; a solver of an engine without several is still set by hand."""
    assert settings_class({"settings": "calibrated", "solver": "vbd"}, "v", "newton") == CALIBRATED
    assert settings_class({"settings": "defaults", "solver": "semi_implicit"}, "v", "newton") == AS_SHIPPED
    assert settings_class({"settings": "defaults", "solver": "semi_implicit", "friction": 1.0}, "v", "newton") == "v"
    assert settings_class({"solver": "cg"}, "v", "pybullet") == "v"


# -- end to end: score.json, the console, the report ------------------------------------------------------

def test_score_json_carries_the_verdict_and_the_console_prints_it(write_map, band, tmp_path, capsys):
    root = tmp_path / "run"
    write_map(root / "ref", band(12, 10, 6))
    write_map(root / "good", band(12, 10, 6), engine="mujoco", settings={"settings": "calibrated"})
    write_map(root / "bad", band(12, 10, 0), engine="mujoco", settings={"settings": "defaults"})
    code, out, _ = run_cli(capsys, "score", root)
    assert code == 0
    assert out.index("Verdict") < out.index("Summary")
    doc = json.loads((root / "score.json").read_text())
    assert doc["schema_version"] == 2 and doc["metrics_version"] == "3"
    rows = {r["settings"]: r for r in doc["verdict"]["variants"]}
    assert rows[CALIBRATED]["value"] == 0.0 and rows[CALIBRATED]["rank"] == 1
    assert rows[AS_SHIPPED]["fails"] and "overturns in 100 %" in rows[AS_SHIPPED]["reasons"][0]
    assert all(p["complete"] is True and p["cells_missing"] == 0 for p in doc["pairs"])


def test_a_variant_tied_with_the_best_is_never_ranked_behind_one_the_best_beats():
    """The default suite's case: m's mean is raised by one bad scenario but it wins four of eight, so it
    ties with p; e is farther than p in every scenario, though its mean is smaller than m's."""
    p = _variant("p", [0.006, 0.0, 0.0, 0.005, 0.023, 0.014, 0.007, 0.012])
    m = _variant("m", [0.0, 0.0, 0.006, 0.005, 0.549, 0.007, 0.012, 0.024])
    e = _variant("e", [0.083, 0.024, 0.064, 0.024, 0.029, 0.037, 0.041, 0.059])
    assert e.value < m.value
    assert not paired(m, p)["resolved"] and paired(e, p)["resolved"]
    assert rank([p, m, e]) == {"p": 1, "m": 1, "e": 2}


def test_a_one_cell_grid_gives_a_verdict_not_an_error(write_map, tmp_path, capsys):
    """A one-cell map has no cell diagonal: the units stay positive, the ratios of two perfect maps defined."""
    root = tmp_path / "run"
    codes = np.array([[2]])
    write_map(root / "ref", codes, w=(3.0, 3.0), a=(2.0, 2.0))
    write_map(root / "a", codes, engine="mujoco", w=(3.0, 3.0), a=(2.0, 2.0))
    write_map(root / "b", codes, engine="pybullet", w=(3.0, 3.0), a=(2.0, 2.0))
    code, out, err = run_cli(capsys, "score", root, "--no-write")
    assert code == 0, err
    assert "tied with" in out
