"""Drake adapter: the rocking block in Drake's compliant contact (``MultibodyPlant``).

The model
---------
A box of full width ``b`` (x), depth ``d`` (y) and height ``h`` (z), with the block's mass and
uniform density, stands on a table in a discrete ``MultibodyPlant`` (time step = the case's Δt)
wired to a ``SceneGraph``. They touch only through Drake's own compliant contact; no constraint
and no impact law of ours replaces it.

* **Contact** (``contact``): ``point`` (default) puts small spheres (radius ``corner_radius_m``)
  inside the bottom corners of the block, flush with its base and sides, against the table (a half
  space, or a box for the table drive). Drake's point contact between a box and a plane gives one
  contact point, the deepest, which cannot hold a block standing on its base; spheres at the corners
  give one point per corner, as the rigid model has it. In the plane (``planar=True``) the two
  in-plane corners (y = 0) carry the contact; a free 3-D block has all four, each with half the
  stiffness, so ``point_stiffness_n_m`` is per bottom edge either way. ``hydroelastic`` makes the block
  a compliant-hydroelastic box (modulus ``hydroelastic_modulus_pa``) pressed into a rigid-hydroelastic
  table: the pressure field spreads the contact over the part of the base that penetrates.
* **Discrete solver** (``approximation``): SAP (``sap``, default when calibrated), or the
  Hunt–Crossley approximations ``similar`` and ``lagged`` (Drake's own default). SAP models
  dissipation with a linear Kelvin–Voigt law and a relaxation time ``relaxation_time_s`` [s]; the
  others with Hunt–Crossley dissipation ``hunt_crossley_dissipation_s_m`` [s/m]. The table carries a
  stiffness of 1e20 (point) or is rigid (hydroelastic) and no dissipation, so the block's values
  are the contact's (Drake combines the two materials in series).
* **Planar** (default): a ``PlanarJoint`` keeps the block in the x–z plane (translation in x and
  z, rotation about +y, so θ > 0 tilts the top towards +x: the contract's sign). ``planar=False``
  makes it a free body.
* **Anti-slip**: Coulomb friction 10 (``friction``, static = dynamic) on block and table.
* **Drives** (``drive``): ``inertial`` (default): the table is fixed and the block feels ``−m·ü``
  at its centre of mass as a generalized force on its x translation; ``table``: the table is a
  heavy body (``table_mass_ratio`` × the block's mass) on a prismatic joint along x, pushed by
  ``(M_table + m)·ü``, so it moves along ``u(t)`` with the velocity its contact needs; the largest
  tracking error is recorded as ``table_track_err_rel``. Either force, over step ``[tₙ, tₙ₊₁]``, is
  the step average ``(u̇(tₙ₊₁) − u̇(tₙ))/Δt`` of ``ü`` times the mass: the impulse per step is exact.
* **Restitution**: Drake has no η. ``settings="calibrated"`` (default) runs the contact parameters
  :func:`~rockbench.engines.calibration.routine.calibrate` found for the case's η (cached on disk, see
  :mod:`rockbench.engines.calibration.cache`); ``settings="shipped"`` runs Drake as shipped: its default
  discrete approximation (``lagged``) and contact parameters (stiffness and dissipation from its
  default penetration allowance of 1 mm), with only the time step, the geometry and the anti-slip
  friction set.

Speed and batches: one world a batch
------------------------------------
A step of a ``MultibodyPlant`` has a fixed cost (the SAP solve's set-up, the geometry queries, the
diagram's update: about 40 µs here) that one block pays alone. Blocks of one plant would share it,
but SAP solves a plant's blocks as one problem with one convergence test, so a block's θ would move
with its batch-mates. The adapter's diagram of ``n`` worlds (:class:`_Scene`) holds a plant of its
own (with its own scene graph, drive and log) for each world, all advanced by one ``Simulator``: a
world's step is its own solve and its θ is the same bit for bit in any batch
(``tests/engines/test_batch_independence.py``). Such worlds share nothing worth having (each pays
its plant's fixed cost; measured: no cheaper a cell than one world at a time), so cells run one world
a batch (``max_worlds = 1``): docs/drake.md, "Speed and batches". The diagram is built once per
geometry, contact and number of worlds and kept in the process; a batch only resets the context
(time, state, logs, filters) and hands each world's drive to its source as a zero-order hold, then
the ``Simulator`` advances it in segments: no Python call per step. A world whose run ended is taken
out of contact (:meth:`_World.retire`).

The run, its end and the free-rocking test
------------------------------------------
The adapter implements the four methods of the contact base
(:class:`~rockbench.engines.contact.ContactEngine`): the diagram is the scene, a segment is one
``AdvanceTo``, and the logged plant state gives the block's pose and velocity. The base tests floor
1's end-of-run rule (:func:`~rockbench.reference_solver.classify.run_end`) after each
segment and drops the samples after the stop, so the result does not depend on ``segment_s``; η is
read with the shared peak ratio (:data:`~rockbench.engines.calibration.free_rocking.PEAK_RATIO`).
"""

