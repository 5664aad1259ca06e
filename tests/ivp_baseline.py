"""An independent, event-driven solution of the rocking block with SciPy's ``solve_ivp``.

Written apart from :mod:`rockbench.reference_solver.solver` (it shares only the pulses' ``ü(t)``)
to check it and to time it against: adaptive DOP853 with ``rtol = 1e-10``; impacts are events at
``θ = 0`` located by SciPy's root finder; uplift instants are found by scanning ``|ü(t)|`` and
refining with Brent's method; the pulse's end is a breakpoint. The run ends when the overturn is
certain (after the pulse, ``|θ|`` passes α moving outward, or ``|θ|`` reaches π/2 − 0.01), or when
the block has rocked freely through two impacts after the pulse without overturning (free rocking
only loses energy, so a block that falls back twice never goes over), or when it is at rest.

Used by ``tests/test_solver_physics.py`` (the independent check of the solver) and
``tests/measurements/bench_reference.py`` (the timing against it).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

G = 9.81
FLAT = 0.5 * math.pi - 0.01


def _rhs_factory(alpha, p, accel, s, linearized):
    p2 = p * p
    if linearized:
        def rhs(t, y):
            return [y[1], p2 * (y[0] - alpha * s - accel(t) / G)]
    else:
        def rhs(t, y):
            z = alpha * s - y[0]
            return [y[1], -p2 * (math.sin(z) + accel(t) / G * math.cos(z))]
    return rhs


def _first_uplift(accel, t0, t_end, thr, n_scan):
    """First t in [t0, t_end] with |ü(t)| > thr, refined by Brent; None if none."""
    if t0 >= t_end:
        return None
    if abs(accel(t0)) > thr:
        return t0
    ts = np.linspace(t0, t_end, n_scan)
    a = np.abs(np.array([accel(t) for t in ts]))
    above = np.nonzero(a > thr)[0]
    if above.size == 0:
        return None
    i = int(above[0])
    return brentq(lambda t: abs(accel(t)) - thr, ts[i - 1], ts[i], xtol=1e-14, rtol=1e-15)


def solve_events(alpha, p, eta, pulse, *, linearized=False, rtol=1e-10, atol=1e-12, max_impacts=10000):
    """Solve one case event by event.

    Parameters
    ----------
    alpha, p : float
        Slenderness angle [rad], frequency parameter [rad/s].
    eta : float
        Restitution [-].
    pulse : rockbench Pulse
        Anything with ``accel(t)`` [m/s^2] and ``duration_s`` [s].

    Returns
    -------
    dict
        ``outcome`` ("rest" | "rocking" | "overturn"), ``impacts`` (list of (t, θ̇⁻, θ̇⁺)),
        ``t_uplift`` (first uplift [s] or None), ``max_abs_theta`` [rad], ``t_overturn`` (outward
        crossing of |θ| = α [s] or None), ``nfev``.
    """
    t_end = float(pulse.duration_s)
    thr = G * (alpha if linearized else math.tan(alpha))

    def accel(t):
        return float(pulse.accel(t)) if t <= t_end else 0.0

    t, th, thd, s = 0.0, 0.0, 0.0, 0
    impacts, lifted, t_up, max_th, nfev = [], False, None, 0.0, 0
    impacts_after = 0
    n_scan = 4001
    while True:
        if s == 0:
            if t >= t_end:
                return _classified(alpha, "rocking" if lifted else "rest", impacts, t_up, max_th, None, nfev)
            tu = _first_uplift(accel, t, t_end, thr, n_scan)
            if tu is None:
                return _classified(alpha, "rocking" if lifted else "rest", impacts, t_up, max_th, None, nfev)
            t, th, thd = tu, 0.0, 0.0
            s = -1 if accel(tu) > 0 else 1
            if not lifted:
                lifted, t_up = True, tu
        post = t >= t_end
        if post and abs(th) > alpha and th * thd > 0:
            return _classified(alpha, "overturn", impacts, t_up, max(max_th, abs(th)), None, nfev)
        t_stop = t_end if not post else t + 200.0 / p
        rhs = _rhs_factory(alpha, p, accel if not post else (lambda _t: 0.0), s, linearized)

        def hit(_t, y):
            return y[0]
        hit.terminal = True
        hit.direction = -s

        def flat(_t, y):
            return abs(y[0]) - FLAT
        flat.terminal = True

        def over(_t, y):
            return (abs(y[0]) - alpha) if post else -1.0
        over.terminal = True
        over.direction = 1

        sol = solve_ivp(rhs, (t, t_stop), [th, thd], method="DOP853", rtol=rtol, atol=atol,
                        events=[hit, flat, over], dense_output=False, max_step=(t_stop - t) / 50)
        nfev += sol.nfev
        max_th = max(max_th, float(np.max(np.abs(sol.y[0]))))
        if sol.t_events[1].size or sol.t_events[2].size:
            t_over = float(sol.t_events[2][0]) if sol.t_events[2].size else None
            return _classified(alpha, "overturn", impacts, t_up, max_th, t_over, nfev)
        if sol.t_events[0].size:
            ti = float(sol.t_events[0][0])
            vm = float(sol.y_events[0][0][1])
            vp = eta * vm
            impacts.append((ti, vm, vp))
            if post:
                impacts_after += 1
                if impacts_after >= 2:
                    return _classified(alpha, "rocking", impacts, t_up, max_th, None, nfev)
            s = -s
            t, th, thd = ti, 0.0, vp
            a0 = rhs(ti, [0.0, vp])[1]
            # the shrinking series of impacts ends within a microsecond: the block is at rest
            if s * a0 < 0 and eta < 1 and 2 * abs(vp) / abs(a0) / (1 - eta) < 1e-6:
                s, thd = 0, 0.0
            if len(impacts) > max_impacts:
                return _classified(alpha, "rocking", impacts, t_up, max_th, None, nfev)
            continue
        # reached t_stop without an event
        t, th, thd = float(sol.t[-1]), float(sol.y[0][-1]), float(sol.y[1][-1])
        if post:
            return _classified(alpha, "rocking", impacts, t_up, max_th, None, nfev)


def _classified(alpha, outcome, impacts, t_up, max_th, t_over, nfev):
    """The result, with the classifier's rule 1: a motion that never leaves the one uplift tolerance
    (2 % of α) is rest."""
    if outcome == "rocking" and max_th <= 0.02 * alpha:
        return _result("rest", [], None, max_th, None, nfev)
    return _result(outcome, impacts, t_up, max_th, t_over, nfev)


def _result(outcome, impacts, t_up, max_th, t_over, nfev):
    return {"outcome": outcome, "impacts": impacts, "t_uplift": t_up, "max_abs_theta": max_th,
            "t_overturn": t_over, "nfev": nfev}


def critical_amplitude(outcome_of, lo, hi, rel_tol=1e-4):
    """Bisection for the amplitude where ``outcome_of(a) == "overturn"`` starts, in [lo, hi] [m/s^2].

    ``outcome_of(lo)`` must not overturn and ``outcome_of(hi)`` must.
    """
    if outcome_of(lo) == "overturn" or outcome_of(hi) != "overturn":
        raise ValueError("the bracket does not hold the boundary")
    while hi - lo > rel_tol * hi:
        mid = 0.5 * (lo + hi)
        if outcome_of(mid) == "overturn":
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)
