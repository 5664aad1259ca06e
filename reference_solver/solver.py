"""The reference solution: the paper's Newmark scheme with exact uplift and impacts (paper §2.2).

Equation of motion (paper eqs (1)–(2) in one line, docs/physics.md §1), per unit corner inertia::

    θ̈ = −p²·[sin(α·s − θ) + (ü/g)·cos(α·s − θ)]        (nonlinear, the default)
    θ̈ =  p²·[θ − α·s − ü/g]                             (linearised)

where ``s = ±1`` is the side the block pivots on (``s = sgn θ`` while it rocks).

Algorithm
---------
**Time stepping.** Newmark's trapezoidal rule (γ = ½, β = ¼), paper eqs (3)–(6): at each step the
nonlinear equation for ``θ_{n+1}`` is solved by Newton–Raphson until ``|update| < 1e-9`` rad,
starting from ``θ_n + Δt·θ̇_n + ¼Δt²·(θ̈_n + θ̈*)`` with ``θ̈*`` a guess of ``θ̈_{n+1}``
(extrapolated through up to four previous steps; on the first step after an event,
``θ̈_n + Δt·dθ̈/dt`` from the equation of motion); θ̇ and θ̈ then follow from eqs (3) and (4). The linearised
equation is affine in θ and is solved in one step.

**Uplift.** A block at rest (``θ = θ̇ = 0``) stays at rest until the first instant ``t_u`` with
``|ü(t)| > g·tanα`` (linearised: ``g·α``). ``t_u`` is found exactly: in closed form for the
harmonic pulses (``asin``/``acos`` of ``g·tanα/|a₀|``; the cosine pulse starts at ``ü = a₀`` and so
lifts at ``t = 0`` when ``|a₀|`` is above the threshold), and on the linear segment of a record
where ``|ü|`` reaches the threshold. The block then starts on side ``s = −sgn ü(t_u)`` (a positive
table acceleration tips it to negative θ) with ``θ = θ̇ = 0`` and ``θ̈`` from that side's equation.

**Impacts.** When the Newton solution of a step has the sign opposite to the side the step was
computed on, the step is solved again for its unknown length ``Δt'`` with ``θ_{n+1} = 0`` (Newton
on ``Δt'`` with a bisection safeguard, to ``|update| < 1e-12·Δt``); eq (7) gives ``θ̇⁻``, then
``θ̇⁺ = η·θ̇⁻``, the side switches, and ``θ̈⁺`` comes from the new side's equation at ``θ = 0``.

**The step grid** restarts at every event: after an uplift and after an impact the next step is a
full ``Δt`` from the event's time (as the paper does: "the original time-step length Δt is
restored"). The one exception is the end of the pulse, which is always hit exactly by a shortened
step (the cosine pulse and the records jump to ``ü = 0`` there); after it ``θ̈`` is recomputed
with ``ü = 0`` and the grid restarts from the pulse's end.

**Coming back to rest.** After an impact the block pivots on the new side with ``θ̇⁺`` and
``θ̈⁺``. When ``θ̈⁺`` pulls it back (``s·θ̈⁺ < 0``), the impacts that follow form a geometric
series (each flight lasts about ``2|θ̇|/|θ̈|`` and the velocity shrinks by η each time) that ends
after about ``T_Z = 2|θ̇⁺| / (|θ̈⁺|·(1 − η))``: a Zeno series. When ``T_Z < Δt`` the whole
series fits inside one step, and the block is put to rest at the impact (``θ = θ̇ = 0``): it then
waits for the next uplift condition, exactly as at the start. (With ``η = 1`` there is no Zeno
series; only a flight shorter than ``1e-9·Δt`` puts such a block to rest, so that time advances.)
A block that "lifts" but whose first step already puts it back through zero did not really lift:
it stays at rest to the end of that step and the uplift condition is checked again from there.

**How a run ends** (both modes stop at once when the block lies on its side,
``|θ| ≥ π/2 − 0.01``; a guard also stops any run after ``10·t_max/Δt + 10⁶`` steps and events):

- ``mode="energy"`` (the fast default): at the end of the pulse the fate of the free rocking is
  decided exactly by :func:`~rockbench.reference_solver.energy.free_rocking_fate`. If the block
  rests or will not overturn, the run ends there. If it will overturn, the free motion is
  integrated on with the same scheme until ``|θ|`` passes α moving outward, so ``t_overturn_s``
  is the real crossing time (at most one impact happens on the way; should the integrator, in a
  case on the boundary, make a second one, the run ends one step later and the classifier
  decides on that state).
- ``mode="to-rest"`` (as in the paper): integrate past the pulse until the overturn is certain
  (``|θ| > α`` moving outward after the pulse), or the block is at rest (the Zeno rule above; with
  no excitation left it never lifts again), or ``t_max_s`` (default: the pulse's end plus twenty
  periods ``2π/p``) is reached; a block still rocking then is "rocking", since after the pulse
  the energy only falls and an overturn would have happened within the first half-cycle.

**Classification** uses the one rule of :mod:`~rockbench.reference_solver.classify` on the samples
(every step, every impact and uplift, the pulse's end). :func:`solve` with ``history=True`` calls
:func:`~rockbench.reference_solver.classify.classify` itself; the compiled kernels apply the same
rule sample by sample (a test checks that both agree), so :func:`solve_batch` needs no history.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange, set_parallel_chunksize

from rockbench.reference_solver.classify import FLAT_ANGLE_RAD, OUTCOME_CODES, UPLIFT_TOL_FRAC, Outcome, OUTCOME_FROM_CODE, classify
from rockbench.reference_solver.demand import D_MAX_F, D_MIN_N, demand_start, demand_update
from rockbench.reference_solver.errors import ConfigError, check_positive
from rockbench.reference_solver.model import G, Block
from rockbench.reference_solver.pulses import MIN_STEPS_PER_WAVE, PULSE_CODES, Pulse

#: Newton–Raphson tolerance on the update of θ_{n+1} [rad] (paper §2.2).
NEWTON_TOL_RAD = 1e-9
#: Newton tolerance on the impact step length, relative to Δt [-].
IMPACT_TOL_REL = 1e-12
#: Most Newton iterations per step before the last iterate is accepted.
MAX_NEWTON = 50
#: Default length of the free motion after the pulse in ``to-rest`` mode, in periods 2π/p.
TAIL_PERIODS = 20.0

MODES = ("energy", "to-rest")
#: Cases handed to a thread at a time by :func:`solve_batch`.
BATCH_CHUNK = 16

_REST = OUTCOME_CODES[Outcome.REST]
_ROCKING = OUTCOME_CODES[Outcome.ROCKING]
_OVERTURN = OUTCOME_CODES[Outcome.OVERTURN]

#: The paper's time step (§2.2) [s]: the reference engine's own, and the step the calibration's rigid
#: answers are computed at (rockbench.engines.calibration.rigid)
PAPER_DT_S = 1e-3

_FLAT = FLAT_ANGLE_RAD
_HARMONIC_CODES = {k: v for k, v in PULSE_CODES.items() if k != "record"}

# indices of the stats vector the kernel returns
_S_OUTCOME, _S_NIMP, _S_MAXTH, _S_TUP, _S_TOVER, _S_STEPS, _S_NEWTON, _S_NEVENTS, _S_MINN, _S_MAXF = range(10)
_N_STATS = 10


# --------------------------------------------------------------------------------------------
# compiled pieces
#
# ``pulse`` is the tuple ``(code, a0 [m/s^2], ω [rad/s], t_end [s], t_knots [s], a_knots [m/s^2])``
# of :meth:`~rockbench.reference_solver.pulses.Pulse.kernel_spec`. What runs at every step takes
# scalars only: a compiled function that takes an array (or a tuple holding one) pays for its
# reference count at each call, and passing ``pulse`` to the per-step helpers made a map 10–30 %
# slower. Events (uplifts, impacts, the pulse's end) are rare enough to take it.
# --------------------------------------------------------------------------------------------
@njit(cache=True)
def _pulse_acc(t, pulse):
    """Table acceleration ü(t) [m/s^2]; 0 outside [0, t_end] (and before a record's first sample)."""
    code, a0, w, t_end, tk, ak = pulse
    if t < 0.0 or t > t_end:
        return 0.0
    if code == 0 or code == 2:
        return a0 * math.sin(w * t)
    if code == 1:
        return a0 * math.cos(w * t)
    if t < tk[0]:
        return 0.0
    i = np.searchsorted(tk, t, side="right") - 1
    if i > tk.size - 2:
        i = tk.size - 2
    return ak[i] + (ak[i + 1] - ak[i]) / (tk[i + 1] - tk[i]) * (t - tk[i])


@njit(cache=True)
def _harmonic_acc(t, code, a0, w, t_end):
    """ü(t) [m/s^2] of the harmonic pulses (codes 0–2), the same value as :func:`_pulse_acc`, without
    the record arrays (the per-step path)."""
    if t < 0.0 or t > t_end:
        return 0.0
    if code == 1:
        return a0 * math.cos(w * t)
    return a0 * math.sin(w * t)


@njit(cache=True)
def _table_acc_g(t, post, pulse):
    """ü(t)/g [-], 0 once the pulse has ended (``post``)."""
    return 0.0 if post else _pulse_acc(t, pulse) / G


@njit(cache=True)
def _pulse_jerk(t, pulse):
    """Time derivative of ü [m/s^3] (for Newton on the impact step length)."""
    code, a0, w, t_end, tk, ak = pulse
    if t < 0.0 or t > t_end:
        return 0.0
    if code == 0 or code == 2:
        return a0 * w * math.cos(w * t)
    if code == 1:
        return -a0 * w * math.sin(w * t)
    if t < tk[0]:
        return 0.0
    i = np.searchsorted(tk, t, side="right") - 1
    if i > tk.size - 2:
        i = tk.size - 2
    return (ak[i + 1] - ak[i]) / (tk[i + 1] - tk[i])


@njit(cache=True)
def _next_uplift(t0, pulse, thr):
    """First instant t ≥ t0 (t ≤ t_end) at which |ü| exceeds ``thr``; −1 if none [s].

    Harmonic pulses in closed form, records exactly on their linear segments. When |ü(t0)| is
    already above the threshold the answer is t0 itself.
    """
    code, a0, w, t_end, tk, ak = pulse
    if t0 > t_end:
        return -1.0
    if abs(_pulse_acc(t0, pulse)) > thr:
        return t0
    if code <= 2:
        return _next_harmonic_uplift(t0, code, a0, w, t_end, thr)
    return _next_record_uplift(t0, tk, ak, thr)


@njit(cache=True)
def _next_harmonic_uplift(t0, code, a0, w, t_end, thr):
    """:func:`_next_uplift` of a harmonic pulse with |ü(t0)| ≤ ``thr``, in closed form [s]."""
    A = abs(a0)
    if A <= thr:
        return -1.0
    r = thr / A
    phi0 = w * t0
    if code == 1:
        # |cos φ| > r on [0, c), (π − c, π + c), (2π − c, 2π]
        c = math.acos(r)
        cands = (0.0, math.pi - c, 2.0 * math.pi - c)
    elif code == 0:
        b = math.asin(r)
        cands = (b, math.pi + b, 1e300)
    else:
        b = math.asin(r)
        cands = (b, 1e300, 1e300)
    for phi in cands:
        if phi >= phi0:
            tc = phi / w
            if tc > t_end:
                return -1.0
            return max(tc, t0)
    return -1.0


@njit(cache=True)
def _next_record_uplift(t0, tk, ak, thr):
    """:func:`_next_uplift` of a record with |ü(t0)| ≤ ``thr``: walk the linear segments from the one
    holding t0 [s]."""
    n = tk.size
    if t0 < tk[0]:
        t0 = tk[0]
        if abs(ak[0]) > thr:
            return t0
    i = np.searchsorted(tk, t0, side="right") - 1
    if i < 0:
        i = 0
    while i < n - 1:
        a1 = ak[i + 1]
        if abs(a1) > thr:
            a_start = ak[i] + (a1 - ak[i]) / (tk[i + 1] - tk[i]) * (max(t0, tk[i]) - tk[i])
            if abs(a_start) > thr:
                return max(t0, tk[i])
            target = thr if a1 > 0.0 else -thr
            tc = tk[i] + (target - ak[i]) / (a1 - ak[i]) * (tk[i + 1] - tk[i])
            return min(max(tc, t0, tk[i]), tk[i + 1])
        i += 1
    return -1.0


@njit(cache=True)
def _acc(th, u, s, alpha, p2, lin):
    """θ̈ on side s for rotation th and ü/g = u [rad/s^2] (paper eqs (1)–(2))."""
    if lin:
        return p2 * (th - alpha * s - u)
    x = alpha * s - th
    return -p2 * (math.sin(x) + u * math.cos(x))


@njit(cache=True)
def _energy(th, thd, alpha, p2, lin):
    """Compiled twin of :func:`~rockbench.reference_solver.energy.energy_rad2_s2` with ``p² = p2``
    [rad^2/s^2]."""
    a = abs(th)
    if lin:
        return 0.5 * thd * thd - 0.5 * p2 * (a - alpha) ** 2
    return 0.5 * thd * thd + p2 * math.cos(alpha - a)


@njit(cache=True)
def _fate(th, thd, alpha, p2, eta, lin):
    """Compiled twin of :func:`~rockbench.reference_solver.energy.free_rocking_fate`."""
    E = _energy(th, thd, alpha, p2, lin)
    Eb = 0.0 if lin else p2
    if th == 0.0 and thd == 0.0:
        return False, 0
    if abs(th) > alpha and th * thd >= 0.0:
        return True, 0
    if th * thd > 0.0 or th == 0.0:
        # θ = 0 with θ̇ ≠ 0 is a post-impact (or uplift) state: the block is leaving the base
        return E > Eb, 0
    if abs(th) > alpha and E <= Eb:
        return True, 0
    E0 = -0.5 * p2 * alpha * alpha if lin else p2 * math.cos(alpha)
    after = E0 + eta * eta * (E - E0)
    if after > Eb:
        return True, 1
    return False, 0


@njit(cache=True)
def _fate_at_pulse_end(th, thd, alpha, p2, eta, lin):
    """Energy mode's decision at the end of the pulse: (overturns, impacts allowed on the way).

    When the pulse ended right at an impact (θ = 0), θ̇ is already the post-impact velocity: the
    block overturns when its energy exceeds the barrier, with no impact on the way.
    """
    if th == 0.0:
        return _energy(th, thd, alpha, p2, lin) > (0.0 if lin else p2), 0
    return _fate(th, thd, alpha, p2, eta, lin)


# classifier state vector (the rule of classify.classify, applied one sample at a time)
_C_LIFTED, _C_TUP, _C_SIDE, _C_NIMP, _C_MAX, _C_PREVA, _C_PREVT, _C_TCROSS, _C_CERTAIN, _C_N, \
    _C_LASTT, _C_LASTTH, _C_LASTTHD = range(13)


@njit(cache=True)
def _new_classifier():
    """A running classification with no sample yet (state vector indexed by ``_C_*``)."""
    cs = np.zeros(13)
    cs[_C_TCROSS] = np.nan
    return cs


@njit(cache=True)
def _new_records(t_end, dt, record, events):
    """Buffers for the samples (n, 4), the impacts (m, 3) and the uplifts (k, 1); one row each when
    not kept. The history holds the pulse's steps and a second of free motion before it grows."""
    cap = 64
    if record:
        cap = int((t_end + 1.0) / dt) + 64
    hist = np.empty((cap if record else 1, 4))
    imps = np.empty((16 if events else 1, 3))
    upls = np.empty((8 if events else 1, 1))
    return hist, imps, upls


@njit(cache=True)
def _emit(cs, t, th, thd, alpha, t_end):
    """Add one sample to the running classification (the rule of classify.classify)."""
    a = abs(th)
    if a > 0.0 and cs[_C_LIFTED] == 0.0:
        cs[_C_LIFTED] = 1.0
        cs[_C_TUP] = t
    side = 1.0 if th > 0.0 else (-1.0 if th < 0.0 else 0.0)
    if side != 0.0:
        if cs[_C_SIDE] != 0.0 and side != cs[_C_SIDE]:
            cs[_C_NIMP] += 1.0
        cs[_C_SIDE] = side
    if a > cs[_C_MAX]:
        cs[_C_MAX] = a
    if cs[_C_N] > 0.0:
        pa = cs[_C_PREVA]
        if pa <= alpha and a > alpha:
            # same formula as classify._last_outward_alpha_crossing
            f = (alpha - pa) / (a - pa) if a != pa else 0.0
            cs[_C_TCROSS] = cs[_C_PREVT] + f * (t - cs[_C_PREVT])
    if a >= _FLAT or (t >= t_end and a > alpha and th * thd > 0.0):
        cs[_C_CERTAIN] = 1.0
    cs[_C_PREVA] = a
    cs[_C_PREVT] = t
    cs[_C_N] += 1.0
    cs[_C_LASTT] = t
    cs[_C_LASTTH] = th
    cs[_C_LASTTHD] = thd


@njit(cache=True)
def _sample(hist, n, record, cs, t, th, thd, thdd, alpha, t_end):
    """Take sample ``n``: into the history (when ``record``; the caller keeps a free row) and the
    running classification ``cs``; returns the new count of samples."""
    if record:
        hist[n, 0] = t
        hist[n, 1] = th
        hist[n, 2] = thd
        hist[n, 3] = thdd
    _emit(cs, t, th, thd, alpha, t_end)
    return n + 1


@njit(cache=True)
def _sample_if_new(hist, n, record, cs, t, th, thd, thdd, alpha, t_end):
    """:func:`_sample` unless the time ``t`` is not later than the last sample's (an event that
    coincides with a sample already taken)."""
    if t > cs[_C_LASTT]:
        return _sample(hist, n, record, cs, t, th, thd, thdd, alpha, t_end)
    return n


@njit(cache=True)
def _grow(a, n):
    """``a`` with room for row ``n``: a copy about twice as long when it is full."""
    if n >= a.shape[0]:
        new = np.empty((2 * a.shape[0] + 8,) + a.shape[1:])
        new[:n] = a[:n]
        return new
    return a


@njit(cache=True)
def _log_uplift(upls, nu, t, events):
    """Count an uplift at ``t`` [s] and list it when ``events``; returns the list and the count."""
    if events:
        upls = _grow(upls, nu)
        upls[nu, 0] = t
    return upls, nu + 1


@njit(cache=True)
def _log_impact(imps, ni, t, vm, vp, events):
    """Count an impact at ``t`` [s] with θ̇⁻ = ``vm``, θ̇⁺ = ``vp`` [rad/s] and list it when
    ``events``; returns the list and the count."""
    if events:
        imps = _grow(imps, ni)
        imps[ni, 0] = t
        imps[ni, 1] = vm
        imps[ni, 2] = vp
    return imps, ni + 1


@njit(cache=True)
def _start(dm, th0, thd0, pulse, alpha, p2, lin):
    """The side a run starts on (that of θ0, else of θ̇0; 0, at rest, when both are 0) and θ̈ at t = 0
    [rad/s^2] (0 at rest); counts the initial state in the contact demand ``dm``."""
    s = 0.0
    if th0 != 0.0:
        s = 1.0 if th0 > 0.0 else -1.0
    elif thd0 != 0.0:
        s = 1.0 if thd0 > 0.0 else -1.0
    u = _pulse_acc(0.0, pulse) / G
    thdd = 0.0 if s == 0.0 else _acc(th0, u, s, alpha, p2, lin)
    demand_update(dm, th0, thd0, thdd, u, s, alpha, p2)
    return s, thdd


@njit(cache=True)
def _lift_off(dm, tu, pulse, alpha, p2, lin):
    """The block lifts at ``tu`` with θ = θ̇ = 0: returns (side, θ̈ [rad/s^2]) and counts the state in
    the contact demand ``dm``. A positive table acceleration tips the block to negative θ."""
    ua = _pulse_acc(tu, pulse)
    s = -1.0 if ua > 0.0 else 1.0
    thdd = _acc(0.0, ua / G, s, alpha, p2, lin)
    demand_update(dm, 0.0, 0.0, thdd, ua / G, s, alpha, p2)
    return s, thdd


@njit(cache=True)
def _step_length(t, dt, t_end, post):
    """Length of the next step [s] and whether it ends the pulse: the pulse's end is always hit
    exactly (a step that would reach within 1e-6·Δt of it is shortened or stretched to it)."""
    if not post and t + dt >= t_end - 1e-6 * dt:
        return t_end - t, True
    return dt, False


# The θ̈ trend along a smooth stretch (the steps since the last event), for the Newton start:
# (length of the previous step [s] (0: no step yet), steps of that length in a row, θ̈ one, two and
# three steps back [rad/s^2]).
@njit(cache=True)
def _no_trend():
    """The trend at an event: the step grid restarts, nothing to extrapolate from."""
    return (0.0, 0, 0.0, 0.0, 0.0)


@njit(cache=True)
def _extend_trend(trend, h, thdd):
    """The trend after an accepted step of length ``h`` that started with θ̈ = ``thdd``."""
    h_prev, n_same, a1, a2, a3 = trend
    n_same = n_same + 1 if (h == h_prev and h_prev > 0.0) else 1
    return (h, n_same, thdd, a1, a2)


@njit(cache=True)
def _extrapolate_thdd(trend, h, thdd):
    """A guess of θ̈_{n+1} [rad/s^2] for the Newton start of a step of length ``h`` along a smooth
    stretch (``trend[0] > 0``): extrapolated through up to four steps (cubic or quadratic when the
    last steps had the same length ``h``, else linear)."""
    h_prev, n_same, a1, a2, a3 = trend
    if n_same >= 3 and h == h_prev:
        return 4.0 * (thdd + a2) - 6.0 * a1 - a3   # cubic, last four
    if n_same >= 2 and h == h_prev:
        return 3.0 * (thdd - a1) + a2   # quadratic through the last three
    return thdd + (thdd - a1) * (h / h_prev)


@njit(cache=True)
def _thdd_after_event(h, t, th, thd, thdd, s, post, pulse, alpha, p2, lin):
    """A guess of θ̈_{n+1} [rad/s^2] for the Newton start of the first step after an event (nothing
    to extrapolate from): ``θ̈_n + h·dθ̈/dt`` from the equation of motion."""
    un = _table_acc_g(t, post, pulse)
    jn = 0.0 if post else _pulse_jerk(t, pulse) / G
    if lin:
        return thdd + h * p2 * (thd - jn)
    z = alpha * s - th
    cz = math.cos(z)
    return thdd + h * p2 * ((cz - un * math.sin(z)) * thd - cz * jn)


@njit(cache=True)
def _newton_step(th, thd, thdd, a_pred, h, u1, s, alpha, p2, lin):
    """Solve the Newmark equation (paper eqs (5)/(6)) for θ_{n+1}; returns (θ_{n+1}, iterations).

    Newton–Raphson until ``|update| < 1e-9`` rad, from the start ``θ_n + Δt·θ̇_n + ¼Δt²·(θ̈_n +
    a_pred)`` where ``a_pred`` is a guess of θ̈_{n+1} (:func:`_extrapolate_thdd`), so the first update is
    usually already below the tolerance.
    """
    c = 4.0 / (h * h)
    rhs = c * th + 4.0 / h * thd + thdd  # c·θ_{n+1} − θ̈(θ_{n+1}) = rhs
    if lin:
        # θ̈ is affine in θ: one exact solve
        return (rhs + p2 * (-alpha * s - u1)) / (c - p2), 1
    x = th + h * thd + 0.25 * h * h * (thdd + a_pred)
    sa = alpha * s
    it = 0
    while it < MAX_NEWTON:
        it += 1
        z = sa - x
        sz = math.sin(z)
        cz = math.cos(z)
        r = c * x + p2 * (sz + u1 * cz) - rhs
        dx = -r / (c - p2 * (cz - u1 * sz))
        x += dx
        if abs(dx) < NEWTON_TOL_RAD:
            break
    return x, it


@njit(cache=True)
def _newmark_rates(x, th, thd, thdd, h):
    """θ̇_{n+1} and θ̈_{n+1} of a step of length ``h`` that ends at θ_{n+1} = ``x`` (paper eqs (3), (4))."""
    thd1 = 2.0 / h * (x - th) - thd                          # eq (3)
    thdd1 = 4.0 / (h * h) * (x - th) - 4.0 / h * thd - thdd  # eq (4)
    return thd1, thdd1


@njit(cache=True)
def _impact_g(tau, th, thd, thdd, t, s, post, pulse, alpha, p2, lin, cg):
    """F(τ) (or F(τ)/τ when θ_n = 0) of :func:`_impact_time` and its derivative."""
    tt = t + tau
    ug = 0.0 if post else _pulse_acc(tt, pulse) / G
    jg = 0.0 if post else _pulse_jerk(tt, pulse) / G
    a_0 = _acc(0.0, ug, s, alpha, p2, lin)
    da_0 = -p2 * cg * jg
    q = thdd + a_0
    if th != 0.0:
        return th + tau * thd + 0.25 * tau * tau * q, thd + 0.5 * tau * q + 0.25 * tau * tau * da_0
    return thd + 0.25 * tau * q, 0.25 * q + 0.25 * tau * da_0


@njit(cache=True)
def _impact_time(th, thd, thdd, h, t, s, post, pulse, alpha, p2, lin, x_end):
    """Length Δt' of the step that ends at θ = 0 (θ_{n+1} := 0, paper §2.2); returns (Δt', iterations).

    With θ_{n+1} = 0 the trapezoidal rule reads F(τ) = θ_n + τθ̇_n + τ²/4·(θ̈_n + θ̈(0, t_n + τ)) = 0;
    when θ_n = 0 (a step that starts at an impact or an uplift) the trivial root τ = 0 is divided
    out. Newton on τ, kept inside a bracket by bisection.
    """
    cg = math.cos(alpha) if not lin else 1.0
    lo = 0.0
    hi = h
    ghi, _ = _impact_g(hi, th, thd, thdd, t, s, post, pulse, alpha, p2, lin, cg)
    if s * ghi > 0.0:
        # the sign change came only from θ̈ at θ_{n+1} ≠ 0 versus θ = 0: a grazing contact at the
        # very end of the step
        return h, 0
    if th != 0.0:
        tau = h * th / (th - x_end)
    else:
        tau = 0.5 * h
    if not (tau > lo and tau < hi):
        tau = 0.5 * (lo + hi)
    it = 0
    tol = IMPACT_TOL_REL * h
    while it < 100:
        it += 1
        g, dg = _impact_g(tau, th, thd, thdd, t, s, post, pulse, alpha, p2, lin, cg)
        if s * g > 0.0:
            lo = tau
        else:
            hi = tau
        new = tau - g / dg if dg != 0.0 else 0.5 * (lo + hi)
        if not (new > lo and new < hi):
            new = 0.5 * (lo + hi)
        if abs(new - tau) < tol or hi - lo < tol:
            tau = new
            break
        tau = new
    return tau, it


@njit(cache=True)
def _locate_impact(th, thd, thdd, h, t, t1, hits_end, s, post, pulse, alpha, p2, lin, x_end):
    """The impact inside the step from ``t`` to ``t1`` (side ``s``, Newton end ``x_end`` past zero).

    Returns
    -------
    t_imp : float
        The impact instant [s]: ``t + Δt'`` (:func:`_impact_time`), the step's end for a grazing
        contact, the pulse's end when the step hits it and Δt' is within 1e-12·Δt of the full step.
    post : bool
        Whether the pulse has ended at the impact.
    vm : float
        θ̇⁻ from eq (7) with θ_{n+1} = 0 [rad/s].
    iterations : int
        Newton iterations on Δt'.
    """
    tau, it = _impact_time(th, thd, thdd, h, t, s, post, pulse, alpha, p2, lin, x_end)
    vm = 2.0 / tau * (0.0 - th) - thd                        # eq (7)
    t_imp = t1 if tau >= h else t + tau
    if hits_end and tau >= h * (1.0 - 1e-12):
        t_imp = pulse[3]
        post = True
    return t_imp, post, vm, it


@njit(cache=True)
def _zeno_rest(vp, thdd, s, eta, dt):
    """Whether the impacts after one with θ̇⁺ = ``vp`` (then θ̈⁺ = ``thdd`` on side ``s``) form a
    Zeno series that ends within one step Δt (module docstring, "Coming back to rest").

    With η = 1 there is no series: only a flight shorter than 1e-9·Δt counts.
    """
    return s * thdd < 0.0 and 2.0 * abs(vp) < dt * abs(thdd) * max(1.0 - eta, 1e-9)


@njit(cache=True)
def _restitute(vm, u, s, eta, dt, alpha, p2, lin):
    """The state just after an impact on side ``s`` with θ̇⁻ = ``vm`` and ü/g = ``u``: returns the new
    (side, θ̇, θ̈) at θ = 0 (θ̇⁺ = η·θ̇⁻ on the other side, or all 0 when :func:`_zeno_rest` puts the
    block to rest)."""
    s = -s
    vp = eta * vm
    thdd = _acc(0.0, u, s, alpha, p2, lin)
    if _zeno_rest(vp, thdd, s, eta, dt):
        return 0.0, 0.0, 0.0
    return s, vp, thdd


@njit(cache=True)
def _impact(dm, th, thd, thdd, h, t, t1, hits_end, s, post, pulse, eta, dt, alpha, p2, lin, x_end):
    """The impact inside a step on side ``s`` whose Newton solution ``x_end`` crossed θ = 0.

    Locates it (:func:`_locate_impact`), applies the restitution (:func:`_restitute`) and counts the
    states just before and just after it in the contact demand ``dm`` (the impulse itself is not a
    force). Returns (t_imp [s], post, new side, θ̇⁺ [rad/s], θ̈⁺ [rad/s^2], θ̇⁻ [rad/s], iterations);
    θ = 0 after it.
    """
    t, post, vm, it = _locate_impact(th, thd, thdd, h, t, t1, hits_end, s, post, pulse, alpha, p2, lin, x_end)
    u = _table_acc_g(t, post, pulse)
    demand_update(dm, 0.0, vm, _acc(0.0, u, s, alpha, p2, lin), u, s, alpha, p2)
    s, thd, thdd = _restitute(vm, u, s, eta, dt, alpha, p2, lin)
    demand_update(dm, 0.0, thd, thdd, u, s, alpha, p2)
    return t, post, s, thd, thdd, vm, it


@njit(cache=True)
def _verdict(cs, dm, steps, newton, ni, energy_mode, t_end, alpha, p2, eta, lin):
    """The stats vector of :func:`_integrate`: the classifier's verdict on the samples (rules of
    classify.classify, from the running state ``cs``), step counts and the contact demand ``dm``."""
    stats = np.empty(_N_STATS)
    stats[_S_STEPS] = steps
    stats[_S_NEWTON] = newton
    stats[_S_NEVENTS] = ni
    stats[_S_MAXTH] = cs[_C_MAX]
    stats[_S_MINN] = dm[D_MIN_N]
    stats[_S_MAXF] = dm[D_MAX_F]
    if cs[_C_LIFTED] == 0.0 or (cs[_C_CERTAIN] == 0.0 and cs[_C_MAX] <= UPLIFT_TOL_FRAC * alpha
                                and not (energy_mode and cs[_C_LASTT] >= t_end
                                         and _fate(cs[_C_LASTTH], cs[_C_LASTTHD], alpha, p2, eta, lin)[0])):
        # rule 1 of classify.classify: never beyond the one uplift tolerance, and not overturned
        stats[_S_OUTCOME] = _REST
        stats[_S_NIMP] = 0.0
        stats[_S_TUP] = np.nan
        stats[_S_TOVER] = np.nan
    else:
        stats[_S_TUP] = cs[_C_TUP]
        nimp = cs[_C_NIMP]
        if cs[_C_CERTAIN] != 0.0:
            stats[_S_OUTCOME] = _OVERTURN
            stats[_S_TOVER] = cs[_C_TCROSS]
        else:
            stats[_S_OUTCOME] = _ROCKING
            stats[_S_TOVER] = np.nan
            if energy_mode and cs[_C_LASTT] >= t_end:
                goes, extra = _fate(cs[_C_LASTTH], cs[_C_LASTTHD], alpha, p2, eta, lin)
                if goes:
                    stats[_S_OUTCOME] = _OVERTURN
                    nimp += extra
        stats[_S_NIMP] = nimp
    return stats


@njit(cache=True)
def _excitation_off(dm, th, thd, s, alpha, p2, lin):
    """θ̈ [rad/s^2] of the state (θ, θ̇) on side ``s`` once the excitation stops (ü = 0, the end of the
    pulse); that state also counts in the contact demand ``dm``."""
    thdd = _acc(th, 0.0, s, alpha, p2, lin)
    demand_update(dm, th, thd, thdd, 0.0, s, alpha, p2)
    return thdd


@njit(cache=True)
def _run_ends(certain, post, s, t, th, thd, cont, extra_left, energy_mode, t_max, alpha, p2, eta, lin):
    """Whether the run ends here (module docstring, "How a run ends"); returns (ends, cont, extra_left).

    It ends when the classifier is ``certain`` of the overturn, or after the pulse when the block rests,
    when ``t_max`` is reached, or (energy mode) when the decision at the pulse's end says it will
    not overturn; when it will, ``cont`` turns on and ``extra_left`` is the impacts allowed on the way.
    """
    if certain:
        return True, cont, extra_left
    if not post:
        return False, cont, extra_left
    if s == 0.0:
        return True, cont, extra_left
    if energy_mode and not cont:
        goes, extra_left = _fate_at_pulse_end(th, thd, alpha, p2, eta, lin)
        if not goes:
            return True, cont, extra_left
        cont = True
    return t >= t_max, cont, extra_left


@njit(cache=True)
def _integrate(alpha, p, eta, code, a0, w, t_end, tk, ak, dt, lin, energy_mode, t_max, record, th0, thd0, events):
    """Integrate one case (module docstring). Returns the samples t, θ, θ̇, θ̈ (n, 4; empty unless
    ``record``), each impact's time, θ̇⁻ and θ̇⁺ (m, 3) and each uplift's time (k,) (both empty unless
    ``events``), and the stats vector (:func:`_verdict`)."""
    pulse = (code, a0, w, t_end, tk, ak)
    p2 = p * p
    thr = G * (alpha if lin else math.tan(alpha))   # uplift threshold on |ü| [m/s^2]
    max_loops = 10.0 * t_max / dt + 1e6
    hist, imps, upls = _new_records(t_end, dt, record, events)
    cs, dm = _new_classifier(), demand_start()      # running classification and contact demand
    n = ni = nu = steps = newton = 0                # samples, impacts, uplifts, steps, Newton iterations
    t, th, thd = 0.0, th0, thd0
    s, thdd = _start(dm, th0, thd0, pulse, alpha, p2, lin)   # s: 0 at rest, else the pivot side
    # the pulse has ended; energy mode goes on to a certain overturn (extra_left impacts allowed)
    post, cont, extra_left, stop_next = False, False, 0, False
    trend = _no_trend()
    n = _sample(hist, n, record, cs, t, th, thd, thdd, alpha, t_end)
    while True:
        if record and n >= hist.shape[0]:
            hist = _grow(hist, n)   # room for this pass's sample (one at most)
        if s == 0.0:
            # at rest: lift at the next uplift instant, or rest to the end of the pulse
            tu = -1.0 if post else _next_uplift(t, pulse, thr)
            if tu < 0.0:
                if t < t_end and not post:
                    n = _sample(hist, n, record, cs, t_end, 0.0, 0.0, 0.0, alpha, t_end)
                break
            t, th, thd = tu, 0.0, 0.0
            s, thdd = _lift_off(dm, tu, pulse, alpha, p2, lin)
            trend = _no_trend()
            upls, nu = _log_uplift(upls, nu, tu, events)
            n = _sample_if_new(hist, n, record, cs, t, th, thd, thdd, alpha, t_end)
            continue
        h, hits_end = _step_length(t, dt, t_end, post)
        if hits_end and h <= 1e-12 * dt:
            # an event landed on the pulse's end already: only switch the excitation off
            t, post, trend = t_end, True, _no_trend()
            thdd = _excitation_off(dm, th, thd, s, alpha, p2, lin)
            n = _sample_if_new(hist, n, record, cs, t, th, thd, thdd, alpha, t_end)
        else:
            # one Newmark step of length h on side s
            t1 = t_end if hits_end else t + h
            u1 = 0.0 if post else (_harmonic_acc(t1, code, a0, w, t_end) if code < 3 else _pulse_acc(t1, pulse)) / G
            a_pred = _extrapolate_thdd(trend, h, thdd) if trend[0] > 0.0 else \
                _thdd_after_event(h, t, th, thd, thdd, s, post, pulse, alpha, p2, lin)
            x, it = _newton_step(th, thd, thdd, a_pred, h, u1, s, alpha, p2, lin)
            steps, newton = steps + 1, newton + it
            if s * x > 0.0:
                # still on side s: accept the step; at the pulse's end the grid restarts
                trend = _extend_trend(trend, h, thdd)
                thd, thdd = _newmark_rates(x, th, thd, thdd, h)
                t, th = t1, x
                demand_update(dm, th, thd, thdd, u1, s, alpha, p2)
                if hits_end:
                    post, trend = True, _no_trend()
                    thdd = _excitation_off(dm, th, thd, s, alpha, p2, lin)
                n = _sample(hist, n, record, cs, t, th, thd, thdd, alpha, t_end)
            elif th == 0.0 and thd == 0.0:
                # lifted only on paper: the first step already pushes it back into the table
                t, s, thdd, post = t1, 0.0, 0.0, post or hits_end
                n = _sample(hist, n, record, cs, t, 0.0, 0.0, 0.0, alpha, t_end)
            else:
                # θ crossed 0 inside the step: an impact
                t, post, s, thd, thdd, vm, it = _impact(dm, th, thd, thdd, h, t, t1, hits_end, s, post, pulse, eta,
                                                        dt, alpha, p2, lin, x)
                th, trend = 0.0, _no_trend()
                newton += it
                imps, ni = _log_impact(imps, ni, t, vm, eta * vm, events)
                n = _sample(hist, n, record, cs, t, th, thd, thdd, alpha, t_end)
                if cont:
                    if extra_left == 0:
                        stop_next = True   # one more step, then the run ends
                        continue
                    extra_left -= 1
        ends, cont, extra_left = _run_ends(cs[_C_CERTAIN] != 0.0, post, s, t, th, thd, cont, extra_left,
                                           energy_mode, t_max, alpha, p2, eta, lin)
        if ends or stop_next or steps + ni > max_loops:   # the last: a guard only, no test comes near it
            break
    stats = _verdict(cs, dm, steps, newton, ni, energy_mode, t_end, alpha, p2, eta, lin)
    return hist[:n if record else 0], imps[:ni if events else 0], upls[:nu if events else 0, 0], stats


@njit(parallel=True, cache=True)
def _batch(alpha, p, eta, code, a0, w, t_end, dt, lin, energy_mode, t_max, out):
    empty = np.empty(0)
    for i in prange(alpha.size):
        _, _, _, st = _integrate(alpha[i], p[i], eta[i], code[i], a0[i], w[i], t_end[i], empty, empty,
                                 dt[i], lin, energy_mode, t_max[i], False, 0.0, 0.0, False)
        out[i, :] = st


# --------------------------------------------------------------------------------------------
# Python API
# --------------------------------------------------------------------------------------------
@dataclass
class Solution:
    """One reference solution.

    Attributes
    ----------
    t_s, theta_rad, theta_dot_rad_s, theta_ddot_rad_s2 : ndarray or None
        The samples: time [s], rotation [rad], angular velocity [rad/s], angular acceleration
        [rad/s^2] (every step, impact, uplift and the pulse's end); None when ``history=False``.
    impacts : ndarray, shape (m, 3)
        Each impact's time [s], pre-impact θ̇⁻ [rad/s] (eq (7)) and post-impact θ̇⁺ = η·θ̇⁻ [rad/s].
    uplifts : ndarray
        Each instant the block lifted off from rest [s].
    t_pulse_end_s : float
        End of the excitation [s].
    eta : float
        Restitution used [-].
    dt_s : float
        Time step [s].
    mode : str
        ``"energy"`` or ``"to-rest"``.
    linearized : bool
        Linearised equation of motion.
    outcome : Outcome
        rest, rocking or overturn (the classifier's rule).
    n_impacts : int
        Impacts up to the decision, as the classifier counts them [-].
    max_abs_theta_rad : float
        Largest |θ| [rad].
    t_uplift_s : float or None
        First sample with |θ| > 0, as the classifier reports it [s] (the exact instant is
        ``uplifts[0]``).
    t_overturn_s : float or None
        Last outward crossing of |θ| = α before the overturn was certain [s]; None unless overturned.
    n_steps : int
        Newmark steps taken [-].
    n_newton : int
        Newton iterations, steps and impact steps together [-].
    min_normal_mg : float
        The rigid model's smallest normal force at the pivot over ``m·g``, from uplift to the
        decision (:mod:`~rockbench.reference_solver.demand`); 1 when the block never lifted [-].
    max_friction_ratio : float
        The largest ``|F|/N`` it needs there while ``N > 0``; 0 when the block never lifted [-].
    """

    t_s: np.ndarray | None
    theta_rad: np.ndarray | None
    theta_dot_rad_s: np.ndarray | None
    theta_ddot_rad_s2: np.ndarray | None
    impacts: np.ndarray
    uplifts: np.ndarray
    t_pulse_end_s: float
    eta: float
    dt_s: float
    mode: str
    linearized: bool
    outcome: Outcome
    n_impacts: int
    max_abs_theta_rad: float
    t_uplift_s: float | None
    t_overturn_s: float | None
    n_steps: int
    n_newton: int
    min_normal_mg: float = 1.0
    max_friction_ratio: float = 0.0

    def impact_list(self) -> list[dict]:
        """The impacts as JSON-ready dicts ``{t_s, theta_dot_minus_rad_s, theta_dot_plus_rad_s}``."""
        return [{"t_s": float(a), "theta_dot_minus_rad_s": float(b), "theta_dot_plus_rad_s": float(c)}
                for a, b, c in self.impacts]


@dataclass
class BatchResult:
    """Arrays of results of :func:`solve_batch`, one entry per (broadcast) case.

    Attributes
    ----------
    outcome : ndarray of int8
        Codes of :data:`~rockbench.reference_solver.classify.OUTCOME_CODES`.
    n_impacts : ndarray of int
        Impacts up to the decision [-].
    max_abs_theta_rad : ndarray
        Largest |θ| [rad].
    t_uplift_s : ndarray
        First sample with |θ| > 0 [s] (NaN when the block never lifted).
    t_overturn_s : ndarray
        Last outward crossing of |θ| = α [s] (NaN when not overturned, or decided by energy
        before θ reached α).
    n_steps, n_newton : ndarray of int
        Newmark steps and Newton iterations per case [-].
    min_normal_mg, max_friction_ratio : ndarray
        The rigid model's contact demand (see :class:`Solution`) [-].
    """

    outcome: np.ndarray
    n_impacts: np.ndarray
    max_abs_theta_rad: np.ndarray
    t_uplift_s: np.ndarray
    t_overturn_s: np.ndarray
    n_steps: np.ndarray
    n_newton: np.ndarray
    min_normal_mg: np.ndarray
    max_friction_ratio: np.ndarray

    @classmethod
    def from_stats(cls, out: np.ndarray, shape: tuple) -> "BatchResult":
        """The result from the kernels' stats vectors (one row per case), shaped ``shape``."""
        return cls(
            outcome=out[:, _S_OUTCOME].astype(np.int8).reshape(shape),
            n_impacts=out[:, _S_NIMP].astype(np.int64).reshape(shape),
            max_abs_theta_rad=out[:, _S_MAXTH].reshape(shape),
            t_uplift_s=out[:, _S_TUP].reshape(shape),
            t_overturn_s=np.where(out[:, _S_OUTCOME] == _OVERTURN, out[:, _S_TOVER], np.nan).reshape(shape),
            n_steps=out[:, _S_STEPS].astype(np.int64).reshape(shape),
            n_newton=out[:, _S_NEWTON].astype(np.int64).reshape(shape),
            min_normal_mg=out[:, _S_MINN].reshape(shape),
            max_friction_ratio=out[:, _S_MAXF].reshape(shape),
        )

    def outcomes(self) -> np.ndarray:
        """The outcomes as strings (an object array of ``"rest"``/``"rocking"``/``"overturn"``)."""
        names = np.array([OUTCOME_FROM_CODE[i].value for i in range(3)], dtype=object)
        return names[self.outcome]


def _check_mode(mode: str) -> bool:
    if mode not in MODES:
        raise ConfigError(f"--mode must be energy or to-rest, got {mode!r}.")
    return mode == "energy"


def default_t_max_s(t_pulse_end_s: float, p_rad_s: float) -> float:
    """Default end of a ``to-rest`` run: the pulse's end plus :data:`TAIL_PERIODS` periods 2π/p [s]."""
    return t_pulse_end_s + TAIL_PERIODS * 2.0 * math.pi / p_rad_s


def solve(block: Block, pulse: Pulse, eta: float, *, dt_s: float = PAPER_DT_S, linearized: bool = False,
          mode: str = "energy", history: bool = True, t_max_s: float | None = None,
          theta0_rad: float = 0.0, theta_dot0_rad_s: float = 0.0) -> Solution:
    """Solve one case with the paper's scheme (see the module docstring).

    Parameters
    ----------
    block : Block
        The block (α [rad] and p [rad/s] are used).
    pulse : Pulse
        The table motion; any pulse, including records.
    eta : float
        Coefficient of restitution in (0, 1] [-].
    dt_s : float
        Time step Δt [s] (paper: 1e-3); checked against the pulse.
    linearized : bool
        Linearised equation of motion (uplift threshold g·α).
    mode : {"energy", "to-rest"}
        How the run ends (module docstring).
    history : bool
        Keep the samples t, θ, θ̇, θ̈.
    t_max_s : float, optional
        Latest end of the run [s] (after the pulse's end); default :func:`default_t_max_s`.
    theta0_rad, theta_dot0_rad_s : float
        Initial rotation [rad] and angular velocity [rad/s] (default: at rest on the base); a
        non-zero start rocks on the side of ``θ0`` (of ``θ̇0`` when ``θ0 = 0``). For free-rocking
        checks; |θ0| must stay below π/2 − 0.01.

    Returns
    -------
    Solution
    """
    energy_mode = _check_mode(mode)
    dt = pulse.check_dt(dt_s)
    eta = _check_eta(eta)
    code, a0, w, t_end, tk, ak = pulse.kernel_spec()
    t_max = _check_t_max(t_max_s, t_end, block.p_rad_s)
    th0, thd0 = float(theta0_rad), float(theta_dot0_rad_s)
    if not (math.isfinite(th0) and math.isfinite(thd0) and abs(th0) < _FLAT):
        raise ConfigError(f"the initial state must be finite with |θ0| < {_FLAT:.4f} rad, got θ0 = {theta0_rad!r}, "
                          f"θ̇0 = {theta_dot0_rad_s!r}.")
    hist, imps, upls, st = _integrate(block.alpha_rad, block.p_rad_s, eta, int(code), float(a0),
                                      float(w), float(t_end), np.ascontiguousarray(tk, dtype=float),
                                      np.ascontiguousarray(ak, dtype=float), dt, bool(linearized),
                                      energy_mode, t_max, bool(history), th0, thd0, True)
    common = dict(impacts=np.array(imps), uplifts=np.array(upls), t_pulse_end_s=float(t_end), eta=eta, dt_s=dt,
                  mode=mode, linearized=bool(linearized), n_steps=int(st[_S_STEPS]), n_newton=int(st[_S_NEWTON]),
                  min_normal_mg=float(st[_S_MINN]), max_friction_ratio=float(st[_S_MAXF]))
    if history:
        t, th, thd, thdd = (np.array(hist[:, j]) for j in range(4))
        c = classify(t, th, thd, alpha_rad=block.alpha_rad, p_rad_s=block.p_rad_s, t_pulse_end_s=float(t_end),
                     eta=eta if energy_mode else None, linearized=linearized)
        return Solution(t, th, thd, thdd, outcome=c.outcome, n_impacts=c.n_impacts,
                        max_abs_theta_rad=c.max_abs_theta_rad, t_uplift_s=c.t_uplift_s,
                        t_overturn_s=c.t_overturn_s, **common)
    outcome = OUTCOME_FROM_CODE[int(st[_S_OUTCOME])]
    return Solution(None, None, None, None, outcome=outcome, n_impacts=int(st[_S_NIMP]),
                    max_abs_theta_rad=float(st[_S_MAXTH]),
                    t_uplift_s=None if math.isnan(st[_S_TUP]) else float(st[_S_TUP]),
                    t_overturn_s=float(st[_S_TOVER]) if outcome is Outcome.OVERTURN else None, **common)


def solve_batch(alpha_rad, p_rad_s, eta, pulse_kind: str, omega_rad_s, amplitude_mps2, *, dt_s=PAPER_DT_S,
                linearized: bool = False, mode: str = "energy", t_max_s=None) -> BatchResult:
    """Solve many cases of a harmonic pulse at once, in parallel on all cores.

    Array arguments broadcast against each other; every case runs exactly as :func:`solve` would
    (records go through :func:`solve`).

    Parameters
    ----------
    alpha_rad : array_like
        Slenderness angles α [rad].
    p_rad_s : array_like
        Frequency parameters p [rad/s].
    eta : array_like
        Coefficients of restitution in (0, 1] [-].
    pulse_kind : {"sine", "cosine", "half-sine"}
        The pulse shape, one for all cases.
    omega_rad_s : array_like
        Pulse frequencies ω [rad/s].
    amplitude_mps2 : array_like
        Amplitudes a₀ [m/s^2] (non-zero; the sign flips the pulse).
    dt_s : array_like
        Time steps [s].
    linearized : bool
        Linearised equation of motion.
    mode : {"energy", "to-rest"}
        How runs end.
    t_max_s : array_like, optional
        Latest end of each run [s]; default :func:`default_t_max_s`.

    Returns
    -------
    BatchResult
        Arrays shaped like the broadcast arguments.
    """
    energy_mode = _check_mode(mode)
    if pulse_kind not in _HARMONIC_CODES:
        raise ConfigError(f"solve_batch takes pulse_kind sine, cosine or half-sine, got {pulse_kind!r}; "
                          "run records one at a time with solve().")
    shape, (al, p, et, w, a0, dt) = _batch_cases(alpha_rad, p_rad_s, eta, omega_rad_s, amplitude_mps2, dt_s)
    t_end, t_max = _batch_times(pulse_kind, w, p, dt, t_max_s, shape)
    out = np.empty((al.size, _N_STATS))
    # cases differ a lot in cost (a rocking tail is long, an early overturn short): hand them out in
    # small chunks rather than one static half per core
    old = set_parallel_chunksize(BATCH_CHUNK)
    try:
        _batch(al, p, et, np.full(al.size, _HARMONIC_CODES[pulse_kind], dtype=np.int64), a0, w, t_end, dt,
               bool(linearized), energy_mode, t_max, out)
    finally:
        set_parallel_chunksize(old)
    return BatchResult.from_stats(out, shape)


def _batch_cases(alpha_rad, p_rad_s, eta, omega_rad_s, amplitude_mps2, dt_s):
    """:func:`solve_batch`'s case arrays, broadcast against each other, checked, and flattened into
    contiguous float arrays; returns ``(shape, (α, p, η, ω, a0, Δt))``."""
    arrs = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in
                                 (alpha_rad, p_rad_s, eta, omega_rad_s, amplitude_mps2, dt_s)))
    al, p, et, w, a0, dt = flat = tuple(np.ascontiguousarray(a.ravel()) for a in arrs)
    if not (np.all(np.isfinite(al)) and np.all((al > 0) & (al < 0.5 * math.pi))):
        raise ConfigError("alpha_rad must be finite and in (0, π/2) rad.")
    if not (np.all(np.isfinite(p)) and np.all(p > 0)):
        raise ConfigError("p_rad_s must be finite and > 0 rad/s.")
    if not np.all((et > 0) & (et <= 1)):
        raise ConfigError("eta must be in (0, 1]; use 1 for no energy loss at impact.")
    if not (np.all(np.isfinite(w)) and np.all(w > 0)):
        raise ConfigError("omega_rad_s must be finite and > 0 rad/s.")
    if not (np.all(np.isfinite(a0)) and np.all(a0 != 0)):
        raise ConfigError("amplitude_mps2 must be finite and non-zero m/s^2.")
    if not (np.all(np.isfinite(dt)) and np.all(dt > 0)):
        raise ConfigError("dt_s must be finite and > 0 s.")
    return arrs[0].shape, flat


