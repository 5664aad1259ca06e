"""The verdict as a picture: a forest plot of every engine variant's value and 95 % interval on one axis,
grouped as the verdict answers (calibrated; as shipped; each held-out variant beside its in-sample twin;
the planted restitutions that measure the suite's power; those that fail, apart at the bottom).

Each compared class's best is a filled diamond, the variants that may be the best (its tie group,
Hsu's best subset) filled circles, those resolved behind it open circles; a shaded band from the
class's best shows the smallest difference the suite detects there (80 % power); the restitution
margin (the mean η_H–η_M reference gap, or the declared number) and the fail limit (its rule's value, or the declared number) are
vertical lines. Labels are tick labels (the variant on the left, its numbers on the right), so they
never overlap and the layout keeps them inside the figure. When a value lies past twice the fail limit
(a failing mean reaches 18.6, the map's diagonal) the axis is linear up to the fail limit and
logarithmic above it.

:func:`verdict_rows` is the table of rows (no matplotlib); :func:`plot_verdict` draws it.
"""

from __future__ import annotations

import math

from rockbench.benchmark.scoring.failing import scenario_words
from rockbench.benchmark.scoring.labels import for_matplotlib
from rockbench.benchmark.report.verdict_words import delta_words, number, signed
from rockbench.benchmark.report.plots.style import DOUBLE_COLUMN_IN, LABEL_PT, OKABE_ITO, SMALL_PT, tint

#: Group headers, in the picture's order.
HEADERS = {"calibrated": "Calibrated to η_H (best achievable)", "as-shipped": "As shipped (out of the box)",
           "other": "Other settings", "held-out": "Held out: calibrated on another block (○ twin)",
           "planted": "Planted: reference solver, restitution × (1 − δ)", "fails": "Fail (a scenario beyond the limit)"}

#: Colour of each group's marks (the one palette, :mod:`.style`).
COLOURS = {"calibrated": OKABE_ITO["blue"], "as-shipped": OKABE_ITO["orange"], "other": "#555555",
           "held-out": OKABE_ITO["sky_blue"], "planted": OKABE_ITO["green"], "fails": OKABE_ITO["vermillion"]}

#: Height of one row [in] and the room above and below the rows (title, axis, legend) [in].
ROW_IN, FRAME_IN = 0.15, 1.0


def verdict_rows(v: dict) -> list[dict]:
    """The rows of the picture from a verdict object: headers (``kind`` "header") and variants (``kind``
    "variant": ``group``, ``label``, ``value``, ``lo``, ``hi``, ``mark`` best/tied/behind/held-out/
    planted/fails/other, ``twin`` (a held-out row's in-sample value), ``right`` (its numbers in words))."""
    rows = v["variants"]
    groups: dict = {}
    for r in rows:
        g = "fails" if r["fails"] else r["group"]
        if g in ("calibrated", "as-shipped", "other") and r["value"] is None:
            continue
        groups.setdefault(g, []).append(r)
    out = []
    for g in HEADERS:
        if g in groups:
            out.append({"kind": "header", "group": g, "label": HEADERS[g]})
            out += [_row(g, r) for r in groups[g]]
    for row in out:
        if row["kind"] == "variant" and row["group"] == "planted":
            row["right"] += _planted_words(v["power"], row["variant"])
    return out


def _planted_words(power: dict | None, variant: str) -> str:
    """``: resolved`` / ``: not resolved`` from δ = 0 (nothing for δ = 0 itself)."""
    r = next((p for p in (power or {}).get("planted", []) if p["variant"] == variant), None)
    if r is None or r["delta"] == 0:
        return ""
    return ": resolved" if r["resolved"] else ": not resolved"


