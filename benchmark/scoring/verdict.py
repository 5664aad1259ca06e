"""The verdict of a score document: each engine variant's value on the fixed suite with its 95 % interval,
each variant against the best of its settings class, what the suite could have detected, which variants
fail and where, equivalence with the restitution's uncertainty and of the held-out calibration, claims
about problems in general where the suite may make them, and the sentences that say so.

Pure functions of a score document (the ``pairs`` of
:func:`rockbench.benchmark.scoring.score_runs.score_entries`) and the suite's declarations
(:class:`~rockbench.benchmark.scoring.declared.Declared`); no file, no plotting. docs/scores.md argues
every rule; each lives in its own module:

- **The measure** is :data:`~rockbench.benchmark.scoring.metrics.PRIMARY_METRIC` per scenario (block ×
  pulse), scenarios in problems (slenderness × pulse, :mod:`~rockbench.benchmark.scoring.scenarios`).
- **The value** on the fixed suite: the mean over problems, its error the scenarios' measured errors
  only (:func:`~rockbench.benchmark.scoring.statistics.fixed`).
- **Comparisons**: within each class (calibrated; as shipped) against the best by Hsu's multiple
  comparisons with the best, with the class's minimal detectable difference
  (:mod:`~rockbench.benchmark.scoring.comparisons`); planted restitutions measure the suite's power
  (:mod:`~rockbench.benchmark.scoring.power`).
- **Failing**: one in-sample scenario beyond the declared ``fail_distance`` (:mod:`~rockbench.benchmark.scoring.failing`).
- **Equivalence** with the restitution's uncertainty, and the held-out check, by tests against declared
  margins (:mod:`~rockbench.benchmark.scoring.equivalence`).
- **In words**: the report's :mod:`~rockbench.benchmark.report.verdict_words` (the verdict holds numbers only).
"""

from __future__ import annotations

import math

from rockbench.benchmark.scoring.comparisons import ON_SUITE, COMPARED, Family, add_general, headline, critical_for_power, families, general_scope, general_value, ranks
from rockbench.benchmark.scoring.declared import DEFAULTS, Declared, fail_limit
from rockbench.benchmark.scoring.equivalence import held_out_check, restitution_test
from rockbench.benchmark.scoring.failing import failing_scenarios, fails, reason_kinds, reasons
from rockbench.benchmark.scoring.metrics import PRIMARY, PRIMARY_METRIC
from rockbench.benchmark.scoring.engine_power import engine_planted_power
from rockbench.benchmark.scoring.labels import ENGINE_PLANTED_CLASS
from rockbench.benchmark.scoring.power import planted_power, restitution_response
from rockbench.benchmark.scoring.scenarios import Variant, items, reference_gaps, variants_of
from rockbench.benchmark.scoring.statistics import CONFIDENCE, fixed

#: The groups of the verdict's table and picture, in their order.
GROUPS = ("calibrated", "as-shipped", "other", "held-out", "planted", "engine-planted")


def group_of(v: Variant) -> str:
    """Where a variant is shown: its compared class, ``held-out``, ``planted`` (the reference solver's),
    ``engine-planted`` (an engine calibrated to η·(1 + δ)) or ``other`` (set by hand)."""
    if v.held_out_only:
        return "held-out"
    if v.planted_factor is not None:
        return "engine-planted" if v.settings == ENGINE_PLANTED_CLASS else "planted"
    return v.settings if v.settings in COMPARED else "other"


