"""PhysX adapter: the rocking block in NVIDIA PhysX 5, through SAPIEN (``sapien``, CPU).

The model
---------
A box block ``b × d × h`` (x, y, z) with the case's mass (uniform density) stands on a box table
whose top is z = 0, in a physics-only SAPIEN scene (``sapien.Scene([PhysxCpuSystem()])``, no
renderer). They touch only through PhysX's own contact: its box–box collision finds the contact
points (persistent contact manifolds as shipped) and its solver (TGS as shipped, or PGS) computes
impulses with Coulomb friction. No constraint and no impact law of ours.

* **Planar** (default): the block's y translation and its rotations about x and z are locked
  (PhysX's lock flags, ``set_locked_motion_axes``); ``planar=False`` leaves a free 3-D body.
* **Anti-slip**: friction 10 on both shapes (static and dynamic; PhysX averages the two materials'
  coefficients as shipped).
* **Restitution**: PhysX's material restitution (0 as shipped). PhysX applies it only where the
  normal approach speed exceeds the scene's bounce threshold (2 m/s as shipped); the landing corners
  of the benchmark's blocks arrive far slower, so restitution does nothing (docs/physx.md).
* **Drives** (``drive``): ``inertial`` (default) adds the force ``−m·ü`` at the centre of mass before
  every PhysX step, ``ü`` that step's average ``(u̇(tₖ₊₁) − u̇(tₖ))/h`` (the impulse per step is
  exact); ``table`` makes the table a kinematic body whose target at every PhysX step is the pulse's
  displacement ``u(tₖ₊₁)`` (PhysX gives a kinematic body the velocity that reaches its target, so
  the contact sees the table move); a kinematic body is not pushed back by the block.
* **Sleeping** is off (the block's sleep threshold is 0), so a block at rest under a later pulse
  never misses it.
* **Scene settings are global in SAPIEN** (``set_scene_config``: solver type, bounce threshold) and
  copied when a system is created, so the adapter sets them just before it creates each scene.

The time step
-------------
PhysX steps ``substeps`` times per benchmark step (``h = Δt/substeps``); the run records one sample
per benchmark step. As shipped, SAPIEN's system steps 0.01 s (:data:`SHIPPED_DT_S`), and so does a
case that poses no step, never coarser than 1/20 of its pulse's wave (the one resolver,
:meth:`~rockbench.engines.contact.ContactEngine.step_for`); calibrated, the time-step rule's (docs/physx.md).
``settings="calibrated"`` runs PGS and searches the substeps (:attr:`PhysxAdapter.KNOBS`):
PhysX's impact loses more energy the longer its step, and the substeps are the knob that moves η
towards Housner's; PGS because TGS lets the pivot corner creep along the table at friction 10.

Speed
-----
A fresh scene per run (creating one costs well under a millisecond), so no contact cache or warm
start carries from one case to the next. No batch API on the CPU system: ``batching = "none"``.

The run, its end and the read-out are the contact base's (:mod:`rockbench.engines.contact`).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from rockbench.reference_solver.model import G, Block
from rockbench.engines.calibration.knobs import Knob
from rockbench.engines.contact import ContactEngine
from rockbench.engines.motion import Motion, pivot_pose
from rockbench.engines.adapters.free_body import motion_of

#: SAPIEN's own time step of a ``PhysxCpuSystem`` [s]: what PhysX users run unless they set one
SHIPPED_DT_S = 0.01

#: PhysX as shipped by SAPIEN 3.0.3: TGS, 10 position and 1 velocity iterations per body, contact
#: offset 1 cm, plastic material (restitution 0), bounce threshold 2 m/s, one PhysX step per step
SHIPPED_CONTACT = {"solver": "tgs", "position_iterations": 10, "velocity_iterations": 1,
                   "contact_offset_m": 0.01, "contact_restitution": 0.0, "bounce_threshold_m_s": 2.0, "substeps": 1}

#: ``solver`` values: PhysX's temporal Gauss–Seidel (shipped) or projected Gauss–Seidel
SOLVERS = ("tgs", "pgs")

#: The solver a calibration runs: PGS holds the pivot corner at friction 10 where TGS (shipped) lets it
#: creep past the slip tolerance (B3M sine 17 × 17: 0 spurious slip flags against 22, docs/physx.md)
CALIBRATED_SOLVER = "pgs"

#: Substeps a calibration tries in turn, coarsest first, until free rocking reaches the target (1 %);
#: at 0.5 ms no more than 12: from a PhysX step of about 30 µs on, B3M's landing corner bounces and its
#: impacts scatter (docs/physx.md)
SUBSTEPS_TRIED = (1, 2, 3, 4, 6, 8, 12)

#: Half extents of the table box [m]: wider than any table stroke
_TABLE_HALF_EXTENTS_M = (5.0, 1.0, 0.05)

#: The UserWarning SAPIEN raises on import where the system has no libvulkan (only its renderer needs it)
_VULKAN_WARNING = "Failed to find system libvulkan"


def _sapien():
    """The ``sapien`` module, imported without its renderer's libvulkan warning (physics needs none)."""
    return PhysxAdapter.load_engine()


