"""The verdict's inference on hand-built maps and documents where the truth is known (issue 43's
acceptance): a planted shift is separated and grid noise is not; equivalence margins met and missed as
constructed; Hsu's best subset holds the true best in 95 % of simulated draws; the minimal detectable
difference is found with 80 % power; Dunnett's critical value agrees with SciPy's multivariate normal;
the general-claim interval equals the balanced mixed model's; the planted restitutions give the
smallest δ the suite resolves."""

import json
import math

import numpy as np
import pytest

from rockbench.benchmark.scoring.declared import Declared
from rockbench.benchmark.scoring.labels import CALIBRATED, PLANTED_CLASS
from rockbench.benchmark.scoring.statistics import (detectable, differences, dunnett_critical, general, mcb,
                                                    paired, slenderness_means, tost, z_one_sided)
from rockbench.benchmark.scoring.verdict import verdict
from rockbench.benchmark.report.verdict_words import sentences
from test_score_runs import run_cli

PROBLEMS = [(b, p) for b in ("B3M", "B6M") for p in ("sine", "cosine")]
SLENDER = {"B2M": 1.5, "B3M": 2.25, "B6M": 4.5, "B8M": 6.0}


def _pair(variant, block, pulse, value, *, sd_cell=0.2, gap=None, settings=CALIBRATED, **extra):
    step = sd_cell / math.sqrt(2)       # a cell diagonal of sd_cell: each scenario's error is a tenth of it
    return {"variant": variant, "engine": variant.split("[")[0], "label": variant, "settings": settings,
            "block": block, "pulse": pulse, "like_for_like": True, "slenderness": SLENDER[block],
            "scores": {"boundary_mean": value}, "cells": {"w_step": step, "a_step": step},
            "cells_in_domain": 1000, "reference_standing": 800, "reference_overturn": 200, **extra}


def _doc(values: dict, problems=PROBLEMS, gap=None, **kw) -> dict:
    pairs = [_pair(v, b, p, x, **kw.get(v, {})) for v, xs in values.items() for (b, p), x in zip(problems, xs)]
    gaps = [{"block": b, "pulse": p, "boundary_mean": gap} for b, p in problems] if gap is not None else []
    return {"pairs": pairs, "reference_gaps": gaps}


# -- Dunnett's critical value -----------------------------------------------------------------------------

@pytest.mark.parametrize("lambdas", [[math.sqrt(0.5)] * 2, [math.sqrt(0.5)] * 5, [0.3, 0.6, 0.8]])
def test_dunnett_critical_value_agrees_with_scipys_multivariate_normal(lambdas):
    """P(max Z_j ≤ q) = 95 % for equicorrelated (½) and one-factor (λ_j·λ_k) correlations, by SciPy's
    own multivariate normal (Genz's integration, to its own error)."""
    from scipy import stats
    q = dunnett_critical(lambdas)
    lam = np.array(lambdas)
    cov = np.outer(lam, lam)
    np.fill_diagonal(cov, 1.0)
    p = stats.multivariate_normal(mean=np.zeros(len(lam)), cov=cov).cdf(np.full(len(lam), q))
    assert p == pytest.approx(0.95, abs=2e-4)
    # Dunnett's table, one-sided, infinite degrees of freedom, correlation ½: 1.92 (2), 2.23 (5)
    if lambdas == [math.sqrt(0.5)] * 2:
        assert q == pytest.approx(1.916, abs=1e-3)
    if lambdas == [math.sqrt(0.5)] * 5:
        assert q == pytest.approx(2.234, abs=1e-3)


def test_one_comparison_is_the_normals_one_sided_quantile():
    assert dunnett_critical([0.7]) == pytest.approx(z_one_sided()) and dunnett_critical([]) == 0.0


# -- Hsu's best subset and the detectable difference, by simulation ------------------------------------------

def _draws(truth, sds, n, seed, clusters=8):
    """Simulated values of each variant: the mean over ``clusters`` problems of truth + noise with each
    variant's own per-problem error."""
    rng = np.random.default_rng(seed)
    k = len(truth)
    noise = rng.normal(0.0, 1.0, size=(n, k, clusters)) * np.asarray(sds)[None, :, None]
    return np.asarray(truth)[None, :] + noise.mean(axis=2)


