"""θ(t) of the reference and the engines for one case (the paper's Fig. 17 by default)."""

from __future__ import annotations


def plot_theta(histories, *, alpha_rad=None, t_pulse_end_s=None, title="", ax=None):
    """Draw θ(t)/α of several runs of one case.

    Parameters
    ----------
    histories : list of (str, array_like, array_like)
        ``(label, t_s [s], theta_rad [rad])`` per run; labels starting with ``reference`` are drawn
        in black and grey.
    alpha_rad : float, optional
        The block's α [rad]: θ is drawn as θ/α and the overturning threshold ±1 is marked.
    t_pulse_end_s : float, optional
        End of the pulse [s] (a vertical dotted line).
    ax : matplotlib Axes, optional

    Returns
    -------
    dict
        ``ax`` and ``lines`` (label → Line2D).
    """
    import matplotlib.pyplot as plt
    import numpy as np

    if ax is None:
        _, ax = plt.subplots(figsize=(7.5, 4.0))
    scale = 1.0 / alpha_rad if alpha_rad else 1.0
    lines = {}
    n_ref = 0
    for label, t, th in histories:
        kw = {}
        if label.startswith("reference"):
            kw = {"color": ["k", "0.45", "0.7"][n_ref % 3], "lw": 2.0, "ls": ["-", "--", "-."][n_ref % 3]}
            n_ref += 1
        lines[label] = ax.plot(np.asarray(t), np.asarray(th) * scale, label=label, **kw)[0]
    if alpha_rad:
        for s in (-1, 1):
            ax.axhline(s, color="r", lw=0.6, ls=":")
        ax.set_ylabel("θ/α [-]")
        ax.set_ylim(-2.0, 2.0)
    else:
        ax.set_ylabel("θ [rad]")
    if t_pulse_end_s is not None:
        ax.axvline(t_pulse_end_s, color="0.5", lw=0.8, ls=":")
    ax.set_xlabel("t [s]")
    ax.set_title(title)
    if lines:
        ax.legend(fontsize=7, loc="lower left")
    return {"ax": ax, "lines": lines}
