"""The verdict in words: the full sentences (:func:`sentences`) and the short verdict of at most
:data:`SHORT_WORDS` words for the report's first screen (:func:`short_verdict`), both generated from the
numbers of the verdict object (:func:`rockbench.benchmark.scoring.verdict.verdict`), never typed. The
verdict holds numbers only; these words are the report's, written afresh wherever they are shown.
"""

from __future__ import annotations

import math

from rockbench.benchmark.scoring.comparisons import COMPARED
from rockbench.benchmark.scoring.declared import RESTITUTION_GAP, rule_words
from rockbench.benchmark.scoring.failing import scenario_words
from rockbench.benchmark.scoring.labels import AS_SHIPPED, CALIBRATED, engine_name

#: The most words the short verdict may have.
SHORT_WORDS = 120

#: How the verdict was made, one sentence per part (under the report's and the console's tables).
METHOD = {
    "value": ("A variant's value is the mean of its boundary distances over the suite's problems (slenderness × "
              "pulse; the sizes of one problem averaged first); its 95 % interval holds for these problems, the "
              "suite's own, not a sample: normal, from each scenario's own location error alone (measured on its two "
              "maps from their bisection's last intervals; assumed from the grid's cell where a score document "
              "lacks it)."),
    "comparisons": ("Each variant is compared with the best of its settings class (calibrated; as shipped; each "
                    "class its own family) by Hsu's multiple comparisons with the best: it stays in the best subset "
                    "unless its paired difference from another variant of the class exceeds q·se, q the one-sided "
                    "Dunnett critical value for the class's comparisons, so the subset holds the true best with "
                    "probability at least 95 %; the class's minimal detectable difference at 80 % power is "
                    "(q + z₀.₈)·se, se its typical paired standard error; identical maps count once. Two scopes: "
                    "on this suite (these problems fixed, each scenario's grid error alone, normal quantiles) and "
                    "across problems (the problems a sample: each paired difference also errs by the engine × "
                    "problem interaction of the class's two-way table, on its (k − 1)(C − 1) degrees of freedom, "
                    "never below the grid's error; q Dunnett's multivariate t, the detectable difference "
                    "(q + t₀.₈)·se). The standing a variant is named by is the one across problems; one that holds "
                    "on this suite only is said so."),
    "failing": ("A variant fails when in any in-sample scenario its boundary lies farther from the reference's than "
                "the suite's declared fail distance, whatever its mean."),
    "equivalence": ("\"Within the uncertainty of the restitution\" is said only where a one-sided 5 % test shows the "
                    "mean over the problems of distance over the declared margin below 1; per scenario, where the "
                    "distance plus 1.645 of its error lies below the margin."),
    "held_out": ("A held-out calibration \"carries over\" only where two one-sided 5 % tests put its paired difference "
                 "from its in-sample twin within the declared held-out margin."),
    "general": ("Claims about problems in general are made only where the suite's problems span the declared "
                "slenderness range with at least 3 slendernesses: Student's t over the slenderness means (pulses "
                "averaged), the mixed model with random problem and engine × slenderness effects for a balanced "
                "design, with no grid term added."),
}

_TITLES = {CALIBRATED: "Best achievable (engines calibrated by rockbench)", AS_SHIPPED: "Out of the box (engines as shipped)"}
_SHORT_TITLES = {CALIBRATED: "Calibrated", AS_SHIPPED: "As shipped"}


def number(x) -> str:
    """A primary value as the verdict writes it: three decimals below 10, one above."""
    if x is None or not math.isfinite(x):
        return "n/a"
    return f"{x:.3f}" if abs(x) < 10 else f"{x:.1f}"


def signed(x) -> str:
    """A difference with its sign: ``+0.012``, ``−0.004`` (``+0.000`` for what rounds to 0)."""
    if x is None or not math.isfinite(x):
        return "n/a"
    return ("−" if x < 0 and number(abs(x)) != number(0.0) else "+") + number(abs(x))


def declared_number(x) -> str:
    """A declared value as the suite wrote it: ``0.3``."""
    return f"{float(x):g}"


