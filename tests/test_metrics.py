"""Scores on hand-made maps with known answers, and properties that hold for every map."""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st
from hypothesis.extra import numpy as hnp

from rockbench.benchmark.maps.result import MapResult, from_cells
from rockbench.benchmark.scoring.metrics import (FAILED, METRICS, METRICS_VERSION, NEARER_ZERO, OVERTURN, REST, ROCKING,
                                               boundary_points, check_gate, critical_amplitude,
                                               cell_counts, is_perfect, parse_thresholds, score)
from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.errors import IncomparableError

N = 10
AX = np.arange(N, dtype=float)  # unit spacing on both axes: distances are easy to count


def band_map(first_overturn_row, below=ROCKING, n=N):
    c = np.full((n, n), below)
    c[first_overturn_row:, :] = OVERTURN
    return MapResult.from_outcomes(np.arange(n, dtype=float), np.arange(n, dtype=float), c)


def test_metrics_table_is_complete():
    assert METRICS_VERSION
    for m in METRICS.values():
        assert m.direction in ("higher", "lower", NEARER_ZERO)
        assert m.definition and m.unit
        assert m.tolerance >= 0


def test_a_new_metric_is_one_object(monkeypatch):
    """docs/scores.md's claim: a metric is one ``Metric`` (name, definition, direction, unit, titles,
    tolerance, version and how it is computed); registered alone, it is scored, gets its column in the
    pairs table and the summary, and ``compare`` its default tolerance, with nothing else changed."""
    from rockbench.benchmark.report import tables
    from rockbench.benchmark.scoring import metrics, score_runs
    from rockbench.benchmark.scoring.scores import Scores, pair_key

    m = metrics.Metric("overturn_cells", "Engine cells judged overturn.", "lower", 0.0, "-", 3.0,
                       kind="count", short="ov cells", title="overturn cells",
                       value=lambda c: float(np.count_nonzero(c.judged & (c.ce == OVERTURN))))
    monkeypatch.setitem(metrics.METRICS, m.name, m)
    s = score(band_map(4), band_map(5))
    assert s["overturn_cells"] == 6 * N and s["boundary_mean"] == 1.0
    pair = {"variant": "e", "block": "B3M", "pulse": "sine", "restitution": "housner", "like_for_like": True,
            "reference": {"restitution": "housner"}, "scores": s}
    scores = Scores.from_json({"pairs": [{"key": pair_key(pair), **pair}], "verdict": {}})
    head, row = tables.pairs_table(scores).splitlines()[0::2]
    assert "ov cells" in head and f"{6 * N}" in row.split()
    assert tables.summary(scores)["e"]["overturn_cells"] == 6 * N
    assert score_runs.parse_tolerances([])["overturn_cells"]["at_least"] == 3.0
    assert m.version == METRICS_VERSION and m.to_dict()["title"] == "overturn cells"


def test_shifted_boundary_by_one_row():
    ref, eng = band_map(5), band_map(6)
    s = score(eng, ref)
    assert s["agreement"] == pytest.approx(1 - 1 / N)  # row 5 disagrees
    assert s["overturn_agreement"] == pytest.approx(1 - 1 / N)
    assert s["iou_overturn"] == pytest.approx((N - 6) / (N - 5))
    assert s["boundary_mean"] == pytest.approx(1.0)  # every edge moved by one step
    assert s["boundary_max"] == pytest.approx(1.0)
    assert s["critical_error_mean"] == pytest.approx(1.0)
    assert s["critical_error_max"] == pytest.approx(1.0)
    assert s["critical_one_sided"] == 0
    assert s["spurious_invalid"] == 0 and s["failed_cells"] == 0
    assert math.isnan(s["consistency"])   # no cell outside the domain: n/a, never perfect


