"""The bisection rule that locates the boundary below the cell, on hand-made outcome functions with
known crossings, and its polyline (marching squares)."""

import numpy as np
import pytest

from rockbench.benchmark.maps.bisection import (ALONG_A, ALONG_W, FAILED_EDGE, MULTIPLE, NO_REGIME, STANDING,
                                                 UNFINISHED, UNSAMPLED, bisect, edges_between, overturn_regime)
from rockbench.benchmark.maps.boundary import locate, marching_chords, midpoint_boundary

S, O0, O1, O2 = STANDING, 1, 2, 3   # standing; overturn after 0, 1, 2 impacts


def along(profile, calls=None):
    """A sampler for one edge whose regime at ``t`` is ``profile(t)``; records each round's batch."""
    def sample(i, j, axis, t):
        if calls is not None:
            calls.append(len(t))
        return [profile(float(x)) for x in t]
    return sample


def one_edge(r0, r1, depth, profile, calls=None):
    return bisect(np.array([[r0, r1]]), depth, along(profile, calls))


def test_one_crossing_to_the_tolerance():
    calls = []
    b = one_edge(S, O1, 6, lambda t: S if t < 0.3 else O1, calls)
    assert b.flag.tolist() == [""] and b.edge.tolist() == [0] and not b.band[0]
    assert abs(b.t[0] - 0.3) <= 0.5 / 2 ** 6          # the midpoint of the last interval, 1/64 wide
    assert calls == [1] * 6 and b.n_samples == 6      # one sample per round, one batch per round


def test_crossing_from_the_overturn_side():
    b = one_edge(O0, S, 5, lambda t: O0 if t < 0.71 else S)
    assert abs(b.t[0] - 0.71) <= 0.5 / 2 ** 5


def test_depth_zero_is_the_midpoint():
    b = one_edge(S, O0, 0, lambda t: pytest.fail("depth 0 takes no sample"))
    assert b.t.tolist() == [0.5] and b.n_samples == 0


def test_thin_band_inside_one_edge_gives_two_crossings():
    """overturn(0) | overturn(1) with a standing band on [0.40, 0.45): the first samples overturn, one
    lands in the band, then both halves are bisected on."""
    def profile(t):
        return O0 if t < 0.40 else S if t < 0.45 else O1

    calls = []
    b = one_edge(O0, O1, 7, profile, calls)
    assert b.flag.tolist() == [""] and b.band.tolist() == [True, True]
    np.testing.assert_allclose(b.t, [0.40, 0.45], atol=0.5 / 2 ** 7)
    assert calls[:4] == [1, 1, 1, 1] and calls[4:] == [2, 2, 2]   # found at 0.4375 in round 4


def test_band_thinner_than_the_tolerance_has_no_crossing():
    b = one_edge(O0, O1, 4, lambda t: O0 if t < 0.40 else S if t < 0.401 else O1)
    assert b.t.size == 0 and b.flag.tolist() == [""]


def test_failed_sample_stops_the_edge_at_its_interval():
    # samples at 0.5 (overturn), 0.25 (standing), then 0.375 fails: the crossing is (0.25 + 0.5) / 2
    b = one_edge(S, O1, 6, lambda t: NO_REGIME if t == 0.375 else S if t < 0.3 else O1)
    assert b.flag.tolist() == [FAILED_EDGE] and b.t.tolist() == [0.375] and b.n_samples == 3


def test_sample_of_another_regime_marks_multiple():
    # standing | overturn(1) whose midpoint overturns after 2 impacts: a tongue or island inside the edge
    b = one_edge(S, O1, 6, lambda t: S if t < 0.3 else O2 if t < 0.6 else O1)
    assert b.flag.tolist() == [MULTIPLE] and b.t.tolist() == [0.5] and b.n_samples == 1


def test_unstored_sample_marks_unfinished():
    b = one_edge(S, O1, 6, lambda t: UNSAMPLED if t < 0.3 else O1)
    assert b.flag.tolist() == [UNFINISHED] and b.t.tolist() == [0.25]


