"""DART adapter: the rocking block in DART's rigid contact (``dartpy``).

The model
---------
A block of full width ``b`` (x), depth ``d`` (y) and height ``h`` (z), with the block's mass and
the inertia of a uniform box, stands on a box table whose top is z = 0, in a DART ``World`` whose
time step is the case's Δt. They touch only through DART's own contact: the collision detector
(``collision_detector``, FCL as shipped) finds the contact points and the boxed-LCP constraint
solver (Dantzig) computes impulses that keep every contact point from approaching, with Coulomb
friction (a 4-sided friction pyramid per point). No constraint and no impact law of ours.

* **Planar** (default): a ``PlanarJoint`` in the z–x plane (translation in z and x, rotation about
  +y, so θ > 0 tilts the top towards +x: the contract's sign). Its collision shapes are two spheres
  of radius ``corner_radius_m`` (0.1 mm) flush inside the bottom corners, in the plane y = 0: one
  contact point per corner. A box would touch with two points per bottom edge (y = ±d/2) whose
  constraint rows are identical for a planar joint; the LCP then splits the impulse between them
  arbitrarily, and 14 of 20 mirrored pulses gave another max |θ|, one by 2.2 % (docs/dart.md).
  With the spheres the mirror is exact. ``planar=False`` makes it a box on a ``FreeJoint`` (DART
  as shipped; DART reports its velocities in the world frame); its four base corners are
  independent rows, and it is mirror-exact too.
* **Anti-slip**: friction 10 on both shapes (``friction``; DART combines the two with ``min``).
* **Restitution**: DART's impact is plastic (restitution 0 as shipped). ``contact_restitution`` is
  the block's coefficient; the table's is set to 1, since DART multiplies the two. DART applies
  it only where the bounce velocity ``e·v_n`` exceeds 0.1 m/s, a compile-time constant
  (``DART_BOUNCING_VELOCITY_THRESHOLD``), which the corners of the benchmark's blocks rarely reach;
  where it acts, the landing corner's bounce launches the block off the table (docs/dart.md).
* **Contact softness**: DART's error reduction (ERP 0.01, at most 1 mm/s) and constraint force
  mixing (1e-5) are static members of its ``ContactConstraint`` that dartpy does not expose; the
  contact stays rigid. ``split_impulse`` (dartpy exposes it) corrects penetration by a separate
  position impulse instead of a velocity bias.
* **Drives** (``drive``): ``inertial`` (default) tilts the gravity vector to ``(−ü, 0, −g)`` for
  every step, ``ü`` being the step average ``(u̇(tₙ₊₁) − u̇(tₙ))/Δt`` (the impulse per step is
  exact); ``table`` makes the table a kinematic body on a prismatic joint along x whose
  acceleration is prescribed (DART's ``ACCELERATION`` actuator) with the same step average, so its
  velocity is exact at the step ends and its position follows ``u(t)`` to ``u̇·Δt/2``
  (``table_track_err_rel`` records it). A kinematic body is not pushed back by the block.
* **Sleeping**: DART puts bodies at rest to sleep after 0.5 s; the adapter turns that off, so a
  block at rest under a later pulse never misses it.

Speed
-----
One world per geometry, drive and contact setting is built in a process and kept; a case only
resets the joints. The step loop makes one drive call, one ``World.step`` and two state reads per
step (no batch API: ``batching = "none"``, maps spread cells over processes).

The run, its end and the read-out are the contact base's (:mod:`rockbench.engines.contact`).
"""

from __future__ import annotations

import functools
import math
import os

import numpy as np

from rockbench.reference_solver.model import G, Block
from rockbench.engines.calibration.knobs import Knob
from rockbench.engines.contact import ContactEngine
from rockbench.engines.motion import Motion, pivot_pose, table_track_err_rel

#: The collision detectors dartpy offers, by setting value
COLLISION_DETECTORS = {"fcl": "FCLCollisionDetector", "ode": "OdeCollisionDetector",
                       "bullet": "BulletCollisionDetector", "dart": "DARTCollisionDetector"}

