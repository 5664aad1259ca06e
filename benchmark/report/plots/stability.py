"""Stability graphs in the paper's style (Figs 4–9 and 13–16), and one map's picture (``map.png``).

Normalised axes: ω/p horizontal, a₀/(g·tanα) vertical. A boundary is drawn as a smooth line, the
0.5 contour of the map's overturn indicator (cells are values at grid points; the contour runs
half-way between an overturn and a not-overturn point), not as cell staircases. The rigid model's
own domain ends where its trajectory needs the table to pull the block down or more friction than
μ (the reference's ``lift-required`` / ``slip-required`` cells, docs/physics.md §9): that region is
hatched in every picture. Experimental outcomes are the paper's letters T, R, O; the shaking
table's faithful limit (25 m/s², paper §5) is a dashed line labelled on the chart, drawn only where
it lies inside the chart.

Small multiples (:func:`plot_panels`): one panel per engine variant (or per block and pulse), each
with the reference boundaries, the engine's overturn region filled, its disagreements with the
like-for-like reference marked by kind, the hatched region, the ST limit and the points; one legend
for the figure, below the panels, never over data.

matplotlib is imported inside the functions only; figures are made without pyplot
(``matplotlib.figure.Figure``), so nothing here needs a display or a global figure manager.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rockbench.engines.adapters.reference import is_planted
from rockbench.benchmark.blocks.experiments import SHAKING_TABLE_LIMIT_MPS2, st_limit_a_ratio
from rockbench.benchmark.maps.bisection import MULTIPLE
from rockbench.benchmark.maps.result import MapResult
from rockbench.benchmark.scoring.labels import for_matplotlib, restitution_symbol, variant_label
from rockbench.benchmark.report.plots.output import save_formats
from rockbench.benchmark.report.plots.style import DOUBLE_COLUMN_IN, LABEL_PT, OKABE_ITO, SINGLE_COLUMN_IN, SMALL_PT, SUPTITLE_PT, TITLE_PT, tint

#: Line styles of the reference boundaries, in the order given (η_H, η_M average k, η_M exact k,
#: a constant η such as an engine's own measured one): each has its own dash as well as its own
#: colour of the one palette (:mod:`.style`).
REFERENCE_STYLES = [
    {"color": OKABE_ITO["black"], "linestyle": "solid", "linewidth": 1.7},
    {"color": OKABE_ITO["blue"], "linestyle": (0, (5, 2)), "linewidth": 1.5},
    {"color": OKABE_ITO["green"], "linestyle": (0, (6, 2, 1.5, 2)), "linewidth": 1.5},
    {"color": OKABE_ITO["purple"], "linestyle": (0, (1.5, 1.5)), "linewidth": 1.6},
    {"color": "#7f7f7f", "linestyle": (0, (3, 1, 1, 1, 1, 1)), "linewidth": 1.3},
]
#: Line colours of overlaid maps in :func:`plot_stability` (first one also shaded).
COLORS = [OKABE_ITO["black"], OKABE_ITO["blue"], OKABE_ITO["vermillion"], OKABE_ITO["green"], OKABE_ITO["purple"],
          OKABE_ITO["orange"], OKABE_ITO["sky_blue"]]

ENGINE_FILL = tint(OKABE_ITO["orange"], 0.45)          # the engine's overturn region
#: The engine's own located boundary over its cells in map.png (the reference's is REFERENCE_STYLES[0]).
ENGINE_LINE = {"color": OKABE_ITO["vermillion"], "linestyle": (0, (3, 1.5)), "linewidth": 1.2}
#: rest, rocking, overturn (map.png)
OUTCOME_COLOURS = ("#ffffff", tint(OKABE_ITO["sky_blue"], 0.35), tint(OKABE_ITO["orange"], 0.45))
HATCH = "////"
HATCH_COLOUR = "#8a8a8a"
#: The engine's flagged cells (slip, jump, energy gain): a dotted area over the cells each flagged
#: simulation stands for (:func:`flag_area`), not a mark per simulated cell.
FLAG_HATCH = "...."
FLAG_COLOUR = "#444444"
#: A reference boundary that encloses at most this many cells is an island: drawn as the outline
#: of its cells, not as a line loop (a loop around one cell is a blob at print size).
ISLAND_CELLS = 4
DOMAIN_LABEL = "outside the rigid model's domain (lift-off or sliding)"
FLAG_LABEL = "engine flagged slip, jump or energy gain (dotted)"
ISLAND_LABEL = "reference: single cells across its boundary (outlined in its colour)"

#: Disagreement kinds: label, marker style.
MARKS = {
    "false_overturn": ("overturns where the reference does not", {"marker": "^", "color": OKABE_ITO["vermillion"],
                                                                   "ms": 4.6, "mec": "white", "mew": 0.4,
                                                                   "mfc": OKABE_ITO["vermillion"]}),
    "missed_overturn": ("misses an overturn of the reference", {"marker": "o", "color": OKABE_ITO["blue"], "ms": 4.2,
                                                                "mfc": "white", "mec": OKABE_ITO["blue"], "mew": 1.1}),
    "failed": ("simulation failed", {"marker": "s", "color": "#000000", "ms": 3.0, "mfc": "#000000"}),
}
#: Experimental outcomes: the paper's letters.
POINT_STYLE = {"T": ("translation (no uplift)", OKABE_ITO["green"]), "R": ("rocking", OKABE_ITO["blue"]),
               "O": ("overturning", OKABE_ITO["vermillion"])}



# -- maps as grids -------------------------------------------------------------------------------

def as_grid(m) -> MapResult:
    """The map as the pictures draw it: its outcome codes as integers (:data:`MISSING` -2, :data:`FAILED`
    -1, 0 rest, 1 rocking, 2 overturn), and an adaptive map's inferred cells valid and without flags
    (it knows nothing of them). ``m`` is a :class:`MapResult` (or anything with its arrays)."""
    codes = np.asarray(m.outcome, dtype=int)
    shape = codes.shape
    sim = getattr(m, "simulated", None)
    sim = np.ones(shape, bool) if sim is None else np.asarray(sim, bool)
    valid = getattr(m, "valid", None)
    valid = (codes >= 0) if valid is None else np.asarray(valid, bool)
    left = getattr(m, "left_model", None)
    left = np.zeros(shape, bool) if left is None else np.asarray(left, bool)
    # an adaptive map knows nothing of its inferred cells' flags: they count as valid
    valid = valid | ~sim
    return MapResult(None, codes, sim, np.full(shape, -1, np.int32), np.full(shape, np.nan), valid, left & sim,
                     axes=(np.asarray(m.w_ratio, float), np.asarray(m.a_ratio, float)))


# -- pieces, each drawing on an Axes and returning what it drew ----------------------------------

#: Width of the smoothing along a boundary line [vertices; about half a cell apart]: it turns the
#: cell staircase of an oblique boundary into a line without moving it across a cell.
SMOOTH_VERTICES = 1.6


def boundary_lines(m) -> list[np.ndarray]:
    """The overturn boundary of map ``m`` as smooth polylines ``[(n, 2) arrays of (ω/p, a₀/(g·tanα))]``.

    The 0.5 contour of the overturn indicator (1 overturn, 0 any other outcome) at the cell
    centres runs half-way between every overturn cell and its non-overturn neighbours, so every
    cell stays on its side (an isolated cell is a small loop, a one-cell safe band stays open).
    Each line is then smoothed along itself by a Gaussian over its vertices
    (:data:`SMOOTH_VERTICES`, less on short loops so they do not shrink away), which rounds the
    staircase of an oblique boundary without moving the line by more than a fraction of a cell.
    Failed cells take the value of the nearest cell with an outcome (they are marked separately).
    """
    return [_smooth_polyline(p) for p in _raw_lines(m)]


def boundary_parts(m) -> tuple[list[np.ndarray], list[tuple[float, float, float, float]]]:
    """:func:`boundary_lines` split into lines and islands: ``(lines, boxes)``.

    A closed loop around at most :data:`ISLAND_CELLS` cells (an overturn cell amid others, or a
    not-overturn cell amid overturns) is an island: it is returned as the box ``(w0, a0, w1, a1)``
    of the cells it encloses, edges half-way to the neighbours, to be drawn as an outline.
    """
    from matplotlib.path import Path as MPath  # matplotlib on first drawing (start-up time)

    g = as_grid(m)
    lines, boxes = [], []
    pts = np.column_stack([np.tile(g.w_ratio, g.a_ratio.size), np.repeat(g.a_ratio, g.w_ratio.size)])
    we, ae = _edges(g.w_ratio), _edges(g.a_ratio)
    for p in _raw_lines(m):
        inside = None
        if len(p) > 3 and np.allclose(p[0], p[-1]):
            inside = np.nonzero(MPath(p).contains_points(pts))[0]
        if inside is None or not 0 < inside.size <= ISLAND_CELLS:
            lines.append(_smooth_polyline(p))
            continue
        i, j = inside // g.w_ratio.size, inside % g.w_ratio.size
        boxes.append((we[j.min()], ae[i.min()], we[j.max() + 1], ae[i.max() + 1]))
    return lines, boxes


def _edges(c: np.ndarray) -> np.ndarray:
    """Cell edges of centres ``c``: half-way between neighbours, the outer ones on the centres (the
    chart ends at the first and last centre)."""
    c = np.asarray(c, float)
    if c.size < 2:
        return np.array([c[0], c[0]]) if c.size else c
    return np.concatenate([[c[0]], (c[1:] + c[:-1]) / 2.0, [c[-1]]])


def _raw_lines(m) -> list[np.ndarray]:
    from contourpy import contour_generator  # matplotlib's contouring, on first drawing (start-up time)
    from scipy import ndimage  # SciPy on first use (start-up time)

    g = as_grid(m)
    if min(g.outcome.shape) < 2:
        return []
    vals = g.outcome[g.known] == 2
    if vals.size == 0 or vals.all() or not vals.any():
        return []
    ind = (g.outcome == 2).astype(float)
    if not g.known.all():
        idx = ndimage.distance_transform_edt(~g.known, return_distances=False, return_indices=True)
        ind = ind[tuple(idx)]
    lines = contour_generator(g.w_ratio, g.a_ratio, ind).lines(0.5)
    return [np.asarray(p, float) for p in lines if len(p) >= 2]


def _smooth_polyline(p: np.ndarray) -> np.ndarray:
    closed = len(p) > 3 and np.allclose(p[0], p[-1])
    n = len(p) - 1 if closed else len(p)
    sigma = min(SMOOTH_VERTICES, n / 8.0)
    if sigma < 0.3:
        return p
    from scipy import ndimage  # SciPy on first use (start-up time)
    if closed:
        body = ndimage.gaussian_filter1d(p[:-1], sigma, axis=0, mode="wrap")
        return np.vstack([body, body[:1]])
    out = ndimage.gaussian_filter1d(p, sigma, axis=0, mode="nearest")
    out[0], out[-1] = p[0], p[-1]   # an open line ends on the chart's edge: keep it there
    return out


def located_of(m):
    """The located boundary of map ``m`` (bisected at least once), or None: then its boundary is drawn
    from its cells."""
    b = getattr(m, "located", None)
    return b if b is not None and b.depth > 0 else None


def draw_located(ax, b, *, label=None, zorder=3, **style):
    """Draw a located boundary (:class:`~rockbench.benchmark.maps.boundary.LocatedBoundary`): its
    polyline's chords as a LineCollection, and a cross at the midpoint of each edge flagged
    ``multiple`` (more crossings inside the edge than the rule follows). Returns ``(lines, marks)``."""
    from matplotlib.collections import LineCollection  # matplotlib on first drawing (start-up time)

    st = {**REFERENCE_STYLES[0], **style}
    lc = marks = None
    chords = b.chords()
    if chords.size:
        lc = ax.add_collection(LineCollection(list(chords), colors=st["color"], linewidths=st["linewidth"],
                                              linestyles=[st["linestyle"]], zorder=zorder, label=label,
                                              capstyle="round", joinstyle="round"))
    lone = b.segments()[chords.shape[0]:, 0, :]
    if lone.size:   # crossings no chord joins (a side of the grid or of the domain): dots
        ax.plot(lone[:, 0], lone[:, 1], ls="none", marker=".", ms=2.5, color=st["color"], zorder=zorder)
    multiple = b.flagged_edges(MULTIPLE)
    if multiple.size:
        at = b.points[np.isin(_edge_ids(b.cell_a, b.axis), _edge_ids(multiple[:, :2], multiple[:, 2]))]
        if at.size:
            (marks,) = ax.plot(at[:, 0], at[:, 1], ls="none", marker="x", ms=4.5, mew=1.1, color=st["color"],
                               zorder=zorder + 0.1)
    return lc, marks


def _edge_ids(cells: np.ndarray, axis: np.ndarray) -> np.ndarray:
    cells = np.asarray(cells, np.int64).reshape(-1, 2)
    return (cells[:, 0] * 1_000_003 + cells[:, 1]) * 2 + np.asarray(axis, np.int64)


def multiple_handle(color="k"):
    """The legend entry of the crosses on edges flagged ``multiple``."""
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)
    return Line2D([], [], ls="none", marker="x", ms=4.5, mew=1.1, color=color,
                  label="edge with more crossings than located (multiple)")


def draw_boundary(ax, m, *, label=None, zorder=3, **style):
    """Draw the boundary of map ``m``: its located polyline when it has one (:func:`draw_located`),
    else its lines (:func:`boundary_parts`) as a LineCollection and its islands as thin outlines of
    their cells in the same colour. Returns ``(lines, islands)``: the LineCollection and the
    PatchCollection (the crosses of ``multiple`` edges for a located boundary), each None when there
    is none."""
    from matplotlib.collections import LineCollection, PatchCollection  # matplotlib on first drawing (start-up time)
    from matplotlib.patches import Rectangle  # matplotlib on first drawing (start-up time)

    if located_of(m) is not None:
        return draw_located(ax, located_of(m), label=label, zorder=zorder, **style)
    lines, boxes = boundary_parts(m)
    st = {**REFERENCE_STYLES[0], **style}
    lc = isl = None
    if lines:
        lc = ax.add_collection(LineCollection(lines, colors=st["color"], linewidths=st["linewidth"],
                                              linestyles=[st["linestyle"]], zorder=zorder, label=label,
                                              capstyle="round", joinstyle="round"))
    if boxes:
        rects = [Rectangle((w0, a0), w1 - w0, a1 - a0) for w0, a0, w1, a1 in boxes]
        isl = ax.add_collection(PatchCollection(rects, facecolor="none", edgecolor=st["color"], linewidth=0.9,
                                                zorder=zorder))
    return lc, isl


def extra_handle(m):
    """The legend entry of what :func:`draw_boundary` returns beside its lines for map ``m``: the crosses
    of a located boundary's ``multiple`` edges, or the outlines of a cell-level boundary's islands."""
    return multiple_handle() if located_of(m) is not None else island_handle()


def island_handle():
    """The legend entry of the islands' outlines."""
    from matplotlib.patches import Patch  # matplotlib on first drawing (start-up time)
    return Patch(facecolor="none", edgecolor="#000000", lw=0.9, label=ISLAND_LABEL)


