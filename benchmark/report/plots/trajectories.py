"""θ(t) of one case by several runs (the reference and engines), like the paper's Fig. 17.

The reference curves are drawn in front of the engines' (black and greys, thicker); every curve
runs to its own end (an engine stops at its own decision), with its impacts marked on the zero line
and its end marked by its outcome (× where |θ| passes α: overturn; ● where the run ended, decided
not to overturn). The vertical range is fitted to the data up to where a curve passes the
overturning threshold (θ/α; the threshold ±1 is drawn when it lies on the chart); the table's
acceleration is drawn in a small panel beneath, sharing the time axis. matplotlib is imported
inside the functions only, and figures are made without pyplot.
"""

from __future__ import annotations

import numpy as np

from rockbench.reference_solver.model import G
from rockbench.benchmark.scoring.labels import for_matplotlib
from rockbench.benchmark.report.plots.style import CYCLE, DOUBLE_COLUMN_IN, LABEL_PT, OKABE_ITO, SMALL_PT, SUPTITLE_PT

#: Reference curve styles, in order (black solid first).
REFERENCE_STYLES = [{"color": "#000000", "ls": "solid"}, {"color": "#555555", "ls": (0, (5, 2))},
                    {"color": "#8c8c8c", "ls": (0, (6, 2, 1.5, 2))}, {"color": "#8c8c8c", "ls": (0, (1.5, 1.5))}]
#: Engine curve colours, in order: the one palette's cycle (no black or grey: those are the reference's).
ENGINE_COLOURS = CYCLE
#: The overturning threshold |θ| = α and the table's acceleration.
THRESHOLD_COLOUR = "#444444"
PULSE_COLOUR = OKABE_ITO["black"]


def _runs(histories):
    out = []
    for h in histories:
        if isinstance(h, dict):
            out.append(dict(h))
        else:  # (label, t_s, theta_rad)
            label, t, th = h
            out.append({"label": label, "t_s": t, "theta_rad": th, "reference": str(label).startswith("reference")})
    return out


def plot_theta(histories, *, alpha_rad=None, pulse=None, t_end_s=None, t_pulse_end_s=None, title="", ax=None,
               ax_pulse=None, legend: str = "below") -> dict:
    """Draw θ(t) (as θ/α when ``alpha_rad`` is given) of several runs of one case.

    Parameters
    ----------
    histories : list of dict or (label, t_s, theta_rad)
        One run each: ``label``, ``t_s`` [s], ``theta_rad`` [rad], and optionally ``reference``
        (bool; default: the label starts with "reference"), ``impacts_s`` (impact times [s]) and
        ``outcome`` (``rest``, ``rocking``, ``overturn``; marks the curve's end).
    alpha_rad : float, optional
        The block's α [rad]: θ is drawn as θ/α and the overturning threshold ±1 marked.
    pulse : Pulse, optional
        The table motion, drawn beneath as ü/(g·tanα) (needs ``alpha_rad``; else ü [m/s²]).
    t_end_s : float, optional
        Right end of the time axis [s] (default: the longest run).
    t_pulse_end_s : float, optional
        End of the pulse [s] (a dotted vertical line; default: the pulse's duration).
    title : str
        Figure title.
    ax, ax_pulse : matplotlib Axes, optional
        Where to draw θ and the pulse; with neither, a new figure with both (the pulse panel a
        quarter of the height); with ``ax`` alone, no pulse panel.
    legend : {"below", "none"}
        A legend below the axes (outside the data), or none.

    Returns
    -------
    dict
        ``figure``, ``ax``, ``ax_pulse`` (or None), ``lines`` (label → Line2D), ``impacts``
        (label → Line2D of its impact marks), ``ends`` (label → Line2D of its end mark),
        ``pulse`` (the ü line or None), ``ylim`` and ``legend``.
    """
    runs = _runs(histories)
    if ax is None:
        ax, ax_pulse = _new_axes(pulse)
    fig = ax.figure
    t_end = t_end_s if t_end_s is not None else max((float(np.asarray(r["t_s"])[-1]) for r in runs if len(r["t_s"])),
                                                    default=1.0)
    lines, impacts, ends, peak, over = _draw_runs(ax, runs, alpha_rad, t_end)
    lim, threshold = _theta_axis(ax, peak, over, alpha_rad)
    ax.set_xlim(0.0, t_end)
    tpe = t_pulse_end_s if t_pulse_end_s is not None else (pulse.duration_s if pulse is not None else None)
    for a in (ax, ax_pulse):
        if a is not None and tpe is not None and tpe <= t_end:
            a.axvline(tpe, color="0.45", lw=0.8, ls=":", zorder=1)
    pulse_line = None
    if ax_pulse is not None and pulse is not None:
        pulse_line = _draw_pulse(ax, ax_pulse, pulse, t_end, alpha_rad)
    else:
        ax.set_xlabel("t [s]", fontsize=LABEL_PT)
    ax.tick_params(labelsize=SMALL_PT)
    ax.yaxis.label.set_size(LABEL_PT)
    if title:
        (fig.suptitle if ax_pulse is not None else ax.set_title)(for_matplotlib(title), fontsize=SUPTITLE_PT)
    leg = None
    if legend == "below" and lines:
        shown_end = tpe is not None and tpe <= t_end
        leg = _legend(fig, lines, impacts, threshold, shown_end, [r.get("outcome") for r in runs if r["label"] in ends])
    return {"figure": fig, "ax": ax, "ax_pulse": ax_pulse, "lines": lines, "impacts": impacts, "ends": ends,
            "pulse": pulse_line, "ylim": (-lim, lim), "legend": leg}


