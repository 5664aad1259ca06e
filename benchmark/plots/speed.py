"""Speed against accuracy: wall time per simulated cell and agreement with the reference, per engine."""

from __future__ import annotations

#: Metrics that are fractions: drawn on their whole 0–1 scale, so a small difference looks small.
FRACTIONS = ("agreement", "overturn_agreement", "iou_overturn", "consistency")


def plot_speed_accuracy(rows, *, metric="agreement", ax=None):
    """Scatter of ``ms_per_cell`` against ``metric``, one point per engine variant (in the legend).

    The time axis is logarithmic (variants differ by orders of magnitude) with plain numbers as
    tick labels (0.1, 1, 10 ms); a fraction metric is drawn on its whole 0–1 scale.

    Parameters
    ----------
    rows : list of dict
        ``{"variant", "ms_per_cell", metric}`` per engine variant, optionally ``label`` (the legend
        text; default the variant).
    metric : str
        The score on the vertical axis.
    ax : matplotlib Axes, optional
        Where to draw (a new figure, without pyplot, when None).

    Returns
    -------
    dict
        ``ax``, ``points`` (variant → PathCollection) and ``legend``.
    """
    import math

    from matplotlib.ticker import FuncFormatter, LogLocator

    from ..labels import for_matplotlib

    if ax is None:
        from matplotlib.figure import Figure
        ax = Figure(figsize=(8.4, 3.9), layout="constrained").add_subplot()
    pts = {}
    xs = []
    markers = "osD^vP*Xh"
    for k, r in enumerate(rows):
        x, y = r.get("ms_per_cell"), r.get(metric)
        if x is None or y is None or not (math.isfinite(x) and math.isfinite(y)) or x <= 0:
            continue
        pts[r["variant"]] = ax.scatter([x], [y], s=46, zorder=3, marker=markers[k % len(markers)],
                                       label=for_matplotlib(r.get("label", r["variant"])))
        xs.append(x)
    ax.set_xscale("log")
    ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
    if xs:
        lo, hi = min(xs), max(xs)
        ax.set_xlim(lo / 2.0, hi * 2.0)
    if metric in FRACTIONS:
        ax.set_ylim(0.0, 1.02)
        ax.set_ylabel(f"{metric.replace('_', ' ')} [-], whole 0–1 scale")
    else:
        ax.set_ylabel(f"{metric.replace('_', ' ')}")
    ax.set_xlabel("wall time per simulated cell [ms] (logarithmic)")
    ax.grid(True, which="major", lw=0.3)
    leg = None
    if pts:
        # a legend outside the axes: variants of one engine often sit on top of each other
        leg = ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=7.5, frameon=False)
    return {"ax": ax, "points": pts, "legend": leg}