def flag_area(m) -> np.ndarray:
    """The cells each flagged simulation stands for: every cell with an outcome takes the flag of
    the nearest simulated cell (itself on a full grid; on an adaptive grid the inferred cells around
    it, as the outcomes are inferred), so the flags form areas rather than rows of the coarse grid."""
    from scipy import ndimage  # SciPy on first use (start-up time)

    g = as_grid(m)
    flagged = g.known & g.simulated & ~g.valid
    if not flagged.any():
        return flagged
    if not g.simulated.all():
        idx = ndimage.distance_transform_edt(~g.simulated, return_distances=False, return_indices=True)
        flagged = flagged[tuple(idx)]
    return flagged & g.known


def draw_flags(ax, m, mask, *, zorder=2.5):
    """A dotted area over each cell of ``mask`` (cell edges half-way to the neighbours). Returns the
    PatchCollection, or None when no cell is marked."""
    from matplotlib.collections import PatchCollection  # matplotlib on first drawing (start-up time)
    from matplotlib.patches import Rectangle  # matplotlib on first drawing (start-up time)

    if not np.asarray(mask).any():
        return None
    g = as_grid(m)
    we, ae = _edges(g.w_ratio), _edges(g.a_ratio)
    rects = []
    for i in range(mask.shape[0]):
        j = 0
        while j < mask.shape[1]:   # one rectangle per run of marked cells in a row
            if not mask[i, j]:
                j += 1
                continue
            k = j
            while k + 1 < mask.shape[1] and mask[i, k + 1]:
                k += 1
            rects.append(Rectangle((we[j], ae[i]), we[k + 1] - we[j], ae[i + 1] - ae[i]))
            j = k + 1
    pc = PatchCollection(rects, facecolor="none", edgecolor=FLAG_COLOUR, hatch=FLAG_HATCH, linewidth=0.0,
                         zorder=zorder)
    return ax.add_collection(pc)


