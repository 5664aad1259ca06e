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
:func:`~rockbench.engines.calibration.time_step.step_for`); calibrated, the time-step rule's (docs/physx.md).
``settings="calibrated"`` runs PGS and searches the substeps (:attr:`PhysxAdapter.KNOBS`):
PhysX's impact loses more energy the longer its step, and the substeps are the knob that moves η
towards Housner's; PGS because TGS lets the pivot corner creep along the table at friction 10.

Batches
-------
Cases of one block, settings and step run as up to :data:`MAX_WORLDS` worlds of one scene
(``batching = "native"``): every block at the origin on a table of its own, each world's two shapes
carrying one bit of PhysX's collision groups, so a block touches its own table only; PhysX's enhanced
determinism keeps each world's island independent of the others. A world whose run ended is taken
out of the scene (its components disabled). The scene is built once per block, settings and step and
reused batch after batch (a world taken back in is re-enabled, placed at rest, its velocities
zeroed): measured, a cell's answer is the same to the last digit alone on a fresh scene, in any batch
and after any other (PGS; tests/engines/test_batch_independence_physx.py). With TGS a world's answer moves with the other worlds in the scene
(float32 round-off that the rocking grows), so TGS runs one world at a time (docs/physx.md). The drive
of every PhysX step is computed once per run, and the state of every body is read in one call per
benchmark step (``PhysxCpuSystem.pack``).

The run, its end and the read-out are the contact base's (:mod:`rockbench.engines.contact`).
"""

from __future__ import annotations

import json
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

#: The most worlds one scene holds: a world's two shapes carry one bit of PhysX's 32-bit collision groups
MAX_WORLDS = 32

#: The resolved settings a scene is built with (with the block and the step: the key of a reused scene)
_SCENE_KEYS = ("drive", "planar", "friction", *SHIPPED_CONTACT)

#: A row's first 13 columns (position, quaternion w x y z, velocity, angular velocity) in a body's record
#: of ``PhysxCpuSystem.pack`` (quaternion w x y z, position, velocity, angular velocity)
_ROW_OF_PACK = np.r_[4:7, 0:4, 7:13]

#: The UserWarning SAPIEN raises on import where the system has no libvulkan (only its renderer needs it)
_VULKAN_WARNING = "Failed to find system libvulkan"


def _sapien():
    """The ``sapien`` module, imported without its renderer's libvulkan warning (physics needs none)."""
    return PhysxAdapter.load_engine()


