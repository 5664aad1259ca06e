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
The run is the contact base's loop (:mod:`rockbench.engines.loop`), integrated in fixed segments of
``segment_s`` inside Exudyn's C++ solver, with every contact engine's one end-of-run
rule (:func:`~rockbench.reference_solver.classify.run_end`) tested at every row Exudyn's sensors
stored, at its own time (Exudyn shortens its step where Newton struggles, so a segment may hold
more rows than steps: the rule counts rows, not steps). The segments stay fixed because each is a
new ``SolveSteps`` call, which refreshes the modified Newton's Jacobian, restarts at the full step
and lands on the segment's end time: a segment ending elsewhere moves θ (docs/exudyn.md, "Where a
run stops"). Instead, in a segment that holds one of the run's marks (its pulse's end, the trapped
rule's first step), a post-step hook tests the same rule on the solver's current state at the marks
and every :data:`CHECK_S` after the pulse's end (:func:`check_steps`) and stops the solver after the
step where it fires; the loop's own test then finds the stop in the rows, so the runs are those of the
fixed segments bit for bit, with fewer steps past their stops. A run also ends where Exudyn's solver
stopped (Newton did not converge even at its smallest step): ``advance`` raises
:class:`~rockbench.engines.loop.EngineHalted`, and the base retries the case as
:attr:`ExudynAdapter.RETRIES` says (module notes, "Solver"). The shared classifier decides the outcome
from the samples.

Restitution
-----------
Exudyn has no η of its own. Its penalty contact with linear damping (the shipped impact model 0)
lets the landing corner bounce, which breaks the rocking model (jumps) whenever an impact is
strong; the probes found that Exudyn's impact model 2 (Gonthier et al., hysteretic damping that
reaches a prescribed normal restitution coefficient without sticky forces) with a nearly plastic
coefficient lands the corner without bouncing, which is exactly Housner's assumption, and gives
η within 0.5 % of η_H for B3M and B6M. ``settings="calibrated"`` (default) therefore searches
that coefficient (:attr:`ExudynAdapter.KNOBS`) for the case's target η and caches the result on
disk. ``settings="shipped"`` keeps Exudyn's shipped
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

from rockbench.reference_solver.classify import overturn_certain, run_end
from rockbench.reference_solver.model import G, Block
from rockbench.reference_solver.pulses import Pulse
from rockbench.engines.calibration.knobs import Knob
from rockbench.engines.contact import ContactEngine
from rockbench.engines.loop import EngineHalted, segment_steps
from rockbench.engines.motion import Motion, run_steps, steps_of_times

#: Static penetration of one corner under half the block's weight that sets the default contact
#: stiffness [m]: 1.34 µm, the value of k = 2e6 N/m for B3M, inside the range docs/physics.md §8 gives as
#: reproducing Housner's η (2e6–2e7 N/m at Δt ≤ 1e-4 s).
STATIC_PENETRATION_M = 1.34e-6

#: Exudyn contact restitution coefficients (impact model 2) tried by the calibration's scan [-].
CALIBRATION_RESTITUTIONS = (0.02, 0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.8)

#: The scan for the distributed contact (docs/contact.md): its η rises with the coefficient from about
#: η_H, and the probe (tests/measurements/probes/probe_eta_m_exudyn.py) found η_M between 0.1 and 0.3 for B3M.
CALIBRATION_RESTITUTIONS_DIST = (0.05, 0.08, 0.1, 0.12, 0.14, 0.17, 0.2, 0.24, 0.28, 0.33, 0.4, 0.5)

#: Inside a segment that holds one of a run's marks, Exudyn's solver also tests the end-of-run rule this often
#: after the pulse's end [s] (:func:`check_steps`)
CHECK_S = 0.01

#: Relative tolerance of a calibration (the issue asks for 1 %) [-].
CALIBRATION_RTOL = 0.01

#: Half the side of the table triangle [m]: far larger than any table travel of a pulse.
_TABLE_HALF_SIZE_M = 1.0e3

#: the contact parameters a model is built from (in the order a measurement records them)
_CONTACT_KEYS = ("stiffness_n_m", "contact_points", "damping_n_s_m", "impact_model", "restitution_coefficient",
                 "friction", "friction_zone_m_s", "sphere_radius_m", "spectral_radius", "modified_newton_iterations")

#: the symbolic variables of a harmonic pulse: a₀, ω, its length, cosine (1) or sine (0), and the
#: table's displacement and velocity at its end
_PULSE_VARS = ("a0", "w", "tb", "cs", "utb", "vtb")


