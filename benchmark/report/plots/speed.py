"""Accuracy against cost: each engine's boundary distance against its CPU seconds per simulated second, one
curve per engine through its time steps (score.json's ``speed``, :mod:`rockbench.benchmark.scoring.speed`).

- Cost across, logarithmic (costs differ by orders of magnitude); the boundary distance up, logarithmic
  where its range spans more than a factor of :data:`LOG_RANGE`.
- One curve per engine: its colour and dash are its own (the legend names it; past the palette's six
  colours an engine shares a colour with another, then with another dash and hollow markers); each point's marker is its
  time step (the legend says which), and the step is also written beside the point where the words fit
  without touching another point or coming within :data:`LABEL_GAP_PT` of another label
  (:func:`place_labels`), else left to the marker.
- The time-step rule's choice is circled: the point of the step every block chose, or, where the blocks
  chose different steps, the point those maps make together, drawn on its own.
- The detectable difference (the row's ``band``: the verdict's where the run has one, else the stage's own
  for the engine): a band in the engine's colour at the finest step's distance ± that difference, reaching
  from the finest point leftwards over the engine's own costs (the cheaper steps inside it reach matched
  accuracy (a)); the declared distance of criterion (b) a dashed line.
- The names are in a legend outside the axes, so no label lies over the data or leaves the figure.
"""

from __future__ import annotations

from rockbench.benchmark.scoring.labels import for_matplotlib
from rockbench.benchmark.report.plots.style import CYCLE, DOUBLE_COLUMN_IN, LABEL_PT, SMALL_PT

#: Ratio of the largest to the smallest distance above which the distance axis is logarithmic.
LOG_RANGE = 10.0

#: A point's marker by its step's place in the stage's ladder, coarsest first.
STEP_MARKERS = "o s ^ D v P X h".split()

#: How far an engine's band reaches left of its cheapest point (a factor of cost).
BAND_MARGIN = 1.25

#: Space kept clear around a placed step's words [points], so that two engines' words never read as one.
LABEL_GAP_PT = 4.0

#: The dashes of the engines' curves, taken in turn with the colours (an engine is never told by colour alone).
DASHES = ["-", "--", "-.", ":"]


def _step_words(dt_s: float) -> str:
    return f"{dt_s * 1e3:g} ms"


