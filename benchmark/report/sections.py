"""The report's tables and the words around them, built from the scores (:class:`~rockbench.benchmark.scoring.scores.Scores`) and the maps (rows of
text, one list per table): summary, verdict, calibration and its price, speed, experiments, pairs,
versions and settings. :mod:`~rockbench.benchmark.report.page` writes them as Markdown and HTML.
"""

from __future__ import annotations

import math

from rockbench.benchmark.scoring.labels import restitution_symbol
from rockbench.benchmark.scoring.metrics import METRICS, PRIMARY_METRIC
from rockbench.benchmark.report.tables import (SCENARIO_TITLE, best_group_marks, fmt, incomplete_note, method_line, primary_cell,
                              ranked_summary, reference_label, render, row_label, scenario_rows,
                              short_verdict_text, verdict_text)
from rockbench.benchmark.scoring.scores import Scores
from rockbench.benchmark.store.loading import MapEntry



def _num(x, spec=".4f", why: str | None = None):
    """``x`` formatted, or "n/a" with the reason where one is given."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return f"n/a ({why})" if why else "n/a"
    return format(x, spec)


def summary_rows(scores: Scores, labels) -> tuple[list[str], list[list[str]], list[str], dict]:
    """Head, body and the variant key of each row, in the verdict's order (rank, then the primary
    value), and per metric which rows to highlight (:func:`~rockbench.benchmark.report.tables.best_group_marks`)."""

    ranked = ranked_summary(scores)
    second = [m for m in METRICS if m != PRIMARY_METRIC]
    head = (["rank", "engine variant", "pairs", f"{METRICS[PRIMARY_METRIC].title} [95 % interval] (primary)"]
            + [METRICS[m].title for m in second])
    body = []
    for r, row in ranked:
        body.append([str(r["rank"] or "-"), row_label(r, labels.get(r["variant"])), str(row["pairs"]), primary_cell(r)]
                    + [fmt(m, row[m]) for m in second])
    cols = {PRIMARY_METRIC: 3, **{m: 4 + k for k, m in enumerate(second)}}
    marks = {cols[m]: flags for m, flags in best_group_marks(ranked).items()}
    return head, body, [r["variant"] for r, _ in ranked], marks


def scenario_tables(scores: Scores) -> tuple[str, str, list[str], list[list[str]]]:
    """The method sentence under the summary, and the per-scenario table's title, head and rows."""
    return (method_line(), SCENARIO_TITLE, *scenario_rows(scores))


def verdict_sentences(scores: Scores) -> list[str]:
    """The verdict's sentences (:func:`~rockbench.benchmark.report.verdict_words.sentences`)."""
    return verdict_text(scores)


def short_verdict_lines(scores: Scores) -> list[str]:
    """The verdict in at most 120 words (:func:`~rockbench.benchmark.report.verdict_words.short_verdict`)."""
    return short_verdict_text(scores)


def calib_table(rows, labels):
    head = ["engine variant", "block", "calibrated to", "η target", "η measured in free rocking",
            "measured vs η_H (Housner)", "measured vs η_M (size's average k)",
            "measured vs the block's own free-rocking test (η_M, exact k)"]
    body = [[labels.get(r["variant"], r["variant"]), r["block"], restitution_symbol(r["restitution"], r["block"]),
             _num(r["eta_target"], why="no target: the engine runs as shipped"),
             _num(r["eta_measured"], why="not measured (no calibration or own-η measurement recorded)"),
             *(_pct(r.get(f"{k}_rel_error"), _no_target(r, k)) for k in ("housner", "modified_average_k", "experiment"))]
            for r in rows]
    return head, body


def _no_target(row: dict, key: str) -> str:
    """Why a calibration row has no relative error against target ``key``."""
    if not math.isfinite(row["eta_measured"]):
        return "η not measured"
    if "housner_eta" in row:   # a preset outside Table 1: no free-rocking test of its own
        return "not in Table 1: no free-rocking test of its own"
    return "a custom block has no published η"


def _pct(x, why: str) -> str:
    """A relative difference in per cent, or "n/a (why)"."""
    return _num(None if x is None else 100 * x, "+.2f", why=why) + (" %" if x is not None and math.isfinite(x) else "")


def _tolerance(uplift: dict) -> str:
    """The static uplift's tolerance as the calibration recorded it (a record made before it was
    recorded says so in words)."""
    rtol = uplift.get("rtol")
    return f"{100 * rtol:g} %" if rtol is not None else "its tolerance"