class _Scene:
    """One SAPIEN scene: the block (planar or free) on a table (static, or kinematic for the table
    drive), contact and solver as in the resolved settings ``s``, stepping ``dt/substeps``."""

    def __init__(self, block: Block, s: dict, dt: float):
        sapien = _sapien()
        px = sapien.physx
        # global in SAPIEN, copied by the system created next
        px.set_scene_config(gravity=np.array([0.0, 0.0, -G], dtype=np.float32),
                            bounce_threshold=float(s["bounce_threshold_m_s"]), enable_tgs=s["solver"] == "tgs")
        self.system = px.PhysxCpuSystem()
        self.substeps = int(s["substeps"])
        self.h = dt / self.substeps
        self.system.set_timestep(self.h)
        self.scene = sapien.Scene([self.system])
        self.mass_kg, self._pose = block.mass_kg, sapien.Pose
        mu = float(s["friction"])
        material = px.PhysxMaterial(mu, mu, float(s["contact_restitution"]))
        self.table = px.PhysxRigidDynamicComponent() if s["drive"] == "table" else px.PhysxRigidStaticComponent()
        hx, hy, hz = _TABLE_HALF_EXTENTS_M
        self._table_z = -hz
        self.table.attach(self._box((hx, hy, hz), material, s))
        if s["drive"] == "table":
            self.table.set_kinematic(True)
        self._add(self.table, (0.0, 0.0, -hz))
        self.block = px.PhysxRigidDynamicComponent()
        shape = self._box((block.width_m / 2, block.depth_m / 2, block.height_m / 2), material, s)
        shape.set_density(block.mass_kg / (block.width_m * block.depth_m * block.height_m))
        self.block.attach(shape)
        self.block.set_solver_position_iterations(int(s["position_iterations"]))
        self.block.set_solver_velocity_iterations(int(s["velocity_iterations"]))
        self.block.set_sleep_threshold(0.0)
        if s["planar"]:
            self.block.set_locked_motion_axes([False, True, False, True, False, True])
        self._add(self.block, (0.0, 0.0, block.height_m / 2))
        self.table_drive = s["drive"] == "table"
        self.acc = np.zeros(0)   # inertial drive: ü per PhysX step [m/s^2]
        self.disp = np.zeros(0)  # table drive: u at the end of each PhysX step [m]

    def load(self, pulse, dt: float, n_steps: int) -> None:
        """The drive of every PhysX step of ``n_steps`` benchmark steps of ``dt`` [s] under ``pulse``
        (None: none): the table's u at its end, or the step average of ü (the velocity change per
        PhysX step is exact)."""
        if pulse is None:
            return
        n = min(n_steps, int(math.ceil(pulse.duration_s / dt - 1e-9))) * self.substeps
        t = np.arange(n + 1) * self.h
        if self.table_drive:
            self.disp = np.asarray(pulse.disp(t[1:]), dtype=float)
        else:
            self.acc = np.diff(np.asarray(pulse.vel(t), dtype=float)) / self.h

    def _box(self, half_m, material, s: dict):
        px = _sapien().physx
        shape = px.PhysxCollisionShapeBox(np.asarray(half_m, dtype=np.float32), material)
        shape.set_contact_offset(float(s["contact_offset_m"]))
        return shape

    def _add(self, body, xyz) -> None:
        entity = _sapien().Entity()
        entity.add_component(body)
        entity.set_pose(self._pose(list(xyz)))
        self.scene.add_entity(entity)

    def place(self, block: Block, theta0: float) -> None:
        """The block at rest at ``theta0`` [rad] pivoting on its lower corner."""
        xc, zc = pivot_pose(block, theta0)
        self.block.entity.set_pose(self._pose([xc, 0.0, zc], [math.cos(theta0 / 2), 0.0, math.sin(theta0 / 2), 0.0]))

    def row(self) -> np.ndarray:
        """The state now: the block's position (3), quaternion w, x, y, z (4), velocity (3) and angular
        velocity (3), then the table's x and ẋ."""
        pose = self.block.entity_pose
        tab = self.table.entity_pose.p[0] if self.table_drive else 0.0
        v_tab = self.table.linear_velocity[0] if self.table_drive else 0.0
        return np.concatenate([pose.p, pose.q, self.block.linear_velocity, self.block.angular_velocity, [tab, v_tab]])

    def advance(self, n_from: int, n_to: int) -> np.ndarray:
        """Benchmark steps ``n_from … n_to − 1`` (``substeps`` PhysX steps each, the drive of each from
        :attr:`acc` or :attr:`disp`); the states after each benchmark step."""
        step, k = self.system.step, self.substeps
        rows = np.empty((n_to - n_from, 15))
        zero = np.zeros(3, dtype=np.float32)
        force = np.zeros(3, dtype=np.float32)
        for r, i in enumerate(range(n_from, n_to)):
            for j in range(i * k, (i + 1) * k):
                if self.table_drive:
                    u = self.disp[j] if j < len(self.disp) else self.disp[-1] if len(self.disp) else 0.0
                    self.table.set_kinematic_target(self._pose([u, 0.0, self._table_z]))
                elif j < len(self.acc):
                    force[0] = -self.mass_kg * self.acc[j]
                    self.block.add_force_torque(force, zero)
                step()
            rows[r] = self.row()
        return rows


