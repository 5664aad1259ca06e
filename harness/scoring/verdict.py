"""The verdict of a score document: one primary measure per engine variant, its 95 % interval, ranks
in which unresolved differences tie, which variants fail and why, and the sentences that say so.

Pure functions of a score document (the ``pairs`` of :func:`rockbench.harness.scoring.score_runs.score_entries`);
no file, no plotting. docs/scores.md argues every rule below; in short:

- **The measure** is :data:`~rockbench.harness.scoring.metrics.PRIMARY_METRIC` (the mean distance between the
  overturning boundaries), taken per *scenario* (block × pulse) from the variant's like-for-like pairs,
  and averaged over its scenarios.
- **The interval** is Student's t over the scenarios (the scenarios are the independent replicates;
  cells of one map are not). The spread is never taken below the grid's own unit (what moving one
  boundary edge by one cell changes the value), so a variant that matches the reference cell for cell
  everywhere still gets an interval of a grid's width, not a point. With one scenario there is no
  spread to measure: the interval is half a cell either side (the grid's resolution only).
- **Ties**: two variants are compared over the scenarios they share, by the same interval on the
  per-scenario log ratios (distances span orders of magnitude); a ratio whose interval contains 1 is
  not resolved. A variant's rank is 1 + the number of variants resolved closer to the reference:
  rank 1 is every variant that no other beats, and a variant's rank says how many beat it.
- **Failing**: a variant fails when its boundary lies on average more than :data:`FAIL_CELLS` cell
  diagonal from the reference's (the grid itself resolves that), or nothing it simulated could be
  judged; the reasons are read from its cell counts (what it gets wrong, in what share of which cells).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .metrics import PRIMARY, PRIMARY_METRIC

#: Confidence of every interval the verdict states.
CONFIDENCE = 0.95

#: A variant fails when the best end of its interval is farther than this many cell diagonals [-].
FAIL_CELLS = 1.0

#: A reason for failing is named when it concerns at least this share of its cells [-].
REASON_SHARE = 0.10

#: The settings classes the verdict answers apart (best achievable, out of the box).
CALIBRATED, AS_SHIPPED = "calibrated", "as-shipped"

#: Engine settings a calibration chooses itself (they do not make a variant "custom").
_CALIBRATION_KEYS = {"settings", "contact"}


@dataclass
class Scenario:
    """One block × pulse of a variant: its primary value and the grid's units there.

    ``unit`` is what moving one boundary edge by one cell changes the value (the cell diagonal over
    the pair's boundary edges); ``cell`` is the cell diagonal [w/a units]."""

    value: float
    unit: float
    cell: float


@dataclass
class Variant:
    """A variant's scenarios and what its verdict rests on."""

    name: str
    engine: str
    label: str
    settings: str
    scenarios: dict = field(default_factory=dict)    # (block, pulse) -> Scenario
    counts: dict = field(default_factory=dict)       # summed cell counts of its pairs
    cells_missing: int = 0

    def finite(self) -> dict:
        return {k: s for k, s in self.scenarios.items() if math.isfinite(s.value)}

    @property
    def value(self) -> float:
        vals = [s.value for s in self.finite().values()]
        return sum(vals) / len(vals) if vals else math.nan


def settings_class(engine_settings: dict | None, variant: str, engine: str | None = None) -> str:
    """``calibrated`` (rockbench's calibration, any contact layout it chose), ``as-shipped`` (the
    engine's defaults and nothing else) or, for anything else set by hand, the variant's own name.
    The settings that choose the ``engine``'s model (:func:`~.labels.model_settings`: Newton's
    solver) are the engine's, not a tweak: they leave the class as it is."""
    from .labels import model_settings

    model = model_settings(engine) if engine else {}
    s = {k: v for k, v in (engine_settings or {}).items() if k not in model}
    kind = s.get("settings", "calibrated")
    if kind == "defaults" and set(s) <= {"settings"}:
        return AS_SHIPPED
    if kind == "calibrated" and set(s) <= _CALIBRATION_KEYS:
        return CALIBRATED
    return variant


# -- intervals ---------------------------------------------------------------------------------------

def t_quantile(n: int) -> float:
    """The two-sided :data:`CONFIDENCE` quantile of Student's t with ``n - 1`` degrees of freedom."""
    from scipy import stats
    return float(stats.t.ppf(0.5 + CONFIDENCE / 2, n - 1))


def mean_interval(values: list[float], units: list[float], cells: list[float]) -> tuple[float, float, str]:
    """``(mean, half-width, basis)`` of the mean of per-scenario ``values``.

    The standard deviation is floored at the mean grid unit (so equal values do not give a point);
    one scenario gives half a cell either side. ``basis`` says which in words.
    """
    n = len(values)
    mean = sum(values) / n
    if n == 1:
        return mean, 0.5 * cells[0], "one scenario: the grid's resolution (half a cell) only"
    sd = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1))
    floor = sum(units) / n
    basis = f"Student's t over {n} scenarios" + (" (spread floored at one grid unit)" if sd < floor else "")
    return mean, t_quantile(n) * max(sd, floor) / math.sqrt(n), basis