def test_shift_scales_with_axis_spacing():
    c_ref = np.full((N, N), REST)
    c_ref[5:] = OVERTURN
    c_eng = np.full((N, N), REST)
    c_eng[7:] = OVERTURN
    a = np.linspace(1.0, 5.5, N)  # step 0.5
    s = score(MapResult.from_outcomes(AX, a, c_eng), MapResult.from_outcomes(AX, a, c_ref))
    assert s["boundary_mean"] == pytest.approx(1.0)  # two steps of 0.5
    assert s["critical_error_max"] == pytest.approx(1.0)


def test_island_known_answer():
    ref = band_map(7)
    ref.outcome[2, 5] = OVERTURN  # an island of overturn far below the main region
    eng = band_map(7)
    s = score(eng, ref)
    assert s["agreement"] == pytest.approx(0.99)
    assert s["iou_overturn"] == pytest.approx(30 / 31)
    # pooled: 10 + 10 crossings on the common line a = 6.5, plus the island's 4 crossings, whose distances
    # to the engine's polyline (the segment a = 6.5, w 0..9; point to segment, not to its nearest
    # crossing) are 5 (below), 4 (above), 4.5 and 4.5 (the sides)
    assert boundary_points(ref).shape == (14, 2)
    assert s["boundary_mean"] == pytest.approx((5 + 4 + 4.5 + 4.5) / 24)
    assert s["boundary_max"] == pytest.approx(5.0)
    # column 5: lowest overturn at a = 2 in the reference, 7 in the engine
    assert s["critical_error_max"] == pytest.approx(5.0)
    assert s["critical_error_mean"] == pytest.approx(0.5)


def test_tongue_below_a_safe_band():
    ref = band_map(7)
    ref.outcome[3, 2:5] = OVERTURN  # one-impact tongue below the safe band (rows 4-6)
    # a map without bisection samples crosses at its edge midpoints: below row 3 (the tongue), below row 7
    np.testing.assert_array_equal(critical_amplitude(ref)[2:5], [2.5, 2.5, 2.5])
    assert critical_amplitude(ref)[0] == 6.5
    s = score(band_map(7), ref)
    assert s["critical_error_max"] == pytest.approx(4.0)
    assert s["critical_error_mean"] == pytest.approx(3 * 4.0 / N)
    assert s["iou_overturn"] == pytest.approx(30 / 33)
    # the tongue's edges: 3 below, 3 above, one at each end
    assert boundary_points(ref).shape == (10 + 8, 2)


def test_thin_safe_band_is_boundary():
    ref = band_map(5)
    ref.outcome[6, :] = ROCKING  # a safe band inside the overturn region
    assert boundary_points(ref).shape == (30, 2)
    s = score(band_map(5), ref)
    # band edges at 5.5 and 6.5 lie 1 and 2 from the engine's only edge at 4.5
    assert s["boundary_max"] == pytest.approx(2.0)
    assert s["boundary_mean"] == pytest.approx((10 * 1 + 10 * 2) / 40)
    assert s["critical_error_max"] == 0.0  # the lowest overturn is unchanged


def test_empty_maps():
    empty = MapResult.from_outcomes(AX, AX, np.full((N, N), REST))
    assert is_perfect(score(empty, empty))
    s = score(empty, band_map(5))
    diag = math.hypot(N - 1, N - 1)
    assert s["boundary_mean"] == s["boundary_max"] == pytest.approx(diag)
    assert s["iou_overturn"] == 0.0
    assert s["critical_one_sided"] == N
    # censored half a step above the axis, 9.5, against the crossing below row 5 at 4.5
    assert s["critical_error_mean"] == pytest.approx(5.0)
    s2 = score(band_map(5), empty)
    assert s2["boundary_mean"] == pytest.approx(diag)


def test_failed_cells_never_match():
    ref = band_map(5)
    eng = band_map(5)
    eng.outcome[7, 3] = FAILED
    eng.valid[7, 3] = False
    s = score(eng, ref)
    assert s["failed_cells"] == 1
    assert s["agreement"] == pytest.approx(0.99)
    assert s["iou_overturn"] < 1.0
    # a failed reference cell is not judged
    ref2 = band_map(5)
    ref2.outcome[7, 3] = FAILED
    s2 = score(eng, ref2)
    assert s2["agreement"] == 1.0 and s2["failed_cells"] == 0