class _Worlds:
    """One SAPIEN scene of worlds, each a block (planar or free) on its own table (static, or kinematic
    for the table drive), every one at the origin and colliding only with its own table (PhysX's
    collision groups: world ``w``'s two shapes carry bit ``w``); contact and solver as in the resolved
    settings ``s``, stepping ``dt/substeps``. A world not running is disabled (out of PhysX's scene)."""

    def __init__(self, block: Block, s: dict, dt: float):
        sapien = _sapien()
        px = sapien.physx
        # global in SAPIEN, copied by the system created next
        px.set_scene_config(gravity=np.array([0.0, 0.0, -G], dtype=np.float32),
                            bounce_threshold=float(s["bounce_threshold_m_s"]), enable_tgs=s["solver"] == "tgs",
                            enable_enhanced_determinism=True)
        self.system = px.PhysxCpuSystem()
        self.substeps = int(s["substeps"])
        self.h = dt / self.substeps
        self.system.set_timestep(self.h)
        self.scene = sapien.Scene([self.system])
        self.block, self.s, self._pose = block, s, sapien.Pose
        mu = float(s["friction"])
        self._material = px.PhysxMaterial(mu, mu, float(s["contact_restitution"]))
        self.table_drive = s["drive"] == "table"
        self._table_z = -_TABLE_HALF_EXTENTS_M[2]
        self.worlds: list[tuple] = []   # (block, table) components of each world built
        self.active = np.zeros(0, dtype=bool)   # of the worlds of the batch now: running
        self._forces: list = []         # per running world: (w, its block's add_force_torque, forces, how many)
        self._targets: list = []        # per running world: (w, its table's set_kinematic_target, poses)

    def _world(self, w: int) -> tuple:
        """World ``w``'s block and table, added to the scene (bit ``w`` of the collision groups)."""
        px, b, s = _sapien().physx, self.block, self.s
        table = px.PhysxRigidDynamicComponent() if self.table_drive else px.PhysxRigidStaticComponent()
        table.attach(self._box(_TABLE_HALF_EXTENTS_M, w))
        if self.table_drive:
            table.set_kinematic(True)
        body = px.PhysxRigidDynamicComponent()
        shape = self._box((b.width_m / 2, b.depth_m / 2, b.height_m / 2), w)
        shape.set_density(b.mass_kg / (b.width_m * b.depth_m * b.height_m))
        body.attach(shape)
        body.set_solver_position_iterations(int(s["position_iterations"]))
        body.set_solver_velocity_iterations(int(s["velocity_iterations"]))
        body.set_sleep_threshold(0.0)
        if s["planar"]:
            body.set_locked_motion_axes([False, True, False, True, False, True])
        for comp in (table, body):
            entity = _sapien().Entity()
            entity.add_component(comp)
            entity.set_pose(self._pose([0.0, 0.0, self._table_z]))
            self.scene.add_entity(entity)
        return body, table

    def _box(self, half_m, w: int):
        shape = _sapien().physx.PhysxCollisionShapeBox(np.asarray(half_m, dtype=np.float32), self._material)
        shape.set_contact_offset(float(self.s["contact_offset_m"]))
        shape.set_collision_groups([1 << w, 1 << w, 0, 0])
        return shape

    def start(self, pulses: list, theta0: float, dt: float, n_steps: int) -> np.ndarray:
        """One world per pulse at rest at ``theta0`` [rad] on its lower corner, its drive loaded for
        ``n_steps`` steps of ``dt`` [s]; the worlds beyond them disabled. The first rows ``(W, 1, 15)``."""
        while len(self.worlds) < len(pulses):
            self.worlds.append(self._world(len(self.worlds)))
        self.active = np.ones(len(pulses), dtype=bool)
        for w in range(len(self.worlds)):
            self._enable(w, w < len(pulses))
        xc, zc = pivot_pose(self.block, theta0)
        q = [math.cos(theta0 / 2), 0.0, math.sin(theta0 / 2), 0.0]
        self._forces, self._targets = [], []
        for w, pulse in enumerate(pulses):
            body, table = self.worlds[w]
            body.entity.set_pose(self._pose([xc, 0.0, zc], q))
            body.set_linear_velocity(np.zeros(3, dtype=np.float32))
            body.set_angular_velocity(np.zeros(3, dtype=np.float32))
            if self.table_drive:
                table.entity.set_pose(self._pose([0.0, 0.0, self._table_z]))
            self._load(w, pulse, dt, n_steps)
        self._index()
        return self._rows([self.system.pack()])

    def _enable(self, w: int, on: bool) -> None:
        for comp in self.worlds[w]:
            if comp.is_enabled != on:
                (comp.enable if on else comp.disable)()

    def _load(self, w: int, pulse, dt: float, n_steps: int) -> None:
        """World ``w``'s drive of every PhysX step of ``n_steps`` benchmark steps of ``dt`` [s] under
        ``pulse`` (None: none), computed once for the run: the table's target pose at the step's end
        (held at the last after the pulse), or the force −m·ü, ü the step average (the velocity change
        per PhysX step is exact), float32 as PhysX takes it."""
        body, table = self.worlds[w]
        n = 0 if pulse is None else min(n_steps, int(math.ceil(pulse.duration_s / dt - 1e-9))) * self.substeps
        t = np.arange(n + 1) * self.h
        if self.table_drive:
            u = np.asarray(pulse.disp(t[1:]), dtype=float) if n else np.zeros(1)
            self._targets.append((w, table.set_kinematic_target, [self._pose([x, 0.0, self._table_z]) for x in u]))
        elif n:
            force = np.zeros((n, 3), dtype=np.float32)
            force[:, 0] = -self.block.mass_kg * (np.diff(np.asarray(pulse.vel(t), dtype=float)) / self.h)
            self._forces.append((w, body.add_force_torque, force, n))

    def _index(self) -> None:
        """Where each running world's block (and table) sits in :meth:`PhysxCpuSystem.pack`'s records."""
        order = {c.entity.per_scene_id: i for i, c in enumerate(self.system.get_rigid_dynamic_components())}
        on = np.nonzero(self.active)[0]
        self._on = on
        self._at_block = np.array([order[self.worlds[w][0].entity.per_scene_id] for w in on], dtype=int)
        self._at_table = (np.array([order[self.worlds[w][1].entity.per_scene_id] for w in on], dtype=int)
                          if self.table_drive else None)

    def retire(self, w: int) -> None:
        """World ``w`` stops: out of PhysX's scene, its drive dropped."""
        if w < len(self.active) and self.active[w]:
            self.active[w] = False
            self._enable(w, False)
            self._forces = [d for d in self._forces if d[0] != w]
            self._targets = [d for d in self._targets if d[0] != w]
            self._index()

    def _rows(self, packs: list) -> np.ndarray:
        """The states of every world ``(W, n, 15)`` (NaN for a world not running) from ``n`` records of
        :meth:`PhysxCpuSystem.pack` (per body: q w x y z, p, v, ω, float32): the block's position (3),
        quaternion w, x, y, z (4), velocity (3), angular velocity (3), then the table's x and ẋ."""
        packed = np.frombuffer(b"".join(packs), dtype=np.float32).reshape(len(packs), -1, 13)
        out = np.full((len(self.active), len(packs), 15), np.nan)
        out[self._on, :, :13] = packed[:, self._at_block][..., _ROW_OF_PACK].transpose(1, 0, 2)
        if self.table_drive:
            tab = packed[:, self._at_table].transpose(1, 0, 2)
            out[self._on, :, 13], out[self._on, :, 14] = tab[..., 4], tab[..., 7]
        else:
            out[self._on, :, 13:15] = 0.0
        return out

    def advance(self, n_from: int, n_to: int) -> np.ndarray:
        """Benchmark steps ``n_from … n_to − 1`` of every running world (``substeps`` PhysX steps
        each, each world's drive call with its precomputed drive); the states after each step
        ``(W, n, 15)``, read in one call per step (PhysX's packed state of every body)."""
        step, pack, k = self.system.step, self.system.pack, self.substeps
        packs = []
        zero = np.zeros(3, dtype=np.float32)
        for i in range(n_from, n_to):
            for j in range(i * k, (i + 1) * k):
                for _, add, force, n in self._forces:
                    if j < n:
                        add(force[j], zero)
                for _, set_target, poses in self._targets:
                    set_target(poses[min(j, len(poses) - 1)])
                step()
            packs.append(pack())
        return self._rows(packs)


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
    batching = "native"
    max_worlds = MAX_WORLDS
    #: the loop's segments end at each run's marks and last at most this after its pulse [s]
    #: (:mod:`rockbench.engines.loop`): PhysX steps one step a call, so where a segment starts changes
    #: nothing (runs measured bit for bit the same), and fewer steps run past a stop
    near_segment_s = 0.05
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

    def worlds_per_batch(self, s: dict) -> int:
        """Up to :data:`MAX_WORLDS` worlds in one scene with PGS; with TGS one world at a time, since
        TGS's answer moves with the other worlds in the scene (measured, docs/physx.md)."""
        return self.max_worlds if s["solver"] == "pgs" else 1

    def build(self, block: Block, s: dict, dt_s: float) -> _Worlds:
        """The scene of the block, settings and step: built once, its worlds reused batch after batch."""
        key = (json.dumps(block.to_dict(), sort_keys=True), dt_s, *(s[k] for k in _SCENE_KEYS))
        if key not in self.scenes:
            self.scenes[key] = _Worlds(block, s, dt_s)
        return self.scenes[key]

    def start(self, scene: _Worlds, block: Block, s: dict, dt_s: float, pulses: list, theta0_rad: float,
              n_steps: int) -> np.ndarray:
        return scene.start(pulses, theta0_rad, dt_s, n_steps)

    def advance(self, scene: _Worlds, n_from: int, n_to: int) -> np.ndarray:
        return scene.advance(n_from, n_to)

    def retire(self, scene: _Worlds, w: int) -> None:
        scene.retire(w)

    def read(self, scene: _Worlds, block: Block, s: dict, rows: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        return motion_of(rows, t_s, pulse, scene.table_drive, {k: s[k] for k in self.SHIPPED})