def check_steps(n_pulse: int, n_min: int, n_last: int, chunk: int, every: int) -> list[int]:
    """The steps inside a run's fixed segments of ``chunk`` steps at which Exudyn's solver tests the
    end-of-run rule itself: each of the run's marks (its pulse's end ``n_pulse``, the trapped rule's first
    step ``n_min``) that is not a segment's end, and every ``every`` steps after the pulse's end in the
    segments that hold a mark (module notes, "End of a run"); ``n_last``: the run's last step."""
    out: set[int] = set()
    for mark in (n_pulse, n_min):
        if mark >= n_last or mark % chunk == 0:
            continue
        lo, hi = mark // chunk * chunk, min((mark // chunk + 1) * chunk, n_last)
        out |= {mark} | {n for n in range(n_pulse, hi, every) if n > lo}
    return sorted(out)


def _rule_fires(model, block: Block, dt_s: float, n_pulse: int, n_min: int):
    """Whether floor 1's end-of-run rule names one state row of ``model`` (:meth:`_Model.rows`), read as
    the loop reads a row (θ and θ̇ of :meth:`_Model.angles`, the step t/Δt)."""
    def fires(row: np.ndarray) -> bool:
        theta, theta_dot = model.angles(row[None])
        return run_end(steps_of_times(row[:1], dt_s), theta, theta_dot, alpha_rad=block.alpha_rad,
                       p_rad_s=block.p_rad_s, pulse_end_step=n_pulse, min_tail_step=n_min) is not None
    return fires


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
        self.sensor_kinds = kinds
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

    # -- running (the adapter's four methods call these) ----------------------------------------
    def start(self, chunk_steps: int, full_newton: bool, check_steps=(), fires=None) -> np.ndarray:
        """Initialise Exudyn's solver for segments of ``chunk_steps`` steps (``full_newton``: a new
        Jacobian at every Newton iteration), the previous run's solver closed; no samples yet (the
        first segment stores t = 0). ``check_steps``: the steps inside the segments at which the
        solver tests ``fires`` (a state row → whether the run ends there) and stops where it does
        (:func:`check_steps`)."""
        if getattr(self, "solver", None) is not None:
            self.solver.FinalizeSolver(self.mbs, self.ss)
        ss = self.ss
        ss.timeIntegration.newton.useModifiedNewton = not full_newton
        self.n_chunk, self.steps, self.n_raw, self.t_raw = chunk_steps, 0, 0, -math.inf
        self.check_t, self.fires, self.stopped_at = np.asarray(check_steps, dtype=float) * self.dt_s, fires, None
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
        """One segment (the run's last one too: the loop drops the rows after its last step), cut short
        where a check inside it fires; the state rows the sensors stored in it (:meth:`rows`)."""
        if self.message is not None:
            return np.empty((0, 7 if self.planar else 19))
        if self.stopped_at is not None:
            raise RuntimeError(f"Exudyn's solver stopped itself at t = {self.stopped_at:.6g} s, where the end-of-run "
                               "rule fired, but the run was asked to go on")
        t_from = self.mbs.systemData.GetTime()
        if not self.first:
            self.solver.it.endTime = t_from + self.n_chunk * self.dt_s
        self.first = False
        tol = 1e-6 * self.dt_s
        self._next, self._t_prev = int(np.searchsorted(self.check_t, t_from + tol)), t_from
        inside = self._next < self.check_t.size and self.check_t[self._next] < self.solver.it.endTime - tol
        self.mbs.SetPostStepUserFunction(self._post_step if inside else 0)
        ok = self.solver.SolveSteps(self.mbs, self.ss)
        self.steps += int(round((self.mbs.systemData.GetTime() - t_from) / self.dt_s))
        if not ok:
            self.message = (f"Exudyn's solver stopped at t = {self.mbs.systemData.GetTime():.6g} s "
                            "(Newton did not converge even at the minimum step size)")
            raise EngineHalted(self.message, self.rows()[None])
        return self.rows()

    def _post_step(self, mbs, t: float) -> bool:
        """Exudyn's post-step hook in a segment that holds a check: at the first whole step at or after
        each check (a step of Δt from the step before, so the sensors store its row and :meth:`rows`
        keeps it), the current state tested with ``fires``; False (the solver stops after this step,
        its row stored) where it fires."""
        t_prev, self._t_prev = self._t_prev, t
        tol = 1e-6 * self.dt_s
        # a step of Δt (to rounding, 1e-9 Δt) after a stored or dropped row: the sensors store this one
        # (they store the first step at or after each multiple of Δt, within 1e-10 s) and rows() keeps it
        if (self._next >= self.check_t.size or t < self.check_t[self._next] - tol
                or abs(t - t_prev - self.dt_s) > 1e-9 * self.dt_s or abs(t / self.dt_s - round(t / self.dt_s)) > 1e-6):
            return True
        self._next = int(np.searchsorted(self.check_t, t + tol))
        row = np.concatenate([[t], *(mbs.GetNodeOutput(self.node, k) for k in self.sensor_kinds)])
        if self.fires(row):
            self.stopped_at = t
            return False
        return True

    def rows(self) -> np.ndarray:
        """The sensors' rows stored since the last call: ``t, x, y, φ, ẋ, ẏ, φ̇`` (planar) or ``t``,
        position, rotation matrix, angular velocity, velocity (3-D). Each segment boundary is stored
        twice (end of one segment, start of the next): a row within half a step of the one
        before is dropped. (Exudyn hands back a sensor's whole history, the one copy it makes; only
        the new rows are joined.)"""
        parts = [self.mbs.GetSensorStoredData(s)[self.n_raw:] for s in self.sensors]
        raw = (np.concatenate([parts[0]] + [x[:, 1:] for x in parts[1:]], axis=1) if len(parts[0])
               else np.empty((0, 7 if self.planar else 19)))
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


