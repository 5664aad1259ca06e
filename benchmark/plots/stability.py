"""Stability graphs in the paper's style (Figs 4–9 and 13–16).

Normalised axes (ω/p horizontal, a₀/(g·tanα) vertical), the overturn region of the first map
shaded, the overturn boundary of every map drawn and labelled, experimental outcomes as markers
(T translation, R rocking, O overturning) and the shaking table's limit (25 m/s², paper §5) as a
dashed line at ``25/(g·tanα)``. matplotlib is imported inside the functions only.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...reference_solver.model import G
from ..experiments import SHAKING_TABLE_LIMIT_MPS2

#: The Quanser ST-III table's faithful limit for one sine wave (paper §5) [m/s^2]: the one value
#: the experimental data module holds.
ST_LIMIT_MPS2 = SHAKING_TABLE_LIMIT_MPS2

#: Line colours of the overlaid boundaries, in order.
COLORS = ["#1f4e9a", "#c0392b", "#2e8b57", "#8e44ad", "#d35400", "#16a085", "#7f8c8d"]
_MARKERS = {"T": ("^", "#2e8b57"), "R": ("s", "#1f4e9a"), "O": ("x", "#c0392b")}


def st_limit_a_ratio(alpha_rad: float, st_limit_mps2: float = ST_LIMIT_MPS2) -> float:
    """The table limit in the block's normalised amplitude ``a₀/(g·tanα)`` [-]."""
    return st_limit_mps2 / (G * math.tan(alpha_rad))


def _overturn_mask(result) -> np.ndarray:
    return (result.outcome == 2).astype(float)


