"""The toy engine's adapter: a planar block on two damped penalty springs at its bottom corners.

Built on rockbench's public contract only (docs/engines.md), engine contract 2: the contact base
:class:`~rockbench.engines.contact.ContactEngine` owns the settings, the loop, the end of a run, the
read-out, the free-rocking test, the calibration and the judge; this class builds and steps its
"engine" (a few lines of NumPy) in the four methods ``build``, ``start``, ``advance`` and ``read``
and declares its shipped contact. Its contact is a toy, not a model worth benchmarking. It runs as
shipped only (``settings = "shipped"``): it declares no knobs to calibrate.
"""

from __future__ import annotations

import math

import numpy as np

from rockbench.engines.contact import ContactEngine
from rockbench.engines.motion import Motion, pivot_pose
from rockbench.reference_solver.model import G


class ToyEngine(ContactEngine):
    """A planar block on two critically damped penalty springs at its bottom corners."""

    CONTRACT_VERSION = 2    # the engine contract this adapter is written to
    name = "toy"
    module = "rockbench_toy"  # the engine's module, imported lazily; its __version__ is the version reported
    install_hint = "pip install rockbench-toy"
    #: the versions of its engine library (NumPy) the adapter is known to work with, as pip reads them
    SUPPORTED_VERSIONS = {"numpy": ">=1.24"}
    #: a planar model under the inertial drive only: drive = table or planar = false is a ConfigError
    SUPPORTED_MODES = {"drive": ("inertial",), "planar": (True,)}
    own_dt_s = 2e-4     # the engine's own step [s]
    SETTINGS = {"settings": "shipped", "tail_s": 1.0, "min_tail_s": 0.25}
    #: the shipped contact: given, contact_stiffness_n_m [N/m] replaces it
    SHIPPED = {"contact_stiffness_n_m": 1e6}

    def validate(self, s):
        self.number_setting(s, "contact_stiffness_n_m", "N/m")

    def build(self, block, s, dt_s):
        return {"block": block, "k": s["contact_stiffness_n_m"], "mu": s["friction"], "dt": dt_s}

    def start(self, w, block, s, dt_s, pulses, theta0_rad, n_steps):
        x_m, z_m = pivot_pose(block, theta0_rad)
        # the inertial drive: -ü at each step's midpoint (zero for free rocking); one world
        mid_s = (np.arange(n_steps) + 0.5) * dt_s
        w["acc"] = np.zeros(n_steps) if pulses[0] is None else -pulses[0].accel(mid_s)
        w["state"] = np.array([x_m, z_m, theta0_rad, 0.0, 0.0, 0.0])  # x, z, θ, ẋ, ż, θ̇
        return w["state"][None, None].copy()

    def advance(self, w, n_from, n_to):
        blk, dt, k = w["block"], w["dt"], w["k"]
        m, inertia = blk.mass_kg, blk.inertia_cm_kg_m2
        c = 2.0 * math.sqrt(k * m)  # critically damped springs: plastic impacts
        half_b, half_h = blk.width_m / 2, blk.height_m / 2
        rows = np.empty((n_to - n_from, 6))
        x, z, th, vx, vz, om = w["state"]
        for j, i in enumerate(range(n_from, n_to)):
            fx, fz, tau = m * w["acc"][i], -m * G, 0.0
            cos, sin = math.cos(th), math.sin(th)
            for side in (1.0, -1.0):  # the bottom corners, relative to the centre of mass
                rx, rz = side * half_b * cos - half_h * sin, -side * half_b * sin - half_h * cos
                if z + rz < 0.0:
                    n = max(0.0, -k * (z + rz) - c * (vz - om * rx))
                    t = min(max(-c * (vx + om * rz), -w["mu"] * n), w["mu"] * n)
                    fx, fz, tau = fx + t, fz + n, tau + rz * t - rx * n
            vx, vz, om = vx + dt * fx / m, vz + dt * fz / m, om + dt * tau / inertia
            x, z, th = x + dt * vx, z + dt * vz, th + dt * om
            rows[j] = (x, z, th, vx, vz, om)
        w["state"] = rows[-1].copy()
        return rows[None]

    def read(self, w, block, s, rows, t_s, pulse):
        # x_m in the world frame; the table stays at rest (inertial drive), so table_x_m is None
        return Motion(x_m=rows[:, 0], z_m=rows[:, 1], theta_rad=rows[:, 2], vx_m_s=rows[:, 3], vz_m_s=rows[:, 4],
                      theta_dot_rad_s=rows[:, 5])
