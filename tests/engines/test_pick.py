"""The one calibration pick (engines/calibration/pick.py) on hand-built candidate lists, and no adapter with a
reader or a pick of its own: no engine runs."""

from __future__ import annotations

import inspect
import math
import sys

import pytest

from rockbench.engines.calibration.free_rocking import PEAK_RATIO, EtaReader
from rockbench.engines.calibration.pick import (CAL_MAX_SPREAD, ETA_RESOLUTION, Candidate, damping_ratio_of_restitution,
                                    hop_tol_m, pick, ranked, sink_tie_m)
from rockbench.engines.contact import ContactEngine
from rockbench.engines.registry import BUILTIN, adapter_class
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.calibration.routine import calibrate

BLOCK = get_preset("B6L").block()
T = 0.9294


def _c(name, eta, *, std=0.002, n=4, sink=1e-6, hop=0.0, zeta=1.0):
    return Candidate({"name": name}, eta, std, n, sink, hop, zeta)


def _picked(cands, target=T):
    p = pick(cands, target, BLOCK)
    return p.candidate.knobs["name"], p.reached


def test_a_hopping_candidate_is_never_picked():
    # B6L's old MuJoCo pick: ζ 0.5, stiffer and 0.0006 closer, but both corners rise 0.25 mm
    hopping = _c("zeta-0.5", T + 0.0001, sink=0.1e-6, hop=2.5e-4, zeta=0.5)
    assert hopping.hop_m > hop_tol_m(BLOCK)
    assert _picked([hopping, _c("zeta-1", T + 0.0007, sink=0.3e-6)]) == ("zeta-1", True)
    # even when nothing else is left it is not reached
    assert _picked([hopping]) == ("zeta-0.5", False)


def test_a_closer_eta_within_the_resolution_does_not_beat_a_stiffer_setting():
    stiff = _c("stiff", T * (1 + 0.9 * ETA_RESOLUTION), sink=1e-6)
    soft = _c("soft", T, sink=1e-6 + 2 * sink_tie_m(BLOCK))
    assert _picked([soft, stiff]) == ("stiff", True)
    # outside the resolution the stiffer one is not reached, and the soft one is taken
    far = _c("stiff-far", T * (1 + 1.1 * ETA_RESOLUTION), sink=1e-6)
    assert _picked([far, soft]) == ("soft", True)


def test_ties_in_stiffness_are_broken_by_damping_nearest_critical():
    tie = 0.5 * sink_tie_m(BLOCK)
    cands = [_c("zeta-2", T, sink=1e-6 + tie, zeta=2.0), _c("zeta-0.7", T + 0.001, sink=1e-6, zeta=0.7),
             _c("zeta-1.2", T + 0.004, sink=1e-6 + tie, zeta=1.2)]
    assert _picked(cands) == ("zeta-1.2", True)
    assert [c.knobs["name"] for c in ranked(cands, T, BLOCK)] == ["zeta-1.2", "zeta-0.7", "zeta-2"]
    # no damping knob: counts as critical; then the stiffer, then the closer η
    assert _picked([_c("a", T + 0.003, sink=2e-6, zeta=None), _c("b", T, sink=2e-6, zeta=None)]) == ("b", True)


def test_irregular_candidates_do_not_count():
    scatter = _c("scatter", T, std=1.01 * CAL_MAX_SPREAD * T, sink=0.0)
    one = _c("one-impact", T, n=1, sink=0.0)
    nan = _c("nothing", math.nan, std=math.nan, n=0)
    assert _picked([scatter, one, nan, _c("ok", T * 1.005)]) == ("ok", True)
    # none regular: the closest finite one, not reached
    assert _picked([scatter, nan]) == ("scatter", False)
    # regular but none within the resolution: the closest regular, not reached
    assert _picked([_c("far", T * 1.05), _c("farther", T * 0.9), scatter]) == ("far", False)


def test_nothing_to_pick_is_an_error():
    with pytest.raises(ValueError):
        pick([], T, BLOCK)