def limit_words(v: dict) -> str:
    """The fail limit with what it rests on: ``0.165, the largest η_H–η_M reference gap of the run's
    scenarios (B3M sine)``, ``0.3, the suite's declared limit``, or that the run gives none."""
    lim = v.get("fail_limit") or {"value": v["fail_distance"], "rule": None, "from": None}
    if lim["value"] is None:
        return "a limit (none: the run has no η_H–η_M reference gap for the suite's rule, so only a missing boundary fails)"
    if lim["rule"] is None:
        return f"{declared_number(lim['value'])}, the suite's declared limit,"
    f = lim["from"]
    return f"{number(lim['value'])}, {rule_words(lim['rule'])} ({f['block']} {f['pulse']}),"


def delta_words(delta: float) -> str:
    """A planted δ in per cent: ``1 %``, ``0.5 %``."""
    return f"{100 * delta:.3g} %"


def _and(items_: list[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    if not items_:
        return ""
    return items_[0] if len(items_) == 1 else ", ".join(items_[:-1]) + " and " + items_[-1]


def _plural(n: int, word: str, plural: str | None = None) -> str:
    return f"{n} {word if n == 1 else (plural or word + 's')}"


def _figure(row: dict) -> str:
    """``0.008 (95 % interval 0.000–0.030, 4 problems, 8 scenarios)``."""
    if row["value"] is None:
        return "no value (nothing it simulated could be judged)"
    lo, hi = row["ci95"]
    return (f"{number(row['value'])} (95 % interval on this suite {number(lo)}–{number(hi)}, {_plural(row['clusters'], 'problem')}, "
            f"{_plural(row['scenarios_with_value'], 'scenario')}{offset_words(row, ', ')})")


def offset_words(row: dict, lead: str = "") -> str:
    """A row's signed offset beside its distance: ``offset +0.004 (+1.2 % of a_crit: overturns early)``;
    "" without one."""
    x, pc = row.get("offset"), row.get("offset_percent")
    if x is None:
        return ""
    when = "overturns early" if x > 0 else "overturns late" if x < 0 else "neither early nor late"
    share = f"{'+' if pc >= 0 else '−'}{abs(pc):.1f} % of a_crit: " if pc is not None else ""
    return f"{lead}offset {signed(x)} ({share}{when})"


def _name(row: dict, by: dict) -> str:
    """A row's label, with the variants it is identical to."""
    same = [by[o]["label"] for o in row.get("same_as", []) if o in by]
    return row["label"] + (f" (identical maps: {_and(same)})" if same else "")


# -- the full sentences ----------------------------------------------------------------------------------

def sentences(v: dict) -> list[str]:
    """The verdict in words: each compared class's best, the variants that may be the best and the scale of
    that tie, those resolved behind it, the failures, equivalence, the held-out check, problems in
    general, the suite's power, incomplete maps and the method."""
    rows = v["variants"]
    by = {r["variant"]: r for r in rows}
    out = []
    for cls in COMPARED:
        members = [r for r in rows if r["group"] == cls]
        if members:
            out.append(_class_sentence(cls, members, v, by))
    other = [r for r in rows if r["group"] == "other" and not r["fails"]]
    if other:
        out.append("Other settings (set by hand, compared with nothing): "
                   + "; ".join(f"{r['label']}, {_figure(r)}" for r in other) + ".")
    failing = [r for r in rows if r["fails"] and not any(by[o]["fails"] for o in r["same_as"]
                                                         if rows.index(by[o]) < rows.index(r))]
    if failing:
        out.append(f"Fail (boundary farther than {limit_words(v)} from the reference's "
                   "in at least one scenario, whatever the mean): " + "; ".join(_failure(r, by) for r in failing)
                   + ".")
    out += _equivalence_sentence(v) + _held_out_sentence(rows, v) + _general_sentence(v, by) + _power_sentence(v)
    out += engine_power_sentences(v.get("engine_power"), {r["engine"]: r["label"] for r in rows})
    incomplete = [r for r in rows if r["cells_missing"]]
    if incomplete:
        out.append("Incomplete maps, scored on the cells they have: "
                   + "; ".join(f"{r['label']} lacks {r['cells_missing']} cell(s)" for r in incomplete) + ".")
    out.append("Measure: the mean distance between the engine's and the reference's overturning boundaries in the "
               "normalised plane (ω/p, a₀/(g·tanα)), lower is better, like-for-like pairs. "
               + " ".join(METHOD[k] for k in ("value", "comparisons")))
    return out


def _class_sentence(cls: str, members: list[dict], v: dict, by: dict) -> str:
    title = _TITLES[cls]
    fam = v["mcb"].get(cls)
    if fam is None:
        if len(members) == 1:
            return f"{title}: its only variant, {_name(members[0], by)}, fails (below)."
        return f"{title}: all {len(members)} variants fail (below)."
    best = by[fam["best"]]
    text = f"{title}, on these {_plural(best['clusters'], 'problem')}: best {_name(best, by)}, {_figure(best)}."
    if fam["k"] == 1:
        return text[:-1] + ", its only passing variant."
    scope = _scope_words(fam)
    tied = [by[n] for n in fam["entries"] if n != fam["best"] and by[n]["in_best_subset"]]
    behind = [by[n] for n in fam["entries"] if not by[n]["in_best_subset"]]
    if tied:
        text += (f" Not resolved from it {scope}, so each may be the best (Hsu's multiple comparisons with the best, "
                 "95 %): " + "; ".join(f"{_name(r, by)}, {number(r['value'])}" for r in tied) + ".")
    if behind:
        scope = scope if not tied else scope.split(" (")[0]          # the scope's numbers are said once
        text += f" Resolved behind it {scope}: " + "; ".join(
            f"{_name(r, by)}, {number(r['value'])} (behind the best by at most {number(r['behind_best'])})"
            for r in behind) + "."
    only = [r for r in tied if r.get("on_suite") and not r["on_suite"]["in_best_subset"]] if fam.get("across") else []
    if only:
        text += (" Resolved behind it on this suite only (these problems fixed, the grid's error alone), a decision "
                 "that does not hold across problems: " + "; ".join(_name(r, by) for r in only) + ".")
    scale = scale_words(fam, v["power"])
    return text + " " + scale[0].upper() + scale[1:] + "."


def _scope_words(fam: dict) -> str:
    """``across problems (8 problems, engine × problem spread 0.012 against the grid's 0.005; t on 35
    degrees of freedom)`` or ``on this suite (...)``: the scope of the class's headline standing."""
    a = fam.get("across")
    if a is None:
        return "on this suite (these problems fixed, the grid's error alone)"
    return (f"across problems ({a['problems']} problems as a sample: engine × problem spread {number(a['interaction_sd'])} "
            f"against the grid's {number(a['grid_sd'])}; Dunnett's t on {a['df']} degrees of freedom)")


def scale_words(fam: dict, power: dict | None) -> str:
    """How small a difference the class's comparisons could have seen: its minimal detectable difference,
    and the planted result when the document has one."""
    a = fam.get("across")
    text = (f"between variants of this class the suite detects a difference of {number(a['mdd'])} across problems and "
            f"{number(fam['mdd'])} on this suite, with 80 % power" if a is not None and fam.get("mdd") is not None else
            f"between variants of this class the suite detects a difference of {number(fam['mdd'])} on this suite "
            "with 80 % power" if fam.get("mdd") is not None else "no paired comparison")
    if power:
        text += "; " + planted_words(power)
    return text


def planted_words(power: dict) -> str:
    """``a restitution planted 1 % below the target, its boundary 0.012 away, is resolved from the target
    itself; 0.5 % is not``."""
    rows = {r["delta"]: r for r in power["planted"]}
    small = power["smallest_resolved_delta"]
    if small is None:
        top = max(rows)
        return f"a restitution planted up to {delta_words(top)} below its target is not resolved from the target itself"
    text = (f"a restitution planted {delta_words(small)} below its target, its boundary {number(rows[small]['distance'])} "
            "from the reference's, is resolved from the target itself")
    below = [d for d, r in rows.items() if 0 < d < small and not r["resolved"]]
    return text + (f"; {delta_words(max(below))} is not" if below else "")


#: How many failing scenarios a failure names (worst first).
_NAMED = 3


def _failure(row: dict, by: dict) -> str:
    if not row["fails_in"]:
        why = ["nothing it simulated could be judged"]
    else:
        worst = [scenario_words(b) for b in row["fails_in"][:_NAMED]]
        more = len(row["fails_in"]) - _NAMED
        first = row["fails_in"][0]
        coarse = ("" if first.get("beyond_error", True) else
                  f", which the grid's own error there, {number(first['sd'])}, does not resolve: a grid too coarse "
                  "for the limit decided it")
        why = [f"off in {'; '.join(worst)}" + (f" and {_plural(more, 'more scenario')}" if more > 0 else "")
               + f" (limit {'none' if first['limit'] is None else format(first['limit'], '.3g')}{coarse})"] + row["reasons"]
    if row["shipped_note"]:
        why.append(row["shipped_note"].rstrip("."))
    mean = f" (mean {number(row['value'])})" if row["value"] is not None else ""
    return f"{_name(row, by)}{mean}: {', and '.join(why)}"


def _margin_words(margin) -> str:
    return "each scenario's η_H–η_M reference gap" if margin == RESTITUTION_GAP else f"{float(margin):g}"


def _equivalence_sentence(v: dict) -> list[str]:
    shown = [r for r in v["variants"] if r["group"] in COMPARED and not r["fails"] and r["equivalence"]]
    if not shown:
        return []
    within = [r for r in shown if r["equivalence"]["within"]]
    rest = [r for r in shown if not r["equivalence"]["within"]]

    def one(r):
        e = r["equivalence"]
        w = e["worst"]
        where = ("within it in every scenario" if e["within_every_scenario"] else
                 f"not shown in every scenario: worst {w['block']} {w['pulse']}, distance {w['value'] / w['margin']:.2f} "
                 f"of its margin, bound {w['upper'] / w['margin']:.2f}")
        return f"{r['label']} (mean {e['mean_ratio']:.2f} of the margin, upper bound {e['upper']:.2f}; {where})"

    text = (f"Within the uncertainty of the restitution (margin: {_margin_words(v['declared']['equivalence_margin'])}, "
            "declared by the suite; a one-sided 5 % test that the mean over the problems of distance over margin "
            "is below 1): " + ("; ".join(one(r) for r in within) if within else "no variant"))
    if rest:
        text += ". Not shown: " + "; ".join(one(r) for r in rest)
    return [text + "."]


def _held_out_sentence(rows: list[dict], v: dict) -> list[str]:
    held = [r for r in rows if r["held_out"]]
    if not held:
        return []
    margin = rule_words(v["declared"]["held_out_margin"])
    return [f"Held-out check (calibrated on another block, set against the same settings calibrated on each block "
            f"itself; two one-sided 5 % tests, margin ± {margin}, declared by the suite): "
            + "; ".join(_held_out_words(r) for r in held) + "."]


def _held_out_words(r: dict) -> str:
    h = r["held_out"]
    lo, hi = h["ci95"]
    head = f"{r['label']}, {number(h['value'])} [{number(lo)}, {number(hi)}] over {_plural(h['scenarios'], 'scenario')}"
    gone = h.get("left_out") or []
    if gone:
        head += " (left out of the test: " + "; ".join(f"{b['block']} {b['pulse']}, {b['why']}" for b in gone) + ")"
    if h["tost"] is None and gone and not h.get("tested_scenarios"):
        return head + ": not tested, no held-out scenario that can test it"
    if h["tost"] is None and h.get("in_sample_variant") is not None and h.get("margin", 1) is None:
        return head + ": not tested, no η_H–η_M reference gap in its tested scenarios to set its margin"
    if h["tost"] is None:
        return head + ", with no map of the same settings calibrated on the block itself to test it against"
    where = {"same scenarios": "in the same scenarios",
             "same problems": "on the other size of the same problems"}[h["in_sample_scope"]]
    t = h["tost"]
    word = held_out_word(h)
    return (f"{head}: {word}, against {number(h['in_sample'])} {where}, difference {signed(h['difference'])} "
            f"(90 % interval {signed(t['interval'][0])} to {signed(t['interval'][1])}, margin ±{number(h['margin'])})")


def held_out_word(h: dict) -> str:
    """What a tested held-out variant's TOST says: it carries over (the difference's 90 % interval inside the
    margin), is resolved worse than its in-sample twin (the 95 % interval above 0), or neither."""
    if h["carries_over"]:
        return "carries over"
    if h["difference_ci95"][0] > 0:
        return "does not carry over (resolved worse than its twin)"
    return "not shown to carry over"


def _general_sentence(v: dict, by: dict) -> list[str]:
    g = v["general"]
    lo, hi = g["range"]
    if not g["stated"]:
        return [f"No claim about problems in general: {g['why']}."]
    parts = []
    for cls in COMPARED:
        fam = v["mcb"].get(cls)
        if fam is None:
            continue
        best = by[fam["best"]]
        bits = [f"{_SHORT_TITLES[cls].lower()}, best {best['label']} "
                + (f"{number(best['general']['mean'])} [{number(max(best['general']['ci95'][0], 0.0))}, "
                   f"{number(best['general']['ci95'][1])}]" if best["general"] else "(its problems do not span the range)")]
        for n in fam["entries"]:
            c = next((x["general"] for x in by[n]["versus"] if x.get("general")), None)
            if c is not None:
                bits.append(f"{by[n]['label']} {signed(c['difference'])} [{signed(c['ci95'][0])}, {signed(c['ci95'][1])}] "
                            f"from it, {'resolved' if c['resolved'] else 'not resolved'}")
        text = "; ".join(bits)
        parts.append(text[0].upper() + text[1:])
    n = len(g["slendernesses"])
    return [f"About problems in general (h/b {lo:g}–{hi:g}, {n} slendernesses; Student's t over the slenderness "
            f"means on {n - 1} degrees of freedom, no grid term added; each class's comparisons with its best "
            "Bonferroni-corrected): " + ". ".join(parts) + "."]


def _power_sentence(v: dict) -> list[str]:
    p = v["power"]
    if not p:
        return ["No planted variant in these scores: what the suite could have seen is stated by each class's "
                "minimal detectable difference alone."]
    rows = [r for r in p["planted"] if r["delta"] > 0]
    against = "δ = 0" if p["against"] else "a distance of 0"
    bits = [f"δ = {delta_words(r['delta'])}: distance {number(r['distance'])}, difference {signed(r['difference'])} "
            f"(p {r['p']:.2g}), {'resolved' if r['resolved'] else 'not resolved'}" if r["p"] is not None else
            f"δ = {delta_words(r['delta'])}: no difference" for r in rows]
    small = p["smallest_resolved_delta"]
    tail = (f"the smallest δ this suite resolves from δ = 0: {delta_words(small)}" if small is not None
            else "no planted δ is resolved")
    return [f"The suite's power, measured (the reference solver as an engine with its restitution planted δ below "
            f"the target, each against {against} by {p['critical_from']}, q = {p['critical']:.2f}): "
            + "; ".join(bits) + f"; {tail}."]


def engine_power_sentences(p: dict | None, labels: dict) -> list[str]:
    """One sentence per engine with engine-planted variants (score.json's ``verdict.engine_power``): each
    δ against the engine's δ = 0 variant across problems, by the distance and by the signed offset, and
    the |δ| each resolves; nothing without such variants. ``labels``: ``{engine: a label}`` (its name
    is the label's first words)."""
    out = []
    for engine, e in ((p or {}).get("engines") or {}).items():
        name = str(labels.get(engine, engine)).split(",")[0]
        if e["against"] is None:
            out.append(f"{name} calibrated to η·(1 + δ) has no calibrated variant (δ = 0) in these scores to be "
                       "compared with: its planted restitution errors are not judged.")
            continue
        bits = [f"δ = {'+' if r['delta'] > 0 else '−'}{delta_words(abs(r['delta']))}: "
                + ", ".join(_moved(r[m], m) for m in ("distance", "offset")) for r in e["rows"]]
        df = next((r[m]["df"] for r in e["rows"] for m in ("distance", "offset") if r[m]), None)
        res = e["resolved_abs_delta"]
        tail = "; ".join(f"by the {m}, " + ("|δ| " + _and([delta_words(d) for d in res[m]]) + " resolved" if res[m]
                                            else "no |δ| resolved") for m in ("distance", "offset"))
        out.append(f"The suite's power against {name}'s own restitution error, across problems ({name} calibrated "
                   f"to η·(1 + δ) against its own calibration to η, δ = 0, paired per problem"
                   + (f", t on {df} degrees of freedom" if df is not None else "") + "; the distance one-sided, the "
                   "signed offset two-sided): " + "; ".join(bits) + f"; {tail}.")
    return out


def _moved(d: dict | None, measure: str) -> str:
    """``distance +0.004 (95 % −0.001 to +0.009), not resolved``."""
    if d is None:
        return f"{measure} n/a"
    lo, hi = d["ci95"]
    return (f"{measure} {signed(d['difference'])} (95 % {signed(lo)} to {signed(hi)}), "
            + ("resolved" if d["resolved"] else "not resolved"))


# -- the short verdict ------------------------------------------------------------------------------------

_SHORT_REASONS = {"overturn_extra": "overturns where the reference stands", "overturn_missed":
                  "stands where the reference overturns", "failed": "fails to simulate", "invalid": "flags invalid"}


def words(text: str | list[str]) -> int:
    """The number of words of a text (or of a list of sentences): what :data:`SHORT_WORDS` bounds."""
    if isinstance(text, list):
        return sum(words(t) for t in text)
    return len(str(text).split())


def short_verdict(v: dict) -> list[str]:
    """The verdict in at most :data:`SHORT_WORDS` words: each compared class's best with the variants
    that may be the best and the scale of that tie, the failures with their reason, equivalence and the
    held-out check in a line each. Longer forms are shortened step by step (names counted instead of
    listed, reasons left out) until it fits."""
    for level in range(4):
        out = _short(v, level)
        if words(out) <= SHORT_WORDS:
            return out
    cut = " ".join(out).split()[:SHORT_WORDS - 1]    # not reached by any suite of a few dozen variants
    return [" ".join(cut) + " …"]


def _short(v: dict, level: int) -> list[str]:
    rows = v["variants"]
    by = {r["variant"]: r for r in rows}
    names = _short_names(rows)
    out = []
    for cls in COMPARED:
        fam = v["mcb"].get(cls)
        if fam is not None:
            out.append(_short_class(cls, fam, v, by, level))
    failing = [r for r in rows if r["fails"]]
    if failing:
        beyond = "a missing boundary" if v["fail_distance"] is None else f"a scenario beyond {v['fail_distance']:.3g}"
        out.append(f"Fail ({beyond}): "
                   + _list([_short_failure(r, names, level) for r in failing], level >= 3) + ".")
    within = _within_by_class(v, by, level)
    if within:
        out.append(f"Within the restitution's uncertainty (on the mean): {within}.")
    held = [r for r in rows if r["held_out"] and (r["held_out"]["tost"] is not None or r["held_out"].get("left_out"))]
    if held:
        yes = [names[r["variant"]] for r in held if r["held_out"]["carries_over"]]
        untested = [names[r["variant"]] for r in held if r["held_out"]["tost"] is None and r["held_out"].get("left_out")]
        no = [names[r["variant"]] for r in held if not r["held_out"]["carries_over"] and names[r["variant"]] not in untested]
        text = "Held-out calibration carries over: " + (_list(yes, level >= 1) if yes else "none shown")
        text += f"; not shown: {_list(no, level >= 1)}" if no else ""
        out.append(text + (f"; not tested (held-out scenarios identical or unresponsive): {_list(untested, level >= 1)}."
                           if untested else "."))
    return out


def _within_by_class(v: dict, by: dict, level: int) -> str:
    """``calibrated: all 6; as shipped: DART, Drake``: the variants within the restitution's uncertainty,
    by class."""
    parts = []
    for cls in COMPARED:
        fam = v["mcb"].get(cls)
        if fam is None:
            continue
        members = [by[n] for e in fam["members"].values() for n in e]
        inside = [r for r in members if r["variant"] in v["equivalence"]["within"]]
        if not inside:
            continue
        names = _short_names(inside, qualified=False)
        text = f"all {len(members)}" if len(inside) == len(members) > 2 else _list(list(names.values()), level >= 2)
        parts.append(f"{_SHORT_TITLES[cls].lower()}: {text}")
    return "; ".join(parts)


def _list(items_: list[str], count: bool) -> str:
    if count and len(items_) > 2:
        return f"{items_[0]} and {len(items_) - 1} others"
    return ", ".join(items_)


def _short_class(cls: str, fam: dict, v: dict, by: dict, level: int) -> str:
    names = _short_names([by[n] for n in fam["entries"]], qualified=False)
    best = by[fam["best"]]
    text = f"{_SHORT_TITLES[cls]}: {names[best['variant']]} best ({number(best['value'])})"
    a = fam.get("across")
    where = " across problems" if a is not None else " on this suite"
    tied = [names[n] for n in fam["entries"] if n != fam["best"] and by[n]["in_best_subset"]]
    behind = [names[n] for n in fam["entries"] if not by[n]["in_best_subset"]]
    if tied:
        text += f"; tied{where}: {_list(tied, level >= 1)}"
    if behind:
        text += f"; resolved behind{where}: {_list(behind, level >= 1)}"
    if fam.get("mdd") is not None:
        scale = (f"resolvable: {number(a['mdd'])} across problems, {number(fam['mdd'])} on this suite, at 80 % power"
                 if a is not None else f"resolvable on this suite: {number(fam['mdd'])} at 80 % power")
        p = v["power"]
        if p and p["smallest_resolved_delta"] is not None and level < 3:
            scale += f"; η planted {delta_words(p['smallest_resolved_delta'])} off resolved"
        text += f" ({scale})"
    return text + "."


def _short_failure(r: dict, names: dict, level: int) -> str:
    name = names[r["variant"]]
    if not r["fails_in"]:
        return f"{name} (nothing judged)"
    w = r["fails_in"][0]
    head = (f"{w['block']} {w['pulse']} no boundary" if w.get("missing_boundary")
            else f"{w['block']} {w['pulse']} {number(w['value'])}")
    bits = [head + ("" if w.get("beyond_error", True) or level >= 2 else ", within the grid's error")]
    if level < 2 and r.get("reason_kinds"):
        k = r["reason_kinds"][0]
        bits.append(f"{_SHORT_REASONS[k['kind']]}, {100 * k['share']:.0f} %")
    return f"{name} ({'; '.join(bits)})"


def _short_names(rows: list[dict], qualified: bool = True) -> dict:
    """Each variant's short name: its engine, with its class when ``qualified`` ("DART calibrated"); the
    label where two variants would read alike, or for a variant of no compared class."""
    cls_words = {CALIBRATED: "calibrated", AS_SHIPPED: "as shipped"}
    out = {}
    for r in rows:
        if r["settings"] in cls_words:
            out[r["variant"]] = engine_name(r["engine"]) + (f" {cls_words[r['settings']]}" if qualified else "")
        elif r.get("group") == "held-out":
            out[r["variant"]] = engine_name(r["engine"])     # named beside its twin, in the held-out line
        else:
            out[r["variant"]] = r["label"]
    seen: dict = {}
    for k, n in out.items():
        seen.setdefault(n, []).append(k)
    for n, ks in seen.items():
        if len(ks) > 1:
            for k in ks:
                out[k] = next(r["label"] for r in rows if r["variant"] == k)
    return out
