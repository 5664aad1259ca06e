"""The rocking block in Exudyn: a rigid box on a table, touching it through Exudyn's own
penalty contact (``ObjectContactSphereTriangle``).

Model
-----
- **Block**: a homogeneous rigid box b × d × h with the case's mass. Planar by default
  (``planar=True``): an Exudyn ``ObjectRigidBody2D`` moving in Exudyn's x–y plane (x horizontal,
  y up), the engine's equivalent of "slide x, slide z, hinge y". ``planar=False`` makes it a free
  3-D ``ObjectRigidBody`` (Euler-parameter node, z up) that may slide, twist and tip sideways.
- **Contact**: one small sphere (radius ``sphere_radius_m``) at each bottom corner, its centre
  on the side face one radius above the base so that it touches the table exactly under the
  corner (uplift at exactly g·tanα; the pivot then rolls on the sphere, an error of order r/h,
  0.5 % for B3M). The sphere must be larger than the deepest penetration of an impact: a sphere
  whose centre sinks below the table plane is pushed through it (Exudyn measures an unsigned
  distance), so such a run is an ``engine-error``. Each sphere touches one large triangle fixed
  to the table through
  ``ObjectContactSphereTriangle``: linear penalty stiffness, linear normal damping and regularised
  Coulomb friction, all evaluated by Exudyn. No constraint or impact law of ours replaces it: the
  restitution the block shows is what the engine's contact produces.
- **Anti-slip**: friction coefficient ``friction`` = 10 by default. The tapes of the experiments
  keep the blocks in place, and a block pivoting on a corner needs a friction coefficient of at
  least the ratio of horizontal to vertical contact force, which reaches a few units in the
  strongest pulses (docs/physics.md §8: friction 1 lets blocks slide above 3–4 g). Exudyn's contact has
  no separate no-slip mode; its friction is regularised below ``friction_zone_m_s``, which lets a
  loaded corner creep at about ``friction_zone_m_s · (F_t / (μ F_n))``: 1e-3 m/s keeps that below
  0.1 mm per second of rocking while the Newton iterations still converge.
- **Drive** (setting ``drive``): ``inertial`` (default) applies the horizontal force −m·ü(t) at
  the centre of mass of a block standing on a fixed table, exact for a rigid table (the block's
  frame is the table's frame); ``table`` moves a table body along u(t) through a prescribed
  coordinate constraint, so the contact sees the table's velocity. Both are Exudyn symbolic user
  functions (evaluated in C++), whose parameters (a₀, ω, pulse length) are symbolic variables reset
  between cells; the system is built once per block and setting and reused. A recorded pulse
  (``RecordPulse``) has no closed form and falls back to a Python user function.
- **Solver**: Exudyn's implicit generalized-α (shipped default, spectral radius 0.9) with adaptive
  step reduction on Newton failure; the Newton tolerances are loosened to 1e-6 because the shipped
  1e-8 makes Newton stall when the block settles on both corners (found in probes), and the
  modified Newton method refreshes its Jacobian after 3 iterations instead of 8 (same tolerances,
  10–27 % less time: the stiff regularised friction makes an old Jacobian converge slowly). A run whose
  Newton still stalls (a few violent impacts per thousand cells) is repeated at half the step,
  then with a full Newton method; only if all three fail is the cell an ``engine-error``.

End of a run
------------
The run is the contact-engine skeleton's loop (:mod:`rockbench.engines.skeleton`), integrated in
segments of ``segment_s`` inside Exudyn's C++ solver, with every contact engine's one end-of-run
rule (:func:`~rockbench.reference_solver.classify.run_end`) tested at every row Exudyn's sensors
stored, at its own time (Exudyn shortens its step where Newton struggles, so a segment may hold
more rows than steps: the rule counts rows, not steps). A run also ends where Exudyn's solver
stopped (Newton did not converge even at its smallest step; the solver retries below). The shared
classifier decides the outcome from the samples.

Restitution
-----------
Exudyn has no η of its own. Its penalty contact with linear damping (the shipped impact model 0)
lets the landing corner bounce, which breaks the rocking model (jumps) whenever an impact is
strong; the probes found that Exudyn's impact model 2 (Gonthier et al., hysteretic damping that
reaches a prescribed normal restitution coefficient without sticky forces) with a nearly plastic
coefficient lands the corner without bouncing, which is exactly Housner's assumption, and gives
η within 0.5 % of η_H for B3M and B6M. ``settings="calibrated"`` (default) therefore searches
that coefficient (:meth:`ExudynAdapter.calibrate`) for the case's target η and caches the result
on disk (:mod:`rockbench.engines.calibration`). ``settings="shipped"`` keeps Exudyn's shipped
contact model (impact model 0, restitution coefficient 1, no damping) except the stiffness, whose
shipped value is 0 (no contact at all) and is set by the same rule as the calibrated one
(:func:`default_stiffness_n_m`).
"""

from __future__ import annotations

import itertools
import math
import time
from types import SimpleNamespace

import numpy as np

from ..reference_solver.errors import ConfigError, EngineError
from ..reference_solver.model import G, Block
from ..reference_solver.pulses import Pulse
from ..reference_solver.restitution import Restitution
from . import price as _price
from .base import CalibrationResult, Trajectory
from .contact import POINTS_TRIED, ContactEngineAdapter, overturn_certain
from .free_rocking import FREE_ROCKING_IMPACTS
from .pick import Candidate, damping_ratio_of_restitution, pick, regular
from .knobs import Knob
from .skeleton import Motion, SteppedContactAdapter

#: Static penetration of one corner under half the block's weight that sets the default contact
#: stiffness [m]: 1.34 µm, the value of k = 2e6 N/m for B3M, inside the range docs/physics.md §8 gives as
#: reproducing Housner's η (2e6–2e7 N/m at Δt ≤ 1e-4 s).
STATIC_PENETRATION_M = 1.34e-6

#: Exudyn contact restitution coefficients (impact model 2) tried by the calibration's scan [-].
CALIBRATION_RESTITUTIONS = (0.02, 0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.8)

