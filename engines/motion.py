"""What a contact engine reads from its state, and the one way each quantity is read.

:class:`Motion` is what :meth:`~rockbench.engines.contact.ContactEngine.read` returns: the block's
centre of mass, θ and θ̇ and the table, sample by sample, as the engine reports them. The functions
are the one copy of each reading every adapter shares: the block's start pose (:func:`pivot_pose`),
its bottom corners relative to the table (:func:`corners`), θ from a unit quaternion
(:func:`theta_of_quat`), θ̇ from a body-frame angular velocity (:func:`theta_rate_of_body`), the
table's tracking error (:func:`table_track_err_rel`), the block's own energy (:func:`body_energy_j_kg`)
and the steps of a run (:func:`run_steps`, :func:`steps_of_times`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rockbench.reference_solver.model import G, Block

__all__ = ["Motion", "corners", "pivot_pose", "theta_of_quat", "quat_matrix", "theta_rate_of_body",
           "table_track_err_rel", "body_energy_j_kg", "run_steps", "steps_of_times"]


@dataclass
class Motion:
    """The block's state over a run, sample by sample, as the engine reports it (``(n,)`` arrays).

    Build it with keywords (its positional order is ``x_m, z_m, theta_rad, vx_m_s, vz_m_s,
    theta_dot_rad_s``).

    Attributes
    ----------
    x_m, z_m : ndarray
        Centre of mass: x in the world (the table starts at x = 0), height above the table top [m].
    theta_rad, theta_dot_rad_s : ndarray
        Rotation about +y [rad] and its rate [rad/s].
    vx_m_s, vz_m_s : ndarray
        Velocity of the centre of mass in the world [m/s].
    table_x_m, table_vx_m_s : ndarray or None
        The table's position and velocity along x [m], [m/s] (table drive); None: at rest at 0.
    diagnostics : dict
        The engine's own figures for the run (lateral drift, table tracking, ...), JSON-serialisable.
    t_s : ndarray or None
        The samples' times as the engine reports them [s] (an engine with its own sampling); None:
        one sample per step, step number × step.
    corner_x_m, corner_z_m : ndarray or None
        ``(n, c)`` bottom contact points as the engine measures them: x relative to the table and
        clearance above its top [m]; None: :func:`corners` of the centre of mass and θ.
    energy_j_kg : ndarray or None
        The block's own energy as the engine computes it [J/kg]; None: :func:`body_energy_j_kg`.
    error : str or None
        The engine's own finding that the run is not a measurement (a contact that broke through the
        table, say): the case fails with it (``engine-error``); None: none.
    """

    x_m: np.ndarray
    z_m: np.ndarray
    theta_rad: np.ndarray
    vx_m_s: np.ndarray
    vz_m_s: np.ndarray
    theta_dot_rad_s: np.ndarray
    table_x_m: np.ndarray | None = None
    table_vx_m_s: np.ndarray | None = None
    diagnostics: dict = field(default_factory=dict)
    t_s: np.ndarray | None = None
    corner_x_m: np.ndarray | None = None
    corner_z_m: np.ndarray | None = None
    energy_j_kg: np.ndarray | None = None
    error: str | None = None


def pivot_pose(block: Block, theta0_rad: float) -> tuple[float, float]:
    """The start pose: the centre of mass (x, height above the table) [m] of a block at rest at
    ``theta0_rad`` pivoting on its lower corner (x = ±b/2, z = 0); θ0 = 0 stands on its base."""
    s = 1.0 if theta0_rad >= 0 else -1.0
    R, alpha = block.half_diagonal_m, block.alpha_rad
    return s * (block.width_m / 2 - R * math.sin(alpha - abs(theta0_rad))), R * math.cos(alpha - abs(theta0_rad))


def corners(block: Block, xc, zc, th, u_tab):
    """The (+x, −x) bottom corners relative to the table: x and height above its top, ``(n, 2)`` each
    [m], from the centre of mass (x, height) [m], θ [rad] and the table's x [m]."""
    b, h = block.width_m, block.height_m
    c, s = np.cos(th), np.sin(th)
    # rotation about +y by θ: body (±b/2, −h/2) -> (±(b/2)cosθ − (h/2)sinθ, ∓(b/2)sinθ − (h/2)cosθ);
    # each product made once for both corners (x − y and x + (−y) are the same number)
    bc, bs, hs, hc = b / 2 * c, b / 2 * s, h / 2 * s, h / 2 * c
    x = np.stack([xc + bc - hs - u_tab, xc - bc - hs - u_tab], axis=1)
    z = np.stack([zc - bs - hc, zc + bs - hc], axis=1)
    return x, z