#: DART as shipped: FCL, no split impulse, plastic impacts
SHIPPED_CONTACT = {"collision_detector": "fcl", "split_impulse": False, "contact_restitution": 0.0}

#: The bounce velocity below which DART ignores restitution [m/s] (``DART_BOUNCING_VELOCITY_THRESHOLD``,
#: a compile-time constant of its ContactConstraint)
BOUNCE_THRESHOLD_M_S = 0.1

#: Restitution coefficients a calibration to a target above the shipped contact's η tries [-]
_RESTITUTIONS_TRIED = (0.25, 0.5, 0.75, 1.0)

#: Half extents of the table box [m]: wider than any table stroke
_TABLE_HALF_EXTENTS_M = (5.0, 1.0, 0.05)

#: Worlds kept per process (one per geometry, drive and contact); the least recently used goes first
_MAX_SCENES = 8


class _Scene:
    """One DART world: the block (planar or free) on a table (fixed, or kinematic on a prismatic
    joint for the table drive), contact as in the resolved settings ``s``."""

    def __init__(self, block: Block, s: dict, dt: float):
        import dartpy as dart   # optional engine library

        self.dt, self.planar, self.drive = dt, bool(s["planar"]), s["drive"]
        world = dart.simulation.World()
        world.setTimeStep(dt)
        world.setGravity([0.0, 0.0, -G])
        opts = world.getDeactivationOptions()
        opts.mEnabled = False
        world.setDeactivationOptions(opts)
        solver = world.getConstraintSolver()
        self.detector = getattr(dart.collision, COLLISION_DETECTORS[s["collision_detector"]])
        solver.setCollisionDetector(self.detector())
        solver.setSplitImpulseEnabled(bool(s["split_impulse"]))
        self.table, self.table_joint = table_skeleton(dart, s)
        self.block, self.joint = block_skeleton(dart, block, s)
        world.addSkeleton(self.table)
        world.addSkeleton(self.block)
        self.world, self._dart = world, dart
        self.acc, self.gravity = np.zeros(0), []

    def load(self, pulse, dt: float) -> None:
        """The drive of every step of ``dt`` [s] under ``pulse`` (None: none): the step average of ü
        (the velocity change per step is exact)."""
        if pulse is None:
            self.acc = np.zeros(0)
        else:
            n_pulse = int(math.ceil(pulse.duration_s / dt - 1e-9))
            self.acc = np.diff(np.asarray(pulse.vel(np.arange(n_pulse + 1) * dt), dtype=float)) / dt
        # the gravity vector of each step of the pulse, and once more after it set back upright (−0.0:
        # the pulse's −ü of 0, as it was); arrays, which dartpy takes faster than lists
        self.gravity = list(np.column_stack([-np.append(self.acc, 0.0), np.zeros(self.acc.size + 1),
                                             np.full(self.acc.size + 1, -G)]))

    def angles(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """θ [rad] and θ̇ [rad/s] of state rows."""
        return (rows[:, 2], rows[:, 5]) if self.planar else (_theta_free(rows), rows[:, 7])

    def place(self, block: Block, theta0: float) -> None:
        """The block at rest at ``theta0`` [rad] pivoting on its lower corner; the table at rest at 0."""
        xc, zc = pivot_pose(block, theta0)
        if self.planar:
            self.block.setPositions([zc, xc, theta0])
            self.block.setVelocities(np.zeros(3))
        else:
            tf = self._dart.math.Isometry3()
            c, s = math.cos(theta0), math.sin(theta0)
            tf.set_rotation(np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]))
            tf.set_translation([xc, 0.0, zc])
            self.block.setPositions(self._dart.dynamics.FreeJoint.convertToPositions(tf))
            self.block.setVelocities(np.zeros(6))
        if self.table_joint is not None:
            self.table.setPositions([0.0])
            self.table.setVelocities([0.0])
            self.table.setCommands([0.0])
        self.world.setGravity([0.0, 0.0, -G])
        self.world.setTime(0.0)
        # a fresh collision detector: Bullet's keeps its contact manifolds from the last run on this
        # world, and a run would depend on the one before it (measured: 5e-5 rad, B8M)
        self.world.getConstraintSolver().setCollisionDetector(self.detector())

    def row(self) -> np.ndarray:
        """The state now: the block's joint positions and velocities, then the table's x and ẋ."""
        out = [self.block.getPositions(), self.block.getVelocities()]
        if self.table_joint is not None:
            out += [self.table.getPositions(), self.table.getVelocities()]
        return np.concatenate(out)

    def advance(self, n_from: int, n_to: int) -> np.ndarray:
        """Steps ``n_from … n_to − 1`` (the drive of each step from :attr:`acc`); the states after each."""
        nq = 3 if self.planar else 6
        if self.table_joint is not None:
            return self._advance_table(n_from, n_to, nq)
        step, getq, getv = self.world.step, self.block.getPositions, self.block.getVelocities
        rows = np.empty((n_to - n_from, 2 * nq))
        pos, vel = rows[:, :nq], rows[:, nq:]   # views: a row of each is set faster than a slice of a row
        # gravity tilted by each step's −ü (arrays made once per run), then set back once at the
        # pulse's end (step len(acc)) and left alone after it
        grav, tilted = self.world.setGravity, self.gravity
        n_tilted = min(n_to, len(tilted))
        k = 0
        for i in range(n_from, n_tilted):
            grav(tilted[i])
            step()
            pos[k], vel[k] = getq(), getv()
            k += 1
        for k in range(k, n_to - n_from):
            step()
            pos[k], vel[k] = getq(), getv()
        return rows

    def _advance_table(self, n_from: int, n_to: int, nq: int) -> np.ndarray:
        """:meth:`advance` with the table driven: its acceleration commanded each step; the rows end with
        the table's x and ẋ."""
        step, getq, getv = self.world.step, self.block.getPositions, self.block.getVelocities
        rows = np.empty((n_to - n_from, 2 * nq + 2))
        acc = self.acc
        n_acc = len(acc)
        cmd, tq, tv = self.table.setCommands, self.table.getPositions, self.table.getVelocities
        for k, i in enumerate(range(n_from, n_to)):
            cmd([acc[i] if i < n_acc else 0.0])
            step()
            rows[k, :nq], rows[k, nq:2 * nq] = getq(), getv()
            rows[k, 2 * nq], rows[k, 2 * nq + 1] = tq()[0], tv()[0]
        return rows


