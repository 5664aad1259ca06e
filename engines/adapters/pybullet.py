"""PyBullet adapter: the rocking block in Bullet's impulse-based (LCP) contact.

The model
---------
The block is a box ``b × d × h`` of the case's mass and uniform density. It touches a static box
(the table, top face at ``z = 0``) through Bullet's own box–box contact: no constraint or impact
law of ours replaces it, since that contact is what the benchmark measures.

* **Planar** (default, ``planar=True``): the block is the last link of a Featherstone chain
  fixed to the world: slide x, slide z, hinge y (axis through the centre of mass). The two slider
  links are massless in effect (1e-6 kg each, no collision shape) and carry the block, so the
  block has exactly the three in-plane degrees of freedom of the paper's model and nothing holds
  it but the contact. ``planar=False`` makes it a free 3-D floating body instead.
* **Anti-slip**: the friction coefficient is 10 (``friction``), the largest Bullet allows: it
  multiplies the two bodies' coefficients and clamps the product at 10, so the table gets 1 and
  the block the requested value. Friction 1 lets blocks slide above 3–4 g (docs/physics.md §8); a
  rocking block's impacts ask for far more than the static ratio ``ü/g``. Bullet's friction
  anchors (``friction_anchor``), its no-slip feature that pins a contact point's tangential
  position while it sticks, are on.
* **Drives** (``drive``): ``inertial`` (default) adds ``−m·ü(t)`` to every body through the
  gravity vector ``(−ü, 0, −g)`` (exact for a rigid table, one call per step); ``table`` moves
  the static table along ``u(t)`` and sets its velocity ``u̇(t)`` every step, which the contact
  solver needs to drag the block (a position alone does not).
* **Restitution**: Bullet has no η. ``settings="calibrated"`` (default) runs the contact settings
  the calibration found for the case's η (:attr:`PybulletAdapter.KNOBS`, cached on disk);
  ``settings="shipped"`` runs Bullet as shipped (its rigid contact, 50 solver iterations), with only
  the time step and the anti-slip friction set.

The run, its end and the free-rocking test
------------------------------------------
The adapter implements the four methods of the contact base
(:class:`~rockbench.engines.contact.ContactEngine`): it builds the scene, sets the contact
parameters, steps the engine (one Python call per step: drive, step, read the joint states) and
reads the block's pose and velocity. The base runs the pulse whole and stops the run by floor 1's
end-of-run rule; η is read by the one reader and the calibration takes the one pick.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math
import os
import sys

import numpy as np

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import G, Block
from rockbench.engines.calibration.knobs import Knob
from rockbench.engines.contact import ContactEngine
from rockbench.engines.motion import Motion, pivot_pose, theta_of_quat

#: Largest friction coefficient Bullet keeps: it clamps the product of the two bodies' coefficients [-].
BULLET_MAX_FRICTION = 10.0

#: Bullet's restitution coefficients a corner calibration scans before its bisection [-]
_RESTITUTIONS = tuple(float(r) for r in np.round(np.arange(0.5, 0.981, 0.04), 3))

#: Mass of each of the two slider links of the planar chain [kg]: small enough not to matter
#: (2e-6 of a 0.5 kg block), large enough to keep the articulated-body inertia well conditioned.
_SLIDER_MASS_KG = 1e-6

#: Half extents of the table box [m]: wider than any table stroke, thick enough for stiff contact.
_TABLE_HALF_EXTENTS_M = (5.0, 1.0, 0.05)

#: Radius of the spheres of a distributed contact (``contact_points``) [m].
_POINT_RADIUS_M = 5e-4

#: Bullet's own contact-breaking distance [m] (its process-wide ``gContactBreakingThreshold``).
#: ``resetSimulation`` keeps whatever the last case set, so every build sets it: this value unless
#: the case gives its own.
_BULLET_BREAKING_THRESHOLD_M = 0.02

#: Bullet's own restitution velocity threshold [m/s]: no restitution below this approach speed
#: (``btContactSolverInfo``). ``resetSimulation`` restores it, but a scene reused without a reset keeps
#: it, so every case sets it too: 0 with restitution, this value without.
_BULLET_RESTITUTION_THRESHOLD_MPS = 0.2


def _import_pybullet():
    """Import pybullet without the banner its C code prints at import time (:meth:`PybulletAdapter.load_engine`).

    The banner ("pybullet build time: ...") goes to file descriptor 2, which would make every
    one-line CLI error two lines; descriptors 1 and 2 point at /dev/null while the module loads
    (only the first import prints; later calls return the cached module).
    """
    if "pybullet" in sys.modules:
        return sys.modules["pybullet"]
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
            try:
                import pybullet   # optional engine library
            finally:
                _flush_c_stdio()  # anything left in C's stdio buffers goes to /dev/null too
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in saved:
            os.close(fd)
    return pybullet


def _flush_c_stdio() -> None:
    try:
        ctypes.CDLL(ctypes.util.find_library("c")).fflush(None)
    except Exception:  # noqa: BLE001 - no C library to flush: nothing was buffered there
        pass


class _Scene:
    """One PyBullet DIRECT client and the bodies of one block geometry, reused across cases.

    A case whose geometry (block size, mass, planar or free) and contact settings match the scene's
    only resets the state; anything else rebuilds the bodies in the same client.
    """

    def __init__(self):
        pb = _import_pybullet()
        self.pb = pb
        self.cid = pb.connect(pb.DIRECT)
        self.pid = os.getpid()
        self.key = None
        self.table = self.block = None
        self.block_link = -1

    def alive(self) -> bool:
        return self.pid == os.getpid() and self.pb.isConnected(physicsClientId=self.cid)

    def build(self, block: Block, planar: bool, breaking_threshold_m: float | None, contact: tuple = (),
              points: int | None = None) -> None:
        """Create the table and the block (planar chain or free body) if the geometry or the contact changed.

        ``contact`` identifies the contact settings: Bullet cannot switch a compliant contact back to
        its rigid one, so another contact means new bodies, never a leftover of the previous case.
        """
        key = (block.width_m, block.height_m, block.depth_m, block.mass_kg, planar, breaking_threshold_m, contact, points)
        self.planar = planar
        if key == self.key:
            return
        pb, cid = self.pb, self.cid
        pb.resetSimulation(physicsClientId=cid)
        # must be set before the shapes exist (Bullet copies it into each contact manifold), and set
        # every time: it is a process-wide value that a previous case may have changed
        threshold_m = _BULLET_BREAKING_THRESHOLD_M if breaking_threshold_m is None else breaking_threshold_m
        pb.setPhysicsEngineParameter(contactBreakingThreshold=threshold_m, physicsClientId=cid)
        self.table, self.block, self.block_link = self.add_bodies(block, planar, points)
        self.key = key

    def add_bodies(self, block: Block, planar: bool, points: int | None = None) -> tuple:
        """A table and a block (planar chain or free body) added to the client; ``(table, block, the block's
        link)``."""
        pb, cid = self.pb, self.cid
        tcol = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=_TABLE_HALF_EXTENTS_M, physicsClientId=cid)
        table = pb.createMultiBody(0.0, tcol, -1, [0, 0, -_TABLE_HALF_EXTENTS_M[2]], physicsClientId=cid)
        b, h, d, m = block.width_m, block.height_m, block.depth_m, block.mass_kg
        if points:
            # a row of small spheres along the base, the outer ones under the bottom
            # edges; two rows (front and back) for a free block. Bullet takes the inertia from the
            # shape, so the box's is set below.
            r = _POINT_RADIUS_M
            rows = (0.0,) if planar else (-d / 2 + r, d / 2 - r)
            pos = [[float(x), y, -h / 2 + r] for y in rows for x in np.linspace(-b / 2, b / 2, int(points))]
            bcol = pb.createCollisionShapeArray([pb.GEOM_SPHERE] * len(pos), radii=[r] * len(pos),
                                                collisionFramePositions=pos, physicsClientId=cid)
        else:
            bcol = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[b / 2, d / 2, h / 2], physicsClientId=cid)
        if planar:
            n = 3
            body = pb.createMultiBody(
                baseMass=0.0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=-1, basePosition=[0, 0, h / 2],
                linkMasses=[_SLIDER_MASS_KG, _SLIDER_MASS_KG, m], linkCollisionShapeIndices=[-1, -1, bcol],
                linkVisualShapeIndices=[-1] * n, linkPositions=[[0, 0, 0]] * n,
                linkOrientations=[[0, 0, 0, 1]] * n, linkInertialFramePositions=[[0, 0, 0]] * n,
                linkInertialFrameOrientations=[[0, 0, 0, 1]] * n, linkParentIndices=[0, 1, 2],
                linkJointTypes=[pb.JOINT_PRISMATIC, pb.JOINT_PRISMATIC, pb.JOINT_REVOLUTE],
                linkJointAxis=[[1, 0, 0], [0, 0, 1], [0, 1, 0]], physicsClientId=cid)
            # joints of a new multibody carry velocity motors: switch them off, the joints must be free
            pb.setJointMotorControlArray(body, [0, 1, 2], pb.VELOCITY_CONTROL, forces=[0, 0, 0],
                                         physicsClientId=cid)
            link = 2
            links = (-1, 0, 1, 2)
        else:
            body = pb.createMultiBody(m, bcol, -1, [0, 0, h / 2], physicsClientId=cid)
            link = -1
            links = (-1,)
        for j in links:
            # Bullet damps multibody motion by default (0.04): the model has no damping at all
            pb.changeDynamics(body, j, linearDamping=0.0, angularDamping=0.0, jointDamping=0.0,
                              physicsClientId=cid)
        if points:
            box_i = [m * (d * d + h * h) / 12.0, m * (b * b + h * h) / 12.0, m * (b * b + d * d) / 12.0]
            pb.changeDynamics(body, link, localInertiaDiagonal=box_i, physicsClientId=cid)
        # a block resting on the table for 2 s would fall asleep and ignore a later pulse
        pb.changeDynamics(body, -1, activationState=pb.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=cid)
        return table, body, link

    def apply(self, s: dict, dt_s: float) -> None:
        """Set the contact and solver parameters of ``s`` (a resolved settings dict)."""
        pb, cid = self.pb, self.cid
        # Bullet applies restitution only above an approach speed: 0 when the case has restitution,
        # else Bullet's own (set either way, never the previous case's)
        restitution_threshold_mps = 0.0 if s.get("contact_restitution") else _BULLET_RESTITUTION_THRESHOLD_MPS
        pb.setPhysicsEngineParameter(fixedTimeStep=dt_s, numSubSteps=0, numSolverIterations=int(s["solver_iterations"]),
                                     restitutionVelocityThreshold=restitution_threshold_mps, physicsClientId=cid)
        self.apply_dynamics(s, self.table, self.block, self.block_link)

    def apply_dynamics(self, s: dict, table: int, body: int, link: int) -> None:
        """Set the contact parameters of ``s`` (a resolved settings dict) on a table and a block's ``link``."""
        pb, cid = self.pb, self.cid
        # friction and restitution combine as products: the table carries 1, the block the value
        common = dict(lateralFriction=1.0, restitution=1.0 if s.get("contact_restitution") else 0.0)
        blk = dict(lateralFriction=float(s["friction"]), restitution=float(s.get("contact_restitution") or 0.0),
                   frictionAnchor=1 if s.get("friction_anchor") else 0)
        if s.get("contact_stiffness_n_m") is not None:
            kp, kd = float(s["contact_stiffness_n_m"]), float(s["contact_damping_n_s_m"])
            common.update(contactStiffness=kp, contactDamping=kd)
            blk.update(contactStiffness=kp, contactDamping=kd)
        pb.changeDynamics(table, -1, physicsClientId=cid, **common)
        pb.changeDynamics(body, link, physicsClientId=cid, **blk)

    def place(self, block: Block, planar: bool, theta0: float = 0.0) -> None:
        """Put the block at rest on the table at angle ``theta0`` (pivoting on the lower corner)
        and the table at rest at x = 0; clear the contact cache so the case starts fresh."""
        pb, cid = self.pb, self.cid
        h = block.height_m
        # lift the block clear and run collision detection once: Bullet then drops the old contact
        # manifold, so no warm-start impulse of the previous case leaks into this one
        if planar:
            pb.resetJointState(self.block, 1, 1.0, 0.0, physicsClientId=cid)
        else:
            pb.resetBasePositionAndOrientation(self.block, [0, 0, 1.0 + h / 2], [0, 0, 0, 1], physicsClientId=cid)
        pb.resetBasePositionAndOrientation(self.table, [0, 0, -_TABLE_HALF_EXTENTS_M[2]], [0, 0, 0, 1],
                                           physicsClientId=cid)
        pb.resetBaseVelocity(self.table, [0, 0, 0], [0, 0, 0], physicsClientId=cid)
        pb.performCollisionDetection(physicsClientId=cid)
        xc, zc = pivot_pose(block, theta0)
        if planar:
            for j, q in ((0, xc), (1, zc - h / 2), (2, theta0)):
                pb.resetJointState(self.block, j, q, 0.0, physicsClientId=cid)
        else:
            quat = pb.getQuaternionFromEuler([0.0, theta0, 0.0])
            pb.resetBasePositionAndOrientation(self.block, [xc, 0, zc], quat, physicsClientId=cid)
            pb.resetBaseVelocity(self.block, [0, 0, 0], [0, 0, 0], physicsClientId=cid)

    def load_drive(self, pulse, drive: str, dt_s: float, n_steps: int) -> None:
        """The drive of each step: the inertial force through the gravity vector ``(−ü, 0, −g)``
        (ü at the step's midpoint, during the pulse), or the table's pose u(tₙ) and velocity u̇ at
        the step's midpoint (Bullet's contact drags the block only with a velocity)."""
        self.inertial = drive == "inertial"
        self.acc = None
        self.n_pulse = int(math.ceil(pulse.duration_s / dt_s - 1e-9)) if pulse is not None else -1
        self.drive_table = pulse is not None and not self.inertial
        if pulse is not None:
            # plain lists: indexing them in the loop costs less than numpy scalars. The inertial drive
            # reads steps 0 … n_pulse only; the table's drive every step of the run
            n_drive = min(n_steps, self.n_pulse + 1) if self.inertial else n_steps
            mid = (np.arange(n_drive) + 0.5) * dt_s
            if self.inertial:
                self.acc = (-pulse.accel(mid)).tolist()
            else:
                self.u_pos = pulse.disp(np.arange(n_drive) * dt_s).tolist()
                self.u_vel = pulse.vel(mid).tolist()
        self.pb.setGravity(0.0, 0.0, -G, physicsClientId=self.cid)

    def read(self, velocities: bool = True) -> tuple:
        """The block's state: ``(x, z_slider, θ, ẋ, ż, θ̇)`` planar; position, quaternion and linear
        and angular velocities free (zeros without ``velocities``)."""
        pb, cid = self.pb, self.cid
        if self.planar:
            st = pb.getJointStates(self.block, [0, 1, 2], physicsClientId=cid)
            return st[0][0], st[1][0], st[2][0], st[0][1], st[1][1], st[2][1]
        pos, quat = pb.getBasePositionAndOrientation(self.block, physicsClientId=cid)
        vel = sum(pb.getBaseVelocity(self.block, physicsClientId=cid), ()) if velocities else (0.0,) * 6
        return pos + quat + vel

    def advance(self, n_from: int, n_to: int) -> list:
        """Steps ``n_from`` to ``n_to``: drive, step, read; the states after each step."""
        if self.planar and not self.drive_table:
            return self._advance_planar(n_from, n_to)
        pb, cid = self.pb, self.cid
        step, set_g, table, table_z = pb.stepSimulation, pb.setGravity, self.table, -_TABLE_HALF_EXTENTS_M[2]
        rows = []
        for i in range(n_from, n_to):
            if self.drive_table:
                pb.resetBasePositionAndOrientation(table, (self.u_pos[i], 0.0, table_z), (0.0, 0.0, 0.0, 1.0),
                                                   physicsClientId=cid)
                pb.resetBaseVelocity(table, (self.u_vel[i], 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=cid)
            elif self.acc is not None and i <= self.n_pulse:
                set_g(self.acc[i], 0.0, -G, physicsClientId=cid)
            step(physicsClientId=cid)
            rows.append(self.read())
        return rows

    def _advance_planar(self, n_from: int, n_to: int) -> list:
        """:meth:`advance` of the planar chain under the inertial drive: gravity tilted during the pulse
        (and set back at its step ``n_pulse``), the three joints' states read in one call a step and
        made rows ``(x, z_slider, θ, ẋ, ż, θ̇)`` after the loop."""
        pb, cid, body, joints = self.pb, self.cid, self.block, (0, 1, 2)
        step, set_g, get = pb.stepSimulation, pb.setGravity, pb.getJointStates
        states = []
        keep = states.append
        n_tilted = max(n_from, min(n_to, self.n_pulse + 1)) if self.acc is not None else n_from
        acc = self.acc
        for i in range(n_from, n_tilted):
            set_g(acc[i], 0.0, -G, physicsClientId=cid)
            step(physicsClientId=cid)
            keep(get(body, joints, physicsClientId=cid))
        for _ in range(n_tilted, n_to):
            step(physicsClientId=cid)
            keep(get(body, joints, physicsClientId=cid))
        return [(x[0], z[0], th[0], x[1], z[1], th[1]) for x, z, th in states]


_SCENE: _Scene | None = None


def _scene() -> _Scene:
    """This process's one DIRECT client (a forked worker gets its own)."""
    global _SCENE
    if _SCENE is None or not _SCENE.alive():
        _SCENE = _Scene()
    return _SCENE


class PybulletAdapter(ContactEngine):
    """The rocking block in PyBullet (see the module docstring for the model and the end of a run).

    Settings
    --------
    settings : {"calibrated", "shipped"}
        Contact settings calibrated to the case's η, or Bullet as shipped.
    drive : {"inertial", "table"}
        How the pulse enters (inertial force at the centre of mass, or a moving table).
    planar : bool
        Keep the block in the vertical x–z plane (slide x, slide z, hinge y), or a free 3-D body.
    friction : float
        Friction coefficient block–table [-], at most 10 (Bullet's clamp).
    friction_anchor : bool
        Bullet's friction anchors (pin sticking contact points) [-].
    solver_iterations : int or None
        Bullet's solver iterations; None: 30 when calibrated, Bullet's 50 as shipped. The
        sequential-impulse solver is not fully converged at 30 (a mirrored pulse gives the mirrored
        θ(t) to about 1e-3 of its peak, against 1e-2 at 20 and 1e-1 at 10; 50 gives 4e-6), and
        a step costs about 25 % less than at 50.
    contact_stiffness_n_m, contact_damping_n_s_m : float or None
        Explicit compliant contact [N/m], [N s/m] (give both); overrides calibration.
    contact_restitution : float or None
        Bullet's restitution of the block (the table carries 1) [-]; overrides calibration.
    contact_breaking_threshold_m : float or None
        Bullet's contact-breaking distance [m] (its default is 0.02 m).
    contact : {"auto", "corners", "distributed"}
        ``corners``: the block's box touches the table (Bullet keeps up to 4 corner contacts).
        ``distributed``: a row of ``contact_points`` small spheres along the base instead, the
        outer ones under the bottom edges, calibrated over a compliant contact's
        stiffness and damping ratio. ``auto`` (default): the corners for targets up to 1 % above
        Housner's η_H, the distributed contact above (the modified η_M); explicit contact
        settings with ``auto`` use the corners.
    contact_points : int or None
        Spheres of the distributed contact (≥ 3). None (default): the calibration tries 9, then
        5, then 17 until one reaches the target at an acceptable price; explicit contact
        settings then use 9.
    tail_s, min_tail_s : float
        Longest and shortest simulated time after the pulse [s].
    """

    name = "pybullet"
    module = "pybullet"
    install_hint = ("install it with `pip install 'rockbench[pybullet]'` (or `pip install pybullet`: wheels for Linux, "
                    "macOS and Windows).")
    #: PyBullet's own default step (fixedTimeStep, 1/240 s), what it runs at as shipped
    own_dt_s = 1.0 / 240.0
    #: the loop's segments end at each run's marks and last at most this after its pulse [s]
    #: (:mod:`rockbench.engines.loop`): Bullet's step does not depend on where a segment starts (each
    #: run's samples measured bit for bit the same), so fewer steps run past a stop (docs/speed.md)
    near_segment_s = 0.05
    SETTINGS = {"friction": BULLET_MAX_FRICTION, "friction_anchor": True, "tail_s": 2.0, "min_tail_s": 0.25}
    #: Bullet's rigid contact (no stiffness, no restitution; its own breaking threshold)
    SHIPPED = {"contact_stiffness_n_m": None, "contact_damping_n_s_m": None, "contact_restitution": None,
               "contact_breaking_threshold_m": None}
    MODE_DEFAULTS = {"solver_iterations": (50, 30)}
    CONTACT_ROWS = "spheres"
    #: The corner calibration: Bullet's rigid contact as shipped, kept within 1 %; a target more than
    #: 1 % below its η: a compliant contact at damping ratio 1 (``c = 2√(k·m)``), log10 k bisected from 3
    #: up to the stiffest the step resolves (``k ≤ m/Δt²``: stiffer springs pass free rocking but gain
    #: energy under a pulse), a softer contact losing more at the impact; a target more than 1 % above
    #: it: Bullet's restitution with a 0.1 mm contact-breaking threshold (else the corner's contact point
    #: exists before the impact and Bullet treats it as resting, with no restitution), scanned over
    #: [0.5, 0.98] and bisected, its corner free to bounce (the spread shows it)
    KNOBS = (
        Knob("contact_stiffness_n_m", "N/m", when="above", bisect_steps=12, bisect_regular=False, log10=True,
             span=lambda block, dt: (3.0, max(3.5, math.log10(block.mass_kg / dt**2))), no_eta_low_end=True,
             along=lambda k, block, dt: {"contact_damping_n_s_m": 2.0 * math.sqrt(k * block.mass_kg)}),
        Knob("contact_restitution", "", _RESTITUTIONS, zeta="restitution", when="below", bisect_steps=5,
             bisect_regular=False, along={"contact_breaking_threshold_m": 1e-4}),
    )
    START_KEEP_RTOL = 0.01
    CALIBRATION_VERSION = 6

    @classmethod
    def load_engine(cls):
        return _import_pybullet()

    def validate(self, s: dict) -> None:
        self.bool_setting(s, "friction_anchor")
        # Bullet clamps the combined coefficient at 10
        self.number_setting(s, "friction", allow_none=False, maximum=BULLET_MAX_FRICTION)
        self.number_setting(s, "contact_stiffness_n_m", "N/m")
        self.number_setting(s, "contact_damping_n_s_m", "N s/m", allow_zero=True)
        self.number_setting(s, "contact_restitution", allow_zero=True, maximum=1.0)
        self.number_setting(s, "contact_breaking_threshold_m", "m")
        if (s["contact_stiffness_n_m"] is None) != (s["contact_damping_n_s_m"] is None):
            raise ConfigError("pybullet settings contact_stiffness_n_m and contact_damping_n_s_m go together: "
                              "give both (Bullet ignores one without the other).")
        self.whole_setting(s, "solver_iterations", minimum=1)

    def build(self, block: Block, s: dict, dt_s: float, sc: "_Scene | None" = None) -> "_Scene":
        """The block and its table in this process's client (or in ``sc``'s) as the resolved settings
        ``s`` and the step [s] make them."""
        sc = _scene() if sc is None else sc
        sc.build(block, bool(s["planar"]), s.get("contact_breaking_threshold_m"),
                 tuple(s.get(k) for k in (*self.SHIPPED, "friction", "friction_anchor")), points=self.points(s))
        sc.apply(s, dt_s)
        return sc

    @staticmethod
    def points(s: dict) -> int | None:
        """The contact spheres along the block's base of the resolved settings ``s`` (None: a box)."""
        return s["contact_points"] if s["contact"] == "distributed" else None

    def start(self, sc: "_Scene", block: Block, s: dict, dt_s: float, pulses: list, theta0_rad: float,
              n_steps: int) -> np.ndarray:
        sc.place(block, bool(s["planar"]), theta0_rad)
        sc.load_drive(pulses[0], s["drive"], dt_s, n_steps)
        return np.array([[sc.read(velocities=False)]], dtype=float)

    def advance(self, sc: "_Scene", n_from: int, n_to: int) -> np.ndarray:
        return np.array([sc.advance(n_from, n_to)], dtype=float)

    def read(self, sc: "_Scene", block: Block, s: dict, rows: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        table = pulse is not None and s["drive"] != "inertial"
        u_tab, v_tab = (pulse.disp(t_s), pulse.vel(t_s)) if table else (None, None)
        if bool(s["planar"]):
            return Motion(x_m=rows[:, 0], z_m=rows[:, 1] + block.height_m / 2, theta_rad=rows[:, 2], vx_m_s=rows[:, 3],
                          vz_m_s=rows[:, 4], theta_dot_rad_s=rows[:, 5], table_x_m=u_tab, table_vx_m_s=v_tab)
        qx, qy, qz, qw = rows[:, 3], rows[:, 4], rows[:, 5], rows[:, 6]
        # how far the free body left the plane: lateral drift along y, tilt about x
        roll = np.arcsin(np.clip(2.0 * (qw * qx - qy * qz), -1.0, 1.0))
        diag = {"max_lateral_drift_m": float(max(np.max(np.abs(rows[:, 1])), 0.0)),
                "max_out_of_plane_tilt_rad": float(np.max(np.abs(roll)))}
        return Motion(x_m=rows[:, 0], z_m=rows[:, 2], theta_rad=theta_of_quat(qw, qx, qy, qz), vx_m_s=rows[:, 7],
                      vz_m_s=rows[:, 9], theta_dot_rad_s=rows[:, 11], table_x_m=u_tab, table_vx_m_s=v_tab,
                      diagnostics=diag)

    def candidates(self, block: Block, target: float, dt_s: float, points: int | None, measure) -> list[dict]:
        """The corners: the knobs' search. A row along the base: Bullet's rigid contact and a grid of
        stiffness ``k`` (100 × 10^(−2…0)·m/Δt², nine values up to the stiffest the step resolves) ×
        damping ratio ζ (0.05–1, ``c = 2ζ√(k·m)``), every one measured."""
        if points is None:
            return super().candidates(block, target, dt_s, points, measure)
        m_kg = block.mass_kg
        kmax = m_kg / dt_s**2
        return measure([{}] + [{"contact_stiffness_n_m": float(k), "contact_damping_n_s_m": float(2 * z * math.sqrt(k * m_kg)),
                                "zeta": z} for k in np.logspace(math.log10(kmax) - 2.0, math.log10(kmax), 9)
                               for z in (0.05, 0.1, 0.2, 0.5, 1.0)])