def test_edges_are_those_of_differing_regime():
    r = np.array([[S, S, O0], [S, O1, O0], [NO_REGIME, O1, O1]])
    i, j, ax = edges_between(r)
    got = set(zip(i.tolist(), j.tolist(), ax.tolist()))
    # along ω/p: (0,1)|(0,2) S|O0, (1,0)|(1,1) S|O1, (1,1)|(1,2) O1|O0; along a: (0,1)|(1,1), (1,2)|(2,2)
    assert got == {(0, 1, ALONG_W), (1, 0, ALONG_W), (1, 1, ALONG_W), (0, 1, ALONG_A), (1, 2, ALONG_A)}


def test_overturn_regime_of_regime_keys():
    # regime_key: 0 rest, 1 rocking, 2 + 10 n overturn after n impacts (n ≤ 3), -1 failed
    np.testing.assert_array_equal(overturn_regime([0, 1, 2, 12, 32, -1, -2]), [S, S, 1, 2, 4, -1, -1])


def test_many_edges_one_batch_per_round():
    """A straight boundary a = 0.3 + 0.45 w across a 4 × 4 grid: every round samples every open edge
    at once, and every crossing lies on the line to the tolerance."""
    w = a = np.arange(4.0)
    line = lambda x, y: y >= 0.3 + 0.45 * x          # noqa: E731
    regime = np.where(line(w[None, :], a[:, None]), O0, S)
    calls = []

    def sample(i, j, axis, t):
        calls.append(len(t))
        x = w[j] + t * (axis == ALONG_W)
        y = a[i] + t * (axis == ALONG_A)
        return np.where(line(x, y), O0, S)

    lb = locate(regime, w, a, 8, sample)
    assert len(calls) == 8 and len(set(calls)) == 1
    resid = lb.points[:, 1] - (0.3 + 0.45 * lb.points[:, 0])
    assert np.all(np.abs(resid) <= 0.5 / 2 ** 8 * (1 + 0.45) + 1e-12)
    # the polyline: one chord per square it crosses, joining the crossings along the line
    ch = lb.chords()
    assert ch.shape[0] == lb.n_crossings - 1
    np.testing.assert_allclose(ch[:, :, 1], 0.3 + 0.45 * ch[:, :, 0], atol=0.01)


def test_marching_squares_pairs_a_saddle_by_the_shorter_chords():
    # four crossings on one square's sides (a saddle): near each corner, so the short pairing joins
    # bottom–right and top–left
    pts = np.array([[0.9, 0.0], [1.0, 0.1], [0.1, 1.0], [0.0, 0.9]])
    cell = np.array([[0, 0], [0, 1], [1, 0], [0, 0]])
    axis = np.array([ALONG_W, ALONG_A, ALONG_W, ALONG_A])
    t = np.array([0.9, 0.1, 0.1, 0.9])
    ch = marching_chords(pts, cell, axis, t, (2, 2))
    assert {tuple(map(tuple, c)) for c in ch} == {((0.9, 0.0), (1.0, 0.1)), ((0.1, 1.0), (0.0, 0.9))}


def test_midpoint_boundary_is_depth_zero():
    o = np.array([[0, 0], [2, 2]])
    b = midpoint_boundary(o, [0.0, 1.0], [0.0, 2.0])
    np.testing.assert_array_equal(b.points, [[0.0, 1.0], [1.0, 1.0]])
    assert b.depth == 0 and b.chords().shape == (1, 2, 2)


def test_marching_squares_follows_a_thin_band_along_it():
    """A band 0.05 wide across a square's corner (x + y from 0.3 to 0.35) crosses the bottom side twice
    and the left side twice: the chords run along the band, not across it (the shorter pairing would
    join the two crossings of each side)."""
    pts = np.array([[0.3, 0.0], [0.35, 0.0], [0.0, 0.3], [0.0, 0.35]])
    cell = np.array([[0, 0], [0, 0], [0, 0], [0, 0]])
    axis = np.array([ALONG_W, ALONG_W, ALONG_A, ALONG_A])
    t = np.array([0.3, 0.35, 0.3, 0.35])
    ch = marching_chords(pts, cell, axis, t, (2, 2))
    assert {tuple(map(tuple, c)) for c in ch} == {((0.35, 0.0), (0.0, 0.35)), ((0.0, 0.3), (0.3, 0.0))}