@functools.lru_cache(maxsize=_MAX_SCENES)
def _scene(pid: int, block: Block, dt_s: float, settings: tuple) -> _Scene:
    """This process's world for a block, step [s] and the settings it depends on (``(name, value)``
    pairs); ``pid`` keys it by process, so a forked worker builds its own."""
    return _Scene(block, dict(settings), dt_s)


def table_skeleton(dart, s: dict, name: str = "table") -> tuple:
    """The table of the resolved settings ``s``: a box whose top is z = 0, welded (inertial drive) or
    kinematic on a prismatic joint along x (table drive); the skeleton and that joint (None: welded)."""
    table = dart.dynamics.Skeleton(name)
    if s["drive"] == "table":
        joint, body = table.createPrismaticJointAndBodyNodePair()
        joint.setAxis([1.0, 0.0, 0.0])
        joint.setActuatorType(dart.dynamics.ActuatorType.ACCELERATION)
    else:
        _, body = table.createWeldJointAndBodyNodePair()
        table.setMobile(False)
        joint = None
    hx, hy, hz = _TABLE_HALF_EXTENTS_M
    shape = body.createShapeNode(dart.dynamics.BoxShape([2 * hx, 2 * hy, 2 * hz]))
    shape.setRelativeTranslation([0.0, 0.0, -hz])
    _contact_aspects(shape, float(s["friction"]), 1.0)
    return table, joint