class PhysxAdapter(ContactEngine):
    """The rocking block in PhysX 5 through SAPIEN (see the module docstring for the model).

    Settings
    --------
    settings : {"calibrated", "shipped"}
        PGS with the substeps calibrated to the case's η, or PhysX as shipped (:data:`SHIPPED_CONTACT`).
    drive : {"inertial", "table"}
        The force −m·ü at the centre of mass, or a kinematic table moved along u(t).
    planar : bool
        Lock the block to the vertical x–z plane (PhysX's lock flags), or a free 3-D body.
    friction : float
        Coulomb friction block–table, static and dynamic [-] (anti-slip: 10).
    solver : {"tgs", "pgs"} or None
        PhysX's solver; given, it (like every setting below) replaces calibration.
    position_iterations, velocity_iterations : int or None
        The block's solver iterations [-].
    contact_offset_m : float or None
        Both shapes' contact offset [m]: the gap at which PhysX starts generating contacts.
    contact_restitution : float or None
        The material's restitution in [0, 1] [-] (acts above the bounce threshold only).
    bounce_threshold_m_s : float or None
        The normal approach speed below which PhysX ignores restitution [m/s].
    substeps : int or None
        PhysX steps per benchmark step [-].
    tail_s, min_tail_s : float
        Longest and shortest simulated time after the pulse [s].
    """

    name = "physx"
    module = "sapien"
    install_hint = "install it with `pip install 'rockbench[physx]'` (or `pip install sapien==3.0.3`)."
    own_dt_s = SHIPPED_DT_S
    SETTINGS = {"tail_s": 2.0, "min_tail_s": 0.25}
    SHIPPED = SHIPPED_CONTACT
    #: The calibration: PhysX as shipped but for its solver (:data:`CALIBRATED_SOLVER`) and its
    #: substeps, :data:`SUBSTEPS_TRIED` coarsest first until the pick reaches the target. PhysX's plastic
    #: corner impact loses more than Housner's η_H the longer its step (docs/physx.md); iterations move η
    #: less and do not reach η_H, contact offset and restitution (below the bounce threshold) not at all.
    KNOBS = (Knob("substeps", "", SUBSTEPS_TRIED, until="reached", along={"solver": CALIBRATED_SOLVER}),)

    @classmethod
    def load_engine(cls):
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=_VULKAN_WARNING, category=UserWarning)
            import sapien   # optional engine library
        return sapien

    def validate(self, s: dict) -> None:
        self.choice_setting(s, "solver", SOLVERS)
        self.whole_setting(s, "position_iterations", minimum=1, maximum=255)
        self.whole_setting(s, "velocity_iterations", minimum=0, maximum=255)
        self.whole_setting(s, "substeps", minimum=1, maximum=1000)
        self.number_setting(s, "contact_offset_m", "m")
        self.number_setting(s, "contact_restitution", allow_zero=True, maximum=1.0)
        self.number_setting(s, "bounce_threshold_m_s", "m/s")

    def build(self, block: Block, s: dict, dt_s: float) -> _Scene:
        return _Scene(block, s, dt_s)

    def start(self, scene: _Scene, block: Block, s: dict, dt_s: float, pulses: list, theta0_rad: float,
              n_steps: int) -> np.ndarray:
        scene.place(block, theta0_rad)
        scene.load(pulses[0], dt_s, n_steps)
        return scene.row()[None, None, :]

    def advance(self, scene: _Scene, n_from: int, n_to: int) -> np.ndarray:
        return scene.advance(n_from, n_to)[None]

    def read(self, scene: _Scene, block: Block, s: dict, rows: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        return motion_of(rows, t_s, pulse, scene.table_drive, {k: s[k] for k in self.SHIPPED})