def flag_handle():
    """The legend entry of the flagged cells."""
    from matplotlib.patches import Patch  # matplotlib on first drawing (start-up time)
    return Patch(facecolor="white", edgecolor=FLAG_COLOUR, hatch=FLAG_HATCH, lw=0.0, label=FLAG_LABEL)


def draw_domain_hatch(ax, ref, *, zorder=1):
    """Hatch the reference's cells outside the rigid model's domain (lift-/slip-required). Returns
    the ContourSet, or None when every cell is inside."""
    g = as_grid(ref)
    out = g.outside_domain
    if not out.any() or min(out.shape) < 2:
        return None
    cs = ax.contourf(g.w_ratio, g.a_ratio, out.astype(float), levels=[0.5, 1.5], colors="none", hatches=[HATCH],
                     zorder=zorder)
    cs.set_edgecolor(HATCH_COLOUR)
    cs.set_linewidth(0.0)
    return cs


def draw_fill(ax, m, *, color=ENGINE_FILL, zorder=0):
    """Fill the overturn cells of ``m`` (each cell reaching half-way to its neighbours)."""
    g = as_grid(m)
    z = np.where(g.outcome == 2, 1.0, np.nan)
    if not np.isfinite(z).any():
        return None
    from matplotlib.colors import ListedColormap  # matplotlib on first drawing (start-up time)
    return ax.pcolormesh(g.w_ratio, g.a_ratio, z, shading="nearest", cmap=ListedColormap([color]), vmin=0, vmax=1,
                         zorder=zorder, rasterized=True)