def block_skeleton(dart, block: Block, s: dict, name: str = "block") -> tuple:
    """The block of the resolved settings ``s``: on a planar joint in the z–x plane (positions z, x, θ
    about +y) with a sphere flush inside each bottom corner, or a box on a free joint; the skeleton and
    its joint."""
    mu, e = float(s["friction"]), float(s["contact_restitution"])
    skeleton = dart.dynamics.Skeleton(name)
    if s["planar"]:
        joint, node = skeleton.createPlanarJointAndBodyNodePair()
        joint.setZXPlane()  # positions (z, x, θ about +y)
    else:
        joint, node = skeleton.createFreeJointAndBodyNodePair()
    box = dart.dynamics.BoxShape([block.width_m, block.depth_m, block.height_m])
    if s["planar"]:
        # one contact point per bottom corner: a sphere flush inside it, in the plane y = 0
        r = float(s["corner_radius_m"])
        for side in (1.0, -1.0):
            sphere = node.createShapeNode(dart.dynamics.SphereShape(r))
            sphere.setRelativeTranslation([side * (block.width_m / 2 - r), 0.0, -block.height_m / 2 + r])
            _contact_aspects(sphere, mu, e)
    else:
        _contact_aspects(node.createShapeNode(box), mu, e)
    node.setInertia(dart.dynamics.Inertia(block.mass_kg, [0.0, 0.0, 0.0], box.computeInertia(block.mass_kg)))
    return skeleton, joint


def _contact_aspects(shape_node, friction: float, restitution: float) -> None:
    """Make a shape node collide, with its friction and restitution coefficients [-]."""
    shape_node.createCollisionAspect()
    dyn = shape_node.createDynamicsAspect()
    dyn.setFrictionCoeff(friction)
    dyn.setRestitutionCoeff(restitution)


def _theta_free(rows: np.ndarray) -> np.ndarray:
    """θ about +y from a free joint's rotation vectors (rows' first three columns) [rad]:
    ``atan2(R₀₂, R₀₀)`` of the rotation matrix (Rodrigues)."""
    r = rows[:, :3]
    phi = np.linalg.norm(r, axis=1)
    safe = np.where(phi > 0, phi, 1.0)
    k = r / safe[:, None]
    c, s = np.cos(phi), np.sin(phi)
    r00 = c + (1 - c) * k[:, 0] ** 2
    r02 = (1 - c) * k[:, 0] * k[:, 2] + s * k[:, 1]
    return np.arctan2(r02, r00)


