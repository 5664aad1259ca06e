"""Text and Markdown tables of scores and comparisons (for the terminal, pull requests and report.md)."""

from __future__ import annotations

import html as _html
import math
import textwrap

from rockbench.benchmark.scoring.failing import scenario_words
from rockbench.benchmark.scoring.metrics import METRICS, NEARER_ZERO, PRIMARY_METRIC
from rockbench.benchmark.scoring.scores import Scores
from rockbench.benchmark.report.verdict_words import METHOD, number, sentences, short_verdict

def fmt(name: str, v) -> str:
    """A metric's value as tables write it (:meth:`~rockbench.benchmark.scoring.metrics.Metric.format`)."""
    return METRICS[name].format(v)


def md_cell(text: str) -> str:
    """A Markdown table cell: ``|`` escaped (pair keys contain it) and line breaks folded, so every
    row keeps the header's number of cells."""
    return " ".join(str(text).replace("\\", "\\\\").replace("|", "\\|").split())


def render(head: list[str], rows: list[list[str]], markdown: bool) -> str:
    if markdown:
        lines = ["| " + " | ".join(md_cell(h) for h in head) + " |", "|" + "|".join("---" for _ in head) + "|"]
        lines += ["| " + " | ".join(md_cell(c) for c in r) + " |" for r in rows]
        return "\n".join(lines)
    width = [max(len(h), *(len(r[k]) for r in rows)) if rows else len(h) for k, h in enumerate(head)]
    out = ["  ".join(h.ljust(w) for h, w in zip(head, width)), "  ".join("-" * w for w in width)]
    out += ["  ".join(c.ljust(w) for c, w in zip(r, width)) for r in rows]
    return "\n".join(out)


def pairs_table(scores: Scores, markdown: bool = False) -> str:
    """One row per scored pair, one column per metric."""
    head = ["engine", "block", "pulse", "restitution", "vs reference", "like"] + [METRICS[m].short for m in METRICS]
    rows = [[p["variant"] + incomplete_note(p), p["block"], p["pulse"], p["restitution"], reference_label(p),
             "yes" if p["like_for_like"] else "", *(fmt(m, p["scores"].get(m)) for m in METRICS)]
            for p in scores.pairs]
    return render(head, rows, markdown)


def incomplete_note(p: dict) -> str:
    """`` (incomplete: N cells missing)`` for a pair scored on an incomplete engine map, else nothing."""
    return f" (incomplete: {p['cells_missing']} cells missing)" if p.get("complete") is False else ""


def reference_label(p: dict) -> str:
    """The reference a scored pair was judged against: its restitution, and "(own η)" for a reference
    run at the engine's own measured η."""
    r = p["reference"]
    return r["restitution"] + (" (own η)" if r.get("kind") == "own-eta" else "")


def summary(scores: Scores) -> dict:
    """Per engine variant: the mean of each metric over its like-for-like pairs (counts summed).

    Variants without like-for-like pairs use all their pairs. Returns ``{variant: {metric: value,
    "pairs": n}}``.
    """
    groups: dict[str, list[dict]] = {}
    for p in scores.pairs:
        groups.setdefault(p["variant"], []).append(p)
    out = {}
    for v, ps in sorted(groups.items()):
        use = [p for p in ps if p["like_for_like"]] or ps
        row = {"pairs": len(use)}
        for m in METRICS:
            vals = [p["scores"].get(m) for p in use]
            vals = [math.nan if x is None else float(x) for x in vals]
            if METRICS[m].kind == "count":
                row[m] = float(sum(vals))
            else:
                finite = [x for x in vals if math.isfinite(x)]
                row[m] = sum(finite) / len(finite) if finite else math.nan
        out[v] = row
    return out


def primary_cell(row: dict) -> str:
    """A verdict row's primary value with its 95 % interval: ``0.008 [0.003, 0.013]``; a variant of
    the held-out check alone, its held-out value so marked; a failing variant, what failed first
    (without a mean where a map has no boundary: its distance is a placeholder)."""
    if row.get("value") is None and row.get("held_out"):
        h = row["held_out"]
        return f"{number(h['value'])} [{number(h['ci95'][0])}, {number(h['ci95'][1])}] held out"
    failure = "fails: " + scenario_words(row["fails_in"][0]) if row.get("fails") and row.get("fails_in") else ""
    if row.get("value") is None:
        return failure or "n/a (nothing judged)"
    lo, hi = row["ci95"]
    return f"{number(row['value'])} [{number(lo)}, {number(hi)}]" + (f"; {failure}" if failure else "")