def _new_axes(pulse):
    """A new figure: θ above, the pulse beneath (a quarter of the height) when there is one."""
    from matplotlib.figure import Figure  # matplotlib on first drawing (start-up time)

    fig = Figure(figsize=(DOUBLE_COLUMN_IN, 4.7 if pulse is not None else 3.8), layout="constrained")
    if pulse is not None:
        ax, ax_pulse = fig.subplots(2, 1, sharex=True, height_ratios=[3.2, 1])
        return ax, ax_pulse
    return fig.add_subplot(), None


def _draw_runs(ax, runs, alpha_rad, t_end):
    """Each run's θ (or θ/α) up to ``t_end``, its impacts and its end mark; returns the lines, impact
    and end marks by label, the largest |θ| drawn before any threshold crossing, and whether one crossed."""
    scale = 1.0 / alpha_rad if alpha_rad else 1.0
    lines, impacts, ends = {}, {}, {}
    n_ref = n_eng = 0
    peak, over = 0.0, False
    for r in runs:
        t = np.asarray(r["t_s"], float)
        y = np.asarray(r["theta_rad"], float) * scale
        ended_inside = t.size > 0 and t[-1] <= t_end * (1 + 1e-9)
        keep = t <= t_end * (1 + 1e-9)
        t, y = t[keep], y[keep]
        if r.get("reference", False):
            st = REFERENCE_STYLES[n_ref % len(REFERENCE_STYLES)]
            kw = {"color": st["color"], "ls": st["ls"], "lw": 2.0, "zorder": 6 - 0.1 * n_ref}
            n_ref += 1
        else:
            kw = {"color": ENGINE_COLOURS[n_eng % len(ENGINE_COLOURS)], "ls": "solid", "lw": 1.5, "zorder": 3}
            n_eng += 1
        if t.size == 0:
            continue
        (line,) = ax.plot(t, y, label=for_matplotlib(r["label"]), **kw)
        lines[r["label"]] = line
        if alpha_rad:
            passed = np.nonzero(np.abs(y) >= 1.0)[0]
            over = over or passed.size > 0
            visible = y[: passed[0] + 1] if passed.size else y
        else:
            visible = y
        peak = max(peak, float(np.max(np.abs(visible))))
        ti = np.asarray([x for x in (r.get("impacts_s") or []) if 0 <= x <= t_end], float)
        if ti.size:
            (mk,) = ax.plot(ti, np.zeros_like(ti), ls="none", marker="o", ms=3.6, mfc="white", mec=kw["color"],
                            mew=1.0, zorder=kw["zorder"] + 0.5)
            impacts[r["label"]] = mk
        end = _end_mark(ax, t, y, r.get("outcome"), alpha_rad, kw, ended_inside)
        if end is not None:
            ends[r["label"]] = end
    return lines, impacts, ends, peak, over