from __future__ import annotations

import logging
import math
import os

import numpy as np

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import Block
from rockbench.engines.calibration.knobs import Knob
from rockbench.engines.contact import ContactEngine
from rockbench.engines.motion import Motion, pivot_pose, table_track_err_rel, theta_of_quat

#: The calibrated contact's starting point (kept whenever it is within 0.5 % of the target):
#: point stiffness per bottom edge [N/m], hydroelastic modulus [Pa], SAP relaxation time [s] and
#: Hunt–Crossley dissipation [s/m]. Stiff enough that the block's static sinking (m·g/(2k), 3 µm
#: for B3M) is far below the slip and jump tolerances, dissipative enough that the corner does not
#: bounce: the impact is then plastic and η is Housner's (docs/drake.md).
BASE_CONTACT = {"point_stiffness_n_m": 1e6, "hydroelastic_modulus_pa": 1e8, "relaxation_time_s": 1e-3,
                "hunt_crossley_dissipation_s_m": 0.1}

#: Stiffnesses (factors of the base) where the calibration's search varies the dissipation. Point
#: contact: softer ones, since only a contact the step resolves lets the dissipation change η (a
#: stiffer one is near-rigid and plastic whatever its dissipation). Hydroelastic: stiffer ones
#: first (a stiffer pressure field concentrates the contact towards the corner, which lowers η
#: towards Housner's), then softer [-].
_STIFFNESS_FACTORS = {"point": (0.1, 0.03), "hydroelastic": (10.0, 100.0, 0.1, 0.03)}

#: Dissipation ranges searched, log10 [-]: SAP relaxation time [s], Hunt–Crossley [s/m].
_DISSIPATION_LOG10 = {"relaxation_time_s": (-5.0, -1.0), "hunt_crossley_dissipation_s_m": (-3.0, 1.5)}

#: Half extents of the table box of the table drive [m]: wider than any table stroke.
_TABLE_HALF_EXTENTS_M = (5.0, 1.0, 0.05)

#: Stiffness of the table's point-contact material [N/m]: so stiff that the block's sets the contact.
_TABLE_POINT_STIFFNESS = 1e20

_APPROXIMATIONS = ("sap", "similar", "lagged")
_CONTACTS = ("point", "hydroelastic")

#: Scenes kept per process (one per geometry, contact and size); the oldest goes first.
_MAX_SCENES = 32


def _import_pydrake():
    """Import pydrake's pieces; silence the warnings Drake logs while a model is built."""
    import pydrake.all as pd  # noqa: F401 - the optional engine library, its whole API in one import

    logging.getLogger("drake").setLevel(logging.ERROR)
    return pd