def disagreements(eng, ref) -> dict:
    """Cells where engine map ``eng`` and reference map ``ref`` disagree, by kind.

    ``false_overturn``: the engine overturns, the reference has another outcome; ``missed_overturn``:
    the reverse; both only inside the reference's domain (where the scores judge them).
    ``invalid``: simulated engine cells flagged invalid (anywhere: outside the domain that is
    the right answer). ``failed``: engine cells without an outcome where the reference has one.

    Returns
    -------
    dict
        kind → boolean grid.
    """
    e, r = as_grid(eng), as_grid(ref)
    inside = r.known & r.valid
    return {"false_overturn": inside & e.known & (e.outcome == 2) & (r.outcome != 2),
            "missed_overturn": inside & e.known & (e.outcome != 2) & (r.outcome == 2),
            "invalid": e.known & e.simulated & ~e.valid,
            "failed": r.known & (e.outcome == -1)}


def draw_marks(ax, m, cells: dict, *, zorder=4) -> dict:
    """A marker at the centre of each marked cell, one style per kind (:data:`MARKS`)."""
    g = as_grid(m)
    # about half a cell wide on a 50-cell axis, no smaller than legible on a fine grid
    shrink = float(np.clip(50.0 / max(g.w_ratio.size, g.a_ratio.size, 1), 0.55, 1.0))
    out = {}
    for kind, mask in cells.items():
        i, j = np.nonzero(mask)
        if i.size == 0:
            continue
        _, st = MARKS[kind]
        st = {**st, "ms": st["ms"] * shrink}
        (line,) = ax.plot(g.w_ratio[j], g.a_ratio[i], ls="none", zorder=zorder, **st)
        out[kind] = line
    return out


def draw_st_limit(ax, a_limit: float | None, *, zorder=2):
    """The shaking-table limit as a dashed line labelled "ST limit" on the chart; nothing when it
    lies outside the vertical range. Returns ``(line, text)`` or None."""
    if a_limit is None:
        return None
    lo, hi = ax.get_ylim()
    if not lo <= a_limit <= hi:
        return None
    line = ax.axhline(a_limit, color="k", ls=(0, (4, 2)), lw=0.9, zorder=zorder)
    txt = ax.text(0.985, a_limit, "ST limit", transform=ax.get_yaxis_transform(), ha="right", va="bottom",
                  fontsize=7, zorder=zorder + 3, bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none",
                                                        "alpha": 0.8})
    return line, txt


def draw_points(ax, points, *, zorder=5) -> dict:
    """Experimental outcomes as the paper's letters T, R, O (points outside the chart are left out).

    ``points``: ``(w_ratio, a_ratio, letter, repetitions)`` tuples or dicts with those keys
    (``outcome`` for the letter)."""
    x0, x1 = sorted(ax.get_xlim())
    y0, y1 = sorted(ax.get_ylim())
    out = {}
    for letter, (_, colour) in POINT_STYLE.items():
        sel = []
        for p in points or []:
            if isinstance(p, dict):
                w, a, o = p["w_ratio"], p["a_ratio"], str(p.get("outcome", p.get("letter", ""))).upper()
            else:
                w, a, o = p[0], p[1], str(p[2]).upper()
            if o == letter and x0 <= w <= x1 and y0 <= a <= y1:
                sel.append((w, a))
        if sel:
            (line,) = ax.plot([s[0] for s in sel], [s[1] for s in sel], ls="none", marker=f"$\\mathrm{{{letter}}}$",
                              ms=6.5, color=colour, zorder=zorder)
            out[letter] = line
    return out


def _frame(ax, g: MapResult, *, xlabel=True, ylabel=True):
    ax.set_xlim(g.w_ratio[0], g.w_ratio[-1])
    ax.set_ylim(g.a_ratio[0], g.a_ratio[-1])
    if xlabel:
        ax.set_xlabel("ω/p [-]")
    if ylabel:
        ax.set_ylabel("a₀/(g·tanα) [-]")