def _batch_times(pulse_kind: str, w, p, dt, t_max_s, shape):
    """Each case's pulse end and latest end of the run [s] (:func:`default_t_max_s` unless
    ``t_max_s`` is given), after checking each Δt against its wave (the rule of
    :meth:`~rockbench.reference_solver.pulses.Pulse.check_dt`)."""
    t_end = (math.pi if pulse_kind == "half-sine" else 2.0 * math.pi) / w
    period = 2.0 * math.pi / w
    if np.any(dt > period / MIN_STEPS_PER_WAVE):
        i = int(np.argmax(dt / period))
        raise ConfigError(f"dt_s {dt[i]:g} s is too coarse for a wave of period {period[i]:.4g} s: "
                          f"use dt_s <= {period[i] / MIN_STEPS_PER_WAVE:.3g} s.")
    if t_max_s is None:
        return t_end, default_t_max_s(t_end, p)
    t_max = np.ascontiguousarray(np.broadcast_to(np.asarray(t_max_s, dtype=float), shape).ravel())
    if np.any(~np.isfinite(t_max)) or np.any(t_max <= t_end):
        raise ConfigError("t_max_s must be finite and later than the pulse's end.")
    return t_end, t_max


def _check_eta(eta) -> float:
    try:
        e = float(eta)
    except (TypeError, ValueError):
        raise ConfigError(f"eta must be a number in (0, 1], got {eta!r}.") from None
    if not (0.0 < e <= 1.0):
        raise ConfigError(f"eta must be in (0, 1], got {eta!r}; use 1 for no energy loss at impact.")
    return e


def _check_t_max(t_max_s, t_end: float, p: float) -> float:
    if t_max_s is None:
        return default_t_max_s(t_end, p)
    t = check_positive("t_max_s", t_max_s, "s")
    if t <= t_end:
        raise ConfigError(f"t_max_s must be later than the pulse's end ({t_end:.4g} s), got {t_max_s!r}.")
    return t