def test_invalid_cells_counted_but_judged():
    eng = band_map(5)
    eng.valid[0, :3] = False
    s = score(eng, band_map(5))
    assert s["spurious_invalid"] == 3
    assert s["agreement"] == 1.0
    assert cell_counts(eng, band_map(5))["invalid_cells"] == 3


def test_different_grids_are_incomparable():
    other = MapResult.from_outcomes(AX * 1.01, AX, np.zeros((N, N), int))
    with pytest.raises(IncomparableError):
        score(other, band_map(5))


def test_from_cells_and_duplicates():
    w, a = np.meshgrid([1.0, 2.0], [0.5, 1.5, 2.5])
    out = np.where(a.ravel() > 1, "overturn", "rest")
    m = from_cells(w.ravel(), a.ravel(), out)
    np.testing.assert_array_equal(m.outcome, [[0, 0], [2, 2], [2, 2]])
    # a failed row and an ok row for one cell: the ok row wins, in either order
    w2 = np.append(w.ravel(), 1.0)
    a2 = np.append(a.ravel(), 0.5)
    for o in (np.append(out, ""), np.concatenate([[""], out])[[1, 2, 3, 4, 5, 6, 0]]):
        assert from_cells(w2, a2, o).outcome[0, 0] == REST
    with pytest.raises(ConfigError, match="disagree"):
        from_cells(w2, a2, np.append(out, "overturn"))
    with pytest.raises(ConfigError, match="unknown outcome"):
        from_cells([1.0], [1.0], ["toppled"])


def test_from_cells_fills_adaptive_gaps():
    # a coarse-fine table: the corner cell (2, 2) was never computed
    w = [0.0, 1.0, 2.0, 0.0, 1.0, 2.0, 0.0, 1.0]
    a = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 2.0]
    o = ["rest", "rest", "rest", "rest", "overturn", "overturn", "rest", "overturn"]
    m = from_cells(w, a, o)
    assert m.filled == 1 and m.outcome[2, 2] == OVERTURN
    assert from_cells(w, a, o, fill=False).outcome[2, 2] == FAILED


def test_gates_and_thresholds():
    s = score(band_map(6), band_map(5))
    th = parse_thresholds(["agreement=0.95"], direction="higher")
    assert check_gate(s, th) == ["agreement = 0.9 is below the limit 0.95"]
    assert check_gate(s, parse_thresholds(["agreement=0.85"])) == []
    assert check_gate(s, parse_thresholds(["boundary_max=0.5"], direction="lower"))
    with pytest.raises(ConfigError, match="Did you mean agreement"):
        parse_thresholds(["agrement=0.9"])
    with pytest.raises(ConfigError, match="--fail-over"):
        parse_thresholds(["boundary_max=0.5"], direction="higher")
    with pytest.raises(ConfigError, match="METRIC=VALUE"):
        parse_thresholds(["0.9"])


def test_metric_worse_respects_direction_and_tolerance():
    ag, bm = METRICS["agreement"], METRICS["boundary_mean"]
    assert ag.worse(0.90, 0.95) and not ag.worse(0.95, 0.90) and not ag.worse(0.949, 0.95, tol=0.01)
    assert bm.worse(0.5, 0.1) and not bm.worse(0.1, 0.5)
    assert ag.worse(math.nan, 0.9) and not ag.worse(math.nan, math.nan)


# -- properties ------------------------------------------------------------------------------------

codes_st = hnp.arrays(np.int64, st.tuples(st.integers(2, 7), st.integers(2, 7)),
                      elements=st.sampled_from([REST, ROCKING, OVERTURN]))


