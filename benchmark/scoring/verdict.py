"""The verdict of a score document: one primary measure per engine variant, its 95 % interval, tie
groups, which variants fail and in which scenario, how their errors compare with the physics' own
uncertainty, and the sentences that say so.

Pure functions of a score document (the ``pairs`` of :func:`rockbench.benchmark.scoring.score_runs.score_entries`);
no file, no plotting. docs/scores.md argues every rule below; in short:

- **The measure** is :data:`~rockbench.benchmark.scoring.metrics.PRIMARY_METRIC` (the mean distance between the
  overturning boundaries), taken per *scenario* (block × pulse) from the variant's like-for-like pairs.
- **The replicates** are the clusters slenderness × pulse (:mod:`~rockbench.benchmark.scoring.scenarios`): a
  variant's value is the mean over clusters of its scenarios' values (sizes of one slenderness averaged),
  its interval Student's t over the clusters with each scenario's own error from the grid's resolution
  (:func:`~rockbench.benchmark.scoring.scenarios.resolution_sd`) added
  (:mod:`~rockbench.benchmark.scoring.statistics`).
- **Identical answers** (one engine, the same cells everywhere) are one entry: compared, counted and
  ranked once.
- **Ranks** are tie groups of the passing entries: in order of their value, paired differences over
  the clusters they share (no floor: a perfect 0 is compared as it is, with the grid's own error),
  Holm-corrected over every comparison between passing entries, a new group opened by the first
  entry that a corrected comparison resolves from a member of the current group. A failing variant
  has no rank.
- **Failing**: a variant fails when in *any* scenario its boundary lies more than :data:`FAIL_CELLS`
  cell diagonal from the reference's (the grid itself resolves that), whatever its mean, or when
  nothing it simulated could be judged; the verdict names the scenario, the reasons read from its cell
  counts, and what its adapter says about its shipped settings.
- **The physics' scale**: each distance also over the distance between the η_H and η_M (average k)
  reference boundaries of the same scenario; an interval wholly below 1 is "within the uncertainty of
  the restitution itself".
"""

from __future__ import annotations

import math

from .labels import AS_SHIPPED, CALIBRATED, PLANTED_CLASS, settings_class  # noqa: F401 - the verdict's settings classes
from .metrics import PRIMARY, PRIMARY_METRIC
from .scenarios import Scenario, Variant, entries, variants_of  # noqa: F401 - Scenario: the verdict's unit
from .statistics import CONFIDENCE, estimate, holm, paired, tie_groups

#: A variant fails when in some scenario its boundary is farther than this many cell diagonals [-].
FAIL_CELLS = 1.0

#: A reason for failing is named when it concerns at least this share of its cells [-].
REASON_SHARE = 0.10


# -- one variant -------------------------------------------------------------------------------------

def items(v: Variant, held_out: bool = False, scale: bool = False) -> dict:
    """``{(block, pulse): (value, sd, cluster)}`` of a variant's scenarios with a value: in-sample, or
    held-out; with ``scale`` each over its scenario's η_H–η_M reference gap (scenarios without one left
    out)."""
    out = {}
    for k, s in v.scenarios.items():
        if not math.isfinite(s.value) or s.held_out != held_out:
            continue
        if scale:
            if math.isfinite(s.gap) and s.gap > 0:
                out[k] = (s.value / s.gap, s.sd / s.gap, s.cluster)
        else:
            out[k] = (s.value, s.sd, s.cluster)
    return out


def interval(it: dict) -> tuple[float, float, float, str] | None:
    """``(value, lo, hi, basis)`` of the mean over clusters of ``it`` (:func:`items`), clipped at the
    metric's perfect value; None without an item."""
    if not it:
        return None
    e = estimate(list(it.values()))
    return e["mean"], max(e["mean"] - e["half"], PRIMARY.perfect), e["mean"] + e["half"], e["basis"]


def variant_interval(v: Variant) -> tuple[float, float, float, str] | None:
    """:func:`interval` of a variant's in-sample scenarios."""
    return interval(items(v))


def mean_value(v: Variant) -> float:
    """The order of the tie groups: the variant's value, the mean over clusters that the paired
    differences compare (NaN without a value)."""
    iv = variant_interval(v)
    return math.nan if iv is None else iv[0]


