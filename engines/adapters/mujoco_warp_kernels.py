"""The MuJoCo Warp adapter's own Warp kernels: the per-world table drive, the sample record and
floor 1's end-of-run rule evaluated on the device.

Imported only by :mod:`rockbench.engines.adapters.mujoco_warp` after it has set up Warp (kernel
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


#: codes :data:`end_of_run` writes into ``why`` (the adapter's ``ENDED_BY`` names them)
TAIL, DIVERGED, FLAT, OVERTURN, TRAPPED = (wp.constant(c) for c in range(5))


@wp.kernel
def end_of_run(step: wp.array(dtype=wp.int32), qpos: wp.array2d(dtype=wp.float32),
               qvel: wp.array2d(dtype=wp.float32), planar: int, ith: int, iom: int,
               alpha: wp.array(dtype=wp.float64), p2: wp.array(dtype=wp.float64),
               e_trap: wp.array(dtype=wp.float64), flat: wp.float64, n_pulse: wp.array(dtype=wp.int32),
               n_min: wp.array(dtype=wp.int32), n_max: wp.array(dtype=wp.int32),
               stop: wp.array(dtype=wp.int32), why: wp.array(dtype=wp.int32)):
    """Floor 1's end-of-run rule (``reference_solver.classify.run_end``) on world i's sample k (the
    state after step k − 1 → k, k = step[0] + 1), while the world runs (``stop[i]`` < 0): in its
    order, θ or θ̇ not finite; flat on its side (|θ| ≥ ``flat``); from step ``n_pulse[i]`` on,
    |θ| > α moving outward; from step ``n_min[i]`` on, ½θ̇² + p²cos(α − |θ|) below ``e_trap`` (the
    trapped energy); else step ``n_max[i]`` reached (the tail). The first that holds writes k into
    ``stop[i]`` and its code into ``why[i]``.

    θ and θ̇ are read in float64 from the float32 state as the host reads them: the hinge's column
    ``ith`` and its rate ``iom`` (``planar`` 1), or the rotation about +y of the free joint's
    quaternion (w, x, y, z from column ``ith``) and the world-y angular velocity from its
    body-frame rate (from column ``iom``).
    """
    i = wp.tid()
    if stop[i] >= 0:
        return
    k = step[0] + 1
    one = wp.float64(1.0)
    two = wp.float64(2.0)
    th = wp.float64(qpos[i, ith])
    om = wp.float64(qvel[i, iom])
    if planar == 0:
        qw = th
        qx = wp.float64(qpos[i, ith + 1])
        qy = wp.float64(qpos[i, ith + 2])
        qz = wp.float64(qpos[i, ith + 3])
        th = wp.atan2(two * (qx * qz + qw * qy), one - two * (qx * qx + qy * qy))
        om = (two * (qx * qy + qw * qz) * om + (one - two * (qx * qx + qz * qz)) * wp.float64(qvel[i, iom + 1])
              + two * (qy * qz - qw * qx) * wp.float64(qvel[i, iom + 2]))
    a = wp.abs(th)
    code = -1
    if not (wp.isfinite(th) and wp.isfinite(om)):
        code = DIVERGED
    elif a >= flat:
        code = FLAT
    elif k >= n_pulse[i] and a > alpha[i] and th * om > wp.float64(0.0):
        code = OVERTURN
    elif k >= n_min[i] and wp.float64(0.5) * om * om + p2[i] * wp.cos(alpha[i] - a) < e_trap[i]:
        code = TRAPPED
    elif k >= n_max[i]:
        code = TAIL
    if code >= 0:
        stop[i] = k
        why[i] = code