def _wrap_to(ax, text: str, size_pt: float) -> str:
    """``text`` broken at commas into lines that fit the width of ``ax`` at ``size_pt``."""
    spec = ax.get_subplotspec()
    ncols = spec.get_gridspec().ncols if spec is not None else 1
    return _wrap(text, (ax.figure.get_figwidth() / ncols - 0.3) * 72.0, size_pt)   # less its tick labels


def _wrap(text: str, width_pt: float, size_pt: float) -> str:
    """``text`` broken at commas into lines of ``width_pt`` at ``size_pt`` (about half an em a
    character)."""
    fit = max(12, int(width_pt / (0.5 * size_pt)))
    lines, cur = [], ""
    for part in text.split(", "):
        cand = f"{cur}, {part}" if cur else part
        if cur and len(cand) > fit:
            lines.append(cur + ",")
            cur = part
        else:
            cur = cand
    return "\n".join(lines + [cur])


def _print_sizes(ax) -> None:
    """Tick labels and axis labels at their print sizes (:mod:`.style`)."""
    ax.tick_params(labelsize=SMALL_PT)
    ax.xaxis.label.set_size(LABEL_PT)
    ax.yaxis.label.set_size(LABEL_PT)


def _axes_legend(ax, handles, where: str, below: float):
    """A legend outside the axes, never over the data: ``below`` them (two columns when the labels
    fit, else one: it never sticks out sideways), ``right`` of them, or ``none``."""
    if where == "below":
        long = max((len(h.get_label()) for h in handles), default=0) > 44
        return ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(0.0, below), ncols=1 if long else 2,
                         fontsize=SMALL_PT, frameon=False, borderaxespad=0.0)
    if where == "right":
        return ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=SMALL_PT,
                         frameon=False)
    return None


# -- one panel ------------------------------------------------------------------------------------

def plot_panel(engine=None, references=(), *, domain=None, like=None, points=None, st_limit=None, title=None,
               note=None, ax=None, xlabel=True, ylabel=True) -> dict:
    """One stability graph: an engine map against the reference boundaries.

    Parameters
    ----------
    engine : MapResult, optional
        The engine's map: its overturn cells are filled and its disagreements with ``like`` marked.
    references : list of (str, map) or (str, map, style)
        Reference maps and their legend labels, drawn as lines in :data:`REFERENCE_STYLES` order
        (η_H, η_M average k, η_M exact k, ...) unless a style (a :data:`REFERENCE_STYLES` entry) is
        given.
    domain : map, optional
        The reference whose lift-/slip-required region is hatched (default: ``like``, else the
        first reference).
    like : map, optional
        The reference with the engine's restitution law: disagreements are counted against it
        (default: the first reference).
    points : list, optional
        Experimental outcomes (see :func:`draw_points`).
    st_limit : float, optional
        The shaking-table limit as a₀/(g·tanα).
    title, note : str, optional
        Panel title and a second, smaller line under it (e.g. scores).
    ax : matplotlib Axes, optional
        Where to draw (a new figure when None).

    Returns
    -------
    dict
        ``ax``, ``fill``, ``hatch``, ``references`` (label → LineCollection or None), ``islands``
        (label → PatchCollection of the islands' outlines), ``flags`` (the dotted flagged cells, or
        None), ``marks`` (kind → Line2D),
        ``st_limit`` (``(line, text)`` or None), ``points`` (letter → Line2D) and ``handles``
        (legend label → proxy artist, for a figure legend).
    """
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)
    from matplotlib.patches import Patch  # matplotlib on first drawing (start-up time)

    if ax is None:
        from matplotlib.figure import Figure  # matplotlib on first drawing (start-up time)
        ax = Figure(figsize=(4.6, 3.6), layout="constrained").add_subplot()
    refs = [tuple(r) for r in references]
    like = like if like is not None else (refs[0][1] if refs else None)
    domain = domain if domain is not None else like
    base = engine if engine is not None else (refs[0][1] if refs else None)
    if base is None:
        raise ValueError("plot_panel needs an engine map or at least one reference map")
    _frame(ax, as_grid(base), xlabel=xlabel, ylabel=ylabel)
    handles = {}
    fill = draw_fill(ax, engine) if engine is not None else None
    if engine is not None:
        handles["engine overturns"] = Patch(facecolor=ENGINE_FILL, edgecolor="none", label="engine overturns")
    hatch = draw_domain_hatch(ax, domain) if domain is not None else None
    if domain is not None:
        handles["hatch"] = Patch(facecolor="white", edgecolor=HATCH_COLOUR, hatch=HATCH, lw=0.0,
                                 label=DOMAIN_LABEL)
    lines, islands = _panel_references(ax, refs, handles)
    marks, flags = {}, None
    if engine is not None:
        flags, marks = _panel_engine_marks(ax, engine, like, handles)
    st_art = draw_st_limit(ax, st_limit)
    if st_art is not None:
        handles["st"] = Line2D([], [], color="k", ls=(0, (4, 2)), lw=0.9, label="ST limit (shaking table, 25 m/s²)")
    pts = draw_points(ax, points)
    for h in _point_handles(pts):
        handles[h.get_label()] = h
    if title:
        # a variant's name can be long (a version with its parts, a solver): broken at commas like the note
        ax.set_title(for_matplotlib(_wrap_to(ax, title, TITLE_PT) + (f"\n{_wrap_to(ax, note, TITLE_PT)}" if note else "")),
                     fontsize=TITLE_PT, loc="left")
    _print_sizes(ax)
    return {"ax": ax, "fill": fill, "hatch": hatch, "references": lines, "islands": islands, "flags": flags,
            "marks": marks, "st_limit": st_art, "points": pts, "handles": handles}


