"""Comparisons within a settings class: each variant against the best of its class (calibrated; as
shipped) by Hsu's multiple comparisons with the best, the smallest difference the class's comparisons
could have detected, and, where the suite spans the declared slenderness range, the same comparisons
about problems in general (docs/scores.md, "Comparisons: each variant against the best of its class").

Each class is its own family of tests: its passing variants, identical answers merged into one entry
(:func:`~rockbench.benchmark.scoring.scenarios.entries`). A failing variant is out of its class's family
(the failing rule already says what a test would); held-out, planted and hand-set variants are in no
family.
"""

from __future__ import annotations

import math
import statistics as _py
from dataclasses import dataclass, field

from rockbench.benchmark.scoring.declared import DEFAULTS, MIN_SLENDERNESSES, fail_limit
from rockbench.benchmark.scoring.failing import fails
from rockbench.benchmark.scoring.labels import AS_SHIPPED, CALIBRATED
from rockbench.benchmark.scoring.scenarios import Variant, entries, items
from rockbench.benchmark.scoring.statistics import (CONFIDENCE, POWER, by_cluster, detectable, differences, dunnett_t_critical, fixed,
                                                    general, interaction, mcb, paired, t_quantile,
                                                    z_one_sided)

#: The classes whose variants are compared with the best of their class, in the verdict's order.
COMPARED = (CALIBRATED, AS_SHIPPED)


@dataclass
class Family:
    """One class's comparisons.

    Attributes
    ----------
    cls : str
        The settings class.
    entries : list of list of Variant
        Its passing variants, identical answers merged (the first of each speaks for it).
    values : dict
        Entry (its first variant's name) → its value on the fixed suite [w/a units].
    versus : dict
        ``(i, j)`` → :func:`~.statistics.paired` of entry i against entry j.
    mcb : dict
        Entry → :func:`~.statistics.mcb`'s ``in_best_subset``, ``critical`` and ``behind``.
    best : str or None
        The entry with the smallest value.
    critical : float or None
        The class's one-sided critical value (the median over its entries; equal when every scenario
        has the same error) [-].
    pair_se : float or None
        The class's typical standard error of a paired difference (median over its pairs) [w/a units].
    mdd : float or None
        Its minimal detectable difference at 80 % power, (critical + z₀.₈)·pair_se [w/a units].
    general : dict
        Entry → its comparison with the best about problems in general (only where stated).
    across : dict or None
        The same comparisons across problems (:func:`across_problems`); None with fewer than two
        entries or problems in common.

    ``critical``, ``pair_se``, ``mdd`` and ``mcb`` are **on this suite** (:data:`ON_SUITE`): the
    problems fixed, measurement error only.
    """

    cls: str
    entries: list
    values: dict = field(default_factory=dict)
    versus: dict = field(default_factory=dict)
    mcb: dict = field(default_factory=dict)
    best: str | None = None
    critical: float | None = None
    pair_se: float | None = None
    mdd: float | None = None
    general: dict = field(default_factory=dict)
    across: dict | None = None

    @property
    def best_subset(self) -> list[str]:
        """The entries that may be the best (Hsu's subset), best first."""
        return sorted((n for n, m in self.mcb.items() if m["in_best_subset"]), key=lambda n: self.values[n])

    def to_dict(self) -> dict:
        """score.json's ``verdict.mcb[class]``."""
        return {"class": self.cls, "entries": [e[0].name for e in self.entries], "k": len(self.entries),
                "best": self.best, "best_subset": self.best_subset, "critical": self.critical,
                "pair_se": self.pair_se, "mdd": self.mdd, "power": POWER, "scope": ON_SUITE, "across": self.across,
                "members": {e[0].name: [v.name for v in e] for e in self.entries}}


def family(cls: str, ents: list[list[Variant]]) -> Family:
    """The comparisons of one class's entries (:func:`~.statistics.mcb` on the fixed suite)."""
    f = Family(cls, ents)
    heads = {e[0].name: items(e[0]) for e in ents}
    est = {n: fixed(list(it.values())) for n, it in heads.items()}
    f.values = {n: e["mean"] for n, e in est.items()}
    for i in heads:
        for j in heads:
            if i != j:
                f.versus[(i, j)] = paired(heads[i], heads[j])
    se = {k: (r["se"] if r["se"] is not None else math.inf) for k, r in f.versus.items()}
    f.mcb = mcb(f.values, se, {n: e["se"] ** 2 for n, e in est.items()})
    f.best = min(f.values, key=f.values.get) if f.values else None
    finite = [s for (i, j), s in se.items() if i < j and math.isfinite(s)]
    if finite:
        f.critical = _py.median(m["critical"] for m in f.mcb.values())
        f.pair_se = _py.median(finite)
        f.mdd = detectable(f.critical, f.pair_se)
    f.across = across_problems(f, heads)
    return f