def _subset_hits(truth, sds, n=4000, seed=7, clusters=8):
    """How often variant 0 (a true best) is in the best subset, over ``n`` draws."""
    sds = np.asarray(sds, float)
    var = (sds ** 2) / clusters
    names = [str(i) for i in range(len(truth))]
    se = {(a, b): math.sqrt(var[int(a)] + var[int(b)]) for a in names for b in names if a != b}
    hits = 0
    for row in _draws(truth, sds, n, seed, clusters):
        values = dict(zip(names, row))
        hits += mcb(values, se, dict(zip(names, var)))["0"]["in_best_subset"]
    return hits / n


def test_the_best_subset_holds_the_true_best_in_95_percent_of_draws():
    """Five variants equal in truth (the least favourable case): variant 0 stays in the subset in 95 % of
    4,000 draws (Monte Carlo error 0.35 %); with the others truly worse, more often."""
    hit = _subset_hits([0.02] * 5, [0.03] * 5)
    assert hit == pytest.approx(0.95, abs=0.011)
    assert _subset_hits([0.02, 0.03, 0.04, 0.05, 0.06], [0.03] * 5) > 0.97


def test_the_best_subset_keeps_its_guarantee_with_unequal_errors():
    """The true best measured four times more precisely than the others (correlation ¼ between its
    comparisons, not ½): the critical value for its own correlations keeps the 95 %."""
    assert _subset_hits([0.02] * 4, [0.01, 0.04, 0.04, 0.04]) >= 0.94
    assert _subset_hits([0.02] * 4, [0.04, 0.01, 0.01, 0.01]) >= 0.94


def test_the_minimal_detectable_difference_is_found_with_80_percent_power():
    """Two variants whose truths differ by (q + z₀.₈)·se: the worse is resolved behind the better in 80 %
    of 4,000 draws."""
    sd, clusters = 0.03, 8
    se = math.sqrt(2 * sd ** 2 / clusters)
    q = dunnett_critical([math.sqrt(0.5)])
    mdd = detectable(q, se)
    assert mdd == pytest.approx((1.6448536 + 0.8416212) * se)
    rows = _draws([0.02, 0.02 + mdd], [sd, sd], 4000, seed=11, clusters=clusters)
    found = np.mean(rows[:, 1] - rows[:, 0] > q * se)
    assert found == pytest.approx(0.80, abs=0.02)


# -- separated and not separated, on hand-built maps ------------------------------------------------------------

def _steps(n_w, first, rng=None, flips=0):
    """Per column, the first overturning row: a sloping boundary; ``flips`` columns moved by one row."""
    rows = np.round(first + 12 * np.linspace(0, 1, n_w) ** 2).astype(int)
    if rng is not None and flips:
        cols = rng.choice(n_w, size=flips, replace=False)
        rows[cols] += rng.choice([-1, 1], size=flips)
    return rows


def _map(n_a, first_rows):
    codes = np.ones((n_a, len(first_rows)), int)
    for j, r in enumerate(first_rows):
        codes[r:, j] = 2
    return codes


def test_a_planted_shift_is_separated_and_grid_noise_is_not(write_map, tmp_path, capsys):
    """Four problems on a 46 × 61 grid (cell diagonal 0.24): engine S's boundary lies one row (0.125)
    above the reference's everywhere, engines A and B differ from the reference in 2 columns each (one
    row up or down: grid noise). By `rockbench score`: S is resolved behind the best, A and B are not
    told apart."""
    rng = np.random.default_rng(3)
    n_w, n_a, grid = 46, 61, dict(w=(1.0, 10.0), a=(0.5, 8.0))
    root = tmp_path / "run"
    for block in ("B3M", "B6M"):
        for pulse in ("sine", "cosine"):
            ref = _steps(n_w, 20 + (5 if block == "B6M" else 0) + (3 if pulse == "cosine" else 0))
            kw = dict(block=block, pulse=pulse, **grid)
            write_map(root / f"ref-{block}-{pulse}", _map(n_a, ref), **kw)
            write_map(root / f"s-{block}-{pulse}", _map(n_a, ref + 1), engine="dart", **kw)
            for engine in ("mujoco", "pybullet"):
                noisy = np.clip(ref + _steps(n_w, 0, rng, flips=2) - _steps(n_w, 0), 1, n_a - 1)
                write_map(root / f"{engine}-{block}-{pulse}", _map(n_a, noisy), engine=engine, **kw)
    code, _, err = run_cli(capsys, "score", root)
    assert code == 0, err
    v = json.loads((root / "score.json").read_text())["verdict"]
    rows = {r["engine"]: r for r in v["variants"]}
    assert rows["dart"]["value"] == pytest.approx(0.125, abs=0.01)
    assert rows["dart"]["rank"] == 2 and not rows["dart"]["in_best_subset"]
    assert rows["mujoco"]["rank"] == rows["pybullet"]["rank"] == 1
    assert v["mcb"][CALIBRATED]["mdd"] < 0.125