def failing_scenarios(v: Variant) -> list[dict]:
    """Every in-sample scenario where the boundary lies more than :data:`FAIL_CELLS` cell diagonals
    from the reference's, worst first."""
    bad = [{"block": k[0], "pulse": k[1], "value": s.value, "limit": FAIL_CELLS * s.cell}
           for k, s in v.scenarios.items()
           if not s.held_out and math.isfinite(s.value) and s.value > FAIL_CELLS * s.cell]
    return sorted(bad, key=lambda b: -b["value"] / b["limit"])


def fails(v: Variant) -> bool:
    """The one failing rule: no scenario with a value, or one scenario beyond :data:`FAIL_CELLS` cells.
    A variant of the held-out check alone (every scenario held out) is judged in its own line instead."""
    if v.held_out_only:
        return False
    return not items(v) or bool(failing_scenarios(v))


def reasons(v: Variant) -> list[str]:
    """What the variant gets wrong, from its summed cell counts: each kind of error that concerns at
    least :data:`REASON_SHARE` of its cells, largest first (at most two)."""
    c = v.counts
    inside = c.get("cells_in_domain", 0)
    found = [(_share(c, "overturn_extra", "reference_standing"),
              "overturns in {} of the cells where the reference stays standing"),
             (_share(c, "overturn_missed", "reference_overturn"),
              "stays standing in {} of the cells where the reference overturns"),
             (c.get("failed_in_domain", 0) / inside if inside else 0.0, "fails to simulate {} of the judged cells"),
             (c.get("invalid_in_domain", 0) / inside if inside else 0.0,
              "flags slip, jump or energy gain in {} of the cells where the rigid model holds")]
    found = sorted((x for x in found if x[0] >= REASON_SHARE), key=lambda x: -x[0])[:2]
    return [text.format(percent(share)) for share, text in found]


def percent(share: float) -> str:
    """``0.87`` → ``87 %`` (the project writes a space before %)."""
    return f"{100 * share:.0f} %"


def _share(c: dict, part: str, whole: str) -> float:
    return c.get(part, 0) / c[whole] if c.get(whole) else 0.0


def mean_cell(v: Variant) -> float:
    cells = [s.cell for s in v.scenarios.values()]
    return sum(cells) / len(cells) if cells else math.nan


def per_scenario(v: Variant) -> list[dict]:
    """score.json's per-scenario values of a variant: value, own error, cluster, the η_H–η_M gap and
    the value over it, held-out or not, and whether it fails there (:func:`failing_scenarios`)."""
    bad = {(b["block"], b["pulse"]) for b in failing_scenarios(v)}
    out = []
    for (block, pulse), s in sorted(v.scenarios.items()):
        gap = s.gap if math.isfinite(s.gap) else None
        out.append({"block": block, "pulse": pulse, "cluster": list(s.cluster), "value": _num(s.value),
                    "sd": s.sd, "cell_diagonal": s.cell, "reference_gap": gap,
                    "relative_to_gap": _num(s.value / s.gap) if gap else None, "held_out": s.held_out,
                    "fails": (block, pulse) in bad})
    return out


def _num(x):
    return x if x is not None and math.isfinite(x) else None


# -- comparisons and ranks ----------------------------------------------------------------------------

def comparisons(groups: list[list[Variant]]) -> dict[tuple[str, str], dict]:
    """:func:`~.statistics.paired` for every ordered pair of entries (by their first variants' names).

    The comparisons between passing entries are one family: each gets its Holm-adjusted ``p_holm``
    and ``resolved`` (p_holm below 1 − :data:`CONFIDENCE`). A failing entry is out of the ranking
    (it is named with the scenario it fails in), so its comparisons are reported but not tested:
    ``p_holm`` None, ``resolved`` False; they would cost the passing entries power for nothing.
    """
    heads = [g[0] for g in groups]
    passing = {h.name for h in heads if not fails(h)}
    out = {(a.name, b.name): {"other": b.name, **paired(items(a), items(b))}
           for a in heads for b in heads if a is not b}
    family = {tuple(sorted(k)): r["p"] for k, r in out.items() if set(k) <= passing}
    adj = holm(family)
    for k, r in out.items():
        r["p_holm"] = adj.get(tuple(sorted(k)))
        r["resolved"] = r["p_holm"] is not None and r["p_holm"] < 1 - CONFIDENCE
    return out