#: The two scopes every standing, detectable difference and interval names.
ON_SUITE, ACROSS = "on this suite", "across problems"


def problem_table(heads: dict) -> tuple[list, list, list]:
    """``(names, X, V)``: each entry's value and grid variance per problem (its cluster means,
    :func:`~.statistics.by_cluster`) on the problems every entry has, rows in ``heads``' order."""
    means = {n: by_cluster(list(it.values())) for n, it in heads.items()}
    common = sorted(set.intersection(*(set(m) for m in means.values())), key=str) if means else []
    names = list(heads)
    return names, [[means[n][c][0] for c in common] for n in names], [[means[n][c][1] for c in common] for n in names]


def across_problems(f: Family, heads: dict) -> dict | None:
    """Hsu's comparisons with the best **across problems**: the problems a sample, so each paired
    difference errs by the engine × problem interaction (:func:`~.statistics.interaction` of the
    class's two-way table, (k − 1)(C − 1) degrees of freedom), never less than its grid error on this
    suite (the floor); q Dunnett's one-sided multivariate-t critical value for the k − 1 comparisons
    with the best (:func:`~.statistics.dunnett_t_critical`); the detectable difference (q + t₀.₈)·se.

    Returns ``{"scope", "problems", "df", "interaction_sd", "grid_sd", "critical", "pair_se", "mdd",
    "best", "best_subset", "entries": {name: {"value", "in_best_subset", "behind", "versus_best"}}}``
    (``versus_best``: the difference from the best with its two-sided 95 % t interval); None with fewer
    than two entries or two problems in common."""
    names, x, var = problem_table(heads)
    k, c = len(names), len(x[0]) if x else 0
    if k < 2 or c < 2:
        return None
    ms, df = interaction(x)
    values = {n: sum(row) / c for n, row in zip(names, x)}
    grid = {n: sum(row) / c ** 2 for n, row in zip(names, var)}             # on-suite variance of each mean
    se = {(i, j): max(math.sqrt(2.0 * ms / c), math.sqrt(grid[i] + grid[j]))
          for i in names for j in names if i != j}
    q = dunnett_t_critical(k - 1, df)
    out = {}
    for i in names:
        ups = [values[i] - values[j] + q * se[(i, j)] for j in names if j != i]
        out[i] = {"value": values[i], "in_best_subset": all(values[i] - values[j] <= q * se[(i, j)]
                                                            for j in names if j != i),
                  "behind": max(0.0, max(ups))}
    pair_se = _py.median(se[(i, j)] for (i, j) in se if i < j)
    best = min(values, key=values.get)
    half = t_quantile(0.5 + CONFIDENCE / 2, df)
    for i in names:
        d = values[i] - values[best]
        out[i]["versus_best"] = None if i == best else {
            "against": best, "difference": d, "se": se[(i, best)], "df": df,
            "ci95": [d - half * se[(i, best)], d + half * se[(i, best)]]}
    grid_sd = math.sqrt(sum(v for row in var for v in row) / (k * c))
    return {"scope": ACROSS, "problems": c, "df": df, "interaction_sd": math.sqrt(ms), "grid_sd": grid_sd,
            "critical": q, "pair_se": pair_se, "mdd": (q + t_quantile(POWER, df)) * pair_se,
            "best": best, "best_subset": sorted((n for n in names if out[n]["in_best_subset"]), key=values.get),
            "entries": out}


def families(variants: list[Variant], limit: float) -> dict[str, Family]:
    """``{class: Family}`` for each class of :data:`COMPARED` with a passing variant (``limit``: the
    failing distance)."""
    out = {}
    for cls in COMPARED:
        members = [v for v in variants if v.settings == cls and not v.held_out_only and not fails(v, limit)]
        if members:
            out[cls] = family(cls, entries(members))
    return out


