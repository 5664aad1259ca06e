"""One row layout for engines that report a free block's state: what PhysX and Genesis share.

A row holds the block's position (columns 0–2, x y z [m]), its orientation quaternion (3–6, w x y z),
its velocity (7–9 [m/s]), its angular velocity (10–12 [rad/s]) and, where the table moves, the
table's x and ẋ (13, 14). :func:`motion_of` reads the :class:`~rockbench.engines.motion.Motion`, with
the out-of-plane checks every such engine reports.
"""

from __future__ import annotations

import numpy as np

from rockbench.engines.motion import Motion, table_track_err_rel, theta_of_quat

__all__ = ["motion_of"]


def motion_of(data: np.ndarray, t_s: np.ndarray, pulse, table_moves: bool, diag: dict) -> Motion:
    """The run's :class:`Motion` from its rows; ``diag`` (the engine's own diagnostics) gains the
    block's largest drift out of the plane [m] and tilt about x [rad], and, with a moving table
    driven by ``pulse``, how far the table strayed from u(t) (:func:`~rockbench.engines.motion.table_track_err_rel`)."""
    qw, qx, qy, qz = data[:, 3], data[:, 4], data[:, 5], data[:, 6]
    roll = np.arcsin(np.clip(2.0 * (qw * qx - qy * qz), -1.0, 1.0))
    diag = {**diag, "max_lateral_drift_m": float(np.max(np.abs(data[:, 1]))),
            "max_out_of_plane_tilt_rad": float(np.max(np.abs(roll)))}
    u_tab = v_tab = None
    if table_moves:
        u_tab, v_tab = data[:, 13], data[:, 14]
        if pulse is not None:
            diag["table_track_err_rel"] = table_track_err_rel(u_tab, pulse, t_s)
    return Motion(x_m=data[:, 0], z_m=data[:, 2], theta_rad=theta_of_quat(qw, qx, qy, qz), vx_m_s=data[:, 7],
                  vz_m_s=data[:, 9], theta_dot_rad_s=data[:, 11], table_x_m=u_tab, table_vx_m_s=v_tab,
                  diagnostics=diag)
