"""Speed against accuracy: wall time per simulated cell and disagreement with the reference, per engine.

Engines agree with the reference on most cells, so an agreement axis from 0 to 1 puts every
variant in one corner. The picture draws the other side instead, the share of cells where the
engine disagrees [%], and both axes logarithmic when their range spans more than a factor of ten
(times differ by orders of magnitude, disagreements from a few cells to a few per cent). A variant
that disagrees nowhere sits on the axis' floor, marked "none". Each point is labelled with its
variant beside it (labels pushed apart where they would overlap), so no legend is needed.
"""

from __future__ import annotations

import math

from ...scoring.labels import for_matplotlib
from ...scoring.metrics import METRICS
from .style import CYCLE, DOUBLE_COLUMN_IN, LABEL_PT, SMALL_PT


def _is_fraction(metric: str) -> bool:
    """A fraction of cells (the metric's ``kind``): drawn as the share of disagreeing cells (1 − metric)."""
    return metric in METRICS and METRICS[metric].kind == "fraction"

#: Ratio of the largest to the smallest value above which an axis is logarithmic.
LOG_RANGE = 10.0


def _points(rows, metric):
    out = []
    for r in rows:
        x, y = r.get("ms_per_cell"), r.get(metric)
        if x is None or y is None or not (math.isfinite(x) and math.isfinite(y)) or x <= 0:
            continue
        out.append((r, float(x), (1.0 - float(y)) * 100.0 if _is_fraction(metric) else float(y)))
    return out


def _floor(ys) -> float:
    """Where a zero disagreement is drawn on a log axis: a third of the smallest non-zero value."""
    pos = [y for y in ys if y > 0]
    return min(pos) / 3.0 if pos else 0.01


def plot_speed_accuracy(rows, *, metric="agreement", ax=None):
    """One point per engine variant: ``ms_per_cell`` across, the disagreement with the reference up.

    Parameters
    ----------
    rows : list of dict
        ``{"variant", "ms_per_cell", metric}`` per engine variant, optionally ``label`` (the text
        beside the point; default the variant).
    metric : str
        The score drawn: a fraction of cells (its ``kind``) as ``100·(1 − value)`` [%],
        any other metric as it is.
    ax : matplotlib Axes, optional
        Where to draw (a new figure, without pyplot, when None).

    Returns
    -------
    dict
        ``ax``, ``points`` (variant → PathCollection), ``labels`` (variant → Text), ``logy`` and
        ``legend`` (None: the points are labelled directly).
    """
    from matplotlib.ticker import FuncFormatter, LogLocator  # matplotlib on first drawing (start-up time)

    if ax is None:
        from matplotlib.figure import Figure  # matplotlib on first drawing (start-up time)
        ax = Figure(figsize=(DOUBLE_COLUMN_IN, 3.3), layout="constrained").add_subplot()
    pts = _points(rows, metric)
    ys = [y for _, _, y in pts]
    pos = [y for y in ys if y > 0]
    logy = bool(pos) and (max(pos) / min(pos) > LOG_RANGE or len(pos) < len(ys))
    floor = _floor(ys) if logy else 0.0
    markers = "osD^vP*Xh"
    drawn, texts = {}, {}
    for k, (r, x, y) in enumerate(pts):
        drawn[r["variant"]] = ax.scatter([x], [max(y, floor)], s=40, zorder=3, marker=markers[k % len(markers)],
                                         color=CYCLE[k % len(CYCLE)], edgecolors="black", linewidths=0.5)
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    if pts:
        xs = [x for _, x, _ in pts]
        # limits first: one point autoscales to a singular range, which the log scale warns about
        ax.set_xlim(min(xs) / 2.0, max(xs) * 6.0)   # room on the right for the labels
        ax.set_xscale("log")
        ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        ax.xaxis.set_major_formatter(plain)
        ax.xaxis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
    if logy:
        ax.set_yscale("log")
        ax.set_ylim(floor / 2.0, max(pos) * 2.0)
        ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(plain)
        ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
        if len(pos) < len(ys):
            ax.axhline(floor, color="0.6", lw=0.6, ls=":", zorder=1)
            ax.text(0.005, floor, " none", transform=ax.get_yaxis_transform(), va="bottom", fontsize=SMALL_PT,
                    color="0.35")
    elif pts:
        ax.set_ylim(0.0, max(max(ys) * 1.25, 1e-9))
    ax.set_ylabel(_ylabel(metric), fontsize=LABEL_PT)
    ax.set_xlabel("wall time per simulated cell [ms]" + (" (logarithmic)" if pts else ""), fontsize=LABEL_PT)
    ax.tick_params(labelsize=SMALL_PT)
    ax.grid(True, which="major", lw=0.3)
    for k, (r, x, y) in enumerate(pts):
        texts[r["variant"]] = ax.annotate(for_matplotlib(r.get("label", r["variant"])), (x, max(y, floor)),
                                          xytext=(6, 0), textcoords="offset points", va="center", ha="left",
                                          fontsize=SMALL_PT, zorder=4,
                                          # a leader line, shown only where the label had to move away
                                          arrowprops=dict(arrowstyle="-", lw=0.5, color="0.45", relpos=(0.0, 0.5),
                                                          shrinkA=1.0, shrinkB=4.0))
        texts[r["variant"]].arrow_patch.set_visible(False)
    _spread_labels(ax, texts)
    return {"ax": ax, "points": drawn, "labels": texts, "logy": logy, "legend": None}


def _ylabel(metric: str) -> str:
    """The metric's own axis title (:attr:`Metric.axis_label`), else one from its name and kind."""
    if metric in METRICS and METRICS[metric].axis_label:
        return METRICS[metric].axis_label
    words = metric.replace("_", " ")
    return f"100 % − {words} [%]" if _is_fraction(metric) else words


def _spread_labels(ax, texts: dict, gap_pt: float = 9.0) -> None:
    """Push the point labels apart vertically where two would overlap, or where a label would run over
    another variant's point (in points, on the page)."""
    if len(texts) < 2:
        return
    fig = ax.figure
    to_pt = 72.0 / fig.dpi
    items = []
    for t in texts.values():
        x, y = ax.transData.transform(t.xy)
        items.append([y * to_pt, x * to_pt, t])
    items.sort(key=lambda it: it[0])
    marks = [(y, x) for y, x, _ in items]
    placed = []
    for y, x, t in items:
        # up past every label it would overlap (labels run right of their points) and every point its
        # label would run over; each obstacle is passed once, so the loop ends
        obstacles = sorted([py for py, px, _ in placed if abs(px - x) < 150]
                           + [my for my, mx in marks if 0 < mx - x < 150])
        want = y
        for oy in obstacles:
            if abs(want - oy) < gap_pt:
                want = max(want, oy + gap_pt)
        placed.append((want, x, t))
        t.set_position((6, want - y))
        t.arrow_patch.set_visible(want - y > 2.0)   # moved: a line says whose label it is