def ranks(fams: dict[str, Family]) -> dict[str, int]:
    """Each compared variant's rank: 1 in its class's best subset, 2 resolved behind the best, by its
    :func:`headline` standing (across problems where stated); variants of one entry share it."""
    out = {}
    for f in fams.values():
        for e in f.entries:
            r = 1 if headline(f, e[0].name)["in_best_subset"] else 2
            out.update({v.name: r for v in e})
    return out


def headline(f: Family, name: str) -> dict:
    """An entry's headline standing: across problems where the class has that comparison, else on this
    suite. ``{"scope", "in_best_subset", "best_in_class", "behind"}``."""
    if f.across is not None:
        a = f.across["entries"][name]
        return {"scope": ACROSS, "in_best_subset": a["in_best_subset"], "best_in_class": name == f.across["best"],
                "behind": a["behind"]}
    m = f.mcb[name]
    return {"scope": ON_SUITE, "in_best_subset": m["in_best_subset"], "best_in_class": name == f.best,
            "behind": m["behind"]}


def rank(variants: list[Variant], limit: float | None = None) -> dict[str, int]:
    """:func:`ranks` of ``variants`` compared in their classes (``limit``: the failing distance, default
    the code's rule on the variants' own η_H–η_M gaps)."""
    if limit is None:
        gaps = {k: s.gap for v in variants for k, s in v.scenarios.items()}
        limit = fail_limit(DEFAULTS, gaps)["value"]
    return ranks(families(variants, math.inf if limit is None else limit))


def critical_for_power(fams: dict[str, Family]) -> tuple[float, str]:
    """The critical value a planted difference is judged by, and where it comes from: the calibrated
    class's, when it has comparisons, else one one-sided comparison's."""
    f = fams.get(CALIBRATED)
    if f is not None and f.critical is not None:
        return f.critical, f"the calibrated class's rule ({len(f.entries)} variants)"
    return z_one_sided(), "one comparison's rule"


# -- about problems in general --------------------------------------------------------------------------

def general_scope(variants: list[Variant], declared) -> dict:
    """Whether the suite may state claims about problems in general: its in-sample problems span the
    declared slenderness range with at least :data:`~.declared.MIN_SLENDERNESSES` slendernesses."""
    lo, hi = declared.general_range_h_over_b
    found = sorted({float(s.cluster[0]) for v in variants for s in v.scenarios.values()
                    if not s.held_out and s.cluster and _is_number(s.cluster[0])})
    spans = bool(found) and found[0] <= lo + 1e-9 and found[-1] >= hi - 1e-9
    stated = spans and len(found) >= MIN_SLENDERNESSES
    why = ("" if stated else
           f"the suite's problems span h/b {_span(found)} with {len(found)} slenderness{'es' if len(found) != 1 else ''}; "
           f"a claim about problems in general needs at least {MIN_SLENDERNESSES} spanning the declared "
           f"{lo:g}–{hi:g}")
    return {"stated": stated, "range": [lo, hi], "slendernesses": found, "why": why}


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _span(found: list[float]) -> str:
    if not found:
        return "of no Table 1 slenderness"
    return f"{found[0]:g}" if len(found) == 1 else f"{found[0]:g}–{found[-1]:g}"


def general_value(v: Variant, scope: dict) -> dict | None:
    """A variant's value about problems in general (Student's t over its slenderness means), when the
    scope is stated and its own problems span the range too."""
    if not scope["stated"]:
        return None
    it = list(items(v).values())
    if not _covers(it, scope):
        return None
    return general(it)


def _covers(it: list, scope: dict) -> bool:
    found = {float(c[0]) for _, _, c in it if c and _is_number(c[0])}
    lo, hi = scope["range"]
    return len(found) >= MIN_SLENDERNESSES and min(found) <= lo + 1e-9 and max(found) >= hi - 1e-9


def add_general(f: Family, scope: dict) -> None:
    """Each entry of ``f`` against the best about problems in general: Student's t over the slenderness
    means of their paired differences, Bonferroni over the k − 1 comparisons with the best."""
    if not scope["stated"] or f.best is None:
        return
    best = items(f.entries[[e[0].name for e in f.entries].index(f.best)][0])
    for e in f.entries:
        name = e[0].name
        if name == f.best:
            continue
        diff = differences(items(e[0]), best)
        if _covers(diff, scope):
            g = general(diff, comparisons=max(1, len(f.entries) - 1))
            if g is not None:
                f.general[name] = {"against": f.best, "difference": g["mean"], "ci95": g["ci95"], "df": g["df"],
                                   "p_bonferroni": g["p"], "resolved": g["p"] < 0.05}