class ExudynAdapter(ContactEngine):
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
        (Gonthier et al.) [-]; None: calibrated to the case's η (with ``calibrated``), Exudyn's
        shipped linear model (impact model 0, restitution 1) as shipped.
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
        after the pulse [s] (see the module notes on the end of a run).
    """

    name = "exudyn"
    module = "exudyn"
    install_hint = "install it with `pip install 'rockbench[exudyn]'` (or `pip install exudyn`)."
    #: Exudyn's own default step (SimulationSettings: endTime 1 s in numberOfSteps 100)
    own_dt_s = 1e-2
    fixed_dt_s = 1e-4
    SETTINGS = {"friction_zone_m_s": 1e-3, "contact_stiffness_n_m": None, "contact_damping_n_s_m": 0.0,
                "sphere_radius_m": 5e-4, "spectral_radius": 0.9, "modified_newton_iterations": 3, "segment_s": 0.05,
                "min_tail_s": 0.3}
    #: Exudyn's shipped contact: impact model 0 with restitution coefficient 1 (None here)
    SHIPPED = {"contact_restitution": None}
    SHIPPED_NOTE = ("Exudyn ships no contact stiffness: m·g/(2·1.34 µm) per corner stands in (a static sink of "
                    "1.34 µm), with its shipped linear contact, restitution 1 and no damping (docs/exudyn.md)")
    CONTACT_ROWS = "spheres"
    #: the calibration's knob: the contact restitution coefficient of impact model 2 (the stiffness is
    #: fixed, default_stiffness_n_m), its ladder, then bisection to within 0.2·CALIBRATION_RTOL
    KNOBS = (Knob("contact_restitution", "", CALIBRATION_RESTITUTIONS, zeta="restitution", bisect_steps=5,
                  bisect_rtol=0.2 * CALIBRATION_RTOL),)
    #: the row's: its ladder (η_M lies between 0.1 and 0.3 for B3M, probe_eta_m_exudyn.py), then bisection
    ROW_KNOBS = (Knob("contact_restitution", "", CALIBRATION_RESTITUTIONS_DIST, zeta="restitution", bisect_steps=5,
                      bisect_rtol=0.2 * CALIBRATION_RTOL),)
    #: a run whose Newton stalls (deterministically, in a violent impact): at half the step, then with a
    #: full Newton method at the case's step, both with the same contact (module notes, "Solver")
    RETRIES = ((0.5, {"full_newton": False}), (1.0, {"full_newton": True}))
    CALIBRATION_VERSION = 3

    def validate(self, s: dict) -> None:
        self.number_setting(s, "friction_zone_m_s", "m/s", allow_none=False)
        self.number_setting(s, "contact_stiffness_n_m", "N/m")
        self.number_setting(s, "contact_restitution", maximum=1.0)
        self.number_setting(s, "contact_damping_n_s_m", "N s/m", allow_zero=True, allow_none=False)
        self.number_setting(s, "sphere_radius_m", "m", allow_none=False)
        self.number_setting(s, "spectral_radius", allow_zero=True, allow_none=False, maximum=1.0)
        self.whole_setting(s, "modified_newton_iterations", minimum=1, allow_none=False)

    def _contact(self, block: Block, s: dict) -> dict:
        """Exudyn's contact parameters of the resolved settings ``s`` (:data:`_CONTACT_KEYS`): impact
        model 2 with ``contact_restitution``, or (None) Exudyn's shipped model (linear impact model 0
        with restitution coefficient 1, so only the linear damping, default 0, dissipates); a row of
        ``contact_points`` spheres along the base sharing the corners' total stiffness."""
        points = s["contact_points"] if s["contact"] == "distributed" else 2
        model, e = (0, 1.0) if s["contact_restitution"] is None else (2, float(s["contact_restitution"]))
        stiffness = s["contact_stiffness_n_m"] or default_stiffness_n_m(block)
        return dict(zip(_CONTACT_KEYS, (stiffness * 2.0 / points, points, s["contact_damping_n_s_m"], model, e,
                                        *(s[k] for k in _CONTACT_KEYS[5:]))))

    def build(self, block: Block, s: dict, dt_s: float) -> SimpleNamespace:
        """A holder for the model :meth:`start` picks (it depends on the pulse and the release angle)."""
        return SimpleNamespace(model=None)

    def start(self, scene, block: Block, s: dict, dt_s: float, pulses: list, theta0_rad: float,
              n_steps: int) -> np.ndarray:
        """The model: the one reused for the block, contact and step (a harmonic pulse loaded into its
        symbolic variables), a new one for a recorded pulse or a release from ``theta0_rad``; no sample
        yet (Exudyn's sensors store t = 0 with the first segment)."""
        pulse, contact = pulses[0], self._contact(block, s)
        if pulse is None or theta0_rad != 0.0:
            model = _Model(block, contact, "inertial", s["planar"], dt_s, None, theta0_rad=theta0_rad)
        elif pulse.kind == "record":  # a record's Python user function is bound to that pulse: no reuse
            model = _Model(block, contact, s["drive"], s["planar"], dt_s, pulse)
        else:
            key = (block.width_m, block.height_m, block.depth_m, block.mass_kg, tuple(sorted(contact.items())), dt_s)
            if key not in self.scenes:
                self.scenes[key] = _Model(block, contact, s["drive"], s["planar"], dt_s, None)
            model = self.scenes[key]
        if model.uses_symbolic:
            model.set_pulse(pulse)
        scene.model = model
        chunk, checks, fires = segment_steps(s, dt_s), (), None
        if pulse is not None:
            n_last, n_pulse, n_min = run_steps(dt_s, pulse.duration_s, s["tail_s"], s["min_tail_s"])
            checks = self.stop_check_steps(chunk, dt_s, n_last, n_pulse, n_min)
            fires = _rule_fires(model, block, dt_s, n_pulse, n_min)
        return model.start(chunk, bool(s.get("full_newton")), checks, fires)[None]

    @staticmethod
    def stop_check_steps(chunk: int, dt_s: float, n_last: int, n_pulse: int, n_min: int) -> list[int]:
        """The steps inside a run's fixed segments of ``chunk`` steps at which Exudyn's solver tests the
        end-of-run rule itself (:func:`check_steps`, every :data:`CHECK_S` after the pulse's end); the run's
        last step, its pulse's end and the trapped rule's first step as :func:`~rockbench.engines.motion.run_steps`
        gives them (``tests/measurements/bench_past_stop.py`` replays them)."""
        return check_steps(n_pulse, n_min, n_last, chunk, max(1, int(round(CHECK_S / dt_s))))

    def advance(self, scene, n_from: int, n_to: int) -> np.ndarray:
        return scene.model.advance()[None]

    def read(self, scene, block: Block, s: dict, rows: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        """The block's motion from Exudyn's sensors, with its own contact points: the block's bottom
        corners (x, relative to the table) and its contact spheres' clearance above the table; a run
        whose sphere sank about its radius into the table (before the overturn was certain: the block
        falls through the table after it, by design) is not a measurement (``Motion.error``)."""
        model = scene.model
        wall = time.perf_counter() - model.t0
        t, (th, thd) = rows[:, 0], model.angles(rows)
        spheres, edges, com = model.samples(rows)
        drive_table = pulse is not None and s["drive"] == "table"
        table_x = pulse.disp(t) if drive_table else np.zeros(t.size)
        over = overturn_certain(t, th, thd, alpha_rad=block.alpha_rad,
                                t_pulse_end_s=pulse.duration_s if pulse is not None else 0.0)
        n = int(np.argmax(over)) + 1 if over.any() else t.size
        r = s["sphere_radius_m"]
        pen = float(np.max(r - spheres[:n, :, 1])) if t.size else 0.0
        diag = {"steps": int(model.steps), "wall_engine_s": wall, "steps_per_s": model.steps / wall if wall > 0 else None,
                "max_penetration_m": pen, **{k: model.contact[k] for k in _CONTACT_KEYS[:5]}}
        error = (f"a corner contact sphere sank {pen:.3g} m into the table, about its radius {r:.3g} m: the contact "
                 "broke through (stiffer contact or a larger sphere_radius_m needed)") if pen >= 0.9 * r else None
        return Motion(x_m=com[:, 0], z_m=com[:, 1], theta_rad=th, vx_m_s=com[:, 2], vz_m_s=com[:, 3],
                      theta_dot_rad_s=thd, table_x_m=table_x, table_vx_m_s=pulse.vel(t) if drive_table else None,
                      diagnostics=diag, t_s=t, corner_x_m=edges[..., 0] - table_x[:, None],
                      corner_z_m=spheres[..., 1] - r, error=error)