#: The scan for the distributed contact (docs/contact.md): its η rises with the coefficient from about
#: η_H, and the probe (tests/measurements/probes/probe_eta_m_exudyn.py) found η_M between 0.1 and 0.3 for B3M.
CALIBRATION_RESTITUTIONS_DIST = (0.05, 0.08, 0.1, 0.12, 0.14, 0.17, 0.2, 0.24, 0.28, 0.33, 0.4, 0.5)

#: Relative tolerance of a calibration (the issue asks for 1 %) [-].
CALIBRATION_RTOL = 0.01

#: The knob of the row's calibration (the corners': ExudynAdapter.CALIBRATION_KNOBS): its ladder,
#: then bisection to within 0.2·CALIBRATION_RTOL (5 halvings at most)
DISTRIBUTED_KNOBS = (Knob("contact_restitution", "", "damping", lambda block, dt: CALIBRATION_RESTITUTIONS_DIST,
                          bisect_steps=5, bisect_rtol=0.2 * CALIBRATION_RTOL),)

#: Half the side of the table triangle [m]: far larger than any table travel of a pulse.
_TABLE_HALF_SIZE_M = 1.0e3

#: the contact parameters a model is built from (in the order a measurement records them)
_CONTACT_KEYS = ("stiffness_n_m", "contact_points", "damping_n_s_m", "impact_model", "restitution_coefficient",
                 "friction", "friction_zone_m_s", "sphere_radius_m", "spectral_radius", "modified_newton_iterations")

#: the symbolic variables of a harmonic pulse: a₀, ω, its length, cosine (1) or sine (0), and the
#: table's displacement and velocity at its end
_PULSE_VARS = ("a0", "w", "tb", "cs", "utb", "vtb")


def default_stiffness_n_m(block: Block) -> float:
    """Contact stiffness of one corner sphere [N/m]: ``k = m·g / (2·δ)`` with δ = 1.34 µm."""
    return block.mass_kg * G / (2.0 * STATIC_PENETRATION_M)


_COUNTER = itertools.count()


