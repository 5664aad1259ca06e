"""The end-of-run rule has three forms, checked against each other on one set of shared cases:

* Python, floor 1's :func:`~rockbench.reference_solver.classify.run_end` (every contact engine's loop,
  :mod:`rockbench.engines.loop`);
* numba, the reference solver's running classification (``solver._emit``), whose ``certain`` flag is
  the rule's overturn clause (flat on its side, or from the pulse's end on |θ| > α moving outward);
* Warp, MuJoCo Warp's device kernel (``mujoco_warp_kernels.end_of_run``), the whole rule on the
  device, θ read from the float32 state (a hinge, or a free joint's quaternion, as the host reads it:
  :func:`~rockbench.engines.motion.theta_of_quat`).

Each case is a sequence of samples (step k = 1, 2, ...; θ, θ̇) with the steps at which the pulse ends,
the shortest tail starts and the longest ends; its values are float32 numbers, so that every form
reads the same θ.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rockbench.engines.motion import quat_matrix, theta_of_quat, theta_rate_of_body
from rockbench.reference_solver.classify import FLAT_ANGLE_RAD, overturn_certain, run_end, trapped_energy

ALPHA, P = 0.25, 3.0
N = 40           # samples per case
STEPS = dict(n_pulse=10, n_min=20, n_max=35)


def _f32(x) -> np.ndarray:
    return np.asarray(x, dtype=np.float32).astype(float)


def _cases() -> dict:
    """name → (θ, θ̇) of N samples (k = 1 … N), and the (k, reason) each must end at."""
    k = np.arange(1, N + 1, dtype=float)
    rocking = 0.1 * np.sin(0.6 * k)
    rate = 0.06 * np.cos(0.6 * k) * 10
    out = {}
    # beyond α moving outward from step 6, the pulse ends at 10: an overturn at the pulse's end
    th = np.where(k < 6, rocking, 0.2 + 0.02 * k)
    out["overturn at the pulse's end"] = (th, np.where(k < 6, rate, 0.5), (10, "overturn"))
    # beyond α after the pulse, moving outward from step 14 (moving back in before)
    th = np.where(k < 12, rocking, 0.3)
    om = np.where(k < 14, -0.4, 0.4)
    out["overturn after the pulse"] = (-th, -om, (14, "overturn"))
    # flat on its side during the pulse
    th = np.where(k < 4, 0.1 * k, FLAT_ANGLE_RAD + 0.001)
    out["flat"] = (th, np.full(N, 1.0), (4, "flat"))
    # not finite
    th = rocking.copy()
    th[7] = math.nan
    out["diverged"] = (th, rate, (8, "diverged"))
    # rocking that loses its energy: trapped from the shortest tail on, not before
    out["trapped"] = (0.01 * np.sin(0.6 * k), 0.006 * np.cos(0.6 * k), (20, "trapped"))
    # energetic free rocking (above the barrier's margin), never beyond α outward: the longest tail
    out["tail"] = (rocking, np.full(N, 2.0 * P), (35, "tail"))
    return {name: (_f32(th), _f32(om), end) for name, (th, om, end) in out.items()}


CASES = _cases()


def _python_end(th, om) -> tuple[int, str]:
    """The Python form, as the loop applies it, with the longest tail: (step, reason)."""
    k = np.arange(1, N + 1, dtype=float)
    end = run_end(k, th, om, alpha_rad=ALPHA, p_rad_s=P, pulse_end_step=STEPS["n_pulse"],
                  min_tail_step=STEPS["n_min"])
    if end is None or end[0] + 1 > STEPS["n_max"]:
        return STEPS["n_max"], "tail"
    return end[0] + 1, end[1]


@pytest.mark.parametrize("name", CASES)
def test_the_python_form_ends_each_shared_case_as_written(name):
    th, om, end = CASES[name]
    assert _python_end(th, om) == end


@pytest.mark.parametrize("name", CASES)
def test_the_numba_form_is_certain_of_the_overturn_where_the_python_form_is(name):
    """The reference solver's running classification (numba) turns ``certain`` at the sample where
    floor 1's overturn clause first holds; where the Python form ends a run as flat or overturned,
    that is its step."""
    from rockbench.reference_solver import solver

    th, om, end = CASES[name]
    cs, first = solver._new_classifier(), None
    for k in range(1, N + 1):
        if not (math.isfinite(th[k - 1]) and math.isfinite(om[k - 1])):
            break    # the reference integrates the rigid model: it never holds a non-finite sample
        solver._emit(cs, float(k), th[k - 1], om[k - 1], ALPHA, float(STEPS["n_pulse"]))
        if cs[solver._C_CERTAIN] and first is None:
            first = k
    ks = np.arange(1, N + 1, dtype=float)
    python = np.flatnonzero(overturn_certain(ks, th, om, alpha_rad=ALPHA, t_pulse_end_s=STEPS["n_pulse"]))
    if end[1] == "diverged":
        python = python[python < end[0] - 1]
    assert first == (int(python[0]) + 1 if python.size else None)
    if end[1] in ("flat", "overturn"):
        assert first == end[0]


@pytest.fixture(scope="module")
def kernels():
    pytest.importorskip("mujoco_warp")
    from rockbench.engines.adapters.mujoco_warp import _kernels, _warp

    return _warp()[0], _kernels()["end_of_run"]


def _device_ends(wp, kernel, qpos: np.ndarray, qvel: np.ndarray, planar: bool) -> list:
    """The Warp form on Warp's device: every case a world, its samples written into the state one
    step at a time; each world's (stop step, reason)."""
    n = qpos.shape[0]
    step = wp.zeros(1, dtype=wp.int32)
    q = wp.zeros((n, qpos.shape[2]), dtype=wp.float32)
    v = wp.zeros((n, qvel.shape[2]), dtype=wp.float32)
    f64 = [wp.array(np.full(n, x), dtype=wp.float64) for x in (ALPHA, P * P, trapped_energy(ALPHA, P))]
    i32 = [wp.array(np.full(n, STEPS[c]), dtype=wp.int32) for c in ("n_pulse", "n_min", "n_max")]
    stop, why = wp.full(n, -1, dtype=wp.int32), wp.zeros(n, dtype=wp.int32)
    for k in range(1, N + 1):
        step.assign(np.array([k - 1], dtype=np.int32))
        q.assign(qpos[:, k - 1])
        v.assign(qvel[:, k - 1])
        wp.launch(kernel, dim=n, inputs=[step, q, v, int(planar), 0, 0, *f64, float(FLAT_ANGLE_RAD), *i32, stop, why])
    names = ("tail", "diverged", "flat", "overturn", "trapped")   # the kernel's codes
    return [(int(s), names[int(w)]) for s, w in zip(stop.numpy(), why.numpy())]