def verdict(doc: dict, declared: Declared | None = None) -> dict:
    """The ``verdict`` object of score.json (docs/scores.md, "The verdict in score.json"); ``declared``
    defaults to the code's :data:`~rockbench.benchmark.scoring.declared.DEFAULTS`."""
    declared = declared or DEFAULTS
    vs = variants_of(doc)
    limit = fail_limit(declared, reference_gaps(doc))
    fams = families(vs, _limit(limit))
    scope = general_scope(vs, declared)
    for f in fams.values():
        add_general(f, scope)
    rk = ranks(fams)
    power = planted_power(vs, *critical_for_power(fams))
    response = restitution_response(vs)
    by_name = {v.name: v for v in vs}
    rows = [_row(v, fams, rk, scope, declared, limit, by_name.get(v.in_sample), response) for v in vs]
    rows.sort(key=_order)
    out = {"metric": PRIMARY_METRIC, "direction": PRIMARY.direction, "unit": PRIMARY.unit, "confidence": CONFIDENCE,
           "declared": declared.to_dict(), "fail_distance": limit["value"], "fail_limit": limit,
           "mcb": {cls: f.to_dict() for cls, f in fams.items()}, "power": power,
           "engine_power": engine_planted_power(vs), "general": scope,
           "equivalence": {"margin": declared.equivalence_margin,
                           "within": [r["variant"] for r in rows if (r["equivalence"] or {}).get("within")
                                      and not r["fails"] and r["group"] in COMPARED]},
           "variants": rows}
    return out


def _order(r: dict):
    return (r["fails"], GROUPS.index(r["group"]), r["rank"] or 9,
            -(r["planted"] or {}).get("eta_factor", 0.0), math.inf if r["value"] is None else r["value"], r["label"])


def _limit(limit: dict) -> float:
    """The fail limit's value as the failing rule takes it: infinite where the run gives none (no η_H–η_M
    gap for the declared rule), so only a missing boundary fails."""
    return math.inf if limit["value"] is None else limit["value"]


def _row(v: Variant, fams: dict[str, Family], rk: dict, scope: dict, declared: Declared, fail: dict,
         twin: Variant | None, response: dict | None) -> dict:
    e = fixed(list(items(v).values()))
    value = None if not e["items"] or v.placeholders() else e["mean"]   # never a mean over placeholders
    limit = _limit(fail)
    row = {"variant": v.name, "engine": v.engine, "label": v.label, "settings": v.settings, "group": group_of(v),
           "value": value, "se": None if value is None else e["se"],
           "ci95": None if value is None else [max(e["ci95"][0], PRIMARY.perfect), e["ci95"][1]],
           "basis": _basis(e, v) if value is not None else "", "rank": rk.get(v.name), "pairs": len(v.scenarios),
           "scenarios_with_value": e["items"], "clusters": e["clusters"],
           "cells_judged": v.counts.get("cells_in_domain", 0), "cell_diagonal": _mean_cell(v),
           "fails": fails(v, limit), "fails_in": failing_scenarios(v, limit), "reasons": reasons(v),
           "reason_kinds": reason_kinds(v), "shipped_note": v.shipped_note or None, "cells_missing": v.cells_missing,
           "equivalence": None if v.held_out_only else restitution_test(v, declared),
           "held_out": held_out_check(v, twin, declared, response), "general": general_value(v, scope),
           "planted": _planted(v),
           **offsets(v), "per_scenario": per_scenario(v, limit)}
    row.update(_standing(v, fams))
    return row


def _planted(v: Variant) -> dict | None:
    """A planted variant's factor and δ: the reference's η·(1 − δ), an engine's calibration to η·(1 + δ)."""
    if v.planted_factor is None:
        return None
    sign = 1.0 if v.settings == ENGINE_PLANTED_CLASS else -1.0
    return {"eta_factor": v.planted_factor, "delta": round(sign * (v.planted_factor - 1.0), 12) + 0.0}   # never −0


def _basis(e: dict, v: Variant) -> str:
    if not e["items"]:
        return ""
    n, c = e["items"], e["clusters"]
    return (f"on these {c} problem{'s' if c != 1 else ''} (slenderness × pulse) of {n} scenario{'s' if n != 1 else ''}: "
            "normal interval from each scenario's own error, " + _sd_source(v))


def _sd_source(v: Variant) -> str:
    """Where a variant's scenario errors come from, in words."""
    used = [s.sd_measured for s in v.finite().values()]
    if used and all(used):
        return "measured on its maps (the bisection's last intervals)"
    if any(used):
        return "measured on its maps where they say, else assumed from the grid's cell"
    return "assumed from the grid's cell (a 401 × 401 probe), not measured on these maps"