def ranked_summary(scores: Scores) -> list[tuple[dict, dict]]:
    """``[(verdict row, summary row)]`` in the verdict's order (rank, then value): the rows of every
    summary table."""
    s = summary(scores)
    return [(r, s[r["variant"]]) for r in scores.verdict.variants if r["variant"] in s]


def row_label(r: dict, label: str | None = None) -> str:
    """A summary row's variant (``label``, default the verdict row's) with what the reader must know:
    "(incomplete: N cells missing)", "(fails)"."""
    name = label or r["label"]
    if r["cells_missing"]:
        name += f" (incomplete: {r['cells_missing']} cells missing)"
    return name + (" (fails)" if r["fails"] else "")


def best_group_marks(ranked: list[tuple[dict, dict]]) -> dict[str, list[bool]]:
    """Per metric, which rows to highlight: the primary metric's best group (rank 1, unless it fails),
    and, when that group has two or more rows, for every secondary metric its best value among those
    rows only (a secondary column never praises a variant outside the best group)."""
    top = [r["rank"] == 1 and not r["fails"] for r, _ in ranked]
    if len(ranked) < 2 or not any(top):
        return {}
    marks = {PRIMARY_METRIC: top}
    if sum(top) < 2:
        return marks
    for m, spec in METRICS.items():
        if m == PRIMARY_METRIC:
            continue
        vals = [row[m] for (r, row), t in zip(ranked, top) if t and math.isfinite(row[m])]
        all_vals = {row[m] for _, row in ranked if math.isfinite(row[m])}
        if vals and len(all_vals) > 1:
            best = max(vals) if spec.direction == "higher" else min(vals, key=abs if spec.direction == NEARER_ZERO else None)
            marks[m] = [t and row[m] == best for (r, row), t in zip(ranked, top)]
    return marks


def summary_table(scores: Scores, markdown: bool = False, html: bool = False) -> str:
    """Engine variant × metric in the verdict's order: rank (equal ranks tie), the primary metric with its
    95 % interval, then the secondary metrics; highlights as :func:`best_group_marks` (``**`` in
    Markdown, ``*`` in text, bold in HTML)."""
    ranked = ranked_summary(scores)
    marks = best_group_marks(ranked)
    second = [m for m in METRICS if m != PRIMARY_METRIC]
    head = (["rank", "engine", "pairs", f"{METRICS[PRIMARY_METRIC].short} [95 % CI]"]
            + [METRICS[m].short for m in second])
    rows = []
    for k, (r, row) in enumerate(ranked):
        name = row_label(r)
        cells = [str(r["rank"] or "-"), _html.escape(name) if html else name, str(row["pairs"])]
        for m, text in [(PRIMARY_METRIC, primary_cell(r))] + [(m, fmt(m, row[m])) for m in second]:
            if marks.get(m, [False] * len(ranked))[k]:
                text = f"<b>{text}</b>" if html else (f"**{text}**" if markdown else f"*{text}")
            cells.append(text)
        rows.append(cells)
    if html:
        th = "".join(f"<th>{_html.escape(h)}</th>" for h in head)
        trs = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>" for r in rows)
        return f"<table><thead><tr>{th}</tr></thead><tbody>{trs}</tbody></table>"
    return render(head, rows, markdown)


#: The title of the summary table on a terminal and in Markdown.
SUMMARY_TITLE = ("Summary (mean over like-for-like pairs; rank 1: may be the best of its settings class, 2: resolved "
                 "behind it, the method under the table)")

#: The title of the per-scenario table.
SCENARIO_TITLE = ("Per scenario: boundary distance of each variant ('!' beyond the declared fail distance: it fails "
                  "there; 'held out': calibrated on another block), and the distance between the η_H and η_M "
                  "reference boundaries")


def method_line() -> str:
    """How the values and ranks were made (under every summary table)."""
    return " ".join(METHOD[k] for k in ("value", "comparisons", "failing"))


def scenario_rows(scores: Scores) -> tuple[list[str], list[list[str]]]:
    """Head and rows of the per-scenario table: one row per variant (the verdict's order), one column
    per block × pulse, and a first row with the η_H–η_M reference gap of each scenario."""
    rows = [r for r in scores.verdict.variants if r.get("per_scenario")]
    keys = sorted({(s["block"], s["pulse"]) for r in rows for s in r["per_scenario"]})
    gaps = {(g["block"], g["pulse"]): g.get("boundary_mean") for g in scores.reference_gaps}
    body = [["η_H–η_M reference gap", *(number(gaps.get(k)) for k in keys)]] if gaps else []
    for r in rows:
        by = {(s["block"], s["pulse"]): s for s in r["per_scenario"]}
        cells = []
        for k in keys:
            s = by.get(k)
            if s is None:
                cells.append("")
                continue
            mark = (" !" if s.get("fails") else "") + (" (held out)" if s["held_out"] else "")
            value = "no boundary" if s.get("missing_boundary") == "engine" else (
                "no reference boundary" if s.get("missing_boundary") else number(s["value"]))
            cells.append(value + mark)
        body.append([row_label(r), *cells])
    return ["engine", *(f"{b} {p}" for b, p in keys)], body


