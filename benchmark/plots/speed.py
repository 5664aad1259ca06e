"""Speed against accuracy: wall time per simulated cell and agreement with the reference, per engine."""

from __future__ import annotations


def plot_speed_accuracy(rows, *, metric="agreement", ax=None):
    """Scatter of ``ms_per_cell`` (log scale) against ``metric``, one point per engine variant (in the legend).

    Parameters
    ----------
    rows : list of dict
        ``{"variant", "ms_per_cell", metric}`` per engine variant.
    ax : matplotlib Axes, optional

    Returns
    -------
    dict
        ``ax`` and ``points`` (variant → PathCollection).
    """
    import math

    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.5, 4.0))
    pts = {}
    for r in rows:
        x, y = r.get("ms_per_cell"), r.get(metric)
        if x is None or y is None or not (math.isfinite(x) and math.isfinite(y)) or x <= 0:
            continue
        pts[r["variant"]] = ax.scatter([x], [y], s=40, zorder=3, label=r["variant"])
    ax.set_xscale("log")
    if pts:
        # a legend rather than labels at the points: variants of one engine often sit on top of
        # each other, and their labels would overlap
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=7, frameon=False)
    ax.set_xlabel("wall time per cell [ms]")
    ax.set_ylabel(f"{metric} [-]")
    ax.grid(True, which="both", lw=0.3)
    return {"ax": ax, "points": pts}