def test_the_damping_ratio_of_a_bounce():
    # a plastic impact is critical damping; a spring-dashpot with ζ gives e = exp(−πζ/√(1 − ζ²))
    assert damping_ratio_of_restitution(0.0) == 1.0
    for zeta in (0.05, 0.3, 0.7):
        e = math.exp(-math.pi * zeta / math.sqrt(1 - zeta * zeta))
        assert damping_ratio_of_restitution(e) == pytest.approx(zeta)


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_no_builtin_adapter_reads_eta_or_picks_its_own_way(name):
    """Every contact adapter reads η with the one reader and chooses with the one pick: its module
    holds no reader of its own (no EtaReader but PEAK_RATIO, no ``*_etas`` function), and the class
    no ``eta_reader``, ``_pick`` or spread rule of its own (its search: tests/engines/test_one_rule.py)."""
    cls = adapter_class(name)
    if not issubclass(cls, ContactEngine):
        pytest.skip("not a contact engine (the reference applies η exactly)")
    mod = sys.modules[cls.__module__]
    assert all(v is PEAK_RATIO for v in vars(mod).values() if isinstance(v, EtaReader))
    assert not [k for k, v in vars(mod).items() if k.endswith("_etas") and inspect.isfunction(v)
                and v.__module__ == mod.__name__]
    for attr in ("eta_reader", "_pick", "_regular", "CAL_SPREAD_ABSOLUTE"):
        assert not hasattr(cls, attr), attr


def test_declared_knobs_give_the_grid_then_the_finer_grid_around_the_pick(monkeypatch):
    """The one calibration routine's grid of declared knobs (no engine): every ladder combination, the
    pick, the finer grid around it without the point itself or values under a knob's minimum, the pick
    over all rows; ζ read from a knob that says its value is a damping ratio."""
    from rockbench.engines.calibration import cache
    from rockbench.engines.calibration.knobs import Knob, around, grid
    from rockbench.engines.contract import RestitutionMeasurement

    knobs = (Knob("k", "N/m", (1.0, 2.0), refine=(0.5, 1.0, 2.0), minimum=lambda b, dt: 0.9),
             Knob("zeta", "", (0.5, 1.0), zeta="ratio", refine=(0.8, 1.0)))
    assert grid(knobs, BLOCK, 1e-3) == [{"k": 1.0, "zeta": 0.5}, {"k": 1.0, "zeta": 1.0},
                                        {"k": 2.0, "zeta": 0.5}, {"k": 2.0, "zeta": 1.0}]
    assert around(knobs, {"k": 1.0, "zeta": 1.0}, BLOCK, 1e-3) == [{"k": 1.0, "zeta": 0.8}, {"k": 2.0, "zeta": 0.8},
                                                                   {"k": 2.0, "zeta": 1.0}]

    class Grid(ContactEngine):
        CONTRACT_VERSION = 2
        name = "fake-knobs"
        SHIPPED = {"k": None, "zeta": None}
        KNOBS = knobs

        def measure_many(self, block, settings, dt, theta0_frac=0.5):
            # η on target everywhere; ζ 0.5 hops; the sink falls with k
            return [RestitutionMeasurement([T] * 4, T, 0.001, 0.1, dt, {}, sink_m=1e-3 / s["k"],
                                           hop_m=1e-3 if s["zeta"] < 0.6 else 0.0) for s in settings]

    stored = {}
    monkeypatch.setattr(cache, "store", lambda key, record, engine: stored.update(record["search"]))
    c = calibrate(Grid(), BLOCK, T, dt_s=1e-3, use_cache=False)
    # the stiffest (k 4: 2 × the grid's stiffest, refined) with the damping nearest critical, never the hop
    assert c.reached and c.settings == {"k": 4.0, "zeta": 1.0} and c.evaluations == 4 + 5
    assert len(stored["tried"]) == 9 and "reached" in c.note


def test_one_knob_with_bisect_steps_is_bisected_between_regular_neighbours():
    """A single knob asking for bisection (Exudyn's restitution coefficient): after its ladder, the one
    bisection between the first regular neighbours that bracket the target, until within bisect_rtol;
    a midpoint that is not regular ends it."""
    from rockbench.engines.calibration.knobs import Knob, search

    knob = Knob("e", "", lambda b, dt: (0.0, 0.4, 1.0), bisect_steps=8, bisect_rtol=1e-4)

    def evaluate(hop_at):
        # η rises with e; e = 0.4 hops (never regular), so the bracket is (0, 1)
        return lambda cands: [{**c, "eta": 0.9 + 0.06 * c["e"], "eta_std": 0.001, "n": 4, "sink_m": 0.0,
                               "hop_m": 1e-3 if c["e"] in hop_at else 0.0, "damping_ratio": None} for c in cands]

    rows = search((knob,), BLOCK, T, 1e-3, evaluate({0.4}))
    assert [r["e"] for r in rows][:5] == [0.0, 0.4, 1.0, 0.5, 0.25]
    assert len(rows) == 3 + 8 and abs(rows[-1]["eta"] - T) <= 0.06 / 2**8   # 8 halvings of a range of η 0.06
    stopped = search((knob,), BLOCK, T, 1e-3, evaluate({0.4, 0.25}))
    assert [r["e"] for r in stopped] == [0.0, 0.4, 1.0, 0.5, 0.25]