def _panel_references(ax, refs, handles: dict) -> tuple[dict, dict]:
    """Each reference's boundary (its own style, else :data:`REFERENCE_STYLES` in order) and islands;
    their legend handles go into ``handles``. Returns the lines and the islands by label."""
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)

    lines, islands = {}, {}
    for k, item in enumerate(refs):
        label, m = item[0], item[1]
        st = item[2] if len(item) > 2 else REFERENCE_STYLES[k % len(REFERENCE_STYLES)]
        # the first reference (the like-for-like one) on top where the lines coincide
        cs, isl = draw_boundary(ax, m, label=for_matplotlib(label), zorder=3.5 - 0.1 * k, **st)
        lines[label] = cs
        handles[label] = Line2D([], [], color=st["color"], ls=st["linestyle"], lw=st["linewidth"],
                                label=for_matplotlib(label))
        if isl is not None:
            islands[label] = isl
            h = extra_handle(m)
            handles[h.get_label()] = h
    return lines, islands


def _panel_engine_marks(ax, engine, like, handles: dict):
    """The engine map's flagged cells (dotted) and, against ``like``, its disagreements (marks);
    their legend handles go into ``handles``. Returns the flags (or None) and the marks by kind."""
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)

    marks = {}
    flags = draw_flags(ax, engine, flag_area(engine))
    if flags is not None:
        handles[FLAG_LABEL] = flag_handle()
    if like is not None:
        marks = draw_marks(ax, engine, {k: v for k, v in disagreements(engine, like).items() if k in MARKS})
        for kind, (label, st) in MARKS.items():
            if kind in marks:   # only the kinds this panel has
                handles[label] = Line2D([], [], ls="none", label=label, **st)
    return flags, marks


def _point_handles(drawn: dict) -> list:
    """Legend entries of the experimental outcomes drawn (:func:`draw_points`), in :data:`POINT_STYLE` order."""
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)

    return [Line2D([], [], ls="none", marker=f"$\\mathrm{{{letter}}}$", ms=6.5, color=colour,
                   label=f"experiment {letter}: {words}")
            for letter, (words, colour) in POINT_STYLE.items() if letter in drawn]


def plot_panels(panels: list[dict], *, ncols: int | None = None, suptitle: str | None = None,
                panel_size=None, fig=None) -> dict:
    """Small multiples: one :func:`plot_panel` per entry of ``panels`` (its keyword arguments), on
    shared axes, with one legend for the whole figure below the panels.

    The figure is as wide as a journal's double column (175 mm; a single column for one panel),
    so that its fonts keep their point sizes in print; ``panel_size`` (inches) overrides that.

    Returns
    -------
    dict
        ``figure``, ``axes`` (list), ``panels`` (what each :func:`plot_panel` drew) and ``legend``.
    """
    from matplotlib.figure import Figure  # matplotlib on first drawing (start-up time)

    n = len(panels)
    if n == 0:
        raise ValueError("plot_panels needs at least one panel")
    ncols = ncols or min(n, 3)
    nrows = math.ceil(n / ncols)
    if fig is None:
        fig = Figure(figsize=_panels_size(ncols, nrows, panel_size), layout="constrained")
    axes = fig.subplots(nrows, ncols, sharex=True, sharey=True, squeeze=False)
    drawn, handles = [], {}
    for k, kw in enumerate(panels):
        r, c = divmod(k, ncols)
        d = plot_panel(ax=axes[r][c], xlabel=(r == nrows - 1 or (r == nrows - 2 and k + ncols >= n)),
                       ylabel=(c == 0), **kw)
        drawn.append(d)
        for label, h in d["handles"].items():
            handles.setdefault(label, h)
    for k in range(n, nrows * ncols):
        r, c = divmod(k, ncols)
        axes[r][c].set_visible(False)
        if r > 0:
            axes[r - 1][c].xaxis.set_tick_params(labelbottom=True)
            axes[r - 1][c].set_xlabel("ω/p [-]")
    if suptitle:
        fig.suptitle(for_matplotlib(_wrap(suptitle, (fig.get_figwidth() - 0.2) * 72.0, SUPTITLE_PT)),
                     fontsize=SUPTITLE_PT, x=0.01, ha="left")
    # one order whatever panel brought an entry in: fill, hatch, references, marks, ST limit, points
    marks = [label for label, _ in MARKS.values()]

    def rank(item):
        k, (label, _) = item
        if label == "engine overturns":
            return (0, k)
        if label == "hatch":
            return (1, k)
        if label == ISLAND_LABEL:
            return (2.5, k)
        if label == FLAG_LABEL:
            return (2.7, k)
        if label in marks:
            return (3, marks.index(label))
        if label == "st":
            return (4, k)
        if label.startswith("experiment "):
            return (5, k)
        return (2, k)

    handles = dict(v for _, v in sorted(enumerate(handles.items()), key=rank))
    # as many legend columns as fit the figure's width (about 3.3 inches each at 7 pt)
    width_in = fig.get_figwidth()
    legend = fig.legend(handles=list(handles.values()), loc="outside lower center",
                        ncols=max(1, min(3, len(handles), int(width_in / 3.3 + 0.05))), fontsize=SMALL_PT,
                        frameon=False, handlelength=2.6, columnspacing=1.2)
    return {"figure": fig, "axes": [ax for row in axes for ax in row][:n], "panels": drawn, "legend": legend}


