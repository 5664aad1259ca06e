"""The stability graph of one block and pulse: reference and engine overturn boundaries overlaid,
experimental T/R/O markers and the shaking-table limit (the paper's Figs 13–16, with engines)."""

from __future__ import annotations

import numpy as np

#: marker and colour of each experimental outcome (the paper's letters)
EXPERIMENT_STYLE = {"T": ("s", "#2ca02c"), "R": ("o", "#1f77b4"), "O": ("x", "#d62728")}


def boundary_segments(m) -> np.ndarray:
    """Cell edges between an overturn and a not-overturn cell, as segments [w/a units].

    Parameters
    ----------
    m : LabelMap
        The map.

    Returns
    -------
    ndarray, shape (n, 2, 2)
        ``[[w0, a0], [w1, a1]]`` per edge: the drawn outline of the overturn region (its border
        with failed cells and with the outside of the grid is not drawn).
    """
    from ..scores import FAILED, OVERTURN

    w, a, c = m.w_ratio, m.a_ratio, m.codes
    # cell limits: half-way to the neighbours, outer cells symmetric
    def limits(x):
        if x.size == 1:
            return np.array([x[0] - 0.5, x[0] + 0.5])
        mid = 0.5 * (x[1:] + x[:-1])
        return np.concatenate([[x[0] - (mid[0] - x[0])], mid, [x[-1] + (x[-1] - mid[-1])]])

    wl, al = limits(w), limits(a)
    known, ov = c != FAILED, c == OVERTURN
    segs = []
    i, j = np.nonzero(known[:-1, :] & known[1:, :] & (ov[:-1, :] != ov[1:, :]))
    for ii, jj in zip(i, j):
        segs.append([[wl[jj], al[ii + 1]], [wl[jj + 1], al[ii + 1]]])
    i, j = np.nonzero(known[:, :-1] & known[:, 1:] & (ov[:, :-1] != ov[:, 1:]))
    for ii, jj in zip(i, j):
        segs.append([[wl[jj + 1], al[ii]], [wl[jj + 1], al[ii + 1]]])
    return np.asarray(segs, dtype=float).reshape(-1, 2, 2)


def plot_boundaries(references, engines, *, own_eta=None, points=None, st_limit_a_ratio=None, title="", ax=None):
    """Draw the overturn boundaries of several maps on one stability graph.

    Parameters
    ----------
    references, engines : list of (str, LabelMap)
        Labelled maps; references are drawn as thick grey-scale lines with the first one's overturn
        region shaded, engines as thin coloured lines.
    own_eta : list of (str, LabelMap, int), optional
        Reference maps at an engine's own measured η: label, map and the index in ``engines`` of
        the engine it belongs to; drawn dotted in that engine's colour, so that each engine sits
        beside the reference that shares its energy loss (and apart from the standard references).
    points : list of (w_ratio, a_ratio, letter, repetitions), optional
        Experimental outcomes in normalised coordinates.
    st_limit_a_ratio : float, optional
        The shaking-table limit as a₀/(g·tanα) (drawn dashed, labelled "ST limit").
    title : str
        Axes title.
    ax : matplotlib Axes, optional
        Where to draw (a new figure when None).

    Returns
    -------
    dict
        ``ax`` and ``lines`` (label → artist).
    """
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    from ..scores import OVERTURN

    if ax is None:
        _, ax = plt.subplots(figsize=(7.5, 5.5))
    lines = {}
    if references:
        m0 = references[0][1]
        ax.pcolormesh(m0.w_ratio, m0.a_ratio, np.where(m0.codes == OVERTURN, 1.0, np.nan), shading="nearest",
                      cmap="Greys", vmin=0, vmax=4, alpha=0.6, zorder=0)
    grey = ["#000000", "#555555", "#999999", "#bbbbbb"]
    dash = ["solid", "dashed", "dashdot", "dotted"]
    for k, (label, m) in enumerate(references):
        lc = LineCollection(boundary_segments(m), colors=grey[k % 4], linewidths=2.6 - 0.4 * (k % 4),
                            linestyles=dash[k % 4], label=f"reference {label}", zorder=2)
        lines[f"reference {label}"] = ax.add_collection(lc)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (label, m) in enumerate(engines):
        lc = LineCollection(boundary_segments(m), colors=colours[k % len(colours)], linewidths=1.3,
                            label=label, zorder=3)
        lines[label] = ax.add_collection(lc)
    for label, m, k in own_eta or []:
        lc = LineCollection(boundary_segments(m), colors=colours[k % len(colours)], linewidths=1.8,
                            linestyles="dotted", label=label, zorder=2.5)
        lines[label] = ax.add_collection(lc)
    for letter, (marker, colour) in EXPERIMENT_STYLE.items():
        sel = [p for p in (points or []) if p[2] == letter]
        if sel:
            lines[f"experiment {letter}"] = ax.scatter([p[0] for p in sel], [p[1] for p in sel], marker=marker,
                                                      c=colour, s=[18 + 8 * p[3] for p in sel], zorder=4,
                                                      label=f"experiment {letter}")
    if st_limit_a_ratio is not None:
        lines["ST limit"] = ax.axhline(st_limit_a_ratio, color="k", ls="--", lw=1.0, label="ST limit", zorder=1)
    all_maps = [m for _, m in references] + [m for _, m in engines] + [m for _, m, _ in own_eta or []]
    if all_maps:
        ax.set_xlim(min(m.w_ratio[0] for m in all_maps), max(m.w_ratio[-1] for m in all_maps))
        ax.set_ylim(min(m.a_ratio[0] for m in all_maps), max(m.a_ratio[-1] for m in all_maps))
    ax.set_xlabel("ω/p [-]")
    ax.set_ylabel("a₀/(g·tanα) [-]")
    ax.set_title(title)
    if lines:
        # below the axes: the boundaries fill the plot, a legend inside would hide some
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=7, frameon=False)
    return {"ax": ax, "lines": lines}