def price_table(rows, labels):
    """Per engine variant and block with a measured contact price: reached or not, the
    contact, and what it costs."""
    head = ["engine variant", "block", "target", "η measured", "reached", "contact", "static uplift / g·tanα",
            "slip / jump cells", "quarter period vs rigid", "steps/s"]
    body = []
    for r in rows:
        pr = r.get("price")
        if not pr:
            continue
        up, sl = pr.get("uplift") or {}, pr.get("anti_slip") or {}
        ratio = up.get("ratio", math.nan)
        counts = pr.get("counts")
        body.append([labels.get(r["variant"], r["variant"]), r["block"], restitution_symbol(r["restitution"], r["block"]),
                     _num(r["eta_measured"]), "yes" if r.get("reached") and counts else "no", r["contact"],
                     _num(ratio) + ("" if up.get("within") else f" (outside {_tolerance(up)})"),
                     f"{sl.get('n_slip', '–')} / {sl.get('n_jump', '–')} of {sl.get('cells', '–')}",
                     (_num(100 * pr["period_change"], "+.2f") + " %") if pr.get("period_change") is not None else "–",
                     f"{pr['steps_per_s']:.3g}" if pr.get("steps_per_s") else "–"])
    return head, body


PRICE_WORDS = ("Where an engine variant was calibrated to a target its corner contact cannot reach (the modified "
                "η_M), the calibration searched a contact along the base and measured its price: the table "
                "acceleration at which the block lifts under a slow ramp (must be within 2 % of g·tanα), slip and "
                "jump flags of the one validity rule in default-suite cells the rigid model rocks through without "
                "lift or slip, the free-rocking quarter period against the rigid model's, and engine steps per "
                "second. See docs/contact.md.")


#: The scores the speed table shows beside the wall time: the primary one and the plain agreement.
SPEED_METRICS = (PRIMARY_METRIC, "agreement")


def speed_table(rows, labels):
    head = ["engine variant", "simulated cells", "wall time per simulated cell [ms]",
            "CPU seconds per simulated second",
            *(METRICS[m].title + (" (primary)" if m == PRIMARY_METRIC else "") for m in SPEED_METRICS)]
    body = [[labels.get(r["variant"], r["variant"]), str(r["cells"]),
             _num(r["ms_per_cell"], ".2f", why="no wall times in cells.csv"),
             _num(r.get("cpu_per_simulated_s"), ".3g", why="no cost in cells.csv"),
             *(_speed_score(r, m) for m in SPEED_METRICS)] for r in rows]
    return head, body


def _speed_score(row: dict, metric: str) -> str:
    """A score of the speed table, or "n/a" with the reason."""
    x = row.get(metric)
    if x is not None and math.isfinite(x):
        return fmt(metric, x)
    return "n/a (the yardstick itself)" if row["variant"] == "reference" else "n/a (no like-for-like reference map)"


def exp_table(scores: Scores | None, labels):
    head = ["map", "restitution", "runs", "outside", "accuracy", "overturn accuracy",
            "confusion T/R/O → rest/rocking/overturn/failed"]
    body = []
    for e in (scores.experiments or ()) if scores else ():
        conf = "; ".join(f"{k}: " + "/".join(str(v) for v in row.values()) for k, row in e["confusion"].items())
        body.append([f"{labels.get(e['variant'], e['variant'])}, {e['block']} {e['pulse']}",
                     restitution_symbol(e["restitution"], e["block"]), str(e["runs"]), str(e["outside"]),
                     *(_num(e[k], ".3f", why="no shaking-table run inside the map") for k in
                       ("accuracy", "overturn_accuracy")), conf])
    return head, body


def pairs_table(scores: Scores | None, labels):
    head = ["engine variant", "block", "pulse", "restitution", "vs reference", "like for like"] + \
        [METRICS[m].title for m in METRICS]
    body = [[labels.get(p["variant"], p["variant"]) + incomplete_note(p), p["block"], p["pulse"],
             restitution_symbol(p["restitution"], p["block"]),
             reference_label(p), "yes" if p["like_for_like"] else "", *(fmt(m, p["scores"].get(m)) for m in METRICS)]
            for p in (scores.pairs if scores else [])]
    return head, body


def _located(opts: dict, summ: dict) -> str:
    """How a map's boundary is located, for the maps table: ``; boundary bisected 4× (1,234 samples)``."""
    depth = opts.get("locate_depth")
    if not depth:
        return "; boundary at the cell"
    n = summ.get("bisection_samples")
    return f"; boundary bisected {depth}×" + (f" ({n:,} samples)" if isinstance(n, int) else "")


def _flat(d, prefix="") -> list[str]:
    """Nested settings as ``key = value`` lines (lists and long texts shortened)."""
    out = []
    for k, v in (d or {}).items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out += _flat(v, key + ".")
        elif v is None:
            continue
        else:
            if isinstance(v, float):
                t = f"{v:.6g}"
            elif isinstance(v, (list, tuple)):
                t = ", ".join(f"{x:.6g}" if isinstance(x, float) else str(x) for x in v)
            else:
                t = str(v)
            out.append(f"{key} = {t if len(t) <= 90 else t[:87] + '...'}")
    return out


