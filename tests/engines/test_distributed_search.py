"""The one calibration routine's search of a row of points along the base, without an engine.

A fake adapter gives measured rows (its ``candidates``) and the price functions are
replaced by fakes that read each candidate's answer from its row: the search must try the rows the
one pick reaches in its order (rows without a sink or a hop measured: closest first), skip the full
price of a row outside the uplift threshold, choose the first row that counts, and report ``not
reached`` when none does.
"""

from __future__ import annotations

import pytest

from rockbench.engines.calibration import cache, price, routine
from rockbench.engines.calibration.routine import MAX_PRICE_TRIES
from rockbench.engines.contact import ContactEngine
from rockbench.engines.contract import RestitutionMeasurement
from rockbench.reference_solver.model import Block

BLOCK = Block(0.045, 0.10125, mass_kg=0.5444, name="B3M")
T = 0.8


class _Probe:
    """What ``layout.with_contact`` returns for the fake (the routine's is replaced): the candidate's
    contact, and a free-rocking test (the routine's ``measure_restitution`` is replaced by one that calls it)."""

    def __init__(self, contact):
        self.contact = contact

    def measure_restitution(self, block, dt_s=None):
        return RestitutionMeasurement(etas=[T], eta_mean=T, eta_std=0.0, theta0_rad=0.1, dt_s=dt_s,
                                      settings={}, method="fake", first_quarter_s=0.1)


class _Fake(ContactEngine):
    """An adapter whose candidates along the base are the rows it is given."""

    CONTRACT_VERSION = 2
    name = "fake-rows"
    SETTINGS = {"settings": "shipped"}
    SHIPPED = {"k": None}
    CONTACT_ROWS = "points"

    def __init__(self, rows, **settings):
        super().__init__(**settings)
        self.rows = rows

    def candidates(self, block, target, dt_s, points, measure):
        return [dict(r) for r in self.rows]


def _row(k, rel, std=0.001, n=3, uplift=True, slip=0):
    """A measured candidate ``k`` at η = T·(1 + rel), with the price answers the fakes give."""
    return {"k": k, "eta": T * (1.0 + rel), "eta_std": std, "n": n, "uplift_ok": uplift, "slip": slip}


@pytest.fixture
def calls(monkeypatch):
    """The fake price functions; the candidates each was called for, in order."""
    log = {"uplift": [], "price": []}
    rows = {}

    def answer(k):
        ok = rows[k]["uplift_ok"]
        return {"ratio": 1.0 if ok else 0.9, "within": ok, "rocks_below": False}

    def uplift(fixed, block, rest, dt):
        log["uplift"].append(fixed.contact["k"])
        return answer(fixed.contact["k"])

    def contact_price(fixed, block, rest, dt, *, uplift):
        log["price"].append(fixed.contact["k"])
        r = rows[fixed.contact["k"]]
        assert uplift == answer(r["k"])   # the ramp already run is passed on, not run again
        return {"uplift": uplift, "anti_slip": {"n_slip": r["slip"], "n_jump": 0, "cells": 5},
                "period_change": None, "rigid_first_quarter_s": 0.1, "first_quarter_s": None,
                "steps_per_s": 1e5, "counts": r["uplift_ok"] and r["slip"] == 0}

    monkeypatch.setattr(price, "uplift_threshold", uplift)
    monkeypatch.setattr(price, "contact_price", contact_price)
    monkeypatch.setattr(routine, "with_contact", lambda ad, contact: _Probe(contact))
    monkeypatch.setattr(routine, "measure_restitution", lambda probe, block, dt_s=None: probe.measure_restitution(
        block, dt_s=dt_s))
    monkeypatch.setattr(cache, "store", lambda key, record, engine: log.update(stored=record["search"]))
    log["rows"] = rows
    return log


def _search(calls, given):
    calls["rows"].update({r["k"]: r for r in given})
    ad = _Fake(given)
    return ad, routine.calibrate_layout(ad, BLOCK, T, 1e-3, 9, use_cache=False)


def test_regular_rows_within_one_percent_are_tried_closest_first(calls):
    given = [_row("far", 0.02), _row("plus9", 0.009, slip=1), _row("minus2", -0.002, slip=1),
             _row("scatter", 0.0, std=0.05), _row("one-impact", 0.0, n=1), _row("plus5", 0.005, slip=1)]
    _, c = _search(calls, given)
    assert calls["uplift"][:3] == ["minus2", "plus5", "plus9"]
    assert calls["price"] == ["minus2", "plus5", "plus9"]
    assert not c.reached and "not reached" in c.note and "1 slip / 0 jump" in c.note
    assert c.settings == {"k": "minus2", "contact": "distributed", "contact_points": 9}
    assert c.eta_measured == pytest.approx(T * 0.998)
    assert c.evaluations == len(given) and c.price is None


def test_a_row_outside_the_uplift_threshold_is_not_priced_further(calls):
    _, c = _search(calls, [_row("closest", 0.001, uplift=False), _row("next", 0.003), _row("last", 0.004)])
    assert calls["uplift"][0] == "closest" and calls["price"] == ["next"]
    assert c.reached and c.settings["k"] == "next"
    assert c.price["counts"] and c.price["first_quarter_s"] == 0.1
    assert c.price["period_change"] == pytest.approx(0.0)


def test_the_first_row_that_counts_is_chosen(calls):
    _, c = _search(calls, [_row("slips", 0.001, slip=2), _row("counts", 0.002), _row("also", 0.003)])
    assert c.reached and c.settings["k"] == "counts" and c.eta_measured == pytest.approx(T * 1.002)
    assert calls["price"] == ["slips", "counts"]
    assert [x["k"] for x in calls["stored"]["price_tried"]] == ["slips", "counts"]
    assert c.note.startswith("reached with 9 points along the base, k counts, 3 impacts measured; price:")


def test_none_counts_is_not_reached_after_at_most_max_price_tries(calls):
    given = [_row(f"r{i}", 0.0005 * i, uplift=False) for i in range(MAX_PRICE_TRIES + 3)]
    _, c = _search(calls, given)
    assert calls["uplift"] == [f"r{i}" for i in range(MAX_PRICE_TRIES)] and calls["price"] == []
    assert not c.reached and c.settings["k"] == "r0" and "uplift 0.900" in c.note


def test_nothing_within_one_percent_gives_the_closest_regular(calls):
    _, c = _search(calls, [_row("far", 0.05), _row("scatter", 0.015, std=0.05), _row("near", -0.03)])
    assert calls["uplift"] == [] and not c.reached and c.settings["k"] == "near"
    assert "the closest regular η is" in c.note


def test_rows_are_tried_in_the_picks_order(calls):
    """The one pick orders the reached rows: a hopping row is never tried, a spread beyond 2 % of the
    target (0.016 here) is not regular, and the stiffer row (less resting sink) goes before a closer one."""
    hop, sink = 1e-3, 1e-6       # hop above 0.05 % of b (22.5 µm); sinks 1 and 20 µm differ by more than 4.5 µm
    given = [{**_row("hops", 0.0), "hop_m": hop, "sink_m": 0.0}, _row("scatter", 0.0, std=0.017),
             {**_row("soft-close", 0.0005), "sink_m": 20 * sink}, {**_row("stiff", 0.008), "sink_m": sink}]
    _, c = _search(calls, given)
    assert calls["uplift"] == ["stiff"] and c.reached and c.settings["k"] == "stiff"