def variant_interval(v: Variant) -> tuple[float, float, float, str] | None:
    """``(value, lo, hi, basis)`` of a variant's primary value, clipped to the metric's range; None
    when it has no scenario with a value."""
    sc = list(v.finite().values())
    if not sc:
        return None
    mean, half, basis = mean_interval([s.value for s in sc], [s.unit for s in sc], [s.cell for s in sc])
    return mean, max(mean - half, PRIMARY.perfect), mean + half, basis


def paired(a: Variant, b: Variant) -> dict:
    """``a`` against ``b`` over the scenarios both have a value for.

    Distances range over orders of magnitude (0.01 to 20 w/a units), so the comparison is of ratios:
    per scenario r = ln((a + u) / (b + u)), u the grid unit (so a perfect 0 stays finite); Student's t
    over the scenarios gives the interval of the mean r, its spread floored at what one grid unit
    changes r. ``ratio`` is exp(mean r), a/b "on average"; ``resolved`` when the interval excludes 1.
    One shared scenario: resolved when |a − b| exceeds half a cell (the grid's resolution)."""
    fa, fb = a.finite(), b.finite()
    keys = sorted(set(fa) & set(fb))
    out = {"other": b.name, "scenarios": len(keys), "ratio": None, "ci95": None, "resolved": False}
    if not keys:
        return out
    if len(keys) == 1:
        x, y = fa[keys[0]], fb[keys[0]]
        out.update(ratio=(x.value + x.unit) / (y.value + x.unit), resolved=abs(x.value - y.value) > 0.5 * x.cell)
        return out
    r = [math.log((fa[k].value + fa[k].unit) / (fb[k].value + fa[k].unit)) for k in keys]
    floor = [fa[k].unit / (min(fa[k].value, fb[k].value) + fa[k].unit) for k in keys]
    mean, half, _ = mean_interval(r, floor, [0.0] * len(keys))
    out.update(ratio=math.exp(mean), ci95=[math.exp(mean - half), math.exp(mean + half)], resolved=abs(mean) > half)
    return out


# -- ranks -------------------------------------------------------------------------------------------

def comparisons(variants: list[Variant]) -> dict[tuple[str, str], dict]:
    """:func:`paired` for every ordered pair of ``variants``, by ``(name, other name)``: computed once,
    read by the ranks, the best groups and score.json's ``versus``."""
    return {(a.name, b.name): paired(a, b) for a in variants for b in variants if a is not b}


def rank(variants: list[Variant], versus: dict | None = None) -> dict[str, int]:
    """Competition ranks by resolved comparisons: 1 + the number of variants resolved closer to the
    reference (module docstring). Rank 1 is every variant no other is resolved better than; variants
    without a value get none. ``versus`` is :func:`comparisons` of these variants or more."""
    versus = comparisons(variants) if versus is None else versus
    valued = [v for v in variants if math.isfinite(v.value)]
    out = {}
    for v in valued:
        beaten_by = 0
        for o in valued:
            if o is not v:
                res = versus[(o.name, v.name)]
                better = res["ratio"] < 1 if PRIMARY.direction == "lower" else res["ratio"] > 1
                beaten_by += bool(res["resolved"] and better)
        out[v.name] = 1 + beaten_by
    return out