class _World:
    """One world: a discrete ``MultibodyPlant`` with its own ``SceneGraph``, one block (planar or free)
    on its table (fixed or driven) in the contact given, its drive (a ``TrajectorySource``) and its log
    (a ``VectorLogSink`` sampling the plant's state at every step). Its discrete update is a solve of
    its own: nothing in it reads another world."""

    def __init__(self, pd, builder, block: Block, s: dict, dt: float, w: int):
        self.planar, self.drive = bool(s["planar"]), s["drive"]
        plant, sg = pd.AddMultibodyPlantSceneGraph(builder, time_step=dt)
        plant.set_name(f"plant{w}")
        sg.set_name(f"scene_graph{w}")
        approx = s["approximation"]
        if approx is not None:
            plant.set_discrete_contact_approximation({
                "sap": pd.DiscreteContactApproximation.kSap,
                "similar": pd.DiscreteContactApproximation.kSimilar,
                "lagged": pd.DiscreteContactApproximation.kLagged}[approx])
        hydro = s["contact"] == "hydroelastic"
        plant.set_contact_model(pd.ContactModel.kHydroelasticWithFallback if hydro else pd.ContactModel.kPoint)
        friction = pd.CoulombFriction(float(s["friction"]), float(s["friction"]))
        # in one order (block, table, joint): a world builds as a lone block always did
        body, geometries = self._add_block(pd, plant, block, s, friction)
        table_joint = self._add_table(pd, plant, block, s, friction)
        joint = self._add_planar_joint(pd, plant, body) if self.planar else None
        plant.Finalize()
        self.plant, self.scene_graph = plant, sg
        self.block_geometries = pd.GeometrySet(geometries)
        self.all_geometries = pd.GeometrySet(sg.model_inspector().GetAllGeometryIds())
        self._index_state(plant, body, joint, table_joint)
        self.source = builder.AddSystem(pd.TrajectorySource(pd.PiecewisePolynomial(np.zeros((self.nv, 1)))))
        self.source.set_name(f"drive{w}")
        builder.Connect(self.source.get_output_port(), plant.get_applied_generalized_force_input_port())
        self.logger = pd.LogVectorOutput(plant.get_state_output_port(), builder, dt)
        self.retired = None   # the context's filter that takes the block out of contact, once retired
        self._pd = pd

    @staticmethod
    def _add_planar_joint(pd, plant, body):
        """The block's planar joint: frame F with x along world z, y along world x, z along world +y (so
        the joint's rotation is the contract's θ about +y); the block's frame M rotated the same way."""
        rot = pd.RotationMatrix(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]))
        F = plant.AddFrame(pd.FixedOffsetFrame("plane_F", plant.world_frame(), pd.RigidTransform(rot)))
        M = plant.AddFrame(pd.FixedOffsetFrame("plane_M", body.body_frame(), pd.RigidTransform(rot)))
        return plant.AddJoint(pd.PlanarJoint("plane", F, M, np.zeros(3)))

    def _add_block(self, pd, plant, block: Block, s: dict, friction):
        """The block and its contact geometry: a compliant hydroelastic box, or a small sphere at each
        bottom corner (point contact); returns the body and its geometries."""
        b, h, d, m = block.width_m, block.height_m, block.depth_m, block.mass_kg
        body = plant.AddRigidBody("block", pd.SpatialInertia.SolidBoxWithMass(m, b, d, h))

        def material(stiffness, edge_share: float = 1.0):
            props = pd.ProximityProperties()
            diss = s["hunt_crossley_dissipation_s_m"]
            pd.AddContactMaterial(dissipation=diss, point_stiffness=(None if stiffness is None else stiffness * edge_share),
                                  friction=friction, properties=props)
            if s["relaxation_time_s"] is not None:
                props.AddProperty("material", "relaxation_time", float(s["relaxation_time_s"]))
            return props

        if s["contact"] == "hydroelastic":
            props = material(None)
            modulus = s["hydroelastic_modulus_pa"] if s["hydroelastic_modulus_pa"] is not None else 1e8
            pd.AddCompliantHydroelasticProperties(resolution_hint=min(b, d, h) / 4, hydroelastic_modulus=modulus,
                                                  properties=props)
            return body, [plant.RegisterCollisionGeometry(body, pd.RigidTransform(), pd.Box(b, d, h), "block", props)]
        r = float(s["corner_radius_m"])
        corners = [(1, 0.0), (-1, 0.0)] if self.planar else [(sx, sy) for sx in (1, -1) for sy in (1, -1)]
        share = 1.0 if self.planar else 0.5
        return body, [plant.RegisterCollisionGeometry(
            body, pd.RigidTransform([sx * (b / 2 - r), sy * (d / 2 - r), -h / 2 + r]), pd.Sphere(r),
            f"corner{i}", material(s["point_stiffness_n_m"], share)) for i, (sx, sy) in enumerate(corners)]

    def _add_table(self, pd, plant, block: Block, s: dict, friction):
        """The table: the world's half-space (inertial drive) or a heavy box on a prismatic joint (table
        drive); sets ``push_mass`` (the mass the drive force accelerates) and returns the table's joint
        (None: fixed)."""
        hydro = s["contact"] == "hydroelastic"
        m = block.mass_kg
        self.push_mass = m
        tprops = pd.ProximityProperties()
        if s["settings"] == "shipped" and not hydro:
            pd.AddContactMaterial(friction=friction, properties=tprops)
        else:
            pd.AddContactMaterial(dissipation=0.0, point_stiffness=_TABLE_POINT_STIFFNESS, friction=friction,
                                  properties=tprops)
            tprops.AddProperty("material", "relaxation_time", 0.0)
        if hydro:
            pd.AddRigidHydroelasticProperties(properties=tprops)
        if self.drive != "table":
            plant.RegisterCollisionGeometry(plant.world_body(), pd.RigidTransform(), pd.HalfSpace(), "table", tprops)
            return None
        mt = float(s["table_mass_ratio"]) * m
        hx, hy, hz = _TABLE_HALF_EXTENTS_M
        table = plant.AddRigidBody("table", pd.SpatialInertia.SolidBoxWithMass(mt, 2 * hx, 2 * hy, 2 * hz))
        plant.RegisterCollisionGeometry(table, pd.RigidTransform([0, 0, -hz]), pd.Box(2 * hx, 2 * hy, 2 * hz),
                                        "table", tprops)
        joint = plant.AddJoint(pd.PrismaticJoint("table_x", plant.world_frame(), table.body_frame(), [1.0, 0.0, 0.0]))
        self.push_mass = mt + m
        return joint

    def _index_state(self, plant, body, joint, table_joint) -> None:
        """Where the block (and table) sits in the plant's state: ``cols``, the columns of the world's
        row (block q, table q, block v, table v), whose places ``iq``/``iv`` name; ``force_index``, the
        dof the drive pushes."""
        nq, nv = plant.num_positions(), plant.num_velocities()
        if self.planar:
            q0, v0 = joint.position_start(), joint.velocity_start()
            q, v, push = list(range(q0, q0 + 3)), list(range(v0, v0 + 3)), v0 + 1   # q: (z, x, θ); v: (ż, ẋ, θ̇)
        else:
            q0, v0 = body.floating_positions_start(), body.floating_velocities_start_in_v()
            q, v, push = list(range(q0, q0 + 7)), list(range(v0, v0 + 6)), v0 + 3   # q: (qw..qz, x, y, z); v: (ω, v)
        if table_joint is not None:
            q, v, push = q + [table_joint.position_start()], v + [table_joint.velocity_start()], table_joint.velocity_start()
        self.cols, self.force_index = np.array(q + [nq + i for i in v], dtype=int), push
        o = 3 if self.planar else 7   # the row's first velocity: after the block's q
        o += table_joint is not None
        self.iq = {"z": 0, "x": 1, "th": 2} if self.planar else {"quat": 0, "x": 4, "y": 5, "z": 6}
        self.iv = {"z": o, "x": o + 1, "th": o + 2} if self.planar else {"wx": o, "th": o + 1, "x": o + 3, "z": o + 5}
        if table_joint is not None:
            self.iq["table"], self.iv["table"] = o - 1, len(self.cols) - 1
        self.nq, self.nv = nq, nv

    def bind(self, root_context) -> None:
        """Find the world's contexts in the diagram's ``root_context``."""
        self.plant_context = self.plant.GetMyMutableContextFromRoot(root_context)
        self.sg_context = self.scene_graph.GetMyMutableContextFromRoot(root_context)
        self.root_context = root_context   # the log's: a sink finds its log from the root

    def place(self, block: Block, theta0: float) -> None:
        """The block at rest at angle ``theta0`` (pivoting on the lower corner), the table at rest at x = 0;
        back in contact if it was retired."""
        if self.retired is not None:
            self.scene_graph.collision_filter_manager(self.sg_context).RemoveDeclaration(self.retired)
            self.retired = None
        xc, zc = pivot_pose(block, theta0)
        q, cols = np.zeros(self.nq), self.cols
        if self.planar:
            q[cols[self.iq["z"]]], q[cols[self.iq["x"]]], q[cols[self.iq["th"]]] = zc, xc, theta0
        else:
            i = cols[self.iq["quat"]]
            q[i:i + 4] = (math.cos(theta0 / 2), 0.0, math.sin(theta0 / 2), 0.0)
            q[cols[self.iq["x"]]], q[cols[self.iq["z"]]] = xc, zc
        self.plant.SetPositions(self.plant_context, q)
        self.plant.SetVelocities(self.plant_context, np.zeros(self.nv))

    def retire(self) -> None:
        """The block out of contact from the next step (a filter in the context): it falls freely, and
        its plant's solve has no contact to solve. Locking its joints would take it out of the solve,
        but Drake 1.51.1 crashes (a segmentation fault in ``AdvanceTo``) with a locked tree."""
        pd = self._pd
        manager = self.scene_graph.collision_filter_manager(self.sg_context)
        self.retired = manager.ApplyTransient(pd.CollisionFilterDeclaration().ExcludeBetween(
            self.block_geometries, self.all_geometries))

    def set_drive(self, dt: float, force: np.ndarray) -> None:
        """The generalized force on the driven dof during each step ``[tₙ, tₙ₊₁]``, ``force[n]`` (zero after)."""
        n = len(force)
        # a hold centred on the step starts, so a step's update at tₙ (± round-off) sees value n
        breaks = np.concatenate(([-0.5 * dt], (np.arange(n) + 0.5) * dt, [(n + 0.5) * dt + 1e9]))
        values = np.zeros((self.nv, n + 2))
        values[self.force_index, :n] = force
        self.source.UpdateTrajectory(self._pd.PiecewisePolynomial.ZeroOrderHold(breaks, values))

    def rows(self, n_from: int, n_to: int, first: int) -> np.ndarray:
        """The world's rows of samples ``n_from + 1 … n_to`` from its log, whose first column is sample
        ``first``; the log cleared."""
        log = self.logger.FindMutableLog(self.root_context)
        rows = log.data()[self.cols, n_from + 1 - first:n_to + 1 - first].T.astype(float)
        log.Clear()
        return rows