def _rows(eta_of):
    """An ``evaluate`` whose free rocking gives ``eta_of(candidate)`` with regular impacts."""
    return lambda cands: [{**c, "eta": eta_of(c), "eta_std": 0.001, "n": 4, "sink_m": 0.0, "hop_m": 0.0,
                           "damping_ratio": None} for c in cands]


def test_the_shipped_contact_is_measured_first_and_the_side_of_the_target_chooses_the_knobs():
    """With keep_rtol (PyBullet, DART): the shipped contact first, kept when close enough; else the
    knobs without ``when``, then those of the side the shipped η lies on, each candidate the shipped
    contact changed (PyBullet's compliant stiffness bisected over a log10 span with the damping along,
    its restitution over a ladder; DART's detector grid with the shipped combination left out)."""
    from rockbench.engines.calibration.knobs import Knob, search

    knobs = (Knob("det", "", ("a", "b")),
             Knob("k", "N/m", when="above", span=lambda b, dt: (3.0, 7.0), log10=True, bisect_steps=12,
                  bisect_regular=False, along=lambda k, b, dt: {"c": 2.0 * k}),
             Knob("e", "", when="below", values=lambda b, dt: (0.2, 0.6, 1.0), bisect_steps=5,
                  bisect_regular=False))
    shipped = {"det": "a", "k": None, "e": None}
    kept = search(knobs, BLOCK, T, 1e-3, _rows(lambda c: T * 1.004), keep_rtol=0.005, shipped=shipped)
    assert kept == _rows(lambda c: T * 1.004)([{"det": "a"}])
    # shipped 5 % above: detector b, then k bisected (η rises with log10 k: T at k = 1e5)
    above = search(knobs, BLOCK, T, 1e-3, _rows(lambda c: T * (1.05 if "k" not in c else 1 + 0.1 * (math.log10(c["k"]) - 5))),
                   keep_rtol=0.005, shipped=shipped)
    assert [r.get("det") for r in above[:2]] == ["a", "b"] and above[2]["k"] == 1e5 and above[2]["c"] == 2e5
    assert len(above) == 3 and all("e" not in r for r in above)
    # shipped 5 % below: detector b, then the restitution ladder and its bisection; no stiffness
    below = search(knobs, BLOCK, T, 1e-3, _rows(lambda c: T * (0.95 if "e" not in c else 0.9 + 0.2 * c["e"])),
                   keep_rtol=0.005, shipped=shipped)
    assert [r.get("e") for r in below[2:]] == [0.2, 0.6, 1.0, 0.4, 0.5]   # T at e = 0.5
    assert all("k" not in r for r in below)


def test_a_knob_until_reached_stops_at_the_first_value_the_pick_reaches():
    """PhysX's substeps: the ladder one value at a time, with the settings along, until the pick reaches."""
    from rockbench.engines.calibration.knobs import Knob, search

    knob = Knob("substeps", "", (1, 2, 4, 8), until="reached", along={"solver": "pgs"})
    rows = search((knob,), BLOCK, T, 1e-3, _rows(lambda c: T * (1 - 0.03 / c["substeps"])))
    assert [(r["solver"], r["substeps"]) for r in rows] == [("pgs", 1), ("pgs", 2), ("pgs", 4)]


def test_a_stiffness_ladder_with_a_bisected_damping_at_each_stops_once_close():
    """Drake's search: the starting contact (``start``, not shipped) first; then the stiffness ladder
    value by value, at each the damping's log10 range ends and their bisection, until a candidate is
    within the bisection's tolerance (``until="close"``)."""
    from rockbench.engines.calibration.knobs import Knob, search

    knobs = (Knob("k", "N/m", start=1e6, until="close", values=lambda b, dt: (1e5, 3e4, 1e4)),
             Knob("d", "s", start=1e-3, values=lambda b, dt: (-5.0, -1.0), log10=True, bisect_steps=10,
                  bisect_regular=False))
    # η falls with log10 d; at k 1e5 it stays above the target, at 3e4 it crosses it at d = 1e-3
    rows = search(knobs, BLOCK, T, 1e-3,
                  _rows(lambda c: T * (1.05 if c["k"] >= 1e5 else 1 - 0.01 * (math.log10(c["d"]) + 3))), keep_rtol=0.005)
    assert rows[0]["k"] == 1e6 and rows[0]["d"] == 1e-3
    assert [(r["k"], r["d"]) for r in rows[1:5]] == [(1e5, 1e-5), (1e5, 0.1), (3e4, 1e-5), (3e4, 0.1)]
    assert rows[-1]["k"] == 3e4 and rows[-1]["d"] == 1e-3 and all(r["k"] != 1e4 for r in rows)