def _theta_axis(ax, peak, over, alpha_rad):
    """The θ axis' range (symmetric), label and, with α, the overturning threshold ±1 when it lies on the
    chart; returns the range's half-width and whether the threshold is drawn."""
    lim = max(peak, 1e-9) * 1.08
    threshold = False
    if alpha_rad:
        if over:
            # past the threshold a curve only falls over: the range ends just above it (× marks it)
            lim = max(peak, 1.0) * 1.08
        threshold = lim >= 1.0   # the threshold lies on the chart: show it (named in the legend)
        if threshold:
            for s in (-1.0, 1.0):
                ax.axhline(s, color=THRESHOLD_COLOUR, lw=0.7, ls=(0, (2, 2)), zorder=1)
        ax.set_ylabel("θ/α [-]")
    else:
        ax.set_ylabel("θ [rad]")
    ax.set_ylim(-lim, lim)
    ax.axhline(0.0, color="0.75", lw=0.6, zorder=1)
    return lim, threshold


def _draw_pulse(ax, ax_pulse, pulse, t_end, alpha_rad):
    """The table's acceleration beneath θ, as ü/(g·tanα) with α (else ü [m/s²]); returns its line."""
    tt = np.linspace(0.0, t_end, 1500)
    acc = np.asarray(pulse.accel(tt), float)
    if alpha_rad:
        acc = acc / (G * np.tan(alpha_rad))
        ax_pulse.set_ylabel("ü/(g·tanα) [-]", fontsize=LABEL_PT)
    else:
        ax_pulse.set_ylabel("ü [m/s²]", fontsize=LABEL_PT)
    (pulse_line,) = ax_pulse.plot(tt, acc, color=PULSE_COLOUR, lw=1.1)
    ax_pulse.axhline(0.0, color="0.75", lw=0.6)
    m = float(np.max(np.abs(acc))) or 1.0
    ax_pulse.set_ylim(-1.15 * m, 1.15 * m)
    ax_pulse.set_xlabel("t [s]", fontsize=LABEL_PT)
    ax_pulse.tick_params(labelsize=SMALL_PT)
    ax.tick_params(labelbottom=False)
    return pulse_line


def _legend(fig, lines, impacts, threshold, pulse_end, drawn_ends):
    """The legend below the axes: the runs, then the marks that are on the chart."""
    from matplotlib.lines import Line2D  # matplotlib on first drawing (start-up time)

    handles = list(lines.values())
    if impacts:
        handles.append(Line2D([], [], ls="none", marker="o", ms=3.6, mfc="white", mec="k", label="impact"))
    if threshold:
        handles.append(Line2D([], [], color=THRESHOLD_COLOUR, lw=0.7, ls=(0, (2, 2)),
                              label="overturning threshold |θ| = α"))
    if pulse_end:
        handles.append(Line2D([], [], color="0.45", lw=0.8, ls=":", label="end of the pulse"))
    if "overturn" in drawn_ends:
        handles.append(Line2D([], [], ls="none", marker="X", ms=6, color="k", label="|θ| passes α: overturns"))
    if "rocking" in drawn_ends or "rest" in drawn_ends:
        handles.append(Line2D([], [], ls="none", marker="o", ms=4.5, color="k", label="run ends: decided, no overturn"))
    return fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize=SMALL_PT, frameon=False)


def _end_mark(ax, t, y, outcome, alpha_rad, kw, ended_inside=True):
    """The curve's end by its outcome: × where it passes the threshold (overturn), ● at its last
    sample when the run ended inside the window without overturning (the run decided: back at rest,
    or, for an engine, unable to overturn any more); nothing else."""
    if outcome == "overturn" and alpha_rad:
        k = np.nonzero(np.abs(y) >= 1.0)[0]
        if k.size:
            (m,) = ax.plot([t[k[0]]], [np.sign(y[k[0]]) * 1.0], ls="none", marker="X", ms=7, color=kw["color"],
                           mec="white", mew=0.6, zorder=kw["zorder"] + 1)
            return m
        return None
    if outcome in ("rocking", "rest") and t.size and ended_inside:
        (m,) = ax.plot([t[-1]], [y[-1]], ls="none", marker="o", ms=4.5, color=kw["color"], zorder=kw["zorder"] + 1)
        return m
    return None