def rank(variants: list[Variant], versus: dict | None = None) -> dict[str, int]:
    """Each passing variant's tie group, 1 the best (module docstring); identical variants share their
    entry's; failing variants and those without a value get none."""
    groups = entries(variants)
    versus = comparisons(groups) if versus is None else versus
    valued = sorted((g for g in groups if math.isfinite(mean_value(g[0])) and not fails(g[0])),
                    key=lambda g: mean_value(g[0]))
    cut = tie_groups(valued, lambda x, y: versus[(x[0].name, y[0].name)]["resolved"])
    return {v.name: n for n, grp in enumerate(cut, 1) for e in grp for v in e}


# -- from a score document ---------------------------------------------------------------------------

def verdict(doc: dict) -> dict:
    """The ``verdict`` object of score.json (docs/scores.md, "The verdict")."""
    vs = variants_of(doc)
    # the held-out check's own variants have a line apart, and so has the yardstick (planted variants)
    ranked = [v for v in vs if not v.held_out_only and v.settings != PLANTED_CLASS]
    groups = entries(ranked)
    versus = comparisons(groups)
    ranks = rank(ranked, versus)
    head_of = {v.name: g[0].name for g in groups for v in g}
    by_name = {v.name: v for v in vs}
    rows = [_row(v, ranks, versus, head_of, groups, by_name.get(v.in_sample)) for v in vs]
    rows.sort(key=lambda r: (r["rank"] is None, r["rank"] or 0, r["value"] is None, r["value"] or 0.0, r["label"]))
    return {"metric": PRIMARY_METRIC, "direction": PRIMARY.direction, "unit": PRIMARY.unit,
            "confidence": CONFIDENCE, "fail_cells": FAIL_CELLS, "variants": rows,
            "method": METHOD, "text": sentences(vs, rows)}


def held_out_check(v: Variant, in_sample: Variant | None = None) -> dict | None:
    """The held-out check of a variant: its held-out scenarios' value and interval, and the in-sample
    value it is set beside, the first that exists of: ``in_sample`` (the same settings calibrated on each
    block itself) on the same scenarios; ``in_sample`` on the scenarios of the same problems (the other
    size of each held-out scenario's slenderness × pulse cluster, where a suite maps the calibrated
    variant on one size and holds the other out); the variant's own in-sample value. None without a
    held-out scenario."""
    held_items = items(v, held_out=True)
    held = interval(held_items)
    if held is None:
        return None
    mine = items(in_sample) if in_sample is not None else {}
    clusters = {x[2] for x in held_items.values()}
    same = {k: x for k, x in mine.items() if k in held_items}
    problems = {k: x for k, x in mine.items() if x[2] in clusters}
    if same:
        base, scope, name = interval(same), "same scenarios", in_sample.name
    elif problems:
        base, scope, name = interval(problems), "same problems", in_sample.name
    else:
        base, scope, name = variant_interval(v), "other scenarios", v.name
    return {"value": held[0], "ci95": [held[1], held[2]], "scenarios": len(held_items),
            "in_sample": None if base is None else base[0], "in_sample_scope": scope,
            "in_sample_variant": name}


def _row(v: Variant, ranks: dict, versus: dict, head_of: dict, groups: list, in_sample: Variant | None) -> dict:
    iv, phys = variant_interval(v), interval(items(v, scale=True))
    head = head_of.get(v.name)
    return {"variant": v.name, "engine": v.engine, "label": v.label, "settings": v.settings,
            "value": None if iv is None else iv[0], "ci95": None if iv is None else [iv[1], iv[2]],
            "basis": None if iv is None else iv[3], "rank": ranks.get(v.name),
            "same_as": [o.name for g in groups if g[0].name == head for o in g if o is not v],
            "pairs": len(v.scenarios), "scenarios_with_value": len(items(v)),
            "clusters": len({s[2] for s in items(v).values()}),
            "cells_judged": v.counts.get("cells_in_domain", 0), "cell_diagonal": mean_cell(v),
            "fails": fails(v), "fails_in": failing_scenarios(v), "reasons": reasons(v),
            "shipped_note": v.shipped_note or None, "cells_missing": v.cells_missing,
            "physics": None if phys is None else {"value": phys[0], "ci95": [phys[1], phys[2]],
                                                  "within": phys[2] < 1.0},
            "held_out": held_out_check(v, in_sample), "per_scenario": per_scenario(v),
            "versus": [] if head is None else
            [dict(versus[(head, o)], other=o) for o in dict.fromkeys(head_of.values()) if o != head]}