# -- equivalence, met and missed as constructed -----------------------------------------------------------------

def test_an_equivalence_margin_met_and_missed_as_constructed():
    """Every scenario's gap 0.2, each scenario's error 0.02: A at a quarter of the gap is within on the
    mean and in every scenario; B at 0.95 of it is not shown (its upper bound passes 1); C within on the
    mean but one scenario (0.17 + 1.645 × 0.02 > 0.2) is not, and it is the worst named."""
    doc = _doc({"a": [0.05] * 4, "b": [0.19] * 4, "c": [0.05, 0.05, 0.17, 0.05]}, gap=0.2)
    rows = {r["variant"]: r for r in verdict(doc)["variants"]}
    a, b, c = (rows[n]["equivalence"] for n in "abc")
    assert a["mean_ratio"] == pytest.approx(0.25) and a["within"] and a["within_every_scenario"]
    assert b["mean_ratio"] == pytest.approx(0.95) and b["upper"] > 1 and not b["within"]
    assert c["within"] and not c["within_every_scenario"] and (c["worst"]["block"], c["worst"]["pulse"]) == ("B6M", "sine")
    v = verdict(doc)
    assert v["equivalence"]["within"] == ["a", "c"]
    text = next(t for t in sentences(v) if t.startswith("Within the uncertainty"))
    assert "Not shown: b" in text and "worst B6M sine" in text
    # a declared number instead of the gap: 0.5 holds B too
    assert verdict(doc, Declared(equivalence_margin=0.5))["equivalence"]["within"] == ["a", "c", "b"]


def test_equivalence_is_claimed_wrongly_in_at_most_5_percent_of_draws():
    """A variant exactly at the margin (mean ratio 1): the one-sided test claims "within" in 5 % of 4,000
    draws of its scenarios' errors."""
    rng = np.random.default_rng(5)
    sd, gap, n = 0.02, 0.2, 4000
    claims = 0
    for _ in range(n):
        values = list(gap + rng.normal(0.0, sd, size=4))
        claims += verdict(_doc({"x": values}, gap=gap))["variants"][0]["equivalence"]["within"]
    assert claims / n == pytest.approx(0.05, abs=0.011)


def test_the_held_out_check_is_a_paired_equivalence_test():
    """Held out against its twin on the same scenarios, margin 0.05: 0.01 apart with errors of 0.02 per
    scenario carries over (90 % interval −0.013 to +0.033); 0.03 apart with errors of 0.04 does not show
    it (up to +0.077) nor is it resolved worse; 0.2 apart is resolved worse."""
    own, held = "m[settings=calibrated]", "m[calibrate_on=neighbour,settings=calibrated]"
    for shift, sd, carries, worse in ((0.01, 0.02, True, False), (0.03, 0.04, False, False), (0.2, 0.02, False, True)):
        doc = _doc({own: [0.03] * 4}, **{own: {"sd_cell": 10 * sd}})
        doc["pairs"] += [_pair(held, b, p, 0.03 + shift, settings=held, held_out=True, in_sample_variant=own,
                               sd_cell=10 * sd) for b, p in PROBLEMS]
        h = {r["variant"]: r for r in verdict(doc, Declared(held_out_margin=0.05))["variants"]}[held]["held_out"]
        assert h["in_sample_scope"] == "same scenarios" and h["difference"] == pytest.approx(shift)
        assert h["carries_over"] is carries and (h["difference_ci95"][0] > 0) is worse
        t = tost(h["difference"], paired_se := h["tost"]["interval"][1] - h["difference"], 0.05)
        assert paired_se > 0 and t["equivalent"] is carries