def test_the_warp_form_ends_each_shared_case_where_the_python_form_does(kernels):
    """A hinge's θ and θ̇ (the planar block)."""
    wp, kernel = kernels
    th = np.array([c[0] for c in CASES.values()], dtype=np.float32)
    om = np.array([c[1] for c in CASES.values()], dtype=np.float32)
    ends = _device_ends(wp, kernel, th[..., None], om[..., None], planar=True)
    assert ends == [_python_end(c[0], c[1]) for c in CASES.values()]


def test_the_warp_form_reads_a_free_joints_theta_as_the_host_does(kernels):
    """A free joint: θ from the float32 quaternion and θ̇ from the body-frame rate, read on the
    device as the host's one reader does (:func:`theta_of_quat`, :func:`theta_rate_of_body`); the
    run ends where the Python form ends the host's reading."""
    wp, kernel = kernels
    th = np.array([np.nan_to_num(c[0], nan=0.0) for c in CASES.values()])
    om = np.array([c[1] for c in CASES.values()])
    # a small tilt about x as well, so the reading is not the plain angle
    half_y, half_x = th / 2, 0.01
    quat = np.stack([np.cos(half_y) * math.cos(half_x), np.full_like(th, math.sin(half_x)) * np.cos(half_y),
                     np.sin(half_y) * math.cos(half_x), -np.sin(half_y) * math.sin(half_x)], axis=-1).astype(np.float32)
    body = np.stack([0.05 * om, om, -0.02 * om], axis=-1).astype(np.float32)
    names = list(CASES)
    nan_case = names.index("diverged")
    quat[nan_case, 7, 0] = np.nan   # the diverged case stays diverged
    q64, b64 = quat.astype(float), body.astype(float)
    host_th = theta_of_quat(*(q64[..., c] for c in range(4)))
    host_om = theta_rate_of_body(quat_matrix(*(q64[..., c] for c in range(4))), b64)
    ends = _device_ends(wp, kernel, quat, body, planar=False)
    assert ends == [_python_end(host_th[i], host_om[i]) for i in range(len(names))]
    assert ends[nan_case] == (8, "diverged")
