"""θ(t) of one simulation with its impacts and the table pulse, like the paper's Fig. 17."""

from __future__ import annotations

import numpy as np


def plot_history(t_s, theta_rad, *, impacts=None, pulse=None, alpha_rad=None, t_pulse_end_s=None,
                 title: str | None = None, label: str | None = None, ax=None) -> dict:
    """Draw θ(t) [rad], mark the impacts, and draw the table acceleration on a twin axis.

    Parameters
    ----------
    t_s, theta_rad : array_like
        The samples: time [s] and rotation [rad].
    impacts : array_like, optional
        Impact times [s] (or rows whose first column is the time).
    pulse : Pulse, optional
        The table motion; its ``accel(t)`` [m/s^2] is drawn on a right-hand axis.
    alpha_rad : float, optional
        Slenderness angle [rad]: ``±α`` are drawn as dashed lines (the overturning angle once the
        pulse is over).
    t_pulse_end_s : float, optional
        End of the pulse [s], drawn as a dotted vertical line.
    title, label : str, optional
        Axes title; legend label of the θ line.
    ax : matplotlib Axes, optional
        Where to draw; a new figure (no pyplot, no display needed) when None.

    Returns
    -------
    dict
        ``figure``, ``ax``, ``ax_pulse`` (or None), ``theta`` (the θ line), ``impacts`` (the marker
        collection or None), ``pulse`` (the ü line or None).
    """
    if ax is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(8.0, 4.5), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    t = np.asarray(t_s, dtype=float)
    th = np.asarray(theta_rad, dtype=float)
    (line,) = ax.plot(t, th, color="tab:red", lw=1.5, label=label or "θ(t)")
    marks = None
    if impacts is not None and len(impacts):
        ti = np.asarray(impacts, dtype=float)
        ti = ti[:, 0] if ti.ndim == 2 else ti
        marks = ax.scatter(ti, np.zeros_like(ti), marker="o", s=22, color="k", zorder=3, label="impacts")
    if alpha_rad is not None:
        for sgn in (1, -1):
            ax.axhline(sgn * alpha_rad, color="0.4", ls="--", lw=0.8)
    if t_pulse_end_s is not None:
        ax.axvline(t_pulse_end_s, color="0.4", ls=":", lw=0.8)
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("θ [rad]")
    ax_p = pulse_line = None
    if pulse is not None:
        ax_p = ax.twinx()
        tt = np.linspace(0.0, float(t[-1]) if t.size else pulse.duration_s, 2000)
        (pulse_line,) = ax_p.plot(tt, pulse.accel(tt), color="tab:blue", lw=1.0, alpha=0.6, label="ü(t)")
        ax_p.set_ylabel("ü [m/s²]", color="tab:blue")
        # zero of both axes at one height
        lim_t = 1.05 * max(float(np.max(np.abs(th))) if th.size else 0.0, alpha_rad or 0.0, 1e-6)
        lim_a = 1.05 * max(float(np.max(np.abs(pulse_line.get_ydata()))), 1e-9)
        ax.set_ylim(-lim_t, lim_t)
        ax_p.set_ylim(-lim_a, lim_a)
    handles = [line] + ([marks] if marks is not None else []) + ([pulse_line] if pulse_line is not None else [])
    ax.legend(handles=handles, loc="upper right", fontsize="small")
    if title:
        ax.set_title(title)
    return {"figure": fig, "ax": ax, "ax_pulse": ax_p, "theta": line, "impacts": marks, "pulse": pulse_line}