# -- claims about problems in general ------------------------------------------------------------------------

WIDE = [(b, p) for b in ("B2M", "B3M", "B6M", "B8M") for p in ("sine", "cosine")]


def test_a_claim_about_problems_in_general_needs_the_declared_range():
    """Four slendernesses spanning h/b 1.5–6.0: stated; two (2.25 and 4.5): not, and the verdict says why."""
    vals = [0.01, 0.02, 0.015, 0.03, 0.02, 0.01, 0.04, 0.03]
    v = verdict(_doc({"a": vals, "b": [x + 0.01 for x in vals]}, problems=WIDE))
    assert v["general"]["stated"] and v["general"]["slendernesses"] == [1.5, 2.25, 4.5, 6.0]
    a = next(r for r in v["variants"] if r["variant"] == "a")
    assert a["general"]["df"] == 3 and a["general"]["slendernesses"] == 4
    assert any(t.startswith("About problems in general (h/b 1.5–6, 4 slendernesses") for t in sentences(v))
    narrow = verdict(_doc({"a": vals[:4]}))
    assert not narrow["general"]["stated"] and narrow["variants"][0]["general"] is None
    assert "span h/b 2.25–4.5 with 2 slendernesses" in " ".join(sentences(narrow))


def _balanced(seed=2):
    """y[engine, slenderness, pulse] of a balanced design with every variance component present."""
    rng = np.random.default_rng(seed)
    E, S, P = 2, 4, 2
    a_s = rng.normal(0, 0.03, S)[None, :, None]
    b_sp = rng.normal(0, 0.01, (S, P))[None, :, :]
    ea = rng.normal(0, 0.02, (E, S))[:, :, None]
    eps = rng.normal(0, 0.005, (E, S, P))
    return np.array([0.05, 0.08])[:, None, None] + a_s + b_sp + ea + eps