def settings_tables(entries: list[MapEntry], labels) -> dict:
    """The versions and settings as tables: one row per engine variant, one per map, and the run
    environment (values shared by every map once)."""
    variants, maps, env = {}, [], {}
    for e in entries:
        r = e.run or {}
        eng = r.get("engine") or {}
        spec = r.get("spec") or {}
        if e.variant not in variants:
            variants[e.variant] = [labels.get(e.variant, "reference solver" if e.is_reference else e.variant), e.variant,
                                   str(eng.get("version") or ""), "\n".join(_flat(e.settings)) or "(engine defaults)",
                                   "\n".join(_flat(e.resolved_settings)) or "-"]
        g = e.describe()["grid"]
        opts = r.get("options") or {}
        summ = r.get("summary") or {}
        maps.append([labels.get(e.variant, e.variant) if not e.is_reference else "reference solver", e.block, e.pulse,
                     restitution_symbol(e.restitution, e.block), f"{e.eta:.4f}",
                     f"{g['n_w']}×{g['n_a']}: ω/p {g['w_lo']:g}–{g['w_hi']:g}, a {g['a_lo']:g}–{g['a_hi']:g}",
                     (("adaptive, " + _num(100 * summ.get("fraction_simulated", math.nan), ".0f") + " % simulated")
                      if opts.get("adaptive") else "full") + _located(opts, summ),
                     _num(spec.get("dt_s"), "g") if spec.get("dt_s") else "default",
                     str(r.get("created_utc") or ""), _num(summ.get("wall_s"), ".1f")])
        git = r.get("git") or {}
        for k, v in (("rockbench", r.get("rockbench_version")),
                     ("git commit", (git.get("commit") or "") + (" (uncommitted changes)" if git.get("dirty") else "")),
                     ("Python", r.get("python")), ("platform", r.get("platform"))):
            if v:
                env.setdefault(k, set()).add(str(v))
    return {"variants": (["engine variant", "key", "version", "settings given", "settings used (resolved)"],
                         list(variants.values())),
            "maps": (["engine variant", "block", "pulse", "restitution", "η", "grid", "cells", "Δt [s]", "created",
                      "wall [s]"], maps),
            "env": (["", "value"], [[k, ", ".join(sorted(v))] for k, v in env.items()])}


def md_table(head, body):
    if not body:
        return "_none_"
    esc = [[c.replace("|", "\\|").replace("\n", "<br>") for c in r] for r in body]
    return render(head, esc, markdown=True)


def metric_words(scores: Scores | None) -> list[tuple[str, str, str]]:
    """``(title, how read, question and definition)`` of each metric, the primary first (score.json's
    definitions, else this version's)."""
    ms = list(scores.metrics if scores else ()) or [m.to_dict() for m in METRICS.values()]
    ms = sorted(ms, key=lambda m: m.get("role") != "primary")
    return [((m.get("title") or m["name"]) + f" ({m['name']}, {m.get('role', 'secondary')})",
             f"{m['direction']} is better, perfect {m['perfect']:g}" + _unit_words(m["unit"]),
             (m.get("question", "") + " " + m["definition"]).strip()) for m in ms]


#: Units of score.json's metrics in words for the report (the keys stay score.json's).
UNIT_WORDS = {"w/a units": "measured in the normalised plane (ω/p, a₀/(g·tanα))",
              "a units": "measured in a₀/(g·tanα)", "-": ""}


def _unit_words(unit: str) -> str:
    words = UNIT_WORDS.get(unit, f"unit {unit}")
    return f", {words}" if words else ""


HIGHLIGHTS = ("Rows are in the verdict's order: each settings class (calibrated, as shipped) by its comparisons "
              "with the best of the class, rank 1 the variants that may be the best (Hsu's best subset), rank 2 those "
              "resolved behind it (the method is under the table); held-out, planted and failing variants have no "
              "rank. Bold: rank 1, and among those rows the best value of each other column; no other row is "
              "highlighted.")


INTRO = ("Each row is one engine variant; each number is the mean over its like-for-like pairs (its map "
          "against the reference map with the same restitution law, same block, pulse and grid); counts are "
          "summed. The outcome scores judge only cells inside the rigid model's domain, where the reference is "
          "valid; outside it (where the rigid model would need the table to pull the block down, or more "
          "friction than μ) an engine is right to flag a jump or slip, which consistency measures.")


READ_GRAPHS = ("How to read them: the engine's overturn region is filled; the reference's overturn boundaries "
                "are lines (η_H solid black, η_M with the block's average k dashed, with its exact k dash-dotted, "
                "at the engine's own measured η dotted), and where a boundary encloses only one or a few cells "
                "those cells are outlined; cells where the engine disagrees with the reference of its own "
                "restitution law are marked by kind (▲ overturns where the reference does not, ○ misses an "
                "overturn, ■ failed); dotted areas are where the engine flagged slip, jump or energy gain (on an "
                "adaptive grid, the cells each flagged simulation stands for); the hatched region is outside the "
                "rigid model's domain (it would need lift-off or sliding), so the reference is not valid there; "
                "the dashed ST limit is the shaking table's faithful limit (25 m/s²); T, R, O are experimental "
                "outcomes when given. Under each panel's title: the share of cells with the reference's outcome "
                "(agrees), the mean distance between the two overturn boundaries in the chart's normalised units "
                "(boundary off), and the share of the cells outside the rigid model's domain where the engine "
                "flags slip or jump, as a real block would (flags ... off-model).")
