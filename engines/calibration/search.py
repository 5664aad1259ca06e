"""The one bisection of the calibration searches: a contact knob bisected until free rocking gives
the target η.

A calibration that tunes one knob of an engine's contact (PyBullet's compliant stiffness and its
restitution, Drake's dissipation, Newton's penalty stiffness, Exudyn's contact restitution
coefficient) scans a few values of it, or starts from a range known to hold the target, and
bisects: :func:`bracket` finds the first neighbours of a scan whose η lie on either side of the
target, :func:`bisection` halves the range between them. Where the searches differ (what counts as
close, what a midpoint that cannot be used ends, which side a non-finite η counts on) the caller
says so with an argument; the candidates and their order are each search's own, unchanged.
The search of declared knobs (:func:`~rockbench.engines.calibration.knobs.search`) calls these for a knob with
``bisect_steps``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

__all__ = ["BISECT_RTOL", "bracket", "bisection"]

#: A bisection stops at the first midpoint whose η is within this fraction of the target [-].
BISECT_RTOL = 0.0025


def bracket(points: Sequence[tuple[float, float]], target: float) -> tuple[float, float, float] | None:
    """The first neighbours of a scan whose η lie strictly on either side of the target.

    Parameters
    ----------
    points : sequence of (float, float)
        ``(knob, η)`` in scan order [knob's unit], [-]; a non-finite η brackets nothing.
    target : float
        The η searched for [-].

    Returns
    -------
    (float, float, float) or None
        ``(knob_lo, η_lo, knob_hi)`` of the first bracketing pair, or None.
    """
    for (x1, e1), (x2, e2) in zip(points[:-1], points[1:]):
        if math.isfinite(e1) and math.isfinite(e2) and (e1 - target) * (e2 - target) < 0:
            return x1, e1, x2
    return None


def bisection(measure: Callable[[float], float | None], lo: float, hi: float, steps: int, *, target: float,
              eta_lo: float, done: Callable[[float], bool], nonfinite_low: bool = False) -> None:
    """At most ``steps`` halvings of the knob range ``[lo, hi]`` towards the target η.

    Each step measures the midpoint; it ends the bisection when ``measure`` cannot use it (None) or
    its η is close enough (``done``); otherwise the midpoint replaces ``lo`` when its η lies on the
    same side of the target as ``eta_lo``, else ``hi``. What was measured is the caller's record.

    Parameters
    ----------
    measure : callable
        ``measure(knob) -> η`` [-], or None: the midpoint is unusable and the bisection ends.
    lo, hi : float
        The range's ends [knob's unit, e.g. log10 of a stiffness].
    steps : int
        Midpoints measured at most [-].
    target : float
        The η searched for [-].
    eta_lo : float
        η at the ``lo`` end [-]; ``-inf`` (``+inf``) where η is known to rise (fall) with the knob.
    done : callable
        ``done(η) -> bool``: close enough to the target, stop.
    nonfinite_low : bool
        Whether a non-finite η replaces ``lo`` (default: ``hi``).
    """
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        e = measure(mid)
        if e is None or done(e):
            return
        low = (e - target) * (eta_lo - target) > 0 if math.isfinite(e) else nonfinite_low
        if low:
            lo = mid
        else:
            hi = mid