# -- in words ----------------------------------------------------------------------------------------

#: The method in one sentence: under every verdict and summary table.
METHOD = ("Ranks are tie groups of the variants that pass: variants giving identical maps count once, are taken in "
          "order of their mean boundary distance, and a variant opens a new group when a paired t-test of the "
          "difference of the distances over the slenderness × pulse clusters they share (sizes averaged, each "
          "scenario's grid resolution added), Holm-corrected over all comparisons between passing variants at "
          "5 %, resolves it from any member of the group before it.")

_CLASSES = ((CALIBRATED, "Best achievable (engines calibrated by rockbench)"),
            (AS_SHIPPED, "Out of the box (engines as shipped)"))


def number(x) -> str:
    """A primary value as the verdict writes it: three decimals below 10, one above."""
    if x is None or not math.isfinite(x):
        return "n/a"
    return f"{x:.3f}" if abs(x) < 10 else f"{x:.1f}"


def _figure(row: dict) -> str:
    """``0.008 (95 % interval 0.003–0.013, 4 clusters of 8 scenarios)``."""
    if row["value"] is None:
        return "no value (nothing it simulated could be judged)"
    lo, hi = row["ci95"]
    n, c = row["scenarios_with_value"], row["clusters"]
    return (f"{number(row['value'])} (95 % interval {number(lo)}–{number(hi)}, {c} cluster{'s' if c != 1 else ''} "
            f"of {n} scenario{'s' if n != 1 else ''})")


def _name(row: dict, by: dict) -> str:
    """A row's label, with the variants it is identical to."""
    same = [by[o]["label"] for o in row["same_as"] if o in by]
    return row["label"] + (f" (identical maps: {_and(same)})" if same else "")


def sentences(vs: list[Variant], rows: list[dict]) -> list[str]:
    """The verdict in words: the best group of each settings class (ties named), those that fail and
    where, the physics' scale, the held-out check, the incomplete maps, and the method."""
    by = {r["variant"]: r for r in rows}
    shown: set = set()
    out = []
    for cls, title in _CLASSES:
        members = [by[v.name] for v in vs if v.settings == cls and v.name not in shown and not v.held_out_only]
        if members:
            out.append(_class_sentence(title, members, by))
            shown |= {o for r in members for o in [r["variant"], *r["same_as"]]}
    custom = [by[v.name] for v in vs if v.settings not in (CALIBRATED, AS_SHIPPED, PLANTED_CLASS)
              and not by[v.name]["fails"] and not v.held_out_only]
    if custom:
        out.append("Other settings: " + "; ".join(f"{r['label']}, {_figure(r)}" for r in custom) + ".")
    failing = [r for r in rows if r["fails"] and not any(by[o]["fails"] for o in r["same_as"]
                                                         if rows.index(by[o]) < rows.index(r))]
    if failing:
        out.append(f"Fail (boundary more than {FAIL_CELLS:g} grid cell from the reference's in at least one "
                   "scenario, whatever the mean): " + "; ".join(_failure(r, by) for r in failing) + ".")
    out += _physics_sentence(rows) + _held_out_sentence(rows) + _planted_sentence(rows)
    incomplete = [r for r in rows if r["cells_missing"]]
    if incomplete:
        out.append("Incomplete maps, scored on the cells they have: "
                   + "; ".join(f"{r['label']} lacks {r['cells_missing']} cell(s)" for r in incomplete) + ".")
    out.append("Measure: the mean distance between the engine's and the reference's overturning boundaries in the "
               "normalised plane (ω/p, a₀/(g·tanα)), lower is better, like-for-like pairs; a value is the mean "
               "over slenderness × pulse clusters (sizes of one slenderness averaged), its 95 % interval Student's "
               "t over those clusters with each scenario's grid resolution added. " + METHOD)
    return out