def best_group(variants: list[Variant], versus: dict | None = None) -> list[Variant]:
    """The variants of rank 1 among ``variants`` (empty when none has a value)."""
    r = rank(variants, versus)
    return [v for v in variants if r.get(v.name) == 1]


# -- failing and its reasons -------------------------------------------------------------------------

def mean_cell(v: Variant) -> float:
    cells = [s.cell for s in v.scenarios.values()]
    return sum(cells) / len(cells) if cells else math.nan


def fails(v: Variant, interval) -> bool:
    """Whether the variant's boundary lies on average beyond :data:`FAIL_CELLS` cell diagonals from the
    reference's, or it has no value at all (nothing it simulated could be judged)."""
    if interval is None:
        return True
    return interval[0] > FAIL_CELLS * mean_cell(v)


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


# -- from a score document ---------------------------------------------------------------------------

_SUMMED = ("cells_in_domain", "reference_standing", "reference_overturn", "overturn_extra", "overturn_missed",
           "failed_in_domain", "invalid_in_domain")


def variants_of(doc: dict) -> list[Variant]:
    """The engine variants of a score document, each with its like-for-like pairs (all its pairs when
    it has none) as scenarios, in the document's order."""
    groups: dict[str, list[dict]] = {}
    for p in doc.get("pairs", []):
        groups.setdefault(p["variant"], []).append(p)
    out = []
    for name, ps in groups.items():
        use = [p for p in ps if p.get("like_for_like")] or ps
        first = use[0]
        v = Variant(name, first.get("engine", name), first.get("label") or name,
                    first.get("settings") or settings_class(None, name))
        for p in use:
            v.scenarios[(p["block"], p["pulse"])] = _scenario(p)
            for k in _SUMMED:
                v.counts[k] = v.counts.get(k, 0) + int(p.get(k) or 0)
            v.cells_missing += int(p.get("cells_missing") or 0)
        out.append(v)
    return out


def _scenario(p: dict) -> Scenario:
    value = p["scores"].get(PRIMARY_METRIC)
    c = p.get("cells") or {}
    cell = math.hypot(float(c.get("w_step", 0.0)), float(c.get("a_step", 0.0)))
    edges = max(int(c.get("boundary_edges", 0) or 0), 1)
    # a grid of one row or column has no cell diagonal: a tiny unit keeps the ratios finite
    return Scenario(math.nan if value is None else float(value), max(cell / edges, _TINY), cell)


#: The grid unit of a grid without one (one row or column), so that ratios of zeros stay defined.
_TINY = 1e-12


def verdict(doc: dict) -> dict:
    """The ``verdict`` object of score.json (docs/scores.md, "The verdict")."""
    vs = variants_of(doc)
    versus = comparisons(vs)
    ranks = rank(vs, versus)
    rows = []
    for v in vs:
        iv = variant_interval(v)
        rows.append({"variant": v.name, "engine": v.engine, "label": v.label, "settings": v.settings,
                     "value": None if iv is None else iv[0], "ci95": None if iv is None else [iv[1], iv[2]],
                     "basis": None if iv is None else iv[3], "rank": ranks.get(v.name),
                     "pairs": len(v.scenarios), "scenarios_with_value": len(v.finite()),
                     "cells_judged": v.counts.get("cells_in_domain", 0), "cell_diagonal": mean_cell(v),
                     "fails": fails(v, iv), "reasons": reasons(v), "cells_missing": v.cells_missing,
                     "versus": [versus[(v.name, o.name)] for o in vs if o is not v]})
    rows.sort(key=lambda r: (r["rank"] is None, r["rank"] or 0, r["value"] or 0.0, r["label"]))
    return {"metric": PRIMARY_METRIC, "direction": PRIMARY.direction, "unit": PRIMARY.unit,
            "confidence": CONFIDENCE, "fail_cells": FAIL_CELLS, "variants": rows,
            "text": sentences(vs, rows, versus)}


