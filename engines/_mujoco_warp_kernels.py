"""The MuJoCo Warp adapter's own Warp kernels: the per-world table drive and the sample record.

Imported only by :mod:`rockbench.engines.mujoco_warp_adapter` after it has set up Warp (kernel
cache in rockbench's cache folder); importing it imports Warp.
"""

import warp as wp

#: codes of :data:`drive`'s ``kind`` (the adapter's ``_KIND_CODES``): 0 sine, 1 cosine, 2 half-sine,
#: 3 a velocity table computed on the host (records), 4 no pulse (free rocking)


@wp.func
def pulse_vel(kind: int, a: wp.float64, w: wp.float64, dur: wp.float64, t: wp.float64) -> wp.float64:
    """The table velocity u̇(t) of a harmonic pulse [m/s] (``reference_solver.pulses``)."""
    tc = wp.min(wp.max(t, wp.float64(0.0)), dur)
    if kind == 1:   # cosine: u̇ = (a/ω)·sin ωt
        return a / w * wp.sin(w * tc)
    # sine and half-sine: u̇ = (a/ω)(1 − cos ωt) up to their own duration, constant after it
    return a / w * (wp.float64(1.0) - wp.cos(w * tc))


@wp.kernel
def drive(step: wp.array(dtype=wp.int32), kind: wp.array(dtype=wp.int32), amp: wp.array(dtype=wp.float64),
          omega: wp.array(dtype=wp.float64), dur: wp.array(dtype=wp.float64),
          row: wp.array(dtype=wp.int32), vtab: wp.array2d(dtype=wp.float64),
          push_mass: wp.float64, dt: wp.float64, ctrl: wp.array2d(dtype=wp.float32)):
    """World i's motor force for step k = step[0]: the step average ``−M·(u̇(tₖ₊₁) − u̇(tₖ))/Δt`` [N],
    evaluated in float64 and rounded once."""
    i = wp.tid()
    k = step[0]
    v0 = wp.float64(0.0)
    v1 = wp.float64(0.0)
    if kind[i] == 3:
        r = row[i]
        n = vtab.shape[1]
        v0 = vtab[r, wp.min(k, n - 1)]
        v1 = vtab[r, wp.min(k + 1, n - 1)]
    elif kind[i] < 3:
        t0 = wp.float64(k) * dt
        v0 = pulse_vel(kind[i], amp[i], omega[i], dur[i], t0)
        v1 = pulse_vel(kind[i], amp[i], omega[i], dur[i], t0 + dt)
    ctrl[i, 0] = wp.float32(-push_mass * (v1 - v0) / dt)


@wp.kernel
def record(step: wp.array(dtype=wp.int32), nseg: int, qpos: wp.array2d(dtype=wp.float32),
           qvel: wp.array2d(dtype=wp.float32), nefc: wp.array(dtype=wp.int32), nacon: wp.array(dtype=wp.int32),
           hist: wp.array3d(dtype=wp.float32), peak: wp.array(dtype=wp.int32)):
    """Copy world i's ``qpos``, ``qvel`` after step k into row ``k mod nseg`` of the segment buffer;
    keep the most constraint rows world i needed (``peak[i]``) and the most contacts of the batch
    (``peak[nworld]``), so an overflow at any step is seen."""
    i = wp.tid()
    peak[i] = wp.max(peak[i], nefc[i])
    if i == 0:
        peak[qpos.shape[0]] = wp.max(peak[qpos.shape[0]], nacon[0])
    j = step[0] % nseg
    nq = qpos.shape[1]
    for c in range(nq):
        hist[i, j, c] = qpos[i, c]
    for c in range(qvel.shape[1]):
        hist[i, j, nq + c] = qvel[i, c]


@wp.kernel
def advance(step: wp.array(dtype=wp.int32)):
    """The step counter, on the device (so a captured graph needs no host input)."""
    step[0] = step[0] + 1
