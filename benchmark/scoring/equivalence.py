"""Equivalence claims, each made by a test against a margin the suite declared beforehand
(:mod:`~rockbench.benchmark.scoring.declared`; docs/scores.md, "Equivalence"):

- **Within the uncertainty of the restitution**: a variant's distances against the equivalence margin
  (by default each scenario's own η_H–η_M reference gap), on the mean over the problems (a one-sided
  5 % test that the mean of distance/margin is below 1) and per scenario (d + z₀.₉₅·sd below the
  margin), the worst scenario named.
- **The held-out check**: a held-out variant against its in-sample twin (the same settings calibrated
  on each block itself) by a paired two one-sided test with ``held_out_margin`` (by default half the
  mean η_H–η_M gap of the tested scenarios, :func:`~.declared.held_out_margin_of`); "carries over" only
  when it passes.
"""

from __future__ import annotations

import math

from rockbench.benchmark.scoring.declared import RESTITUTION_GAP, Declared, held_out_margin_of
from rockbench.benchmark.scoring.scenarios import Scenario, Variant, items
from rockbench.benchmark.scoring.statistics import fixed, paired, paired_clusters, tost, upper_bound


def margin_of(s: Scenario, declared: Declared) -> float | None:
    """A scenario's equivalence margin [w/a units]: its η_H–η_M reference gap, or the declared number;
    None when the gap is not known or is 0 on its grid."""
    m = s.gap if declared.equivalence_margin == RESTITUTION_GAP else float(declared.equivalence_margin)
    return m if math.isfinite(m) and m > 0 else None


def restitution_test(v: Variant, declared: Declared) -> dict | None:
    """The equivalence of a variant's in-sample distances with the margin (module docstring); None
    without a scenario that has a margin, or with a scenario whose boundary is missing.

    The margin is taken as declared: the gap as measured on the suite's grid, its own grid error not
    carried (a margin is a definition, not an estimate)."""
    if v.placeholders():
        return None                      # a missing boundary has no distance to test
    rows, ratio_items = [], []
    for (block, pulse), s in sorted(v.scenarios.items()):
        m = margin_of(s, declared)
        if s.held_out or not math.isfinite(s.distance) or m is None:
            continue
        up = upper_bound(s.value, s.sd)
        rows.append({"block": block, "pulse": pulse, "value": s.value, "upper": up, "margin": m,
                     "within": up < m})
        ratio_items.append((s.value / m, s.sd / m, s.cluster))
    if not rows:
        return None
    e = fixed(ratio_items)
    upper = upper_bound(e["mean"], e["se"])
    worst = max(rows, key=lambda r: r["upper"] / r["margin"])
    return {"margin": declared.equivalence_margin, "scenarios": len(rows), "clusters": e["clusters"],
            "mean_ratio": e["mean"], "se": e["se"], "upper": upper, "within": upper < 1.0,
            "within_every_scenario": all(r["within"] for r in rows), "worst": worst, "per_scenario": rows}


def held_out_check(v: Variant, twin: Variant | None, declared: Declared, response: dict | None = None) -> dict | None:
    """The held-out check of a variant: its held-out scenarios' value and interval, its twin's value on
    the same scenarios (else on the other size of the same problems, else none), and the paired two
    one-sided test of their difference with ``held_out_margin``, over the held-out scenarios that can
    test anything (:func:`left_out`; ``response``: :func:`~.power.restitution_response`); the margin
    (``margin``, with ``margin_rule``) from those scenarios' gaps where the suite declares the rule, and
    no test where none of them has a gap. None without a held-out scenario."""
    held_all = items(v, held_out=True)
    if not held_all:
        return None
    e = fixed(list(held_all.values()))
    out_of_test = left_out(v, twin, response)
    held = {k: x for k, x in held_all.items() if k not in {(b["block"], b["pulse"]) for b in out_of_test}}
    mine = items(twin) if twin is not None else {}
    clusters = {x[2] for x in held.values()}
    same = {k: x for k, x in mine.items() if k in held}
    problems = {k: x for k, x in mine.items() if x[2] in clusters}
    margin = held_out_margin_of(declared, [(v.scenarios[k].gap, x[2]) for k, x in held.items()])
    out = {"value": e["mean"], "ci95": _clip(e["ci95"]), "scenarios": len(held_all), "margin": margin,
           "margin_rule": None if isinstance(declared.held_out_margin, float) else declared.held_out_margin,
           "tested_scenarios": len(held), "left_out": out_of_test,
           "in_sample": None, "in_sample_scope": "none", "in_sample_variant": None, "difference": None,
           "difference_ci95": None, "tost": None, "carries_over": False}
    if same:
        d, base, scope = paired(held, same), same, "same scenarios"
    elif problems:
        d, base, scope = paired_clusters(held, problems), problems, "same problems"
    else:
        return out
    out.update(in_sample=fixed(list(base.values()))["mean"], in_sample_scope=scope, in_sample_variant=twin.name,
               difference=d["difference"], difference_ci95=d["ci95"])
    if margin is None:
        return out                       # the rule has no gap to stand on: no test
    t = tost(d["difference"], d["se"], margin)
    out.update(tost=t, carries_over=t["equivalent"])
    return out


def left_out(v: Variant, twin: Variant | None, response: dict | None) -> list[dict]:
    """The held-out scenarios that test nothing, each with why: its value is bit-identical to its in-sample
    twin's in the same scenario (the calibration on the other block chose what the in-sample one chose),
    or its boundary does not respond to the restitution (``response``: a planted restitution error of
    the suite's largest δ is not resolved there)."""
    out = []
    for k, s in sorted(v.scenarios.items()):
        if not s.held_out or not math.isfinite(s.distance):
            continue
        t = twin.scenarios.get(k) if twin is not None else None
        t = None if t is None or t.held_out else t        # a variant of mixed scenarios is not its own twin
        if t is not None and t.value == s.value and (s.cells_id is None or t.cells_id in (None, s.cells_id)):
            out.append({"block": k[0], "pulse": k[1], "why": "identical to its in-sample twin"})
        elif response is not None and response["responds"].get(k) is False:
            out.append({"block": k[0], "pulse": k[1],
                        "why": f"does not respond to the restitution (η {100 * response['delta']:g} % off not resolved)"})
    return out


def _clip(ci: list | None) -> list | None:
    """An interval of a distance (≥ 0) clipped at 0."""
    return None if ci is None else [max(ci[0], 0.0), ci[1]]
