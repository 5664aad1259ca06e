"""The report's two pages: ``report.md`` (:func:`markdown_page`) and the self-contained ``index.html``
(:func:`html_page`: pictures inlined, the style sheet ``report.css`` and the script ``report.js``, shipped
beside this module as package data).
"""

from __future__ import annotations

import base64
import html
from importlib import resources

from rockbench.benchmark.scoring.labels import case_title, for_html
from rockbench.benchmark.report.plots.style import DOUBLE_COLUMN_IN
from rockbench.benchmark.scoring.scores import Scores
from rockbench.benchmark.report.speed_words import NO_STAGE, STAGE_ALONE, matched_table, stage_words
from rockbench.benchmark.report.sections import (HIGHLIGHTS, INTRO, PRICE_WORDS, READ_GRAPHS, calib_table, exp_table, md_table,
                       metric_words, pairs_table, price_table, scenario_tables, settings_tables, speed_table,
                       short_verdict_lines, summary_rows, verdict_sentences)



def markdown_page(ctx) -> str:
    scores, labels = ctx["scores"], ctx["labels"]
    L = ["# rockbench report", "", f"Generated {ctx['created']} from {', '.join(ctx['run_dirs'])}.", ""]
    for n in ctx["notes"]:
        L.append(f"> {n}")
    if stage_alone(ctx):
        L += ["", STAGE_ALONE, ""] + _md_speed(ctx) + _md_versions(ctx)
        return "\n".join(L)
    if scores:
        L += ["", "## Verdict", ""]
        if ctx.get("verdict_img"):
            L += [f"![The verdict: every engine variant's boundary distance with its 95 % interval](img/{ctx['verdict_img']})",
                  ""]
        L += [" ".join(short_verdict_lines(scores)), "", "<details><summary>The verdict in full</summary>", ""]
        L += [f"- {s}" for s in verdict_sentences(scores)] + ["", "</details>", ""]
    L += ["", "## Summary: which engine is how faithful", ""]
    if scores:
        head, body, _, marks = summary_rows(scores, labels)
        for col, flags in marks.items():
            for row, is_best in zip(body, flags):
                if is_best:
                    row[col] = f"**{row[col]}**"
        method, title, s_head, s_body = scenario_tables(scores)
        L += [INTRO + " " + HIGHLIGHTS, "", md_table(head, body), "", method, ""]
        L += [f"{title}:", "", md_table(s_head, s_body), ""]
        L += ["What each column measures:", ""]
        L += [f"- **{t}**, {how}: {d}" for t, how, d in metric_words(scores)] + [""]
    else:
        L += ["_no scores_", ""]
    L += ["## Stability graphs, one per engine variant", "", READ_GRAPHS, ""]
    for v, label, img in ctx["variant_graphs"]:
        L += [f"### {label}", "", f"![{label}](img/{img})", ""]
    L += ["## θ(t) comparison", ""]
    L += [f"![{c.title}](img/{img})" for c, img in ctx["traj"]] or ["_not drawn_"]
    L += ["", "## Calibration: η per engine", "", md_table(*calib_table(ctx["calib"], labels)), ""]
    ph, pb = price_table(ctx["calib"], labels)
    if pb:
        L += ["### What reaching the target costs", "", PRICE_WORDS, "", md_table(ph, pb), ""]
    L += _md_speed(ctx)
    L += ["Each variant of the verdict at the step it ran:", "", md_table(*speed_table(ctx["speed"], labels)), ""]
    if scores and scores.experiments:
        L += ["## Experiments", "", md_table(*exp_table(scores, labels)), ""]
    L += ["<details><summary>Stability graphs by case: every engine variant side by side</summary>", ""]
    for block, pulse, img, _ in ctx["case_graphs"]:
        L += [f"### {case_title(block, pulse)}", "", f"![{block} {pulse}](img/{img})", ""]
    L += ["</details>", "", "<details><summary>Every scored pair</summary>", "",
          md_table(*pairs_table(scores, labels)) if scores else "_none_", "", "</details>", ""] + _md_versions(ctx)
    return "\n".join(L)


def stage_alone(ctx) -> bool:
    """Whether the report's run is the accuracy–cost stage alone (``rockbench run speed``): a speed
    section and no engine map of a verdict variant, so the page shows the stage and its settings only."""
    return bool(speed_of(ctx)) and not ctx["labels"]


def speed_of(ctx) -> dict | None:
    """The scores' speed stage (score.json's ``speed``), None without one."""
    scores = ctx["scores"]
    return None if scores is None or scores.speed is None else scores.speed.record


def _md_speed(ctx) -> list[str]:
    """The speed section's words, picture and matched-accuracy table (or why there is none)."""
    L = ["## Speed and accuracy", ""]
    sp = speed_of(ctx)
    if not sp:
        return L + [NO_STAGE, ""]
    L += [stage_words(sp), ""]
    if ctx["speed_img"]:
        L += [f"![accuracy against cost](img/{ctx['speed_img']})", ""]
    return L + ["Cost at matched accuracy:", "", md_table(*matched_table(sp)), ""]