def _map(codes, failed=None):
    n_a, n_w = codes.shape
    c = codes.copy()
    if failed is not None:
        c[failed[: n_a, : n_w]] = FAILED
    return MapResult.from_outcomes(np.linspace(1, 10, n_w), np.linspace(0.5, 8, n_a), c)


@settings(max_examples=60, deadline=None)
@given(codes_st)
def test_score_of_a_map_with_itself_is_perfect(codes):
    m = _map(codes)
    assert is_perfect(score(m, m))


@settings(max_examples=60, deadline=None)
@given(codes_st, st.data())
def test_symmetric_metrics_and_bounds(c1, data):
    c2 = data.draw(hnp.arrays(np.int64, c1.shape, elements=st.sampled_from([REST, ROCKING, OVERTURN])))
    m1, m2 = _map(c1), _map(c2)
    s12, s21 = score(m1, m2), score(m2, m1)
    for k in ("agreement", "overturn_agreement", "iou_overturn", "boundary_mean", "boundary_max",
              "critical_error_mean", "critical_error_max", "critical_one_sided"):
        assert s12[k] == pytest.approx(s21[k]), k
    diag = math.hypot(9, 7.5)
    for k in ("agreement", "overturn_agreement", "iou_overturn"):
        assert 0.0 <= s12[k] <= 1.0
    assert 0.0 <= s12["boundary_mean"] <= s12["boundary_max"] <= diag + 1e-12
    step = 7.5 / (c1.shape[0] - 1)
    assert 0.0 <= s12["critical_error_mean"] <= s12["critical_error_max"] <= 7.5 + step + 1e-12
    assert s12["overturn_agreement"] >= s12["agreement"]


@settings(max_examples=40, deadline=None)
@given(codes_st, st.randoms(use_true_random=False))
def test_cell_table_row_order_does_not_matter(codes, rnd):
    m = _map(codes)
    W, A = np.meshgrid(m.w_ratio, m.a_ratio)
    names = np.array(["rest", "rocking", "overturn"])[codes.ravel()]
    valid = (codes.ravel() != ROCKING)
    perm = list(range(codes.size))
    rnd.shuffle(perm)
    m1 = from_cells(W.ravel(), A.ravel(), names, valid)
    m2 = from_cells(W.ravel()[perm], A.ravel()[perm], names[perm], valid[perm])
    np.testing.assert_array_equal(m1.outcome, codes)
    np.testing.assert_array_equal(m1.outcome, m2.outcome)
    np.testing.assert_array_equal(m1.valid, m2.valid)
    assert score(m1, m) == score(m2, m)


@settings(max_examples=40, deadline=None)
@given(codes_st, st.data())
def test_failures_never_improve_a_score(codes, data):
    ref = _map(codes)
    eng = _map(codes)
    mask = data.draw(hnp.arrays(np.bool_, codes.shape))
    worse = _map(codes, failed=mask)
    s0, s1 = score(eng, ref), score(worse, ref)
    for k in ("agreement", "overturn_agreement", "iou_overturn"):
        assert s1[k] <= s0[k]
    assert s1["failed_cells"] == mask.sum()


# -- metrics version 2: the reference's domain ------------------------------------------------------

def _outside(ref: MapResult, mask) -> MapResult:
    """``ref`` with the cells of ``mask`` outside its domain (lift-required: invalid, left the model)."""
    return MapResult.from_outcomes(ref.w_ratio, ref.a_ratio, ref.outcome, ~mask, mask)