def test_paired_ladders_on_the_side_of_the_target_are_walked_in_step_until_close():
    """Newton XPBD's shape: the shipped contact (nothing set) first, kept within 0.25 %; beyond that
    (``when_rtol``, not the reader's 1 %) the (iterations, relaxation) pairs of its side, pair by pair
    (``paired``), until one is within the first knob's own ``bisect_rtol``."""
    from rockbench.engines.calibration.knobs import Knob, search

    def side(when, its, relax):
        return (Knob("it", "", when=when, when_rtol=0.0025, until="close", bisect_regular=False,
                     values=lambda b, dt: its),
                Knob("relax", "", when=when, when_rtol=0.0025, paired=True, values=lambda b, dt: relax))

    knobs = side("below", (2, 4, 8), (1.0, 1.0, 1.0)) + side("above", (2, 1, 1), (0.6, 0.8, 0.6))
    # shipped 0.5 % below: the below pairs, ending at (4, 1.0), which is 0.1 % off
    rows = search(knobs, BLOCK, T, 1e-3, _rows(lambda c: T * (0.995 if not c else {2: 0.997, 4: 0.999, 8: 1.0}[c["it"]])),
                  keep_rtol=0.0025)
    assert [(r.get("it"), r.get("relax")) for r in rows] == [(None, None), (2, 1.0), (4, 1.0)]
    # shipped 3 % above: the above pairs, all three (none is close)
    rows = search(knobs, BLOCK, T, 1e-3, _rows(lambda c: T * 1.03), keep_rtol=0.0025)
    assert [(r.get("it"), r.get("relax")) for r in rows] == [(None, None), (2, 0.6), (1, 0.8), (1, 0.6)]


def test_a_nested_ladder_until_close_does_not_stop_at_a_candidate_that_hops():
    """Newton VBD's shape: each stiffness with each damping, one at a time, until a regular candidate is
    within the damping knob's ``bisect_rtol``; a close one that hops is not regular and goes on."""
    from rockbench.engines.calibration.knobs import Knob, search

    knobs = (Knob("k", "N/m", until="close", values=lambda b, dt: (1e4, 3e4)),
             Knob("c", "N s/m", until="close", values=lambda b, dt: (100.0, 30.0, 10.0)))
    hop = 10 * BLOCK.width_m * 5e-4
    table = {(1e4, 30.0): (T, hop), (3e4, 30.0): (T * 1.001, 0.0)}
    rows = search(knobs, BLOCK, T, 1e-3, lambda cands: [
        {**c, "eta": table.get((c["k"], c["c"]), (0.9 * T, 0.0))[0], "eta_std": 0.001, "n": 4, "sink_m": 0.0,
         "hop_m": table.get((c["k"], c["c"]), (0.0, 0.0))[1], "damping_ratio": None} for c in cands])
    assert [(r["k"], r["c"]) for r in rows] == [(1e4, 100.0), (1e4, 30.0), (1e4, 10.0), (3e4, 100.0), (3e4, 30.0)]


def test_a_knob_whose_values_are_neither_a_tuple_nor_a_function_fails_where_it_is_declared():
    """An outside author's wrong values, span or ζ fail in one line at class definition, not as an
    internal error in the middle of a calibration; a tuple or a function of (block, dt) are values."""
    from rockbench.engines.calibration.knobs import Knob
    with pytest.raises(TypeError, match="values must be a tuple or a function"):
        Knob("damping_ratio", "", "0.5, 1.0")
    with pytest.raises(TypeError, match="span must be a function"):
        Knob("k", "N/m", span=(3.0, 7.0))
    with pytest.raises(TypeError, match="zeta must be None, 'ratio' or 'restitution'"):
        Knob("c", "", (1.0,), zeta="critical")
    assert Knob("e", "", (0.1, 0.2)).ladder(BLOCK, 1e-3) == Knob("e", "", lambda b, dt: (0.1, 0.2)).ladder(BLOCK, 1e-3)