def plot_stability(maps, labels=None, *, ax=None, shade: bool = True, experiments=None,
                   st_limit_mps2: float | None = ST_LIMIT_MPS2, title: str | None = None, show_failed: bool = True,
                   extra_handles=()):
    """Draw one or more maps' overturn boundaries on the normalised axes.

    Parameters
    ----------
    maps : MapResult or list of MapResult
        The maps; the first one's overturn region is shaded.
    labels : list of str, optional
        Legend labels (default: each map's engine, block and restitution).
    ax : matplotlib Axes, optional
        Where to draw (a new figure when None).
    shade : bool
        Shade the first map's overturn region.
    experiments : iterable of dict, optional
        Measured outcomes ``{"w_ratio", "a_ratio", "outcome"}`` with outcome ``T``, ``R`` or ``O``.
    st_limit_mps2 : float or None
        The table limit [m/s^2] drawn for the first map's block; None draws nothing.
    title : str, optional
        Axes title.
    show_failed : bool
        Mark failed cells with small red crosses.
    extra_handles : sequence of matplotlib artists
        More legend entries (put first).

    Returns
    -------
    dict
        ``{"ax", "boundaries": [ContourSet...], "st_limit_a_ratio": float or None}``.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    if not isinstance(maps, (list, tuple)):
        maps = [maps]
    if ax is None:
        import matplotlib.pyplot as plt
        _, ax = plt.subplots(figsize=(6.4, 4.8))
    labels = list(labels) if labels is not None else [_label(m) for m in maps]
    handles, drawn = list(extra_handles), []
    first = maps[0]
    if shade:
        W, A = np.meshgrid(first.w_ratio, first.a_ratio)
        m = _overturn_mask(first)
        if m.any() and min(m.shape) > 1:
            ax.contourf(W, A, m, levels=[0.5, 1.5], colors=["#bbbbbb"], alpha=0.55)
            handles.append(Patch(color="#bbbbbb", alpha=0.55, label=f"overturn ({labels[0]})"))
    for k, (res, lab) in enumerate(zip(maps, labels)):
        color = COLORS[k % len(COLORS)]
        W, A = np.meshgrid(res.w_ratio, res.a_ratio)
        m = _overturn_mask(res)
        if 0 < m.sum() < m.size and min(m.shape) > 1:
            cs = ax.contour(W, A, m, levels=[0.5], colors=[color], linewidths=1.6,
                            linestyles="-" if k == 0 else ["--", "-.", ":"][(k - 1) % 3])
            drawn.append(cs)
        handles.append(Line2D([], [], color=color, lw=1.6, ls="-" if k == 0 else ["--", "-.", ":"][(k - 1) % 3],
                              label=lab))
        if show_failed:
            fi, fj = np.nonzero(res.outcome == -1)
            if fi.size:
                ax.plot(res.w_ratio[fj], res.a_ratio[fi], "x", color="red", ms=3, lw=0)
                handles.append(Line2D([], [], color="red", marker="x", lw=0, label=f"failed cells ({fi.size})"))
    for e in experiments or []:
        mk, col = _MARKERS.get(str(e["outcome"]).upper(), ("o", "k"))
        ax.plot(e["w_ratio"], e["a_ratio"], mk, color=col, ms=6, mfc="none" if mk != "x" else col)
    if experiments:
        for o, (mk, col) in _MARKERS.items():
            handles.append(Line2D([], [], color=col, marker=mk, lw=0, mfc="none" if mk != "x" else col,
                                  label={"T": "T translation", "R": "R rocking", "O": "O overturning"}[o]))
    st = None
    if st_limit_mps2 is not None:
        st = st_limit_a_ratio(first.spec.block.alpha_rad, st_limit_mps2)
        ax.axhline(st, color="k", ls="--", lw=1.0)
        lo, hi = first.a_ratio[0], first.a_ratio[-1]
        if lo <= st <= hi:
            ax.annotate("ST limit", (first.w_ratio[-1], st), xytext=(-4, 3), textcoords="offset points",
                        ha="right", va="bottom", fontsize=8)
        handles.append(Line2D([], [], color="k", ls="--", lw=1.0, label=f"ST limit {st_limit_mps2:g} m/s² "
                              f"({first.spec.block.name})"))
    ax.set_xlim(first.w_ratio[0], first.w_ratio[-1])
    ax.set_ylim(first.a_ratio[0], first.a_ratio[-1])
    ax.set_xlabel("ω/p [-]")
    ax.set_ylabel("a₀/(g·tanα) [-]")
    if title:
        ax.set_title(title, fontsize=10)
    ax.legend(handles=handles, fontsize=7, loc="best", framealpha=0.85)
    return {"ax": ax, "boundaries": drawn, "st_limit_a_ratio": st}


def _label(res) -> str:
    s = res.spec
    return f"{s.engine} {s.block.name} {s.restitution.label} (η={s.eta:.4f})"


def save(fig, stem) -> list[Path]:
    """Save ``fig`` as ``stem.png`` and ``stem.svg``; returns the paths."""
    stem = Path(stem)
    out = []
    for ext in (".png", ".svg"):
        p = stem.with_suffix(ext)
        fig.savefig(p, dpi=150, bbox_inches="tight")
        out.append(p)
    return out


def plot_map_png(result, path) -> Path:
    """Draw one map (its outcome classes, failed cells, the ST limit) into ``path`` (PNG).

    The figure is a plain :class:`matplotlib.figure.Figure` on the Agg canvas: no pyplot, so no
    backend selection, no figure manager and none of pyplot's start-up (a map run pays for the
    picture only).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import ListedColormap
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    fig = Figure(figsize=(6.4, 4.8))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    res = result
    # light colours for the three outcomes under the paper-style boundary
    show = np.where(res.outcome >= 0, res.outcome, np.nan).astype(float)
    if min(show.shape) > 1:
        dw = (res.w_ratio[1] - res.w_ratio[0]) / 2 if res.w_ratio.size > 1 else 0.5
        da = (res.a_ratio[1] - res.a_ratio[0]) / 2 if res.a_ratio.size > 1 else 0.5
        ax.imshow(show, origin="lower", aspect="auto", interpolation="nearest", vmin=0, vmax=2,
                  cmap=ListedColormap(["#ffffff", "#dce9f7", "#bbbbbb"]),
                  extent=(res.w_ratio[0] - dw, res.w_ratio[-1] + dw, res.a_ratio[0] - da, res.a_ratio[-1] + da))
    s = res.spec
    frac = f", {100 * res.fraction_simulated:.1f} % simulated" if res.adaptive else ""
    classes = [Patch(facecolor=c, edgecolor="#999999", label=n)
               for c, n in (("#ffffff", "rest"), ("#dce9f7", "rocking"), ("#bbbbbb", "overturn"))]
    plot_stability([res], shade=False, ax=ax, extra_handles=classes,
                   title=f"{s.engine}: {s.block.name}, {s.pulse}, {s.restitution.label} (η = {s.eta:.4f}){frac}")
    path = Path(path)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    return path