class _Scene:
    """One built diagram of ``n_worlds`` worlds (:class:`_World`), each a plant of its own, advanced by
    one ``Simulator``: one ``AdvanceTo`` steps them all, and a world's step is its own solve, so its θ
    is the same bit for bit in any batch (``tests/engines/test_batch_independence.py``).

    ``key`` is everything the diagram depends on; a batch with the same key and size reuses it.
    """

    def __init__(self, block: Block, s: dict, dt: float, n_worlds: int):
        pd = _import_pydrake()
        self.dt = dt
        self.planar = bool(s["planar"])
        self.drive = s["drive"]
        self.n_worlds = n_worlds
        builder = pd.DiagramBuilder()
        self.worlds = [_World(pd, builder, block, s, dt, w) for w in range(n_worlds)]
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        for world in self.worlds:
            world.bind(self.context)
        w0 = self.worlds[0]
        self.iq, self.iv, self.push_mass = w0.iq, w0.iv, w0.push_mass
        self.simulator = pd.Simulator(self.diagram, self.context)

    def retire(self, w: int) -> None:
        """World ``w`` out of contact from the next step; its rows from here on are dropped."""
        self.worlds[w].retire()

    def drive_of(self, pulse) -> np.ndarray:
        """The drive of every step under ``pulse`` (None: none): the step average of ü times the mass
        the drive accelerates, −m (inertial) or M_table + m (table)."""
        if pulse is None:
            return np.zeros(0)
        n_pulse = int(math.ceil(pulse.duration_s / self.dt - 1e-9))
        v = pulse.vel(np.arange(n_pulse + 1) * self.dt)
        return (-1.0 if self.drive == "inertial" else 1.0) * self.push_mass * np.diff(v) / self.dt

    def angles(self, data: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """θ (rotation about +y) [rad] and θ̇ [rad/s] from one world's rows."""
        if self.planar:
            return data[:, self.iq["th"]], data[:, self.iv["th"]]
        i = self.iq["quat"]
        return theta_of_quat(data[:, i], data[:, i + 1], data[:, i + 2], data[:, i + 3]), data[:, self.iv["th"]]

    def start(self, block: Block, pulses: list, theta0: float) -> None:
        """World ``w`` under ``pulses[w]`` (one per world; the worlds beyond them undriven), at rest at
        ``theta0``, in contact."""
        for w, world in enumerate(self.worlds):
            world.set_drive(self.dt, self.drive_of(pulses[w] if w < len(pulses) else None))
            world.place(block, theta0)
            world.logger.FindMutableLog(self.context).Clear()
        self.context.SetTime(0.0)
        self.logged = 0
        self.simulator.Initialize()

    def advance(self, n_from: int, n_to: int) -> np.ndarray:
        """Advance to step ``n_to``; every world's rows of samples ``n_from + 1 … n_to`` (``n_from = -1``:
        from sample 0), ``(W, n, k)``. The logs keep no more than the segment: read, they are cleared."""
        self.simulator.AdvanceTo(n_to * self.dt)
        rows = np.stack([world.rows(n_from, n_to, self.logged) for world in self.worlds])
        self.logged = n_to + 1
        return rows


class DrakeAdapter(ContactEngine):
    """The rocking block in Drake (see the module docstring for the model and the end of a run).

    Settings
    --------
    settings : {"calibrated", "shipped"}
        Contact parameters calibrated to the case's η, or Drake as shipped.
    contact : {"point", "hydroelastic"}
        Point contact at the bottom corners, or hydroelastic contact of the whole base.
    approximation : {"sap", "similar", "lagged"} or None
        Drake's discrete contact approximation (None: ``sap`` calibrated, Drake's ``lagged`` as shipped).
    drive : {"inertial", "table"}
        How the pulse enters (inertial force at the centre of mass, or a driven table body).
    planar : bool
        Keep the block in the vertical x–z plane (a planar joint), or a free 3-D body.
    friction : float
        Coulomb friction block–table, static = dynamic [-].
    point_stiffness_n_m : float or None
        Point-contact stiffness per bottom edge [N/m]; given, it replaces calibration.
    hydroelastic_modulus_pa : float or None
        The block's hydroelastic modulus [Pa]; given, it replaces calibration.
    relaxation_time_s : float or None
        SAP's Kelvin–Voigt dissipation time scale [s]; given, it replaces calibration.
    hunt_crossley_dissipation_s_m : float or None
        Hunt–Crossley dissipation of ``similar``/``lagged`` [s/m]; given, it replaces calibration.
    corner_radius_m : float
        Radius of the corner spheres of point contact [m] (they sit inside the corners, flush).
    table_mass_ratio : float
        Table mass over block mass for ``drive="table"`` [-].
    tail_s, min_tail_s, segment_s : float
        Longest and shortest simulated time after the pulse, and the length of one simulator
        advance between end-of-run tests [s].
    """

    name = "drake"
    module = "pydrake"
    install_hint = "install it with `pip install 'rockbench[drake]'` (or `pip install drake`; 1.51.1 tested)."
    #: Drake's own default step (MultibodyPlantConfig.time_step), what it runs at as shipped
    own_dt_s = 1e-3
    #: the contact base's batch hooks run worlds of one diagram, a plant each (:class:`_Scene`); one world
    #: a batch, since K plants cost K worlds' steps and a world retired early still steps (docs/drake.md,
    #: "Speed and batches")
    batching = "native"
    max_worlds = 1
    #: the loop's segments end at each run's marks and last at most this after its pulse [s]
    #: (:mod:`rockbench.engines.loop`): Drake's discrete steps do not depend on where ``AdvanceTo``
    #: stops (runs measured bit for bit the same), and fewer steps run past a stop: 0.04 s here and
    #: segments of 0.05 s before the pulse's end leave 2.4 % of the steps past the stops (docs/speed.md)
    near_segment_s = 0.04
    SETTINGS = {"contact": "point", "corner_radius_m": 1e-4, "table_mass_ratio": 1000.0, "tail_s": 2.0,
                "min_tail_s": 0.25, "segment_s": 0.05}
    #: Drake's own contact: the stiffness and dissipation from its default penetration allowance
    SHIPPED = {"point_stiffness_n_m": None, "hydroelastic_modulus_pa": None, "relaxation_time_s": None,
               "hunt_crossley_dissipation_s_m": None}
    MODE_DEFAULTS = {"approximation": ("lagged", "sap")}
    START_KEEP_RTOL = 0.005
    CALIBRATION_VERSION = 4

    def validate(self, s: dict) -> None:
        self.choice_setting(s, "contact", _CONTACTS, allow_none=False)
        self.choice_setting(s, "approximation", _APPROXIMATIONS)
        self.number_setting(s, "point_stiffness_n_m", "N/m")
        self.number_setting(s, "hydroelastic_modulus_pa", "Pa")
        self.number_setting(s, "relaxation_time_s", "s", allow_zero=True)
        self.number_setting(s, "hunt_crossley_dissipation_s_m", "s/m", allow_zero=True)
        # the spheres sit inside the corners and move the pivots inwards by their radius
        self.number_setting(s, "corner_radius_m", "m", allow_none=False, maximum=1e-3)
        self.number_setting(s, "table_mass_ratio", allow_none=False)
        unused = [k for k in self.SHIPPED if s[k] is not None and k not in (k.name for k in self.KNOBS)]
        if unused:
            raise ConfigError(f"drake setting {unused[0]!r} does not act on contact = {s['contact']} with approximation "
                              f"= {self._approximation(s)}: give {' and '.join(k.name for k in self.KNOBS)} instead.")

    def build(self, block: Block, s: dict, dt: float) -> dict:
        """What :meth:`start` picks the diagram by (its size is the batch's): the block, settings and step."""
        return {"block": block, "s": s, "dt": dt}

    def start(self, run: dict, block: Block, s: dict, dt: float, pulses: list, theta0: float, n_steps: int):
        """The batch's worlds on a diagram of as many worlds (built once per size and reused)."""
        sc = _scene(block, s, dt, len(pulses))
        run["scene"] = sc
        sc.start(block, pulses, theta0)
        return sc.advance(-1, 0)

    def advance(self, run: dict, n_from: int, n_to: int) -> np.ndarray:
        return run["scene"].advance(n_from, n_to)

    def retire(self, run: dict, w: int) -> None:
        run["scene"].retire(w)

    def read(self, run: dict, block: Block, s: dict, data: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        sc = run["scene"]
        iq, iv = sc.iq, sc.iv
        th, om = sc.angles(data)
        diag: dict = {"contact": s["contact"], "approximation": s["approximation"]}
        u_tab = v_tab = None
        if "table" in iq:
            u_tab, v_tab = data[:, iq["table"]], data[:, iv["table"]]
            if pulse is not None:
                diag["table_track_err_rel"] = table_track_err_rel(u_tab, pulse, t_s)
        if not sc.planar:
            diag["max_lateral_drift_m"] = float(np.nanmax(np.abs(data[:, iq["y"]])))
        return Motion(x_m=data[:, iq["x"]], z_m=data[:, iq["z"]], theta_rad=th, vx_m_s=data[:, iv["x"]],
                      vz_m_s=data[:, iv["z"]], theta_dot_rad_s=om, table_x_m=u_tab, table_vx_m_s=v_tab, diagnostics=diag)

    def _approximation(self, s: dict) -> str:
        return s["approximation"] or ("lagged" if s["settings"] == "shipped" else "sap")

    @property
    def KNOBS(self) -> tuple:  # noqa: N802 - the declaration, per contact model and approximation
        """The calibration: the stiff, plastic contact of :data:`BASE_CONTACT` first (point stiffness
        1e6 N/m per edge or modulus 1e8 Pa; relaxation time 1 ms for SAP, Hunt–Crossley 0.1 s/m
        otherwise), which gives η close to Housner's, kept within 0.5 %; otherwise the stiffnesses
        :data:`_STIFFNESS_FACTORS` × the base one by one, at each the dissipation's range ends
        (:data:`_DISSIPATION_LOG10`) and a bisection of its logarithm when they bracket the target (less
        dissipation, higher η: the corner comes off the table more elastically), until a candidate is
        within 0.25 %. A contact given by hand takes the base for what it leaves out."""
        s = self.settings
        kkey = "hydroelastic_modulus_pa" if s["contact"] == "hydroelastic" else "point_stiffness_n_m"
        dkey = "relaxation_time_s" if self._approximation(s) == "sap" else "hunt_crossley_dissipation_s_m"
        k0, factors = BASE_CONTACT[kkey], _STIFFNESS_FACTORS[s["contact"]]
        return (Knob(kkey, "N/m" if kkey == "point_stiffness_n_m" else "Pa", tuple(k0 * f for f in factors),
                     start=k0, until="close"),
                Knob(dkey, "s" if dkey == "relaxation_time_s" else "s/m", _DISSIPATION_LOG10[dkey],
                     start=BASE_CONTACT[dkey], log10=True, bisect_steps=10, bisect_regular=False))


#: This process's scenes, by everything a diagram depends on and its size (a forked worker builds its own).
_SCENES: dict = {}


def _scene(block: Block, s: dict, dt: float, n_worlds: int) -> _Scene:
    """The diagram of ``n_worlds`` worlds for the block, settings and step: this process's, else built."""
    key = (os.getpid(), block.width_m, block.height_m, block.depth_m, block.mass_kg, dt, n_worlds,
           tuple((k, s.get(k)) for k in sorted(DrakeAdapter.SETTINGS) if k not in ("tail_s", "min_tail_s", "segment_s")))
    sc = _SCENES.get(key)
    if sc is None:
        sc = _Scene(block, s, dt, n_worlds)
        if len(_SCENES) >= _MAX_SCENES:
            _SCENES.pop(next(iter(_SCENES)))
        _SCENES[key] = sc
    return sc