def scenario_table(scores: Scores, markdown: bool = False) -> str:
    """:func:`scenario_rows` as a text or Markdown table."""
    return render(*scenario_rows(scores), markdown)


def verdict_text(scores: Scores) -> list[str]:
    """The verdict's sentences (:func:`~.verdict_words.sentences`)."""
    return sentences(scores.verdict.to_json())


def short_verdict_text(scores: Scores) -> list[str]:
    """The verdict in short (:func:`~.verdict_words.short_verdict`)."""
    return short_verdict(scores.verdict.to_json())


def verdict_block(scores: Scores, markdown: bool = False) -> str:
    """The verdict under its title, in short (at most 120 words) and then every sentence: Markdown, or
    for a terminal folded at 100 columns."""
    short, lines = short_verdict_text(scores), verdict_text(scores)
    if markdown:
        return ("### Verdict\n\n" + (" ".join(md_cell(t) for t in short) + "\n\n" if short else "")
                + "\n".join(f"- {md_cell(t)}" for t in lines))
    head = textwrap.fill(" ".join(short), 100) + "\n\nIn full:\n" if short else ""
    return "Verdict\n" + head + "\n".join(textwrap.fill(t, 100, initial_indent="- ", subsequent_indent="  ")
                                           for t in lines)


def compare_table(res: dict, markdown: bool = False) -> str:
    """Regressions (and improvements) of a comparison, one row per pair and metric."""
    head = ["", "pair", "metric", "baseline", "current", "delta", "tolerance"]
    rows = []
    for tag, items in (("REGRESSION", res["regressions"]), ("improved", res["improvements"])):
        for r in items:
            d = r["delta"]
            rows.append([tag, r["key"], r["metric"], fmt(r["metric"], r["baseline"]), fmt(r["metric"], r["current"]),
                         "n/a" if isinstance(d, float) and math.isnan(d) else f"{d:+.4g}", f"{r['tolerance']:g}"])
    for k in res["missing"]:
        rows.append(["MISSING", k, "", "", "", "", ""])
    title = (f"compare: {res['status']} — {res['compared']} pair(s) compared, {len(res['regressions'])} "
             f"regression(s), {len(res['missing'])} missing, {len(res['improvements'])} improvement(s), "
             f"{len(res['new'])} new")
    if not rows:   # the table is always there, so a pull-request comment keeps its shape
        rows.append(["ok", f"all {res['compared']} pair(s) within their tolerances", "", "", "", "", ""])
    out = (("**" + md_cell(title) + "**\n\n") if markdown else title + "\n") + render(head, rows, markdown)
    sp = res.get("speed")
    return out if not sp else out + "\n" + speed_compare_table(sp, markdown)


def speed_compare_table(sp: dict, markdown: bool = False) -> str:
    """The speed stages' costs at matched accuracy side by side (:func:`~.speed.compare_speed`): each engine
    and criterion, flagged where the cost rose by more than the factor or is no longer reached."""
    def at(p):
        return "not reached" if not p else f"{p['dt_s'] * 1e3:g} ms at {p['cost']:.3g}"

    head = ["", "engine", "criterion", "baseline", "current", "ratio"]
    rows = [["COST" if r in sp["flags"] else ("not compared" if r["flag"] else "ok"), r["engine"],
             {"within_mdd": "(a) within the detectable difference", "within_distance": "(b) within the declared "
              "distance"}[r["criterion"]], at(r["baseline"]), at(r["current"]),
             "–" if r["ratio"] is None else f"{r['ratio']:.2f}"] for r in sp["rows"]]
    title = (f"speed: {len(sp['flags'])} engine cost(s) at matched accuracy rose by more than {sp['factor']:g} "
             f"(or are no longer reached)" + "".join(f"; {n}" for n in sp["notes"]))
    if not rows:
        rows.append(["ok", "no engine in both runs", "", "", "", ""])
    return (("**" + md_cell(title) + "**\n\n") if markdown else title + "\n") + render(head, rows, markdown)
