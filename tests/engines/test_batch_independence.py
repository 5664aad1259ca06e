"""A cell's answer does not depend on its batch-mates.

A map hands an engine with a native batch (``batching = "native"``) its cells in batches of up to
``max_worlds`` worlds, in whatever order and company the sweep's rounds give them. The same target
cells run here alone (a batch of one) and in batches of other composition: the targets together, in
reverse order, beside other pulses, in a full batch of :data:`ENGINES`' worlds. Every target's
verdict (outcome, impacts, validity, flags) must be the same in each, and its θ history the same to
the last digit.

Drake runs one world a batch, but its batch hooks run up to 16 worlds in one diagram, a plant each:
they are checked here at 16, calibrated (SAP) and as shipped (``lagged``). Blocks of one plant were
not independent (SAP solved them as one problem, with one convergence test): as shipped, two of the
targets below changed outcome or moved by 0.5 rad beside their batch-mates in a map's bisection.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from cells import cell_case

from rockbench.engines.registry import get_adapter

pytestmark = pytest.mark.engine

#: variant → (engine, its Python module, settings, worlds a batch here); every θ the same bit for bit
ENGINES = {
    "drake": ("drake", "pydrake", {}, 16),
    "drake-shipped": ("drake", "pydrake", {"settings": "shipped"}, 16),
}

#: the cells checked: B3M, (pulse, ω/p, a₀/(g·tanα)): rest or rocking, impacts, and overturns early
#: and late (the yardstick's range); the last two, from the as-shipped B3M sine map's boundary, moved
#: in one-plant batches of 16 (overturn alone, rocking in a batch; θ 0.49 rad apart)
TARGETS = [("sine", 2.0, 1.5), ("sine", 3.0, 1.5), ("sine", 5.0, 3.0), ("sine", 2.0, 3.0), ("sine", 4.0, 4.5),
           ("sine", 3.0, 6.0), ("sine", 6.142857142857142, 9.721428571428572),
           ("sine", 7.482142857142857, 11.685714285714285)]
#: batch-mates: other pulses, other lengths
OTHERS = [("cosine", w, a) for w in (1.5, 2.5, 4.0, 6.0, 8.0) for a in (1.2, 2.5)]


def _compositions(n_max: int) -> dict:
    """Batches (lists of ("t", i) targets and ("o", j) others), by name; each target also runs alone."""
    t = [("t", i) for i in range(len(TARGETS))]
    o = [("o", j) for j in range(len(OTHERS))]
    out = {"together": t, "reversed": t[::-1], "among others": o[:5] + t[::2] + o[5:7] + t[1::2],
           "full batch": (o + t)[-n_max:] if n_max >= len(t) else t[:n_max]}
    out.update({f"beside one other {k}": [o[k], t[k]] for k in range(len(t))})
    return {k: v[:n_max] for k, v in out.items()}


def _runs(ad, batch: list) -> dict:
    """The targets of one batch (run as one ``_simulate_many`` call, one batch): target → (trajectory, verdict)."""
    cases = [ad.posed(cell_case("B3M", *(TARGETS if kind == "t" else OTHERS)[i])) for kind, i in batch]
    assert len({c.dt_s for c in cases}) == 1, "one step for the batch, so that it is one batch"
    trs = ad._simulate_many(cases)
    return {i: (tr, ad.judge(c, tr)) for (kind, i), c, tr in zip(batch, cases, trs) if kind == "t"}


def _theta_difference(a, b) -> float:
    """The largest |Δθ| [rad] of two runs of one cell, up to the overturn (or over the whole run,
    which must then have the same length): after it θ only says how far the block has fallen."""
    ra, rb = a[1], b[1]
    n = min(a[0].t_s.size, b[0].t_s.size)
    if ra.outcome == "overturn":
        n = min(n, int(np.searchsorted(a[0].t_s, ra.t_overturn_s)))
    else:
        assert a[0].t_s.size == b[0].t_s.size
    return float(np.max(np.abs(a[0].theta_rad[:n] - b[0].theta_rad[:n])))


def differences(variant: str) -> dict:
    """Each composition's largest |Δθ| [rad] from the targets run alone; asserts the verdicts equal."""
    engine, _module, settings, worlds = ENGINES[variant]
    ad = get_adapter(engine, **settings)
    ad.max_worlds = worlds
    alone = {i: _runs(ad, [("t", i)])[i] for i in range(len(TARGETS))}
    assert len({r.outcome for _tr, r in alone.values()}) >= 2, "the cells span more than one outcome"
    out = {}
    for name, batch in _compositions(ad.max_worlds).items():
        worst = 0.0
        for i, run in _runs(ad, batch).items():
            a, b = alone[i][1], run[1]
            assert (b.outcome, b.n_impacts, b.valid, b.flags) == (a.outcome, a.n_impacts, a.valid, a.flags), \
                (name, TARGETS[i])
            worst = max(worst, _theta_difference(alone[i], run))
        out[name] = worst
    return out


@pytest.mark.parametrize("variant", [
    pytest.param(v, marks=pytest.mark.skipif(importlib.util.find_spec(m) is None, reason=f"{e} not installed"))
    for v, (e, m, _s, _w) in ENGINES.items()])
def test_a_cell_does_not_depend_on_its_batch_mates(variant):
    for name, worst in differences(variant).items():
        assert worst == 0.0, (name, worst)


@pytest.mark.skipif(importlib.util.find_spec("pydrake") is None, reason="drake not installed")
def test_drake_runs_one_world_a_batch():
    # measured: a world of a batch costs what it costs alone, and a world retired early still steps
    for settings in ({}, {"settings": "shipped"}, {"contact": "hydroelastic"}):
        ad = get_adapter("drake", **settings)
        assert ad.worlds_per_batch(ad.settings) == 1


if __name__ == "__main__":   # the differences (PYTHONPATH with tests/ for ``cells``)
    for v in ENGINES:
        print(v, {k: f"{x:.2g}" for k, x in differences(v).items()})