def _panels_size(ncols: int, nrows: int, panel_size=None) -> tuple[float, float]:
    """Figure size [in] of ``ncols`` × ``nrows`` panels: a journal's double column wide (one column
    for a single panel), panels about 0.8 as high as wide, and room for the legend below."""
    if panel_size is not None:
        return panel_size[0] * ncols + 0.6, panel_size[1] * nrows + 1.3
    width = SINGLE_COLUMN_IN if ncols == 1 else DOUBLE_COLUMN_IN
    panel_w = (width - 0.5) / ncols
    return width, (panel_w * 0.8 + 0.35) * nrows + (1.3 if ncols == 1 else 0.9)


# -- several maps on one graph (the paper's Figs 4–9) -----------------------------------------------

def plot_stability(maps, labels=None, *, ax=None, shade: bool = True, experiments=None,
                   st_limit_mps2: float | None = SHAKING_TABLE_LIMIT_MPS2, title: str | None = None,
                   show_failed: bool = True,
                   extra_handles=(), legend: str = "below"):
    """Several maps' overturn boundaries on one graph (the paper's Figs 4–9).

    Parameters
    ----------
    maps : MapResult or list of MapResult
        The maps; the first one's overturn region is shaded and its lift-/slip-required region
        hatched.
    labels : list of str, optional
        Legend labels (default: block and restitution in the paper's symbols).
    ax : matplotlib Axes, optional
        Where to draw (a new figure when None).
    shade : bool
        Shade the first map's overturn region.
    experiments : iterable of dict, optional
        Measured outcomes ``{"w_ratio", "a_ratio", "outcome"}`` with outcome ``T``, ``R`` or ``O``.
    st_limit_mps2 : float or None
        The table limit [m/s^2] drawn for the first map's block (only where it lies on the chart);
        None draws nothing.
    title : str, optional
        Axes title.
    show_failed : bool
        Mark failed cells.
    extra_handles : sequence of matplotlib artists
        More legend entries (put first).
    legend : {"below", "right", "none"}
        Where the legend goes: outside the axes, never over the data.

    Returns
    -------
    dict
        ``ax``, ``boundaries`` (list of ContourSet), ``st_limit_a_ratio`` (float or None; None also
        when the limit lies off the chart), ``hatch`` and ``legend``.
    """
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)
    from matplotlib.patches import Patch  # matplotlib on first drawing (start-up time)

    if not isinstance(maps, (list, tuple)):
        maps = [maps]
    if ax is None:
        from matplotlib.figure import Figure  # matplotlib on first drawing (start-up time)
        ax = Figure(figsize=(DOUBLE_COLUMN_IN * 0.7, DOUBLE_COLUMN_IN * 0.66), layout="constrained").add_subplot()
    labels = list(labels) if labels is not None else [_label(m) for m in maps]
    handles = list(extra_handles)
    first = maps[0]
    _frame(ax, as_grid(first))
    if shade and (as_grid(first).outcome == 2).any():
        draw_fill(ax, first, color=ENGINE_FILL)
        handles.append(Patch(color=ENGINE_FILL, label=for_matplotlib(f"overturn, shaded map ({labels[0]})")))
    hatch = draw_domain_hatch(ax, first)
    if hatch is not None:
        handles.append(Patch(facecolor="white", edgecolor=HATCH_COLOUR, hatch=HATCH, lw=0,
                             label=f"{DOMAIN_LABEL}, shaded map"))
    drawn = _boundaries(ax, maps, labels, handles)
    if show_failed:
        _failed_cells(ax, maps, handles)
    handles += _point_handles(draw_points(ax, experiments))
    st = None
    if st_limit_mps2 is not None:
        st_a = st_limit_a_ratio(first.spec.block, st_limit_mps2)
        if draw_st_limit(ax, st_a) is not None:
            st = st_a
            handles.append(Line2D([], [], color="k", ls=(0, (4, 2)), lw=0.9,
                                  label=f"ST limit (shaking table, {st_limit_mps2:g} m/s²)"))
    if title:
        ax.set_title(for_matplotlib(title), fontsize=SUPTITLE_PT, loc="left")
    leg = _axes_legend(ax, handles, legend, below=-0.13)
    _print_sizes(ax)
    return {"ax": ax, "boundaries": drawn, "st_limit_a_ratio": st, "hatch": hatch, "legend": leg}


def _boundaries(ax, maps, labels, handles: list) -> list:
    """Each map's overturn boundary in its own colour and dash (and islands); legend entries appended
    to ``handles``. Returns the ContourSets drawn."""
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)

    drawn, extras = [], {}
    for k, (res, lab) in enumerate(zip(maps, labels)):
        st = {**REFERENCE_STYLES[k % len(REFERENCE_STYLES)], "color": COLORS[k % len(COLORS)]}
        cs, isl = draw_boundary(ax, res, label=for_matplotlib(lab), zorder=3.5 - 0.1 * k, **st)
        if cs is not None:
            drawn.append(cs)
        handles.append(Line2D([], [], color=st["color"], lw=st["linewidth"], ls=st["linestyle"],
                              label=for_matplotlib(lab)))
        if isl is not None:
            h = extra_handle(res)
            extras.setdefault(h.get_label(), h)
    handles.extend(extras.values())
    return drawn


def _failed_cells(ax, maps, handles: list) -> None:
    """Every map's failed cells marked, and one legend entry with their count."""
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)

    nfail = 0
    for res in maps:
        failed = as_grid(res).outcome == -1
        if failed.any():
            draw_marks(ax, res, {"failed": failed})
            nfail += int(failed.sum())
    if nfail:
        handles.append(Line2D([], [], ls="none", label=f"failed cells ({nfail})", **MARKS["failed"][1]))


def _label(res) -> str:
    s = res.spec
    return f"{s.block.name}, {restitution_symbol(s.restitution.label, s.block.name)} = {s.eta:.4f}"


