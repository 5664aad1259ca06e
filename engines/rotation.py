"""The block's rotation about +y read out of an engine's quaternion state.

Several engines report the block's orientation as a unit quaternion; the rotation about +y (the
contract's θ: a positive angle tilts the top towards +x) and its rate are read the same way from
all of them, so one function does it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["theta_of_quat", "quat_matrix", "theta_rate_of_body"]


def theta_of_quat(w, x, y, z):
    """θ about +y [rad] of unit quaternions ``(w, x, y, z)`` (arrays of any one shape): the angle of
    the rotation matrix's (0, 2) and (2, 2) entries."""
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