# -- in words ----------------------------------------------------------------------------------------

_CLASSES = ((CALIBRATED, "Best achievable (engines calibrated by rockbench)"),
            (AS_SHIPPED, "Out of the box (engines as shipped)"))


def number(x) -> str:
    """A primary value as the verdict writes it: three decimals below 10, one above."""
    if x is None or not math.isfinite(x):
        return "n/a"
    return f"{x:.3f}" if abs(x) < 10 else f"{x:.1f}"


def _figure(row: dict) -> str:
    """``0.008 (95 % interval 0.003–0.013, 8 scenarios)``."""
    if row["value"] is None:
        return "no value (nothing it simulated could be judged)"
    lo, hi = row["ci95"]
    return f"{number(row['value'])} (95 % interval {number(lo)}–{number(hi)}, {row['scenarios_with_value']} scenario" \
           f"{'s' if row['scenarios_with_value'] != 1 else ''})"


def sentences(vs: list[Variant], rows: list[dict], versus: dict) -> list[str]:
    """The verdict in words: the closest variants of each settings class (ties named), those that
    fail and why, the others, the incomplete maps, and what the numbers mean (``versus``:
    :func:`comparisons` of ``vs``)."""
    by = {r["variant"]: r for r in rows}
    out = []
    for cls, title in _CLASSES:
        members = [v for v in vs if v.settings == cls]
        if members:
            out.append(_class_sentence(title, members, by, versus))
    custom = [by[v.name] for v in vs if v.settings not in (CALIBRATED, AS_SHIPPED) and not by[v.name]["fails"]]
    if custom:
        out.append("Other settings: " + "; ".join(f"{r['label']}, {_figure(r)}" for r in custom) + ".")
    failing = [r for r in rows if r["fails"]]
    if failing:
        out.append(f"Fail (boundary on average more than {FAIL_CELLS:g} grid cell from the reference's): "
                   + "; ".join(_failure(r) for r in failing) + ".")
    incomplete = [r for r in rows if r["cells_missing"]]
    if incomplete:
        out.append("Incomplete maps, scored on the cells they have: "
                   + "; ".join(f"{r['label']} lacks {r['cells_missing']} cell(s)" for r in incomplete) + ".")
    out.append(f"Measure: the mean distance between the engine's and the reference's overturning boundaries in "
               f"the normalised plane (ω/p, a₀/(g·tanα)), lower is better, like-for-like pairs; 95 % intervals over "
               f"scenarios (block × pulse); two variants tie when the paired 95 % interval of their ratio over the "
               f"scenarios they share contains 1, and a rank is 1 + the number of variants resolved closer, so a "
               f"variant whose mean is raised by one scenario can outrank one that is consistently farther.")
    return out


def _class_sentence(title: str, members: list[Variant], by: dict, versus: dict) -> str:
    group = sorted((by[v.name] for v in best_group(members, versus)), key=lambda r: r["value"])
    passing = [r for r in group if not r["fails"]]
    if not passing:
        if len(members) == 1:
            return f"{title}: its only variant, {by[members[0].name]['label']}, fails (below)."
        return f"{title}: all {len(members)} variants fail (below)."
    head, rest = passing[0], passing[1:]
    text = f"{title}: {head['label']}, {_figure(head)}"
    if rest:
        text += "; tied with " + _and([f"{r['label']}, {number(r['value'])}" for r in rest]) \
                + " (the differences are not resolved)"
    farther = [by[v.name] for v in members if by[v.name] not in group and not by[v.name]["fails"]]
    if farther:
        text += ". Resolved farther: " + "; ".join(
            f"{r['label']}, {number(r['value'])} (rank {r['rank']}: {r['rank'] - 1} variant"
            f"{'s are' if r['rank'] > 2 else ' is'} resolved closer)" for r in farther)
    return text + "."


def _and(items: list[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _failure(row: dict) -> str:
    why = row["reasons"] or [f"its boundary lies on average {number(row['value'])} from the reference's"]
    return f"{row['label']} ({number(row['value'])}): {', and '.join(why)}"