def _style(k: int) -> dict:
    """The k-th engine's colour and dash; past the palette's end a colour comes again with another dash and
    hollow markers (``hollow``), so that two engines of one colour differ in line and in point."""
    return {"color": CYCLE[k % len(CYCLE)], "ls": DASHES[(k // len(CYCLE) + k) % len(DASHES)],
            "hollow": k >= len(CYCLE)}


def _drawn(row: dict) -> list[dict]:
    return [p for p in row["points"] if p.get("value") is not None and p.get("cost") and p["cost"] > 0]


def plot_accuracy_cost(speed: dict, *, ax=None) -> dict:
    """Draw the speed section's curves (module docstring).

    Parameters
    ----------
    speed : dict
        score.json's ``speed``.
    ax : matplotlib Axes, optional
        Where to draw (a new figure, without pyplot, when None).

    Returns
    -------
    dict
        ``ax``, ``figure``, ``curves`` (engine → Line2D), ``labels`` (the step words placed, Text),
        ``rule`` (engine → the circle drawn), ``bands`` (engine → the band), ``legend``, ``logy``.
    """
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)

    if ax is None:
        from matplotlib.figure import Figure  # matplotlib on first drawing (start-up time)
        ax = Figure(figsize=(DOUBLE_COLUMN_IN, 3.6), layout="constrained").add_subplot()
    rows = [r for r in speed.get("engines", []) if _drawn(r)]
    steps = sorted({p["dt_s"] for r in rows for p in r["points"]}, reverse=True)
    marker = {dt: STEP_MARKERS[k % len(STEP_MARKERS)] for k, dt in enumerate(steps)}
    out = {"ax": ax, "figure": ax.figure, "curves": {}, "labels": [], "rule": {}, "bands": {}, "legend": None}
    for k, r in enumerate(rows):
        _curve(ax, r, _style(k), marker, out)
    logy = _axes(ax, rows, speed)
    handles = [out["curves"][r["engine"]] for r in rows]
    handles += [Line2D([], [], ls="none", marker=marker[dt], color="0.3", mfc="white", label=f"step {_step_words(dt)}")
                for dt in steps]
    if out["rule"]:
        handles.append(Line2D([], [], ls="none", marker="o", ms=11, mfc="none", mec="black", mew=1.0,
                              label="the time-step rule's choice"))
    if out["bands"]:
        from matplotlib.patches import Patch  # matplotlib on first drawing (start-up time)
        handles.append(Patch(facecolor="0.85", edgecolor="none", label=band_words(rows)))
    if speed.get("declared", {}).get("matched_distance") and rows:
        d = float(speed["declared"]["matched_distance"])
        handles.append(ax.axhline(d, color="0.25", lw=0.8, ls=(0, (4, 3)), zorder=1, label=f"declared distance {d:g}"))
    if rows:
        out["legend"] = ax.figure.legend(handles=handles, loc="outside right upper", fontsize=SMALL_PT, frameon=False)
    out["logy"] = logy
    out["labels"] = place_labels(ax, [(p, r) for r in rows for p in _drawn(r)],
                                 lines=list(out["curves"].values()), circles=list(out["rule"].values()))
    return out


def band_words(rows: list[dict]) -> str:
    """The band's legend entry: whose detectable difference it is (the verdict's, one number for every
    engine, or each engine's own from the stage where the run has no verdict variants)."""
    sources = {(r.get("band") or {}).get("source") for r in rows if r.get("band")}
    if sources == {"verdict"}:
        value = next(r["band"]["value"] for r in rows if r.get("band"))
        return f"finest step ± the verdict's detectable difference ({value:.3f})"
    return "finest step ± detectable difference (the stage's own)"


def _curve(ax, r: dict, style: dict, marker: dict, out: dict) -> None:
    """One engine: its curve, markers by step, its band and its rule's circle."""
    pts = sorted(_drawn(r), key=lambda p: -p["dt_s"])
    xs, ys = [p["cost"] for p in pts], [p["value"] for p in pts]
    gpu = r.get("device", {}).get("runs_on") == "gpu"
    label = for_matplotlib(r["label"] + (" (GPU: wall time)" if gpu else ""))
    (line,) = ax.plot(xs, ys, color=style["color"], ls=style["ls"], lw=1.1, zorder=3, label=label)
    for p in pts:
        ax.plot([p["cost"]], [p["value"]], ls="none", marker=marker[p["dt_s"]], ms=5, color=style["color"],
                mfc="white" if style["hollow"] else style["color"], mec=style["color"] if style["hollow"] else "black",
                mew=1.0 if style["hollow"] else 0.5, zorder=4)
    out["curves"][r["engine"]] = line
    mdd = (r.get("band") or {}).get("value")
    finest = (r.get("matched") or {}).get("finest")
    if mdd and finest and finest.get("cost"):
        # over the engine's own costs only (its cheaper steps inside it reach matched accuracy (a)), and
        # translucent, so that the bands of engines close together show through each other
        out["bands"][r["engine"]] = ax.fill_between([min(xs) / BAND_MARGIN, finest["cost"]], finest["value"] - mdd,
                                                    finest["value"] + mdd, color=style["color"], alpha=0.18,
                                                    lw=0, zorder=1)
    rule = r.get("rule")
    if rule and rule.get("cost") and rule.get("value") is not None:
        out["rule"][r["engine"]] = ax.plot([rule["cost"]], [rule["value"]], ls="none", marker="o", ms=11, mfc="none",
                                           mec="black", mew=1.0, zorder=5)[0]


def _axes(ax, rows: list[dict], speed: dict) -> bool:
    """Limits, scales and titles; whether the distance axis is logarithmic."""
    from matplotlib.ticker import FuncFormatter, LogLocator  # matplotlib on first drawing (start-up time)

    xs = [p["cost"] for r in rows for p in _drawn(r)]
    ys = [p["value"] for r in rows for p in _drawn(r)]
    declared = float((speed.get("declared") or {}).get("matched_distance") or 0.0)
    if ys and declared > 0:
        ys.append(declared)   # the declared distance's line stays in view
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    logy = bool(ys) and min(ys) > 0 and max(ys) / min(ys) > LOG_RANGE
    if xs:
        ax.set_xlim(min(xs) / 2.0, max(xs) * 2.0)
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(plain)
        ax.xaxis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
    if logy:
        ax.set_yscale("log")
        ax.set_ylim(min(ys) / 1.6, max(ys) * 1.6)
        ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(plain)
        ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
    elif ys:
        ax.set_ylim(0.0, max(ys) * 1.2)
    gpu = any(r.get("device", {}).get("runs_on") == "gpu" for r in rows)
    ax.set_xlabel("CPU seconds per simulated second of block motion" + (" (GPU rows: the device's wall seconds)"
                                                                          if gpu else "") + " (logarithmic)",
                  fontsize=LABEL_PT)
    ax.set_ylabel("boundary distance from the reference\n(mean over the stage's problems; lower is better)",
                  fontsize=LABEL_PT)
    ax.tick_params(labelsize=SMALL_PT)
    ax.grid(True, which="major", lw=0.3)
    return logy


#: Where a point's step words may go, in points from the point: right, left, above, below, then the corners.
_OFFSETS = [(6, -3), (-6, -3), (0, 5), (0, -12), (6, 4), (-6, 4), (6, -11), (-6, -11)]


def place_labels(ax, items: list[tuple[dict, dict]], lines=(), circles=()) -> list:
    """Write each point's step beside it where the words touch no other words, no point, no curve
    (``lines``), no circle of the rule's choice (``circles``) and no legend and stay inside the axes: the
    first free place of :data:`_OFFSETS`, else none (the marker says the step). Points are labelled in
    order of their cost, so that a curve's words alternate least. Returns the texts placed."""
    fig = ax.figure
    if not hasattr(fig.canvas, "get_renderer"):   # a figure made without pyplot: draw it with Agg
        from matplotlib.backends.backend_agg import FigureCanvasAgg  # matplotlib on first drawing (start-up time)
        FigureCanvasAgg(fig)
    fig.canvas.draw()   # the layout first: the words are placed where the page shows them
    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    taken = [_point_box(ax, p) for p, _ in items]
    taken += [c.get_window_extent(renderer) for c in circles]
    paths = [ln.get_transform().transform_path(ln.get_path()) for ln in lines]
    if fig.legends:
        taken += [leg.get_window_extent(renderer) for leg in fig.legends]
    placed, gap = [], LABEL_GAP_PT * fig.dpi / 72.0
    for p, _ in sorted(items, key=lambda it: (it[0]["cost"], it[0]["value"])):
        for dx, dy in _OFFSETS:
            t = ax.annotate(_step_words(p["dt_s"]), (p["cost"], p["value"]), xytext=(dx, dy), textcoords="offset points",
                            ha="left" if dx > 0 else ("right" if dx < 0 else "center"), va="bottom",
                            fontsize=SMALL_PT, color="0.2", zorder=6)
            box = t.get_window_extent(renderer)
            if _inside(box, frame) and not any(box.overlaps(b) for b in taken) and \
                    not any(path.intersects_bbox(box, filled=False) for path in paths):
                taken.append(box.padded(gap))
                placed.append(t)
                break
            t.remove()
    return placed


def _point_box(ax, p: dict):
    """A point's marker as a box on the page (a little larger than the marker)."""
    from matplotlib.transforms import Bbox  # matplotlib on first drawing (start-up time)

    x, y = ax.transData.transform((p["cost"], p["value"]))
    r = 4.0 * ax.figure.dpi / 72.0
    return Bbox([[x - r, y - r], [x + r, y + r]])


def _inside(box, frame) -> bool:
    return box.x0 >= frame.x0 and box.x1 <= frame.x1 and box.y0 >= frame.y0 and box.y1 <= frame.y1