def _md_versions(ctx) -> list[str]:
    t = settings_tables(ctx["entries"], ctx["labels"])
    return ["<details><summary>Versions and settings</summary>", "", "Run environment:", "", md_table(*t["env"]), "",
            "Engine variants:", "", md_table(*t["variants"]), "", "Maps:", "", md_table(*t["maps"]), "", "</details>",
            ""]


def _asset(name: str) -> str:
    """A file shipped beside this module (package data): the page's style sheet and its script."""
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


def _h_table(head, body, *, id_=None, num_from=None, best=None):
    """An HTML table in a scrolling wrapper with a note shown when it is wider than the page."""
    if not body:
        return "<p><em>none</em></p>"
    th = "".join(f"<th>{for_html(h)}</th>" for h in head)
    rows = []
    for ri, r in enumerate(body):
        cells = []
        for ci, c in enumerate(r):
            cls = []
            if num_from is not None and ci >= num_from:
                cls.append("num")
            if best and best.get(ci) and best[ci][ri]:
                cls.append("best")
            if "\n" in c:
                cls.append("pre")
            attr = f" class='{' '.join(cls)}'" if cls else ""
            cells.append(f"<td{attr}>{for_html(c)}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    ident = f" id='{id_}'" if id_ else ""
    return (f"<div class='wrap'><table{ident}><thead><tr>{th}</tr></thead><tbody>{''.join(rows)}</tbody></table></div>"
            "<p class='wide-note'>This table is wider than the page: scroll it sideways.</p>")


def _page_share(width_in: float | None) -> float:
    """How much of the page's width a figure takes [%]: a double-column figure (175 mm) the whole
    width, a narrower one in proportion, so that every figure's text shows at one size."""
    if not width_in:
        return 100.0
    return min(100.0, 100.0 * width_in / DOUBLE_COLUMN_IN)


def _verdict_section(scores: Scores, name: str | None, images: dict) -> str:
    """The first screen: the verdict's picture beside the verdict in at most 120 words, and every sentence
    of it collapsed below."""
    fig = ""
    if name:
        b64 = base64.b64encode(images[name]).decode()
        fig = (f"<figure id='verdict-figure'><img alt='the verdict: every engine variant&#39;s boundary distance "
               f"with its 95 % interval, grouped by class' src='data:image/png;base64,{b64}'></figure>")
    words = "".join(f"<p>{for_html(s)}</p>" for s in short_verdict_lines(scores))
    full = "".join(f"<li>{for_html(s)}</li>" for s in verdict_sentences(scores))
    return (f"<section id='verdict'><h2>Verdict</h2><div class='verdict-first'>{fig}"
            f"<div id='verdict-short' class='verdict-words'>{words}</div></div>"
            f"<details id='verdict-full'><summary>The verdict in full: every sentence, with the test it rests on"
            f"</summary><ul class='verdict'>{full}</ul></details></section>")


def html_page(ctx, images: dict) -> str:
    scores, labels = ctx["scores"], ctx["labels"]

    def img(name, alt, caption=None):
        b64 = base64.b64encode(images[name]).decode()
        cap = f"<figcaption>{for_html(caption)}</figcaption>" if caption else ""
        return (f'<figure style="width:{_page_share(ctx["fig_widths"].get(name)):.0f}%"><img alt="{html.escape(alt)}" '
                f'src="data:image/png;base64,{b64}">{cap}</figure>')

    n_var = len(labels)
    P = ["<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
         "<meta name='viewport' content='width=device-width, initial-scale=1'><title>rockbench report</title>",
         f"<style>{_asset('report.css').rstrip()}</style></head><body>", "<div id='img-warning'></div>",
         "<h1>rockbench report</h1>",
         f"<p class='meta'>Generated {html.escape(ctx['created'])} from {html.escape(', '.join(ctx['run_dirs']))}: "
         f"{len(ctx['entries'])} maps, {n_var} engine variant(s)"
         + (f", metrics version {html.escape(str(scores.metrics_version))}" if scores else "") + ".</p>"]
    if scores and not stage_alone(ctx):
        P.append(_verdict_section(scores, ctx.get("verdict_img"), images))
    P += [f"<p class='note'>{html.escape(n)}</p>" for n in ctx["notes"]]
    if stage_alone(ctx):
        P += [f"<p class='lead'>{for_html(STAGE_ALONE)}</p>", _h_speed(ctx, img), _h_versions(ctx)]
        return "\n".join(P)
    P.append("<section id='summary'><h2>Summary: which engine is how faithful</h2>")
    if scores:
        head, body, _, marks = summary_rows(scores, labels)
        P.append(f"<p class='lead'>{html.escape(INTRO)} {html.escape(HIGHLIGHTS)}</p>")
        P.append(_h_table(head, body, id_="summary-table", num_from=2, best=marks))
        method, title, s_head, s_body = scenario_tables(scores)
        P.append(f"<p class='method'>{html.escape(method)}</p><h3>{for_html(title)}</h3>")
        P.append(_h_table(s_head, s_body, id_="scenario-table", num_from=1))
        P.append("<dl class='metrics'>" + "".join(
            f"<dt>{for_html(t)} <span>({html.escape(how)})</span></dt><dd>{html.escape(d)}</dd>"
            for t, how, d in metric_words(scores)) + "</dl>")
    else:
        P.append("<p><em>no scores</em></p>")
    P.append("</section>")
    P += ["<section id='stability'><h2>Stability graphs, one per engine variant</h2>",
          f"<p class='lead'>{for_html(READ_GRAPHS)}</p>"]
    for v, label, name in ctx["variant_graphs"]:
        P.append(img(name, f"stability graphs of {label}"))
    if not ctx["variant_graphs"]:
        P.append("<p><em>no engine maps</em></p>")
    P.append("</section><section id='trajectories'><h2>θ(t) comparison</h2>")
    P += [img(name, c.title, "The reference (black and grey, in front) and every engine; circles on the zero line "
              "are impacts, × where a curve passes |θ| = α (overturn), ● where a run ended, decided not to overturn; the table's "
              "acceleration beneath.") for c, name in ctx["traj"]] or ["<p><em>not drawn</em></p>"]
    P += ["</section><section id='calibration'><h2>Calibration: η per engine</h2>",
          _h_table(*calib_table(ctx["calib"], labels), num_from=3)]
    ph, pb = price_table(ctx["calib"], labels)
    if pb:
        P += ["<h3>What reaching the target costs</h3>", f"<p>{for_html(PRICE_WORDS)}</p>", _h_table(ph, pb, num_from=3)]
    P += ["</section>", _h_speed(ctx, img, _h_table(*speed_table(ctx["speed"], labels), num_from=1))]
    if scores and scores.experiments:
        P += ["<section id='experiments'><h2>Experiments</h2>", _h_table(*exp_table(scores, labels), num_from=2),
              "</section>"]
    P.append("<details><summary>Stability graphs by case: every engine variant side by side</summary>")
    for block, pulse, name, _ in ctx["case_graphs"]:
        P += [f"<h3>{html.escape(case_title(block, pulse))}</h3>", img(name, f"stability graph {block} {pulse}")]
    P.append("</details>")
    if scores:
        P += [f"<details><summary>Every scored pair ({len(scores.pairs)})</summary>",
              _h_table(*pairs_table(scores, labels), num_from=6), "</details>"]
    P.append(_h_versions(ctx))
    return "\n".join(P)


#: The speed picture's caption.
SPEED_CAPTION = ("One curve per engine through its time steps: its CPU seconds per simulated second across "
                 "(logarithmic), its boundary distance from the reference up (lower is better); each marker is a "
                 "step (the legend), written beside the point where it fits (hollow markers: an engine that shares its "
                 "colour with another, drawn with another dash); the circle is the time-step rule's "
                 "choice; the shaded band, in the engine's colour, spans its finest step's distance ± its detectable "
                 "difference, from that step leftwards over the engine's own costs; the dashed line is the declared "
                 "distance.")


def _h_speed(ctx, img, variants_table: str | None = None) -> str:
    """The speed section: the stage's words, picture and matched-accuracy table (or why there is none), then
    the verdict variants' table at the step each ran where the run has verdict variants."""
    P = ["<section id='speed'><h2>Speed and accuracy</h2>"]
    sp = speed_of(ctx)
    if sp:
        P.append(f"<p>{for_html(stage_words(sp))}</p>")
        if ctx["speed_img"]:
            P.append(img(ctx["speed_img"], "accuracy against cost", SPEED_CAPTION))
        P += ["<h3>Cost at matched accuracy</h3>", _h_table(*matched_table(sp), num_from=2)]
    else:
        P.append(f"<p>{for_html(NO_STAGE)}</p>")
    if variants_table is not None:
        P += ["<h3>Each variant of the verdict at the step it ran</h3>", variants_table]
    return "".join(P) + "</section>"


def _h_versions(ctx) -> str:
    """Versions and settings (collapsed), then the page's script and its end."""
    t = settings_tables(ctx["entries"], ctx["labels"])
    return "\n".join(["<details><summary>Versions and settings</summary><h3>Run environment</h3>", _h_table(*t["env"]),
                      "<h3>Engine variants</h3>", _h_table(*t["variants"]), "<h3>Maps</h3>",
                      _h_table(*t["maps"], num_from=4), "</details>", "<script>\n" + _asset("report.js") + "</script>",
                      "</body></html>"])