class DartAdapter(ContactEngine):
    """The rocking block in DART (see the module docstring for the model).

    Settings
    --------
    settings : {"calibrated", "shipped"}
        Contact settings calibrated to the case's η, or DART as shipped (FCL, plastic impacts).
    drive : {"inertial", "table"}
        How the pulse enters (gravity tilted by −ü, or a kinematic table moved along u(t)).
    planar : bool
        Keep the block in the vertical x–z plane (a planar joint), or a free 3-D body.
    friction : float
        Coulomb friction block–table [-] (anti-slip: 10).
    collision_detector : {"fcl", "ode", "bullet", "dart"} or None
        DART's collision detector; given, it replaces calibration (None: calibrated, or FCL).
    split_impulse : bool or None
        Correct penetration with a separate position impulse; given, it replaces calibration.
    contact_restitution : float or None
        The block's restitution coefficient in [0, 1] (the table's is 1; DART applies it only above
        a bounce velocity of 0.1 m/s); given, it replaces calibration.
    corner_radius_m : float
        Radius of the planar model's corner spheres [m] (at most 1 mm).
    tail_s, min_tail_s : float
        Longest and shortest simulated time after the pulse [s].
    """

    name = "dart"
    module = "dartpy"
    install_hint = "install it with `pip install 'rockbench[dart]'` (or `pip install dartpy==6.20.0`; Python < 3.12)."
    #: DART's own default step (World.getTimeStep()), what it runs at as shipped
    own_dt_s = 1e-3
    #: the loop's segments end at each run's marks and last at most this after its pulse [s]
    #: (:mod:`rockbench.engines.loop`): DART steps one step a call, so where a segment starts changes
    #: nothing (each run's samples measured bit for bit the same), and fewer steps run past a stop
    near_segment_s = 0.05
    SETTINGS = {"corner_radius_m": 1e-4, "tail_s": 2.0, "min_tail_s": 0.25}
    SHIPPED = SHIPPED_CONTACT
    #: The calibration: DART's contact is rigid and its impact plastic, which is Housner's η_H, so the
    #: contact as shipped is kept within 0.5 %; otherwise the other collision detectors and the split
    #: impulse, and for a target more than 1 % above the shipped η the restitution coefficients
    #: :data:`_RESTITUTIONS_TRIED` (which act only above DART's bounce velocity, docs/dart.md). Nothing
    #: softens the contact: dartpy does not expose its error reduction or constraint force mixing.
    KNOBS = (Knob("collision_detector", "", tuple(COLLISION_DETECTORS)), Knob("split_impulse", "", (False, True)),
             Knob("contact_restitution", "", _RESTITUTIONS_TRIED, when="below",
                  note=f"restitution acts only where e·v_n > {BOUNCE_THRESHOLD_M_S:g} m/s (a compile-time constant of "
                       "DART), and where it acts the landing corner's bounce launches the block off the table "
                       "instead of raising η; DART's contact softness (ERP, CFM) is not exposed by dartpy"))
    START_KEEP_RTOL = 0.005

    def validate(self, s: dict) -> None:
        self.choice_setting(s, "collision_detector", tuple(COLLISION_DETECTORS))
        self.bool_setting(s, "split_impulse", allow_none=True)
        self.number_setting(s, "contact_restitution", allow_zero=True, maximum=1.0)
        # the corner spheres sit inside the corners and move the pivots inwards by their radius
        self.number_setting(s, "corner_radius_m", "m", allow_none=False, maximum=1e-3)

    def build(self, block: Block, s: dict, dt_s: float) -> _Scene:
        keys = ("planar", "drive", "friction", "corner_radius_m") + tuple(self.SHIPPED)
        return _scene(os.getpid(), block, dt_s, tuple((k, s[k]) for k in keys))

    def start(self, scene: _Scene, block: Block, s: dict, dt_s: float, pulses: list, theta0_rad: float,
              n_steps: int) -> np.ndarray:
        scene.place(block, theta0_rad)
        scene.load(pulses[0], dt_s)
        return scene.row()[None, None, :]

    def advance(self, scene: _Scene, n_from: int, n_to: int) -> np.ndarray:
        return scene.advance(n_from, n_to)[None]

    def stop_angles(self, scene: _Scene, block: Block, s: dict, rows: np.ndarray, t_s: np.ndarray, pulse) -> tuple:
        """θ and θ̇ of a segment's rows for the loop's end-of-run test, as :meth:`read` gives them (one
        sample a step: no times of its own), without the rest of the read-out."""
        return (*scene.angles(rows), None)

    def read(self, scene: _Scene, block: Block, s: dict, rows: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        th, om = scene.angles(rows)
        diag = {"collision_detector": s["collision_detector"], "split_impulse": bool(s["split_impulse"]),
                "contact_restitution": float(s["contact_restitution"])}
        if scene.planar:
            z, x, vz, vx = rows[:, 0], rows[:, 1], rows[:, 3], rows[:, 4]
        else:
            x, z, vx, vz = rows[:, 3], rows[:, 5], rows[:, 9], rows[:, 11]
            diag["max_lateral_drift_m"] = float(np.nanmax(np.abs(rows[:, 4])))
        u_tab = v_tab = None
        if scene.table_joint is not None:
            u_tab, v_tab = rows[:, -2], rows[:, -1]
            if pulse is not None:
                diag["table_track_err_rel"] = table_track_err_rel(u_tab, pulse, t_s)
        return Motion(x_m=x, z_m=z, theta_rad=th, vx_m_s=vx, vz_m_s=vz, theta_dot_rad_s=om, table_x_m=u_tab,
                      table_vx_m_s=v_tab, diagnostics=diag)