class _Model:
    """One Exudyn system for one block, drive and contact setting, reused across cells."""

    def __init__(self, block: Block, contact: dict, drive: str, planar: bool, dt_s: float,
                 pulse: Pulse | None, theta0_rad: float = 0.0):
        import exudyn as exu   # optional engine library
        import exudyn.itemInterface as ii   # optional engine library

        self.exu, self.ii, self.block, self.drive, self.planar, self.dt_s = exu, ii, block, drive, planar, dt_s
        self.contact, self.r = dict(contact), contact["sphere_radius_m"]
        self.uses_symbolic = pulse is None or pulse.kind != "record"
        # Exudyn's symbolic variables live in one process-wide table: a unique prefix per model
        # keeps two models of one process (a map and a calibration) from sharing pulse values.
        self._pre = f"rb{next(_COUNTER)}_"
        for nm in _PULSE_VARS:
            exu.symbolic.variables.Set(self._pre + nm, 0.0)
        # contact spheres: one per bottom corner, or a row of ``contact_points`` along the base
        # (the outer ones stay under the corners, so the static pivots do not move)
        self.n_points = int(contact.get("contact_points") or 2)
        self.exponent = float(contact.get("stiffness_exponent") or 1.0)
        self.SC = exu.SystemContainer()
        self.mbs = self.SC.AddSystem()
        # the items in this order (Exudyn numbers them as they come)
        table_marker = self._add_table()
        tri, gravity = self._add_block(theta0_rad)
        mcom = self._add_contacts(table_marker, tri, gravity)
        self._inertial_load = None
        if drive == "inertial":
            self._inertial_load = self.mbs.AddLoad(ii.Force(markerNumber=mcom, loadVector=[0.0, 0.0, 0.0]))
        self._add_sensors()
        self._pulse_funcs = []  # keep symbolic expression trees alive as long as the system
        self._install_pulse_functions(pulse)
        self.mbs.Assemble()
        self.ss = self._simulation_settings()

    # -- building -------------------------------------------------------------------------
    def _add_table(self) -> int:
        """The ground and the table: the ground itself (inertial drive) or a body driven along u(t);
        returns the marker the contacts attach to."""
        mbs, ii = self.mbs, self.ii
        ground = mbs.AddObject(ii.ObjectGround())
        if self.drive != "table":
            return mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=ground, localPosition=[0, 0, 0]))
        # a planar body carries the table in both models: its x follows u(t), its height and
        # angle are held at 0 (the triangle lies in its local frame, so it moves with it)
        tnode = mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=[0, 0, 0]))
        table = mbs.AddObject(ii.ObjectRigidBody2D(nodeNumber=tnode, mass=100.0 * self.block.mass_kg, inertia=1.0))
        gnode = mbs.AddNode(ii.NodePointGround(referenceCoordinates=[0, 0, 0]))
        mg0 = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=gnode, coordinate=0))
        self._table_constraints = [
            mbs.AddObject(ii.CoordinateConstraint(markerNumbers=[
                mg0, mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=tnode, coordinate=c))], offset=0.0))
            for c in range(3)]
        return mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=table, localPosition=[0, 0, 0]))

    def _add_block(self, theta0_rad: float):
        """The block (planar or free 3-D body) at rest, or tilted by ``theta0_rad`` onto a corner;
        sets ``node``, ``body``, ``corners_local`` (the bottom corners, measured) and ``spheres_local``
        (the contact spheres' centres); returns the table triangle and the weight."""
        exu, mbs, block, r, L = self.exu, self.mbs, self.block, self.r, _TABLE_HALF_SIZE_M
        b, h, m, d = block.width_m, block.height_m, block.mass_kg, block.depth_m
        row = np.linspace(-b / 2, b / 2, self.n_points)
        x0, z0, phi0 = self._rest_pose_planar(theta0_rad)
        if self.planar:
            # Exudyn's planar bodies move in its x-y plane, y up: the table is the plane y = 0
            # (a triangle spanning x and the out-of-plane z), our θ is minus Exudyn's φ.
            tri = [[-L, 0.0, L], [L, 0.0, L], [0.0, 0.0, -L]]
            self.node = mbs.AddNode(self.ii.NodeRigidBody2D(referenceCoordinates=[0, 0, 0],
                                                            initialCoordinates=[x0, z0, phi0]))
            self.body = mbs.AddObject(self.ii.ObjectRigidBody2D(nodeNumber=self.node, mass=m,
                                                                inertia=block.inertia_cm_kg_m2))
            self.corners_local = np.array([[-b / 2, -h / 2 + r, 0.0], [b / 2, -h / 2 + r, 0.0]])
            self.spheres_local = np.array([[float(x), -h / 2 + r, 0.0] for x in row])
            return tri, [0.0, -m * G, 0.0]
        import exudyn.utilities as eu   # optional engine library
        A0 = np.array([[math.cos(-phi0), 0, math.sin(-phi0)], [0, 1, 0], [-math.sin(-phi0), 0, math.cos(-phi0)]])
        res = mbs.CreateRigidBody(inertia=eu.InertiaCuboid(density=block.density_kg_m3, sideLengths=[b, d, h]),
                                  referencePosition=[x0, 0.0, z0], initialRotationMatrix=A0,
                                  nodeType=exu.NodeType.RotationEulerParameters, returnDict=True)
        self.node, self.body = res["nodeNumber"], res["bodyNumber"]
        self.corners_local = np.array([[sx * b / 2, sy * d / 2, -h / 2 + r] for sy in (-1, 1) for sx in (-1, 1)])
        self.spheres_local = np.array([[float(x), sy * d / 2, -h / 2 + r] for sy in (-1, 1) for x in row])
        return [[-L, -L, 0.0], [L, -L, 0.0], [0.0, L, 0.0]], [0.0, 0.0, -m * G]

    def _add_contacts(self, table_marker: int, tri: list, gravity: list) -> int:
        """The weight at the centre of mass and one sphere–triangle contact per contact sphere (the
        bottom corners, or the row along the base); returns the centre-of-mass marker."""
        exu, ii, mbs, c = self.exu, self.ii, self.mbs, self.contact
        mcom = mbs.AddMarker(ii.MarkerNodePosition(nodeNumber=self.node))
        mbs.AddLoad(ii.Force(markerNumber=mcom, loadVector=gravity))
        for p in self.spheres_local.tolist():
            mc = mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=self.body, localPosition=p))
            dn = mbs.AddNode(ii.NodeGenericData(numberOfDataCoordinates=4, initialCoordinates=[0, 0, 0, 0]))
            mbs.AddObject(ii.ObjectContactSphereTriangle(
                markerNumbers=[mc, table_marker], nodeNumber=dn, sphereRadius=self.r,
                trianglePoints=exu.Vector3DList(tri), includeEdges=0,
                dynamicFriction=c["friction"], frictionProportionalZone=c["friction_zone_m_s"],
                contactStiffness=c["stiffness_n_m"], contactDamping=c["damping_n_s_m"],
                contactStiffnessExponent=self.exponent, restitutionCoefficient=c["restitution_coefficient"],
                impactModel=c["impact_model"]))
        return mcom

    def _add_sensors(self) -> None:
        """Sensors that store the block's state at every step (read by :meth:`samples`): position and
        velocity coordinates (planar), or position, rotation matrix, angular velocity and velocity."""
        OVT = self.exu.OutputVariableType
        kinds = ((OVT.Coordinates, OVT.Coordinates_t) if self.planar else
                 (OVT.Position, OVT.RotationMatrix, OVT.AngularVelocity, OVT.Velocity))
        self.sensors = [self.mbs.AddSensor(self.ii.SensorNode(nodeNumber=self.node, storeInternal=True,
                                                             outputVariableType=k)) for k in kinds]

    def _simulation_settings(self):
        """Exudyn's implicit generalized-α with adaptive steps, the loosened Newton tolerances and
        the Jacobian refresh of the settings (module docstring, "Solver")."""
        ss = self.exu.SimulationSettings()
        ti = ss.timeIntegration
        ti.verboseMode = 0
        ti.newton.relativeTolerance = ti.newton.absoluteTolerance = 1e-6
        ti.generalizedAlpha.spectralRadius = self.contact["spectral_radius"]
        ti.newton.maxModifiedNewtonIterations = self.contact["modified_newton_iterations"]
        ti.adaptiveStep = True
        ss.solution.file.write = False
        ss.solution.sensors.writePeriod = self.dt_s
        return ss

    def _rest_pose_planar(self, theta_rad: float):
        """Centre of mass (x, height) and Exudyn angle for the block standing (θ = 0) or tilted
        onto one corner (θ ≠ 0), its corner sphere(s) pressed in by their static penetration."""
        b, h = self.block.width_m, self.block.height_m
        n = float(self.n_points) if theta_rad == 0.0 else 1.0
        pen = (self.block.mass_kg * G / (n * self.contact["stiffness_n_m"])) ** (1.0 / self.exponent)
        if theta_rad == 0.0:
            return 0.0, h / 2 - pen, 0.0
        s = 1.0 if theta_rad > 0 else -1.0
        # pivot sphere centre at (s·b/2, r − pen); COM = centre + R(θ)·(−s·b/2, h/2 − r), x–z frame;
        # rotation about +y by θ moves +z towards +x: x' = c·x + s·z, z' = −s·x + c·z
        c, sn = math.cos(theta_rad), math.sin(theta_rad)
        vx, vz = -s * b / 2, h / 2 - self.r
        return s * b / 2 + c * vx + sn * vz, self.r - pen + (-sn * vx + c * vz), -theta_rad

    # -- pulse ----------------------------------------------------------------------------
    def _install_pulse_functions(self, pulse: Pulse | None):
        """The drive as user functions: symbolic (evaluated in C++, the pulse's parameters in the
        model's symbolic variables) for a harmonic pulse, Python for a recorded one."""
        from exudyn.advancedUtilities import CreateSymbolicUserFunction   # optional engine library

        mbs, esym, m = self.mbs, self.exu.symbolic, self.block.mass_kg

        def var():
            return [esym.variables[self._pre + nm] for nm in _PULSE_VARS]

        def acc_sym(t):
            a0, w, tb, cs, _, _ = var()
            return esym.IfThenElse(t <= tb, a0 * ((1 - cs) * esym.sin(w * t) + cs * esym.cos(w * t)),
                                   esym.Real(0.0))

        def disp_sym(t):
            a0, w, tb, cs, utb, vtb = var()
            inside = a0 / (w * w) * ((1 - cs) * (w * t - esym.sin(w * t)) + cs * (1 - esym.cos(w * t)))
            return esym.IfThenElse(t <= tb, inside, utb + vtb * (t - tb))

        def vel_sym(t):
            a0, w, tb, cs, _, vtb = var()
            inside = a0 / w * ((1 - cs) * (1 - esym.cos(w * t)) + cs * esym.sin(w * t))
            return esym.IfThenElse(t <= tb, inside, vtb)

        if self.drive == "inertial":
            if self.uses_symbolic:
                def load_uf(mbs, t, load):
                    f = -m * acc_sym(t)
                    return [f, 0.0, 0.0]
                uf = CreateSymbolicUserFunction(mbs, load_uf, "loadVectorUserFunction", self._inertial_load)
            else:
                def uf(mbs, t, load, _p=pulse):
                    return [-m * float(_p.accel(t)), 0.0, 0.0]
            self._pulse_funcs.append(uf)
            mbs.SetLoadParameter(self._inertial_load, "loadVectorUserFunction", uf)
            return
        cx = self._table_constraints[0]
        if self.uses_symbolic:
            def off_uf(mbs, t, itemNumber, lOffset):
                return disp_sym(t)

            def off_t_uf(mbs, t, itemNumber, lOffset):
                return vel_sym(t)
            f0 = CreateSymbolicUserFunction(mbs, off_uf, "offsetUserFunction", cx)
            f1 = CreateSymbolicUserFunction(mbs, off_t_uf, "offsetUserFunction_t", cx)
        else:
            def f0(mbs, t, itemNumber, lOffset, _p=pulse):
                return float(_p.disp(t))

            def f1(mbs, t, itemNumber, lOffset, _p=pulse):
                return float(_p.vel(t))
        self._pulse_funcs += [f0, f1]
        mbs.SetObjectParameter(cx, "offsetUserFunction", f0)
        mbs.SetObjectParameter(cx, "offsetUserFunction_t", f1)

    def set_pulse(self, pulse: Pulse | None):
        """Load a harmonic pulse's parameters into the symbolic variables (None: no excitation)."""
        if pulse is None:
            vals = (0.0, 1.0, -1.0, 0.0, 0.0, 0.0)
        else:
            tb = pulse.duration_s
            vals = (float(pulse.amplitude_mps2), float(pulse.omega_rad_s), float(tb),
                    1.0 if pulse.kind == "cosine" else 0.0, float(pulse.disp(tb)), float(pulse.vel(tb)))
        for nm, val in zip(_PULSE_VARS, vals):
            self.exu.symbolic.variables.Set(self._pre + nm, val)

    # -- running (the skeleton's hooks call these) ----------------------------------------
    def start(self, chunk_steps: int, full_newton: bool) -> np.ndarray:
        """Initialise Exudyn's solver for segments of ``chunk_steps`` steps (``full_newton``: a new
        Jacobian at every Newton iteration); no samples yet (the first segment stores t = 0)."""
        ss = self.ss
        ss.timeIntegration.newton.useModifiedNewton = not full_newton
        self.n_chunk, self.steps, self.n_raw, self.t_raw = chunk_steps, 0, 0, -math.inf
        ss.timeIntegration.startTime = 0.0
        ss.timeIntegration.endTime = chunk_steps * self.dt_s
        ss.timeIntegration.numberOfSteps = chunk_steps
        self.solver = self.exu.MainSolverImplicitSecondOrder()
        self.t0 = time.perf_counter()
        ok = self.solver.InitializeSolver(self.mbs, ss)
        self.message = None if ok else "Exudyn could not initialise its solver"
        self.first = True
        return np.empty((0, 7 if self.planar else 19))

    def advance(self) -> np.ndarray:
        """One segment; the state rows the sensors stored in it (:meth:`rows`)."""
        if self.message is not None:
            return np.empty((0, 7 if self.planar else 19))
        if not self.first:
            self.solver.it.endTime = self.mbs.systemData.GetTime() + self.n_chunk * self.dt_s
        self.first = False
        ok = self.solver.SolveSteps(self.mbs, self.ss)
        self.steps += self.n_chunk
        if not ok:
            self.message = (f"Exudyn's solver stopped at t = {self.mbs.systemData.GetTime():.6g} s "
                            "(Newton did not converge even at the minimum step size)")
        return self.rows()

    def finish(self) -> float:
        """Close the solver; the wall time since :meth:`start` [s]."""
        self.solver.FinalizeSolver(self.mbs, self.ss)
        return time.perf_counter() - self.t0

    def rows(self) -> np.ndarray:
        """The sensors' rows stored since the last call: ``t, x, y, φ, ẋ, ẏ, φ̇`` (planar) or ``t``,
        position, rotation matrix, angular velocity, velocity (3-D). Each segment boundary is stored
        twice (end of one segment, start of the next): a row within half a step of the one
        before is dropped."""
        parts = [self.mbs.GetSensorStoredData(s) for s in self.sensors]
        raw = (np.concatenate([parts[0]] + [x[:, 1:] for x in parts[1:]], axis=1) if len(parts[0])
               else np.empty((0, 7 if self.planar else 19)))[self.n_raw:]
        keep = np.diff(np.concatenate([[self.t_raw], raw[:, 0]])) > 0.5 * self.dt_s
        self.n_raw += raw.shape[0]
        if raw.shape[0]:
            self.t_raw = raw[-1, 0]
        return raw[keep]

    def angles(self, rows: np.ndarray):
        """θ [rad] and θ̇ [rad/s] of state rows (:meth:`rows`)."""
        if self.planar:
            return -rows[:, 3], -rows[:, 6]
        A = rows[:, 4:13].reshape(-1, 3, 3)
        return np.arctan2(A[:, 0, 2], A[:, 2, 2]), rows[:, 14]

    def samples(self, rows: np.ndarray):
        """From the state rows of a run: the corner sphere centres, the block's own bottom corners,
        the centre of mass's x, height and velocity.

        Both point sets are ``(n, ncorners, 2)`` arrays of (x, height) [m]. The sphere centres
        give the clearance to the table (``height − r``); the block's corners (one radius below
        the centres in the block's frame) give slip, since a sphere centre also moves by ``r·θ``
        when its sphere rolls, which is not slip. The last array is ``(n, 4)``: the centre of
        mass's x and height [m] and its horizontal and vertical velocity [m/s].
        """
        nc = len(self.corners_local)
        pts = np.concatenate([self.corners_local, self.corners_local], axis=0)
        pts[nc:, 1 if self.planar else 2] -= self.r
        if self.planar:
            x, y, phi = rows[:, 1], rows[:, 2], rows[:, 3]
            c, s = np.cos(phi), np.sin(phi)
            wx = x[:, None] + c[:, None] * pts[None, :, 0] - s[:, None] * pts[None, :, 1]
            wz = y[:, None] + s[:, None] * pts[None, :, 0] + c[:, None] * pts[None, :, 1]
            com = np.stack([x, y, rows[:, 4], rows[:, 5]], axis=1)
        else:
            world = rows[:, None, 1:4] + np.einsum("nij,cj->nci", rows[:, 4:13].reshape(-1, 3, 3), pts)
            wx, wz = world[..., 0], world[..., 2]
            com = np.stack([rows[:, 1], rows[:, 3], rows[:, 16], rows[:, 18]], axis=1)
        both = np.stack([wx, wz], axis=-1)
        return both[:, :nc], both[:, nc:], com