def _items(y, e):
    keys = [(s, p) for s in (1.5, 2.25, 4.5, 6.0) for p in ("sine", "cosine")]
    return {k: (float(y[e, i // 2, i % 2]), 0.004, k) for i, k in enumerate(keys)}


def test_the_general_interval_equals_the_balanced_mixed_models():
    """The mixed model y = μ_e + a_s + b_sp + (ea)_es + ε, balanced, by its ANOVA (what REML gives when
    every component is positive): the engine contrast's standard error is √(2·MS_E×S/(S·P)) on
    (E − 1)(S − 1) degrees of freedom, a single engine's mean's √(MS_S/(S·P)) on S − 1. The verdict's
    Student's t over slenderness means gives the same numbers."""
    from scipy import stats
    y = _balanced()
    E, S, P = y.shape
    ybar_es = y.mean(axis=2)
    inter = ybar_es - ybar_es.mean(axis=1, keepdims=True) - ybar_es.mean(axis=0, keepdims=True) + ybar_es.mean()
    ms_es = P * (inter ** 2).sum() / ((E - 1) * (S - 1))
    se_diff = math.sqrt(2 * ms_es / (S * P))
    diff = y[1].mean() - y[0].mean()
    t = stats.t.ppf(0.975, (E - 1) * (S - 1))
    g = general(differences(_items(y, 1), _items(y, 0)))
    assert g["mean"] == pytest.approx(diff) and g["se"] == pytest.approx(se_diff)
    assert g["ci95"] == pytest.approx([diff - t * se_diff, diff + t * se_diff]) and g["df"] == 3
    ms_s = P * ((ybar_es[0] - ybar_es[0].mean()) ** 2).sum() / (S - 1)
    one = general(list(_items(y, 0).values()))
    assert one["se"] == pytest.approx(math.sqrt(ms_s / (S * P)))
    assert slenderness_means(list(_items(y, 0).values()))[1.5] == pytest.approx(ybar_es[0, 0])


@pytest.mark.filterwarnings("ignore:The MLE may be on the boundary")
def test_the_general_interval_equals_statsmodels_mixedlm():
    """The same equality against statsmodels' REML fit (where statsmodels is installed; it is no
    dependency of rockbench): random slenderness, problem and engine × slenderness effects, every
    variance component estimated positive (where one sits on 0, REML and the ANOVA part ways)."""
    smf = pytest.importorskip("statsmodels.formula.api")
    import pandas as pd
    y = _balanced()
    E, S, P = y.shape
    data = pd.DataFrame([{"y": y[e, s, p], "engine": e, "s": s, "pulse": p} for e in range(E) for s in range(S)
                         for p in range(P)])
    fit = smf.mixedlm("y ~ C(engine)", data, groups="s", re_formula="1",
                      vc_formula={"sp": "0 + C(pulse)", "es": "0 + C(engine)"}).fit(reml=True)
    assert fit.cov_re.values.min() > 0 and min(fit.vcomp) > 0 and fit.scale > 0
    g = general(differences(_items(y, 1), _items(y, 0)))
    assert fit.params["C(engine)[T.1]"] == pytest.approx(g["mean"], rel=1e-6)
    assert fit.bse["C(engine)[T.1]"] == pytest.approx(g["se"], rel=1e-3)


# -- the suite's power, planted ------------------------------------------------------------------------------------

def test_planted_restitutions_give_the_smallest_delta_resolved():
    """Planted distances growing with δ (0, 0.004, 0.012, 0.03) with errors of 0.004 per scenario over 4
    problems: δ = 0.5 % is not resolved from δ = 0, 1 % and 2 % are; the tie sentence and score.json say so."""
    values = {"d0": [0.0] * 4, "d05": [0.004] * 4, "d1": [0.012] * 4, "d2": [0.03] * 4}
    factors = {"d0": 1.0, "d05": 0.995, "d1": 0.99, "d2": 0.98}
    doc = _doc({**values, "mujoco": [0.01] * 4, "dart": [0.02] * 4}, sd_cell=0.04,
               **{k: {"settings": PLANTED_CLASS, "planted_eta_factor": f, "sd_cell": 0.04} for k, f in factors.items()},
               mujoco={"sd_cell": 0.04}, dart={"sd_cell": 0.04})
    v = verdict(doc)
    p = v["power"]
    assert p["against"] == "d0" and p["smallest_resolved_delta"] == pytest.approx(0.01)
    rows = {r["variant"]: r for r in p["planted"]}
    assert not rows["d05"]["resolved"] and rows["d1"]["resolved"] and rows["d2"]["resolved"]
    assert rows["d1"]["difference"] == pytest.approx(0.012)
    assert {r["variant"] for r in v["variants"] if r["group"] == "planted"} == set(values)
    assert all(r["rank"] is None for r in v["variants"] if r["group"] == "planted")
    cal = sentences(v)[0]
    assert "a restitution planted 1 % below its target, its boundary 0.012 from the reference's, is resolved" in cal
    assert "0.5 % is not" in cal
    assert any("the smallest δ this suite resolves from δ = 0: 1 %" in t for t in sentences(v))
    assert paired({}, {})["difference"] is None
    # a planted restitution far off is the yardstick's own reach, never a failing engine
    doc["pairs"] += [_pair("d10", b, p, 0.6, settings=PLANTED_CLASS, planted_eta_factor=0.9, sd_cell=0.04)
                     for b, p in PROBLEMS]
    far = {r["variant"]: r for r in verdict(doc)["variants"]}["d10"]
    assert not far["fails"] and far["group"] == "planted" and far["fails_in"] == []


def test_dunnetts_t_critical_value():
    """One comparison: Student's t; many: above the normal Dunnett value, falling to it as df grows
    (Dunnett's one-sided table: 2.32 for five comparisons on 35 degrees of freedom, 2.23 on ∞)."""
    from scipy import stats

    from rockbench.benchmark.scoring.statistics import dunnett_critical, dunnett_t_critical
    assert dunnett_t_critical(1, 7) == pytest.approx(stats.t.ppf(0.95, 7))
    assert dunnett_t_critical(5, 35) == pytest.approx(2.32, abs=0.01)
    assert dunnett_t_critical(5, math.inf) == pytest.approx(dunnett_critical([math.sqrt(0.5)] * 5))
    assert dunnett_t_critical(5, 14) > dunnett_t_critical(5, 35) > dunnett_t_critical(5, 1000)
