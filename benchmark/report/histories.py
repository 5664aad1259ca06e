"""How far a θ(t) picture runs (``simulate --plot``, the report's θ(t) comparison,
:meth:`rockbench.benchmark.Simulation.plot`), and the impact times drawn on it; the trajectory that gets there
is :func:`rockbench.benchmark.simulation.trajectory_for_picture`'s.

The reference solver's default mode decides at the pulse's end by the energy test (paper §2.2,
docs/physics.md §2), so its trajectory may stop at the pulse's end, before the impact that decides the
case: the paper's Fig. 17 pair (B3M, sine, ω/p = 6, a₀/(g·tanα) = 6.1) turns at the impact at
0.1465 s, after its pulse ended at 0.091 s. A picture therefore integrates on (``mode="to-rest"``)
over one span that depends on the pulse only, so that two runs of one case (two k, two engines)
are drawn over the same time span.
"""

from __future__ import annotations

import math

import numpy as np

#: A harmonic pulse's picture spans this many pulse durations (Fig. 17: 5 × 0.091 s = 0.45 s, past
#: the decisive impact at 0.1465 s and the overturn with k = 0.7595 at 0.350 s).
SPAN_PULSES = 5.0
#: A record's picture spans the record and this fraction of it after its end.
SPAN_RECORD_TAIL = 0.5


def picture_span_s(pulse, t_overturn_s: float | None = None) -> float:
    """The time span of a θ(t) picture of a case [s].

    ``SPAN_PULSES`` pulse durations for a harmonic pulse (``1 + SPAN_RECORD_TAIL`` for a record),
    stretched when the run overturns later than that so the overturn is in the picture.
    """
    d = float(pulse.duration_s)
    span = d * (SPAN_PULSES if pulse.kind in ("sine", "cosine", "half-sine") else 1.0 + SPAN_RECORD_TAIL)
    if t_overturn_s is not None and math.isfinite(t_overturn_s) and t_overturn_s > 0.9 * span:
        span = t_overturn_s + 0.1 * span
    return span


def impact_times(trajectory) -> list[float]:
    """Impact times of a trajectory [s]: the reference's impact list, or for an engine the sign
    changes of θ after uplift (a pivot change is an impact)."""
    diag = trajectory.diagnostics or {}
    imp = diag.get("impacts")
    if imp:
        return [float(d["t_s"] if isinstance(d, dict) else d[0]) for d in imp]
    t = np.asarray(trajectory.t_s, float)
    th = np.asarray(trajectory.theta_rad, float)
    if t.size < 2:
        return []
    s = np.sign(th)
    k = np.nonzero((s[:-1] * s[1:]) < 0)[0]
    # the crossing instant by linear interpolation
    return [float(t[i] - th[i] * (t[i + 1] - t[i]) / (th[i + 1] - th[i])) for i in k]