def _standing(v: Variant, fams: dict[str, Family]) -> dict:
    """A compared variant's place in its class: identical variants, the best subset and how far behind
    the best it may be by its headline standing (``scope``: across problems where the class has that
    comparison, else on this suite), the same on this suite (``on_suite``) and across problems
    (``across``), and its comparisons on this suite with the other entries of its class."""
    for f in fams.values():
        for ent in f.entries:
            if v in ent:
                head = ent[0].name
                m = f.mcb[head]
                versus = [dict(f.versus[(head, o)], other=o,
                               resolved_behind=_behind(f, head, o), general=f.general.get(head) if o == f.best else None)
                          for o in (e[0].name for e in f.entries) if o != head]
                h = headline(f, head)
                on_suite = {"scope": ON_SUITE, "in_best_subset": m["in_best_subset"], "best_in_class": head == f.best,
                            "behind_best": _finite(m["behind"]), "critical": m["critical"]}
                return {"same_as": [o.name for o in ent if o is not v], "scope": h["scope"],
                        "in_best_subset": h["in_best_subset"], "best_in_class": h["best_in_class"],
                        "behind_best": _finite(h["behind"]), "critical": m["critical"], "on_suite": on_suite,
                        "across": None if f.across is None else f.across["entries"][head], "versus": versus}
    return {"same_as": [], "scope": None, "in_best_subset": None, "best_in_class": False, "behind_best": None,
            "critical": None, "on_suite": None, "across": None, "versus": []}


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _behind(f: Family, i: str, j: str) -> bool:
    """Entry ``i`` is resolved behind ``j``: value_i − value_j > q_i·se_ij (what puts it out of the best subset)."""
    r = f.versus[(i, j)]
    return r["se"] is not None and r["difference"] > f.mcb[i]["critical"] * r["se"]


def _mean_cell(v: Variant) -> float:
    cells = [s.cell for s in v.scenarios.values()]
    return sum(cells) / len(cells) if cells else math.nan


def offsets(v: Variant) -> dict:
    """A variant's signed boundary offset beside its distance: ``offset`` [w/a units] and
    ``offset_percent`` [% of the reference's critical amplitude], each the mean over problems of its
    in-sample scenarios that have one (sizes of a problem averaged first, as the value), + where the
    engine overturns at a lower amplitude than the reference; None where no scenario has one (a record
    scored before the metric, or every scenario without a boundary)."""
    out = {"offset": None, "offset_percent": None}
    if v.placeholders():
        return out                       # no mean where a scenario has no boundary
    for key, attr in (("offset", "offset"), ("offset_percent", "offset_percent")):
        its = [(getattr(s, attr), 0.0, s.cluster) for s in v.scenarios.values()
               if not s.held_out and math.isfinite(getattr(s, attr)) and math.isfinite(s.distance)]
        out[key] = _num(fixed(its)["mean"]) if its else None
    return out


def per_scenario(v: Variant, limit: float) -> list[dict]:
    """score.json's per-scenario values of a variant: value (None where a map has no boundary, named in
    ``missing_boundary``), its signed offset (``offset``, ``offset_percent``), own error (``sd``:
    ``sd_source`` "measured" on the two maps' bisection intervals or "assumed" from the grid, with the
    grid's figure ``sd_assumed`` beside it as a check), cluster, the η_H–η_M gap and the value over it, held-out or not,
    and whether it fails there."""
    bad = {(b["block"], b["pulse"]) for b in failing_scenarios(v, limit)}
    out = []
    for (block, pulse), s in sorted(v.scenarios.items()):
        gap = s.gap if math.isfinite(s.gap) else None
        out.append({"block": block, "pulse": pulse, "cluster": list(s.cluster), "value": _num(s.distance),
                    "missing_boundary": s.missing_boundary or None, "offset": _num(s.offset),
                    "offset_percent": _num(s.offset_percent),
                    "sd": s.sd, "sd_source": "measured" if s.sd_measured else "assumed",
                    "sd_assumed": _num(s.sd_assumed), "cell_diagonal": s.cell, "reference_gap": gap,
                    "relative_to_gap": _num(s.distance / s.gap) if gap else None, "held_out": s.held_out,
                    "fails": (block, pulse) in bad})
    return out


def _num(x):
    return x if x is not None and math.isfinite(x) else None