def save(fig, stem, formats=("png", "svg")) -> list[Path]:
    """Save ``fig`` as ``stem.<format>`` for each of ``formats`` (:mod:`.output`); returns the paths."""
    return save_formats(fig, stem, formats)


# -- one map's picture ----------------------------------------------------------------------------

def plot_map(result, *, reference=None, ax=None) -> dict:
    """One map as its outcome classes (rest, rocking, overturn), failed and invalid cells marked,
    the reference's overturn boundary overlaid and its lift-/slip-required region hatched.

    Parameters
    ----------
    result : MapResult
        The map.
    reference : MapResult, optional
        The reference map of the same case and grid (for an engine map); a reference map is its own.
    ax : matplotlib Axes, optional

    Returns
    -------
    dict
        ``ax``, ``image`` (the outcome cells), ``boundary`` (LineCollection or None), ``hatch``,
        ``flags`` (the dotted flagged cells or None), ``marks`` (failed cells),
        ``st_limit`` and ``legend``.
    """
    from matplotlib.colors import ListedColormap  # matplotlib on first drawing (start-up time)
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)
    from matplotlib.patches import Patch  # matplotlib on first drawing (start-up time)


    if ax is None:
        from matplotlib.figure import Figure  # matplotlib on first drawing (start-up time)
        ax = Figure(figsize=(DOUBLE_COLUMN_IN * 0.75, DOUBLE_COLUMN_IN * 0.72), layout="constrained").add_subplot()
    g = as_grid(result)
    s = result.spec
    is_ref = s.engine == "reference" and not is_planted(s.engine, s.engine_settings)
    ref = result if is_ref else reference
    _frame(ax, g)
    show = np.where(g.outcome >= 0, g.outcome, np.nan).astype(float)
    image = ax.pcolormesh(g.w_ratio, g.a_ratio, show, shading="nearest", cmap=ListedColormap(list(OUTCOME_COLOURS)),
                          vmin=-0.5, vmax=2.5, zorder=0, rasterized=True)
    handles = [Patch(facecolor=c, edgecolor="#999999", lw=0.5, label=n)
               for c, n in zip(OUTCOME_COLOURS, ("rest", "rocking", "overturn"))]
    hatch = boundary = None
    if ref is not None:
        hatch = draw_domain_hatch(ax, ref)
        if hatch is not None:
            handles.append(Patch(facecolor="white", edgecolor=HATCH_COLOUR, hatch=HATCH, lw=0,
                                 label=DOMAIN_LABEL))
        label = for_matplotlib(f"reference boundary ({restitution_symbol(s.restitution.label, s.block.name)})")
        if located_of(ref) is not None:
            label = label[:-1] + f", located to 1/{2 ** located_of(ref).depth} of a step)"
        boundary, islands = draw_boundary(ax, ref, label=label)
        if boundary is not None:
            handles.append(Line2D([], [], color="k", lw=1.7, label=label))
        if islands is not None:
            handles.append(extra_handle(ref))
    own = located_of(result) if not is_ref else None
    if own is not None and own.n_crossings:
        draw_located(ax, own, zorder=3.6, **ENGINE_LINE)
        handles.append(Line2D([], [], lw=ENGINE_LINE["linewidth"], color=ENGINE_LINE["color"],
                              ls=ENGINE_LINE["linestyle"], label=f"engine boundary (located to 1/{2 ** own.depth} of a step)"))
    flags = None if is_ref else draw_flags(ax, result, flag_area(result))
    if flags is not None:
        n = int(np.count_nonzero(g.known & g.simulated & ~g.valid))
        handles.append(flag_handle())
        handles[-1].set_label(f"engine flagged slip, jump or energy gain in {n} simulated cell(s) (dotted)")
    marks = draw_marks(ax, result, {"failed": g.outcome == -1})
    for kind, line in marks.items():
        handles.append(Line2D([], [], ls="none", label=f"simulation failed ({int(len(line.get_xdata()))})",
                              **MARKS[kind][1]))
    st = draw_st_limit(ax, st_limit_a_ratio(s.block))
    if st is not None:
        handles.append(Line2D([], [], color="k", ls=(0, (4, 2)), lw=0.9, label="ST limit, 25 m/s²"))
    who = variant_label(s.engine, s.engine_settings, restitution=s.restitution.label, dt_s=s.dt_s, block=s.block.name)
    frac = f"; {100 * result.fraction_simulated:.0f} % of the cells simulated" if result.adaptive else ""
    ax.set_title(for_matplotlib(f"{who}\n{s.block.name}, {s.pulse}, η = {s.eta:.4f}, {s.y.n}×{s.x.n} cells{frac}"),
                 fontsize=TITLE_PT, loc="left")
    _print_sizes(ax)
    leg = _axes_legend(ax, handles, "below", below=-0.12)
    return {"ax": ax, "image": image, "boundary": boundary, "hatch": hatch, "marks": marks, "flags": flags,
            "st_limit": st,
            "legend": leg}


def plot_map_files(result, stem, *, reference=None, formats=("png",)) -> list[Path]:
    """Draw :func:`plot_map` into ``stem.<format>`` for each of ``formats`` (``map.png``, ...), without
    pyplot; returns the paths."""
    return save_formats(map_figure(result, reference=reference), stem, formats)


def map_figure(result, *, reference=None):
    """:func:`plot_map` on a figure of its own, three quarters of a journal's double column wide."""
    from matplotlib.figure import Figure  # matplotlib on first drawing (start-up time)


    fig = Figure(figsize=(DOUBLE_COLUMN_IN * 0.75, DOUBLE_COLUMN_IN * 0.72), layout="constrained")
    plot_map(result, reference=reference, ax=fig.add_subplot())
    return fig