def _class_sentence(title: str, members: list[dict], by: dict) -> str:
    ranked = [r for r in members if r["rank"] is not None]
    passing = sorted((r for r in ranked if not r["fails"]), key=lambda r: (r["rank"], r["value"]))
    if not passing:
        if len(members) == 1:
            return f"{title}: its only variant, {_name(members[0], by)}, fails (below)."
        return f"{title}: all {len(members)} variants fail (below)."
    best = passing[0]["rank"]
    group = [r for r in passing if r["rank"] == best]
    head, rest = group[0], group[1:]
    text = f"{title}: {_name(head, by)}, {_figure(head)}"
    if rest:
        text += "; tied with " + _and([f"{_name(r, by)}, {number(r['value'])}" for r in rest]) \
                + " (one tie group: no difference among them is resolved)"
    farther = [r for r in passing if r["rank"] != best]
    if farther:
        text += ". Resolved farther: " + "; ".join(
            f"{_name(r, by)}, {number(r['value'])} (tie group {r['rank']})" for r in farther)
    return text + "."


def _and(items_: list[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return items_[0] if len(items_) == 1 else ", ".join(items_[:-1]) + " and " + items_[-1]


#: How many failing scenarios a failure names (worst first).
_NAMED = 3


def _failure(row: dict, by: dict) -> str:
    if row["value"] is None:
        why = ["nothing it simulated could be judged"]
    else:
        worst = [f"{b['block']} {b['pulse']} at {number(b['value'])}" for b in row["fails_in"][:_NAMED]]
        more = len(row["fails_in"]) - _NAMED
        why = [f"off in {_and(worst)}" + (f" and {more} more scenario{'s' if more > 1 else ''}" if more > 0 else "")
               + f" (limit {number(row['fails_in'][0]['limit'])})"] + row["reasons"]
    if row["shipped_note"]:
        why.append(row["shipped_note"].rstrip("."))
    return f"{_name(row, by)} (mean {number(row['value'])}): {', and '.join(why)}"


def _physics_sentence(rows: list[dict]) -> list[str]:
    """Each passing variant's distance over the η_H–η_M reference gap, and which lie within it."""
    shown = [r for r in rows if r["physics"] and not r["fails"]]
    if not shown:
        return []
    parts = [f"{r['label']} {number(r['physics']['value'])} [{number(r['physics']['ci95'][0])}, "
             f"{number(r['physics']['ci95'][1])}]" for r in shown]
    within = [r["label"] for r in shown if r["physics"]["within"]]
    text = ("Against the physics' own scale (each distance over the distance between the η_H and η_M, average k, "
            "reference boundaries of the same scenario): " + "; ".join(parts) + ". ")
    text += (f"Within the uncertainty of the restitution itself (whole interval below 1): {_and(within)}."
             if within else "No variant's whole interval lies within the uncertainty of the restitution itself.")
    return [text]


def _held_out_sentence(rows: list[dict]) -> list[str]:
    """The held-out check: variants mapped on blocks their calibration was not made on."""
    held = [r for r in rows if r["held_out"]]
    if not held:
        return []
    return ["Held-out check (calibrated on one block, mapped on another it was not calibrated on): " + "; ".join(
        f"{r['label']}, {number(r['held_out']['value'])} [{number(r['held_out']['ci95'][0])}, "
        f"{number(r['held_out']['ci95'][1])}] over {r['held_out']['scenarios']} scenario(s), " + _in_sample_words(r)
        for r in held) + "."]


def _planted_sentence(rows: list[dict]) -> list[str]:
    """The suite's yardstick: the reference solver with a planted restitution error, each value as measured
    (its statistics against δ = 0 are the power's)."""
    planted = [r for r in rows if r["settings"] == PLANTED_CLASS]
    if not planted:
        return []
    return ["Planted differences (the reference solver with its η reduced, mapped and scored as an engine): "
            + "; ".join(f"{r['label']}, {_figure(r)}" for r in planted) + "."]


def _in_sample_words(row: dict) -> str:
    """What a held-out value is set beside: the in-sample value, and where it comes from."""
    h = row["held_out"]
    if h["in_sample"] is None:
        return "with no map of it calibrated on the block itself to set it beside"
    where = {"same scenarios": "in the same scenarios",
             "same problems": "on the other size of the same slenderness and pulse"}.get(h["in_sample_scope"],
                                                                                  "in its other scenarios")
    return f"against {number(h['in_sample'])} calibrated on the block itself {where}"