def test_cells_outside_the_reference_domain_are_not_judged_by_outcome():
    mask = np.zeros((N, N), bool)
    mask[7:, :4] = True                        # a lift-required patch inside the overturn region
    ref = _outside(band_map(5), mask)
    eng = band_map(5)
    eng.outcome[7:, :4] = ROCKING                # the engine disagrees only where the reference is invalid
    s = score(eng, ref)
    assert s["agreement"] == 1.0 and s["iou_overturn"] == 1.0
    assert s["boundary_mean"] == 0.0 and s["critical_error_max"] == 0.0
    # the engine did not flag the lift-off the rigid model says a real block makes
    assert s["consistency"] == 0.0
    c = cell_counts(eng, ref)
    assert c["cells_in_domain"] == N * N - 12 and c["cells_outside_domain"] == 12
    # an engine that flags jump there is consistent
    eng2 = MapResult.from_outcomes(eng.w_ratio, eng.a_ratio, eng.outcome, ~mask, mask)
    s2 = score(eng2, ref)
    assert s2["consistency"] == 1.0 and s2["spurious_invalid"] == 0
    # the same disagreement inside the domain counts
    s3 = score(eng, band_map(5))
    assert s3["agreement"] < 1.0


def test_spurious_invalid_counts_only_inside_the_domain():
    mask = np.zeros((N, N), bool)
    mask[8:, :] = True
    ref = _outside(band_map(5), mask)
    eng = band_map(5)
    eng.valid[8:, :] = False                   # invalid where the reference is too: not spurious
    eng.valid[0, 0] = False                    # invalid where the reference is valid: spurious
    s = score(eng, ref)
    assert s["spurious_invalid"] == 1
    assert cell_counts(eng, ref)["invalid_cells"] == N * 2 + 1


def test_consistency_counts_only_simulated_engine_cells():
    mask = np.zeros((N, N), bool)
    mask[8:, :2] = True
    ref = _outside(band_map(5), mask)
    sim = np.ones((N, N), bool)
    sim[8:, 1] = False                         # an adaptive engine map inferred these
    left = mask & sim
    eng = MapResult.from_outcomes(AX, AX, band_map(5).outcome, None, left, sim)
    assert score(eng, ref)["consistency"] == 1.0
    assert cell_counts(eng, ref)["cells_outside_domain_simulated"] == 2


@settings(max_examples=60, deadline=None)
@given(hnp.arrays(np.int64, (6, 7), elements=st.sampled_from([REST, ROCKING, OVERTURN])),
       hnp.arrays(np.bool_, (6, 7)))
def test_score_of_a_reference_map_with_itself_is_perfect_outside_its_domain_too(codes, mask):
    assume(not mask.all())   # an empty domain leaves agreement undefined (NaN), which fails every gate
    m = MapResult.from_outcomes(np.linspace(1, 10, 7), np.linspace(0.5, 8, 6), codes, ~mask, mask)
    s = score(m, m)
    assert is_perfect(s)
    assert s["consistency"] == 1.0 or (math.isnan(s["consistency"]) and not mask.any())


def test_the_current_metrics_version_refuses_version_two():
    from rockbench.benchmark.scoring.score_runs import compare_scores
    from rockbench.benchmark.scoring.scores import Scores
    old, new = (Scores.from_json({"metrics_version": v, "pairs": [], "verdict": {}}) for v in ("2", METRICS_VERSION))
    with pytest.raises(IncomparableError, match=f"metrics version 2, current {METRICS_VERSION}"):
        compare_scores(old, new)


def test_every_metric_is_one_complete_object():
    """A metric carries everything tables, the report, plots and compare read (adding one touches
    metrics.py and its test only)."""
    from rockbench.benchmark.scoring.score_runs import cell_units
    units = cell_units({"grid": {"n_w": 5, "n_a": 4, "w_lo": 1, "w_hi": 5, "a_lo": 1, "a_hi": 4}})
    for m in METRICS.values():
        assert m.short and m.title and m.question and m.definition
        assert m.kind in ("fraction", "distance", "count") and m.direction in ("higher", "lower", NEARER_ZERO)
        assert units[m.name] > 0
        assert m.format(math.nan) == "n/a" and m.format(m.perfect)
    assert [m.name for m in METRICS.values() if m.role == "primary"] == ["boundary_mean"]
    assert len({m.short for m in METRICS.values()}) == len(METRICS)