class ExudynAdapter(SteppedContactAdapter):
    """Exudyn (multibody dynamics, C++ core): the block on a table through penalty contact.

    Settings
    --------
    settings : {"calibrated", "shipped"}
        Contact calibrated to the case's η (default), or Exudyn's shipped contact defaults.
    drive : {"inertial", "table"}
        How the pulse enters: the force −m·ü at the centre of mass, or a table body moved along u(t).
    planar : bool
        Keep the block in the vertical plane of the excitation (default) or a free 3-D body.
    friction : float
        Coulomb friction coefficient of the corner contacts [-] (default 10, see the module notes).
    friction_zone_m_s : float
        Sliding speed below which Exudyn's friction is proportional to the speed [m/s].
    contact_stiffness_n_m : float or None
        Contact stiffness of each corner [N/m]; None: :func:`default_stiffness_n_m`.
    contact_restitution : float or None
        Exudyn's normal restitution coefficient of the corner contacts with its impact model 2
        (Gonthier et al.) [-]; None: calibrated to the case's η (with ``calibrated``).
    contact_damping_n_s_m : float
        Linear normal contact damping [N s/m], added by Exudyn to every impact model (default 0).
    sphere_radius_m : float
        Radius of the corner contact spheres [m].
    contact : {"auto", "corners", "distributed"}
        ``corners``: one contact sphere per bottom corner. ``distributed``: a row of
        ``contact_points`` spheres along the base, the outer ones under the corners, with the
        corners' total stiffness shared among them (same static sink), so an impact's impulse can
        spread into the base while the static pivots stay at the corners. ``auto``
        (default): the corners for targets up to 1 % above Housner's η_H, the distributed
        contact above (the modified η_M); explicit ``contact_restitution`` with ``auto``: corners.
    contact_points : int or None
        Spheres of the distributed contact along the base (≥ 3). None (default): the calibration
        tries 9, then 5, then 17 until one reaches the target at an acceptable price; an explicit
        ``contact_restitution`` then uses 9.
    spectral_radius : float
        Generalized-α spectral radius ρ∞ [-] (Exudyn's default 0.9).
    modified_newton_iterations : int
        Iterations Exudyn's modified Newton method makes with one Jacobian before it computes a
        new one (its ``maxModifiedNewtonIterations``; Exudyn ships 8). The converged solution
        must still meet the same tolerances, so this changes the cost, not the accuracy asked
        for; 3 measured 10–14 % faster calibrated and 27 % faster as shipped than 8 (the stiff
        regularised friction makes an old Jacobian converge slowly), docs/exudyn.md.
    segment_s, min_tail_s, tail_s : float
        Length of the integration segments between stop checks, and the shortest and longest tail
        after the pulse [s] (see the module notes on the end of a run). Old names, accepted for one
        release: ``chunk_s``, ``max_tail_s``, ``stiffness_n_m``, ``damping_n_s_m``
        (:data:`~rockbench.engines.contact.RENAMED_SETTINGS`).
    """

    #: versions of the corner and distributed calibrations (part of their cache keys)
    CALIBRATION_VERSION = 2
    CALIBRATION_VERSION_DIST = 3
    distributed_contact = True
    #: the corner calibration's knob: the contact restitution coefficient of impact model 2 (the
    #: stiffness is fixed, default_stiffness_n_m), its ladder, then bisection (:meth:`_knob_rows`)
    CALIBRATION_KNOBS = (Knob("contact_restitution", "", "damping", lambda block, dt: CALIBRATION_RESTITUTIONS,
                              bisect_steps=5, bisect_rtol=0.2 * CALIBRATION_RTOL),)
    #: a measurement records Exudyn's contact parameters
    MEASURED_SETTINGS = _CONTACT_KEYS + ("planar",)
    POINT_UNIT = "spheres"
    name = "exudyn"
    module = "exudyn"
    install_hint = "install it with `pip install 'rockbench[exudyn]'` (or `pip install exudyn`)."
    default_dt_s = 1e-4
    SHIPPED_NOTE = ("Exudyn ships no contact stiffness: m·g/(2·1.34 µm) per corner stands in (a static sink of "
                    "1.34 µm), with its shipped linear contact, restitution 1 and no damping (docs/exudyn.md)")
    #: Exudyn's own default step (SimulationSettings: endTime 1 s in numberOfSteps 100), what it runs
    #: at as shipped
    shipped_dt_s = 1e-2
    SETTINGS = {
        **ContactEngineAdapter.SHARED_SETTINGS,
        "friction_zone_m_s": 1e-3,
        "contact_stiffness_n_m": None,
        "contact_restitution": None,
        "contact_damping_n_s_m": 0.0,
        "sphere_radius_m": 5e-4,
        "contact": "auto",
        "contact_points": None,
        "spectral_radius": 0.9,
        "modified_newton_iterations": 3,
        "segment_s": 0.05,
        "min_tail_s": 0.3,
    }

    def __init__(self, **settings):
        super().__init__(**settings)
        self._models: dict = {}
        self._calibrations: dict = {}

    # -- settings -------------------------------------------------------------------------
    def _validate_engine_settings(self, s: dict) -> None:
        self._number_setting(s, "friction_zone_m_s", "m/s", allow_none=False)
        self._number_setting(s, "contact_stiffness_n_m", "N/m")
        self._contact_layout_settings(s)
        self._number_setting(s, "contact_restitution", "-")
        if s["contact_restitution"] is not None and s["contact_restitution"] > 1.0:
            raise ConfigError(f"exudyn setting 'contact_restitution' must be in (0, 1], got {s['contact_restitution']!r}.")
        self._number_setting(s, "contact_damping_n_s_m", "N s/m", allow_zero=True, allow_none=False)
        self._number_setting(s, "sphere_radius_m", "m", allow_none=False)
        try:
            rho = float(s["spectral_radius"])
        except (TypeError, ValueError):
            rho = math.nan
        if not (0.0 <= rho <= 1.0):
            raise ConfigError(f"exudyn setting 'spectral_radius' must be in [0, 1], got {s['spectral_radius']!r}.")
        s["spectral_radius"] = rho
        self._whole_setting(s, "modified_newton_iterations", 1, allow_none=False)

    def _stiffness(self, block: Block) -> float:
        return self.settings["contact_stiffness_n_m"] or default_stiffness_n_m(block)

    def _contact(self, block: Block, contact_restitution: float | None, points: int = 2) -> dict:
        """Exudyn contact parameters for one block (:data:`_CONTACT_KEYS`); ``None`` restitution:
        Exudyn's shipped model (linear impact model 0 with restitution coefficient 1, so only the
        linear damping, default 0, dissipates). ``points`` > 2: a row of that many spheres along the
        base sharing the corners' total stiffness."""
        s = self.settings
        model, e = (0, 1.0) if contact_restitution is None else (2, float(contact_restitution))
        return dict(zip(_CONTACT_KEYS, (self._stiffness(block) * 2.0 / points, points, s["contact_damping_n_s_m"],
                                        model, e, *(s[k] for k in _CONTACT_KEYS[5:]))))

    def explicit_contact(self) -> bool:
        """Whether ``contact_restitution`` was given (then nothing is calibrated)."""
        return self.settings["contact_restitution"] is not None

    def _resolved_settings(self, block: Block, dt: float, cal: CalibrationResult | None) -> dict:
        """The settings and Exudyn's contact parameters (``contact_restitution``: explicit, None for
        the shipped model, or calibrated)."""
        s = self.settings
        if cal is None:
            e = s["contact_restitution"]
            points = (s["contact_points"] or POINTS_TRIED[0]) if s["contact"] == "distributed" else 2
        else:
            e = cal.settings["restitution_coefficient"]
            points = int(cal.settings.get("contact_points") or 2)
        return {**s, **self._contact(block, e, points), "dt_s": dt}

    def _fixed(self, contact: dict) -> "ExudynAdapter":
        """A copy of this adapter with the contact of a calibration's settings (explicit)."""
        e = contact.get("restitution_coefficient") if contact.get("impact_model") == 2 else None
        n = int(contact.get("contact_points") or 2)
        return type(self)(**{**self.settings, "contact_restitution": e, "contact": "distributed" if n > 2 else "corners",
                             "contact_points": n if n > 2 else None})

    # -- the skeleton's hooks (one case at a time) ---------------------------------------------
    def _world(self, block: Block, s: dict, dt_s: float) -> SimpleNamespace:
        """A holder for the model :meth:`_start` picks (it depends on the pulse and the release angle)."""
        return SimpleNamespace(model=None)

    def _start(self, world, block: Block, s: dict, dt_s: float, pulse, theta0_rad: float,
               n_steps: int) -> np.ndarray:
        """The model: the one reused for the block, contact and step (a harmonic pulse loaded into its
        symbolic variables), a new one for a recorded pulse or a release from ``theta0_rad``."""
        contact = {k: s[k] for k in _CONTACT_KEYS}
        if pulse is None or theta0_rad != 0.0:
            model = _Model(block, contact, "inertial", s["planar"], dt_s, None, theta0_rad=theta0_rad)
        elif pulse.kind == "record":  # a record's Python user function is bound to that pulse: no reuse
            model = _Model(block, contact, s["drive"], s["planar"], dt_s, pulse)
        else:
            key = (block.width_m, block.height_m, block.depth_m, block.mass_kg, tuple(sorted(contact.items())), dt_s)
            if key not in self._models:
                self._models[key] = _Model(block, contact, s["drive"], s["planar"], dt_s, None)
            model = self._models[key]
        if model.uses_symbolic:
            model.set_pulse(pulse)
        world.model = model
        return model.start(self._segment_steps(s, dt_s), bool(s.get("full_newton")))

    def _advance(self, world, n_from: int, n_to: int) -> np.ndarray:
        return world.model.advance()

    def _sample_steps(self, world, rows: np.ndarray, n_done: int) -> np.ndarray:
        """Each row's step number, from its time (column 0): :func:`steps_of_times`."""
        return steps_of_times(rows[:, 0], world.model.dt_s)

    def _halted(self, world) -> bool:
        return world.model.message is not None

    def _angles(self, world, rows: np.ndarray):
        return world.model.angles(rows)

    def _motion(self, world, block: Block, s: dict, data: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        """The block's motion from Exudyn's sensors, with its own contact points: the block's bottom
        corners (x, relative to the table) and its contact spheres' clearance above the table."""
        model = world.model
        wall = model.finish()
        t, (th, thd) = data[:, 0], model.angles(data)
        spheres, edges, com = model.samples(data)
        drive_table = pulse is not None and s["drive"] == "table"
        table_x = pulse.disp(t) if drive_table else np.zeros(t.size)
        # contact quality only up to the overturn decision: afterwards the block falls through the
        # table by design (no spheres on its top corners)
        over = overturn_certain(t, th, thd, alpha_rad=block.alpha_rad,
                                t_pulse_end_s=pulse.duration_s if pulse is not None else 0.0)
        n = int(np.argmax(over)) + 1 if over.any() else t.size
        r = s["sphere_radius_m"]
        diag = {"steps": int(model.steps), "wall_engine_s": wall, "steps_per_s": model.steps / wall if wall > 0 else None,
                "max_penetration_m": float(np.max(r - spheres[:n, :, 1])) if t.size else 0.0,
                **{k: s[k] for k in ("stiffness_n_m", "damping_n_s_m", "impact_model", "restitution_coefficient",
                                     "friction")}}
        if model.message is not None:
            diag["solver_stopped"] = model.message
        return Motion(x_m=com[:, 0], z_m=com[:, 1], theta_rad=th, vx_m_s=com[:, 2], vz_m_s=com[:, 3],
                      theta_dot_rad_s=thd, table_x_m=table_x, table_vx_m_s=pulse.vel(t) if drive_table else None,
                      diagnostics=diag, t_s=t, corner_x_m=edges[..., 0] - table_x[:, None], corner_z_m=spheres[..., 1] - r)

    def _trajectory(self, block: Block, s: dict, dt: float, pulse=None, theta0: float = 0.0,
                    duration_s: float | None = None) -> tuple[Trajectory, Motion]:
        """The skeleton's run (free rocking in one segment); a case whose Newton stalls is retried
        (module notes, "Solver")."""
        if duration_s is not None:
            return super()._trajectory(block, {**s, "drive": "inertial", "segment_s": duration_s}, dt, pulse,
                                       theta0, duration_s)
        # Newton occasionally stalls in a violent impact (deterministically, for a given cell);
        # a retry at half the step, then one with a full Newton method at the case's step, both
        # with the same contact, resolved the cases met in probes and maps
        retried = None
        for dt_run, full_newton in ((dt, False), (0.5 * dt, False), (dt, True)):
            tr, m = super()._trajectory(block, {**s, "full_newton": full_newton}, dt_run, pulse)
            message = tr.diagnostics.get("solver_stopped")
            over = overturn_certain(tr.t_s, tr.theta_rad, tr.theta_dot_rad_s, alpha_rad=block.alpha_rad,
                                    t_pulse_end_s=tr.t_pulse_end_s)
            if message is None or over.any():
                break
            retried = message
        diag = tr.diagnostics
        diag["dt_s"] = dt
        if retried is not None:
            diag.update(retried_at_dt_s=dt_run, retried_full_newton=full_newton, earlier_attempt=retried)
        # a failure after the overturn was already certain does not change the verdict
        if message is not None and not over.any():
            raise EngineError(message)
        pen, r = diag["max_penetration_m"], s["sphere_radius_m"]
        if pen >= 0.9 * r:
            raise EngineError(f"a corner contact sphere sank {pen:.3g} m into the table, about its radius "
                              f"{r:.3g} m: the contact broke through (stiffer contact or a larger "
                              "sphere_radius_m needed)")
        return tr, m

    def _measure_free_rocking(self, block: Block, s: dict, dt: float, theta0_frac: float = 0.5):
        """The skeleton's free-rocking test; a run whose solver stopped before all impacts is an
        EngineError (an engine failure, not a measurement)."""
        m, tr = super()._measure_free_rocking(block, s, dt, theta0_frac)
        if "solver_stopped" in tr.diagnostics and len(m.etas) < FREE_ROCKING_IMPACTS:
            raise EngineError(f"free rocking: {tr.diagnostics['solver_stopped']}")
        return m, tr

    # -- calibration (the dispatch, the cache and the free-rocking test are the skeleton's) -----
    def _calibrate_corners(self, block: Block, target: float, dt: float, use_cache: bool) -> CalibrationResult:
        return self._calibrate_distributed_n(block, target, 2, dt, use_cache)

    def _evaluate(self, block: Block, dt: float, candidates: list[dict], points: int = 2) -> list[dict]:
        """Free rocking of each candidate restitution coefficient with ``points`` spheres: one row each
        (``contact_restitution``, ``eta``, ``eta_std``, ``n``, ``etas``, ``sink_m``, ``hop_m``,
        ``damping_ratio``, ``first_quarter_s``, and ``error`` where the engine failed)."""
        rows = []
        for c in candidates:
            e = c["contact_restitution"]
            try:
                m, _ = self._measure_free_rocking(block, {**self.settings, **self._contact(block, e, points)}, dt)
            except EngineError as ex:
                rows.append({"contact_restitution": e, "error": str(ex), "eta": math.nan, "eta_std": math.nan, "n": 0,
                             "etas": [], "sink_m": None, "hop_m": None, "damping_ratio": None, "first_quarter_s": None})
                continue
            rows.append({"contact_restitution": e, "eta": m.eta_mean, "eta_std": m.eta_std, "n": len(m.etas),
                         "etas": m.etas, "sink_m": m.sink_m, "hop_m": m.hop_m,
                         "damping_ratio": damping_ratio_of_restitution(e), "first_quarter_s": m.first_quarter_s})
        return rows

    def _calibrate_distributed_n(self, block: Block, target: float, points: int, dt: float,
                                 use_cache: bool) -> CalibrationResult:
        """Exudyn's contact restitution coefficient for ``points`` spheres along the base (2: the
        corners): the skeleton's candidates of the declared knob (:attr:`CALIBRATION_KNOBS`, the row
        :data:`DISTRIBUTED_KNOBS`: the ladder, then the bisection, :meth:`_knob_rows`), the one pick
        (:func:`~rockbench.engines.pick.pick`) among them; the row is ``reached`` only where its price
        also counts. Results are cached on disk (:mod:`.calibration`) and memoised per adapter.
        """
        s = self.settings
        key = self._cache_key(block, target, dt, self.CALIBRATION_VERSION if points == 2 else self.CALIBRATION_VERSION_DIST,
                              planar=s["planar"], stiffness=self._stiffness(block), friction=s["friction"],
                              zone=s["friction_zone_m_s"], radius=s["sphere_radius_m"], rho=s["spectral_radius"],
                              damping=s["contact_damping_n_s_m"], newton=s["modified_newton_iterations"],
                              **({} if points == 2 else {"contact_points": points}))
        res = self._calibrations.get(key) or self._cached(key, use_cache)
        if res is not None:
            self._calibrations[key] = res
            return res
        knobs = self.CALIBRATION_KNOBS if points == 2 else DISTRIBUTED_KNOBS
        scan = self._knob_rows(block, target, dt, knobs, lambda c: self._evaluate(block, dt, c, points))
        cands = [Candidate.of_row(r) for r in scan]
        if not any(math.isfinite(c.eta) for c in cands):
            raise EngineError("calibration: free rocking failed for every contact restitution tried; scan: "
                              + "; ".join(f"e={r['contact_restitution']:.3g}: {r.get('error', '')}" for r in scan))
        chosen = pick(cands, target, block)
        irregular = not any(regular(c, target, block) for c in cands)
        good = [(c.knobs["contact_restitution"], _as_fr(c)) for c in cands if regular(c, target, block)] or \
            [(c.knobs["contact_restitution"], _as_fr(c)) for c in cands if math.isfinite(c.eta)]
        e, fr, reached = chosen.candidate.knobs["contact_restitution"], _as_fr(chosen.candidate), chosen.reached
        settings = {**self._contact(block, e, points), "planar": s["planar"]}
        price = (_price.contact_price(self._fixed(settings), block, Restitution("constant", value=target), dt,
                                      first_quarter_s=fr.first_quarter_s) if points > 2 and reached else None)
        note, reached = _note(e, fr, good, target, irregular, reached, s["friction"], points, price)
        res = CalibrationResult(eta_target=target, eta_measured=fr.eta_mean, eta_std=fr.eta_std,
                                reached=reached, settings=settings, note=note, evaluations=len(scan), price=price)
        self._store(key, res, {"etas": fr.etas, "tried": scan})
        self._calibrations[key] = res
        return res


def steps_of_times(t_s: np.ndarray, dt_s: float) -> np.ndarray:
    """The step numbers of Exudyn's rows at times ``t_s`` [s] with step ``dt_s`` [s]: t/Δt, a
    fraction where Exudyn shortened its step; within 1e-6 of a whole step, that step (the rounding
    in t/Δt) [-]."""
    k = np.asarray(t_s, dtype=float) / dt_s
    whole = np.rint(k)
    return np.where(np.abs(k - whole) < 1e-6, whole, k)



def _as_fr(c: Candidate) -> SimpleNamespace:
    """A candidate as the notes read it (``eta_mean``, ``eta_std``, ``etas``, ``first_quarter_s``)."""
    return SimpleNamespace(eta_mean=c.eta, eta_std=c.eta_std, etas=c.knobs["etas"],
                           first_quarter_s=c.knobs["first_quarter_s"])


def _note(e: float, fr, good: list, target: float, irregular: bool, reached: bool, friction: float, points: int,
          price: dict | None) -> tuple[str, bool]:
    """What the calibration found, in words, and whether it is reached (the row along the base: at
    its ``price``, None where η was not reached, with the span of η its regular free rocking covers)."""
    rel = abs(fr.eta_mean - target) / target
    lo_eta, hi_eta = min(f.eta_mean for _, f in good), max(f.eta_mean for _, f in good)
    span = (f"{points} spheres along the base sharing the corners' stiffness; regular free "
            f"rocking spans η = {lo_eta:.4f}…{hi_eta:.4f} over restitution coefficients "
            f"{min(CALIBRATION_RESTITUTIONS_DIST):g}–{max(CALIBRATION_RESTITUTIONS_DIST):g}")
    if points > 2 and price is not None and not price["counts"]:
        why = ("its static uplift threshold is not within 2 % of g·tanα" if not price["uplift"].get("within")
               else f"{price['anti_slip']['n_slip']} of the {price['anti_slip']['cells']} anti-slip cells slip")
        return (f"not reached at an acceptable price: η = {fr.eta_mean:.4f} ± {fr.eta_std:.4f} "
                f"({100 * rel:.2f} % off target {target:.4f}) with impact model 2 and restitution "
                f"coefficient {e:.3g}, {span}, but {why}."), False
    if points > 2 and not reached and not irregular:
        return (f"not reached: the closest regular free rocking gives η = {fr.eta_mean:.4f} "
                f"({100 * rel:.1f} % off target {target:.4f}) with {span}; smaller coefficients make the "
                "rocking irregular (impact-to-impact spread above 2 %), larger ones let the landing "
                "corner hop (jumps)."), False
    if irregular:
        return (f"not reached: no contact restitution gave regular free rocking (spread < 2 %, no jump); "
                f"the closest η is {fr.eta_mean:.4f} ± {fr.eta_std:.4f} (target {target:.4f}). The block "
                f"slides or bounces in free rocking with these settings (friction {friction:g})."), False
    if reached:
        return (f"reached: η = {fr.eta_mean:.4f} ± {fr.eta_std:.4f} for target {target:.4f} "
                f"({100 * rel:.2f} % off) with Exudyn's impact model 2 and restitution coefficient {e:.3g}."
                + (f" Contact: {span}." if points > 2 else "")), True
    return (f"not reached: the closest regular free rocking gives η = {fr.eta_mean:.4f} "
            f"({100 * rel:.1f} % off target {target:.4f}); regular free rocking spans only η = "
            f"{lo_eta:.4f}…{hi_eta:.4f}. A nearly plastic impact of the landing corner is Housner's "
            "own assumption, so corner contacts give about η_H; a more elastic contact makes the "
            "corner bounce (irregular η, jumps) instead of raising η, and η_M needs the impact "
            "impulse inside the base, where corner contacts cannot put it."), False