def _row(g: str, r: dict) -> dict:
    row = {"kind": "variant", "group": g, "variant": r["variant"], "label": r["label"], "twin": None}
    if g == "held-out":
        h = r["held_out"]
        row.update(label=f"{r['label'].split(',')[0]}, held out", value=h["value"], lo=h["ci95"][0], hi=h["ci95"][1],
                   twin=h["in_sample"], mark="held-out",
                   right=(f"{number(h['value'])} vs {number(h['in_sample'])}: "
                          + ("carries over" if h["carries_over"] else "not shown") if h["tost"] else
                          f"{number(h['value'])}: not tested" if h.get("left_out") or h.get("in_sample") is not None else
                          f"{number(h['value'])}: no twin"))
        return row
    lo, hi = r["ci95"] if r["ci95"] else (math.nan, math.nan)
    row.update(value=r["value"], lo=lo, hi=hi)
    if g == "planted":
        row.update(label=f"δ = {delta_words(r['planted']['delta'])} (" + r["label"].split(", ", 1)[-1].replace(" (planted)", ")"),
                   mark="planted", right=f"{number(r['value'])}")
    elif g == "fails":
        w = r["fails_in"][0] if r["fails_in"] else None
        mean = f"{number(r['value'])}; " if r["value"] is not None else ""
        row.update(mark="fails", right=(mean + _fail_words(r, w) if w else "nothing judged"))
    elif g == "other":
        row.update(mark="other", right=f"{number(r['value'])} [{number(lo)}, {number(hi)}]")
    else:
        mark = "best" if r["best_in_class"] else ("tied" if r["in_best_subset"] else "behind")
        # the header names the class: its words leave the label (another target, e.g. η_M, stays)
        row.update(label=r["label"].replace(", calibrated to η_H", "").replace(", as shipped", ""))
        row.update(mark=mark, right=f"{number(r['value'])} [{number(lo)}, {number(hi)}] "
                                    + {"best": "best", "tied": "tied", "behind": "behind"}[mark]
                                    + ("" if r.get("scope") != "on this suite" else " (on this suite)")
                                    + (f"; offset {signed(r['offset'])}" if r.get("offset") is not None else ""))
    return row


def _fail_words(r: dict, w: dict) -> str:
    """A failing variant's first failing scenario, short enough for the column on the right: where its
    map has no boundary, how many of its maps have none (what their cells do instead is the verdict's
    text: :func:`~rockbench.benchmark.scoring.failing.scenario_words`)."""
    if not w.get("missing_boundary") or w["missing_boundary"] == "reference":
        return scenario_words(w)
    n = sum(bool(s.get("missing_boundary")) for s in r["per_scenario"])
    return f"{w['block']} {w['pulse']}: no boundary ({n} of {len(r['per_scenario'])} maps)"


def _margin(v: dict) -> tuple[float | None, str]:
    """Where the restitution margin is drawn and its legend words."""
    m = v["declared"]["equivalence_margin"]
    if not isinstance(m, str):
        return float(m), f"equivalence margin {float(m):g} (declared)"
    gaps = [s["reference_gap"] for r in v["variants"] for s in r["per_scenario"]
            if not s["held_out"] and s.get("reference_gap")]
    if not gaps:
        return None, ""
    seen = {}
    for r in v["variants"]:
        for s in r["per_scenario"]:
            if s.get("reference_gap"):
                seen[(s["block"], s["pulse"])] = s["reference_gap"]
    mean = sum(seen.values()) / len(seen)
    return mean, f"mean η_H–η_M reference gap, {number(mean)} (the equivalence margin, per scenario)"