def theta_of_quat(w, x, y, z):
    """θ about +y [rad] of unit quaternions ``(w, x, y, z)`` (arrays of any one shape): the angle of
    the rotation matrix's (0, 2) and (2, 2) entries. Every engine that reports a quaternion reads θ
    here (its Warp form, for MuJoCo Warp's device, is tested against it)."""
    return np.arctan2(2.0 * (x * z + w * y), 1.0 - 2.0 * (x * x + y * y))


def quat_matrix(w, x, y, z) -> np.ndarray:
    """The rotation matrices ``(..., 3, 3)`` of unit quaternions ``(w, x, y, z)`` (arrays of one shape)."""
    r = np.empty(np.shape(w) + (3, 3))
    r[..., 0, 0] = 1 - 2 * (y * y + z * z)
    r[..., 0, 1] = 2 * (x * y - w * z)
    r[..., 0, 2] = 2 * (x * z + w * y)
    r[..., 1, 0] = 2 * (x * y + w * z)
    r[..., 1, 1] = 1 - 2 * (x * x + z * z)
    r[..., 1, 2] = 2 * (y * z - w * x)
    r[..., 2, 0] = 2 * (x * z - w * y)
    r[..., 2, 1] = 2 * (y * z + w * x)
    r[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def theta_rate_of_body(r: np.ndarray, omega_body: np.ndarray) -> np.ndarray:
    """θ̇ [rad/s]: the world-y component of angular velocities given in the body frame
    (``omega_body`` ``(..., 3)``), with the body's rotation matrices ``r`` ``(..., 3, 3)``."""
    return np.einsum("...j,...j->...", r[..., 1, :], omega_body)


def table_track_err_rel(table_x_m, pulse, t_s) -> float:
    """How far a driven table strayed from the pulse's displacement u(t) over a run, relative to the
    pulse's largest |u| [-]: ``max |x_table − x_table(0) − u| / max |u|``."""
    x = np.asarray(table_x_m, dtype=float)
    u = np.asarray(pulse.disp(t_s), dtype=float)
    return float(np.max(np.abs(x - x[0] - u)) / max(float(np.max(np.abs(u))), 1e-12))


def body_energy_j_kg(block: Block, vx_m_s, vz_m_s, omega_rad_s, zc_m):
    """The block's own mechanical energy per unit mass in the table's frame [J/kg]:
    ``½(v_x² + v_z²) + ½(I_c/m)ω² + g·z_c`` from its centre of mass's velocity relative to the table
    [m/s], its angular velocity about y [rad/s] and its height above the table top [m]. Unlike the
    rigid model's ``½θ̇² + p²cos(α − |θ|)`` it sees a hop after an impact (the energy-gain check)."""
    return 0.5 * (vx_m_s**2 + vz_m_s**2) + 0.5 * block.inertia_cm_kg_m2 / block.mass_kg * omega_rad_s**2 + G * zc_m


def run_steps(dt_s: float, t_pulse_end_s: float, tail_s: float, min_tail_s: float,
              duration_s: float | None = None) -> tuple[int, float, float]:
    """Steps of a run at ``dt_s`` [s]: the most, the pulse's end and the first at which the trapped rule
    applies; a free-rocking test of ``duration_s`` [s] has no pulse end and no trapped rule (inf)."""
    t_stop = (t_pulse_end_s + tail_s) if duration_s is None else duration_s
    n_max = int(math.ceil(t_stop / dt_s - 1e-9))
    if duration_s is not None:
        return n_max, math.inf, math.inf
    n_pulse = int(math.ceil(t_pulse_end_s / dt_s - 1e-9))
    return n_max, n_pulse, n_pulse + int(math.ceil(min_tail_s / dt_s - 1e-9))


def steps_of_times(t_s, dt_s: float) -> np.ndarray:
    """The step numbers of samples at times ``t_s`` [s] with step ``dt_s`` [s]: t/Δt, a fraction where
    the engine shortened its step; within 1e-6 of a whole step, that step (the rounding of t/Δt) [-]."""
    k = np.asarray(t_s, dtype=float) / dt_s
    whole = np.rint(k)
    return np.where(np.abs(k - whole) < 1e-6, whole, k)