def plot_verdict(v: dict, *, ax=None) -> dict:
    """Draw the forest plot of the verdict object ``v`` (module docstring).

    Returns
    -------
    dict
        ``ax``, ``figure``, ``right`` (the axes of the numbers on the right), ``rows``
        (:func:`verdict_rows`, each with its ``y``), ``marks`` (variant → the artists of its row),
        ``bands`` (class → the detectable-difference band), ``lines`` (``margin``, ``fail``) and
        ``legend``.
    """
    from matplotlib.ticker import FixedLocator, FuncFormatter  # matplotlib on first drawing

    rows = verdict_rows(v)
    own_figure = ax is None
    if own_figure:
        from matplotlib.figure import Figure  # matplotlib on first drawing
        ax = Figure(figsize=(DOUBLE_COLUMN_IN, FRAME_IN + ROW_IN * max(len(rows), 3)), layout="constrained").add_subplot()
    n = len(rows)
    for k, r in enumerate(rows):
        r["y"] = n - 1 - k
    limit, limit_from = _fail_line(v, rows)
    # a logarithmic stretch only for what lies far past the limit (a failing mean of 18.6)
    logx = any(r["kind"] == "variant" and _finite(r.get("value")) and r["value"] > 2 * limit for r in rows)
    marks = {r["variant"]: _draw_row(ax, r) for r in rows if r["kind"] == "variant" and r["value"] is not None}
    bands = _draw_bands(ax, v, rows)
    lines = {}
    margin, margin_words = _margin(v)
    if margin is not None:
        lines["margin"] = ax.axvline(margin, color="0.25", lw=0.9, ls=(0, (4, 2)), label=for_matplotlib(margin_words))
    if limit_from is not None:
        lines["fail"] = ax.axvline(limit, color=COLOURS["fails"], lw=0.9, ls=(0, (1, 1.5)),
                                   label=f"fail limit {limit:.3g} ({limit_from})")
    hi = max([r["hi"] for r in rows if r["kind"] == "variant" and _finite(r.get("hi"))] + [limit, margin or 0.0])
    _x_axis(ax, logx, limit, hi, FixedLocator, FuncFormatter)
    ax.set_ylim(-0.7, n - 0.3)
    _labels(ax, rows)
    right = _right(ax, rows)
    ax.set_xlabel("boundary distance: mean over the suite's problems, normalised plane, lower is better\n"
                  "bars: 95 % intervals on this suite; best, tied, behind and the band: across problems"
                  + ("\nlinear up to the fail limit, logarithmic above it" if logx else ""),
                  fontsize=LABEL_PT)
    ax.grid(True, axis="x", lw=0.3, color="0.85")
    legend = ax.figure.legend(handles=_legend_handles(ax, lines, bands), loc="outside lower center", ncol=2,
                              fontsize=SMALL_PT, frameon=False)
    if own_figure:
        _fit_rows(ax, n)
    return {"ax": ax, "figure": ax.figure, "right": right, "rows": rows, "marks": marks, "bands": bands,
            "lines": lines, "legend": legend}


def _fit_rows(ax, n: int) -> None:
    """Grow the figure until its axes give each of the ``n`` rows :data:`ROW_IN`: the legend and the
    labels take what the layout engine gives them, which differs between matplotlib versions."""
    fig = ax.figure
    fig.draw_without_rendering()
    short_in = n * ROW_IN - ax.get_window_extent().height / fig.dpi
    if short_in > 0:
        w_in, h_in = fig.get_size_inches()
        fig.set_size_inches(w_in, h_in + short_in)


def _finite(x) -> bool:
    return x is not None and math.isfinite(x)


#: Marker of each kind of row: (marker, filled).
_MARKS = {"best": ("D", True), "tied": ("o", True), "behind": ("o", False), "held-out": ("s", True),
          "planted": ("^", True), "fails": ("X", True), "other": ("o", False)}


def _draw_row(ax, r: dict) -> list:
    colour = COLOURS[r["group"]]
    drawn = []
    if _finite(r.get("lo")) and _finite(r.get("hi")):
        drawn += ax.plot([r["lo"], r["hi"]], [r["y"], r["y"]], color=colour, lw=1.3, solid_capstyle="butt", zorder=2)
    marker, filled = _MARKS[r["mark"]]
    drawn += ax.plot([r["value"]], [r["y"]], marker=marker, ms=5.0 if marker != "D" else 5.5, ls="none", zorder=4,
                     markerfacecolor=colour if filled else "white", markeredgecolor="black" if r["mark"] == "best"
                     else colour, markeredgewidth=0.9)
    if _finite(r.get("twin")):
        drawn += ax.plot([r["twin"]], [r["y"]], marker="o", ms=4.5, ls="none", zorder=3, markerfacecolor="white",
                         markeredgecolor="0.2", markeredgewidth=0.8)
    return drawn


def _draw_bands(ax, v: dict, rows: list[dict]) -> dict:
    """The detectable-difference band of each compared class, over its rows, from its best: across
    problems where the class has that comparison (the headline standing's scope), else on this suite."""
    bands = {}
    for cls, fam in v["mcb"].items():
        ys = [r["y"] for r in rows if r["kind"] == "variant" and r["group"] == cls]
        best = next((r for r in rows if r.get("variant") == fam["best"] and r["group"] == cls), None)
        mdd = (fam.get("across") or {}).get("mdd", fam.get("mdd"))     # the headline scope's
        if not ys or best is None or mdd is None:
            continue
        bands[cls] = ax.fill_betweenx([min(ys) - 0.45, max(ys) + 0.45], best["value"], best["value"] + mdd,
                                      color=tint(COLOURS[cls], 0.18), lw=0, zorder=1)
    return bands


def _fail_line(v: dict, rows: list[dict]) -> tuple[float, str | None]:
    """The fail limit and what it rests on for its line's label (``declared``, or the rule's scenario),
    or, where the run gives none, the largest finite interval end for the axis and None (no line)."""
    lim = v.get("fail_limit") or {"value": v["fail_distance"], "rule": None, "from": None}
    if lim["value"] is None:
        ends = [r["hi"] for r in rows if r["kind"] == "variant" and _finite(r.get("hi"))]
        return max(ends + [0.1]), None
    if lim["rule"] is None:
        return lim["value"], "declared"
    return lim["value"], f"largest η_H–η_M gap, {lim['from']['block']} {lim['from']['pulse']}"


def _x_axis(ax, logx: bool, limit: float, hi: float, FixedLocator, FuncFormatter) -> None:
    if logx:
        ax.set_xscale("symlog", linthresh=limit, linscale=3.0)
        ax.set_xlim(0.0, hi * 1.6)
        ticks = [t for t in (0, limit / 3, 2 * limit / 3, limit, 1, 3, 10, 30, 100) if t <= hi * 1.6]
        ax.xaxis.set_major_locator(FixedLocator(ticks))
        ax.xaxis.set_minor_locator(FixedLocator([]))
    else:
        ax.set_xlim(0.0, hi * 1.08)
    ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:.2g}"))
    ax.tick_params(axis="x", labelsize=SMALL_PT)


def _labels(ax, rows: list[dict]) -> None:
    ax.set_yticks([r["y"] for r in rows])
    ax.set_yticklabels([for_matplotlib(r["label"]) for r in rows], fontsize=SMALL_PT)
    for t, r in zip(ax.get_yticklabels(), rows):
        if r["kind"] == "header":
            t.set_fontweight("bold")
    ax.tick_params(axis="y", length=0)


def _right(ax, rows: list[dict]):
    """The numbers of each row, as tick labels of a twin axis on the right."""
    right = ax.twinx()
    right.set_ylim(ax.get_ylim())
    right.set_yticks([r["y"] for r in rows])
    right.set_yticklabels([r.get("right", "") if r["kind"] == "variant" else "" for r in rows], fontsize=SMALL_PT)
    right.tick_params(axis="y", length=0)
    return right


def _legend_handles(ax, lines: dict, bands: dict) -> list:
    from matplotlib.lines import Line2D  # matplotlib on first drawing
    from matplotlib.patches import Patch  # matplotlib on first drawing

    def mark(marker, filled, colour, text, edge=None):
        return Line2D([], [], marker=marker, ls="none", ms=5, markerfacecolor=colour if filled else "white",
                      markeredgecolor=edge or colour, label=text)

    c = COLOURS["calibrated"]
    handles = [mark("D", True, c, "best of its class", "black"),
               mark("o", True, c, "may be the best (Hsu's MCB, 95 %)"),
               mark("o", False, c, "resolved behind the best")]
    if bands:
        handles.append(Patch(color=tint(c, 0.18), label="from the best: detectable difference (80 % power)"))
    return handles + list(lines.values())

