"""Newton adapter: the rocking block in Newton (the Warp-based engine), one of its solvers chosen by
``solver``.

The model
---------
The block is a box ``b × d × h`` of the case's mass with the box's own inertia, on a table box
whose top face is at ``z = 0``; they touch through Newton's collision pipeline (box–box contact,
up to four corner contacts), and the chosen solver turns the contacts into forces or position
corrections: that contact is what the benchmark measures.

* **Solvers** (``solver``): ``xpbd`` (default: position-based, maximal coordinates),
  ``semi_implicit`` (penalty contact ``ke``, ``kd``, viscous-capped friction ``kf``, explicit
  integration), ``featherstone`` (the same penalty contact in generalised coordinates) and
  ``vbd`` (vertex block descent; rigid bodies through its AVBD contact).
* **Planar** (default): a D6 joint (slide x, slide z, hinge y) between the world and the block
  for ``xpbd``, ``featherstone`` and ``vbd``. ``semi_implicit`` holds joints by penalty springs,
  which diverge at these masses, so it keeps a free body in the plane by projecting its pose and
  velocity onto the x–z plane after every step. ``planar=False``: a free 3-D body.
* **Anti-slip**: friction 10 (``friction``) and Newton's sticky contact matching
  (``sticky_contacts``, default on): a contact that persists keeps its anchor points between steps,
  so a sticking corner does not creep. Without it XPBD's corner creeps by about 1.4 mm in 0.5 s
  under half the uplift acceleration (B3M), three times the judge's slip tolerance.
* **Drives** (``drive``): ``inertial`` (default) sets each world's gravity to ``(−ü, 0, −g)``
  (ü at the step's midpoint); ``table`` makes the table a kinematic body whose pose u(tₙ) and
  velocity u̇ (at the step's midpoint) are set before every step.
* **Restitution**: ``settings="shipped"`` runs the solver as shipped (Newton's default iterations
  and contact material) with only the time step and the anti-slip friction set;
  ``settings="calibrated"`` (default) runs the settings the one search of the solver's
  knobs (:attr:`NewtonAdapter.KNOBS`) found for the case's η (cached on disk). XPBD's own restitution (``enable_restitution``) is not
  used: it breaks rocking (docs/newton.md).
* **Batches** (``batching = "native"``, :attr:`~NewtonAdapter.max_worlds`): the cells of a map with
  the same block, step and settings run as the worlds of one model through the contact base's loop; every world advances by the same kernels, so a cell gives the same trajectory
  alone or in a batch.

Warp runs on its CPU device here (the drive and the read-out use NumPy views of Warp's arrays).
"""

from __future__ import annotations

import math
import numpy as np

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import G, Block
from rockbench.engines.calibration.knobs import Knob
from rockbench.engines.contact import ContactEngine
from rockbench.engines.motion import Motion, pivot_pose, theta_of_quat
from rockbench.engines.adapters.warp_start import say_first_compile, start_warp

#: The solvers offered, by their ``solver`` name
SOLVERS = ("xpbd", "semi_implicit", "featherstone", "vbd")

#: Half extents of the table box [m]: wider than any table stroke, thick enough for stiff contact.
_TABLE_HALF_EXTENTS_M = (2.0, 1.0, 0.05)

#: Most worlds in one model (a bigger batch runs in parts)
MAX_WORLDS = 4096

#: Contacts allotted per world (box on box: at most four corners touch; room to spare)
_CONTACTS_PER_WORLD = 8

#: The state row of one block per sample: position (3), quaternion x, y, z, w (4), velocity of the
#: centre of mass (3), angular velocity (3), all in the world frame
_ROW = 13

#: What rockbench says, once per run, where Warp starts without a CUDA driver
CPU_LINE = "rockbench: newton runs on Warp's CPU device here (one thread): expect large maps to be slow"


def _newton():
    """``(warp, newton)``, Warp started once (:func:`~rockbench.engines.warp_start.start_warp`)."""
    wp = start_warp(CPU_LINE)
    import newton   # optional engine library
    return wp, newton


class _Scene:
    """One Newton model of ``worlds`` copies of table and block, its solver, collision pipeline and
    states; built afresh for every run, so no contact state of an earlier run leaks into it."""

    def __init__(self, block: Block, s: dict, dt_s: float, worlds: int = 1):
        wp, newton = _newton()
        say_first_compile("newton", "newton.")
        self.wp, self.newton, self.dt, self.worlds = wp, newton, dt_s, worlds
        self.solver_name, self.planar = s["solver"], bool(s["planar"])
        self.table_drive = s["drive"] == "table"
        self.project = self.planar and self.solver_name == "semi_implicit"
        with wp.ScopedDevice("cpu"):
            one = self._builder(block, s)
            top = newton.ModelBuilder(gravity=(0.0, 0.0, -G))
            top.replicate(one, worlds)
            if self.solver_name == "vbd":
                top.color()
            self.model = top.finalize()
            self.solver = self._solver(s)
            self.pipe = newton.CollisionPipeline(
                self.model, rigid_contact_max=_CONTACTS_PER_WORLD * worlds,
                contact_matching="sticky" if s["sticky_contacts"] else "disabled")
            self.contacts = self.pipe.contacts()
            self.s0, self.s1, self.control = self.model.state(), self.model.state(), self.model.control()
        per = 2 if self.table_drive else 1
        self.block_ids = np.arange(worlds) * per + (per - 1)
        self.table_ids = np.arange(worlds) * per if self.table_drive else None
        self.gravity = self.model.gravity.numpy()   # a view: the inertial drive writes into it

    def _builder(self, block: Block, s: dict):
        """One world: the table (static, or kinematic for the table drive) and the block."""
        wp, newton = self.wp, self.newton
        bld = newton.ModelBuilder(gravity=(0.0, 0.0, -G))
        cfg = bld.default_shape_cfg
        cfg.mu = float(s["friction"])
        cfg.restitution = 0.0
        for key, attr in (("contact_stiffness_n_m", "ke"), ("contact_damping_n_s_m", "kd"), ("friction_gain_n_s_m", "kf")):
            if s.get(key) is not None:
                setattr(cfg, attr, float(s[key]))
        hx, hy, hz = _TABLE_HALF_EXTENTS_M
        table_pose = wp.transform(wp.vec3(0.0, 0.0, -hz), wp.quat_identity())
        if self.table_drive:
            tb = bld.add_body(xform=table_pose, mass=0.0, is_kinematic=True, label="table")
            bld.add_shape_box(tb, hx=hx, hy=hy, hz=hz)
        else:
            bld.add_shape_box(-1, xform=table_pose, hx=hx, hy=hy, hz=hz)
        b, h, d, m = block.width_m, block.height_m, block.depth_m, block.mass_kg
        inertia = wp.mat33(m * (d * d + h * h) / 12.0, 0.0, 0.0, 0.0, m * (b * b + h * h) / 12.0, 0.0,
                           0.0, 0.0, m * (b * b + d * d) / 12.0)
        pose = wp.transform(wp.vec3(0.0, 0.0, h / 2), wp.quat_identity())
        if self.planar and not self.project:
            body = bld.add_link(xform=pose, mass=m, inertia=inertia, lock_inertia=True, label="block")
            dof = newton.ModelBuilder.JointDofConfig
            j = bld.add_joint_d6(-1, body, linear_axes=[dof(axis=(1, 0, 0)), dof(axis=(0, 0, 1))],
                                 angular_axes=[dof(axis=(0, 1, 0))])
            bld.add_articulation([j])
        else:
            body = bld.add_body(xform=pose, mass=m, inertia=inertia, lock_inertia=True, label="block")
        bld.add_shape_box(body, hx=b / 2, hy=d / 2, hz=h / 2)
        return bld

    def _solver(self, s: dict):
        """The solver of ``s["solver"]`` with the settings' iterations and relaxation (None: Newton's)."""
        solvers = self.newton.solvers
        it, relax = s.get("iterations"), s.get("contact_relaxation")
        if self.solver_name == "xpbd":
            kw = {} if it is None else {"iterations": int(it)}
            if relax is not None:
                kw["rigid_contact_relaxation"] = float(relax)
            return solvers.SolverXPBD(self.model, **kw)
        if self.solver_name == "semi_implicit":
            return solvers.SolverSemiImplicit(self.model, angular_damping=0.0)
        if self.solver_name == "featherstone":
            return solvers.SolverFeatherstone(self.model, angular_damping=0.0)
        return solvers.SolverVBD(self.model, **({} if it is None else {"iterations": int(it)}))

    def place(self, block: Block, theta0_rad: np.ndarray) -> None:
        """Every block at rest at its ``theta0_rad`` pivoting on its lower corner, the tables at x = 0."""
        q = self.model.joint_q.numpy().reshape(self.worlds, -1)
        q[:] = 0.0
        for w, th in enumerate(np.asarray(theta0_rad, dtype=float)):
            x, z = pivot_pose(block, float(th))
            row = q[w]
            if self.table_drive:   # the table's free joint: position, then quaternion (x, y, z, w)
                row[2], row[6] = -_TABLE_HALF_EXTENTS_M[2], 1.0
                row = row[7:]
            if self.planar and not self.project:
                row[0], row[1], row[2] = x, z, th
            else:
                row[0], row[2] = x, z
                row[4], row[6] = math.sin(th / 2), math.cos(th / 2)
        self.model.joint_qd.zero_()
        with self.wp.ScopedDevice("cpu"):
            self.newton.eval_fk(self.model, self.model.joint_q, self.model.joint_qd, self.s0)
            self.s0.joint_q.assign(self.model.joint_q)
            self.s0.joint_qd.zero_()
            self.s0.body_qd.zero_()

    def load_drive(self, pulses: list, n_steps: int) -> None:
        """Each world's drive for ``n_steps`` steps: ``−ü`` at each step's midpoint (inertial), or the
        table's x at each step's start and its velocity at the midpoint (table); zero after a pulse."""
        n = int(n_steps)
        t0, mid = np.arange(n) * self.dt, (np.arange(n) + 0.5) * self.dt
        zero = np.zeros(n)
        self.acc = np.stack([zero if p is None else -p.accel(mid) for p in pulses], axis=1)
        self.u_pos = self.u_vel = None
        if self.table_drive:
            self.u_pos = np.stack([zero if p is None else p.disp(t0) for p in pulses], axis=1)
            self.u_vel = np.stack([zero if p is None else p.vel(mid) for p in pulses], axis=1)
        self.gravity[:, :] = (0.0, 0.0, -G)

    def step(self, i: int) -> None:
        """Step ``i``: the drive, collision detection, the solver's step."""
        s0 = self.s0
        if self.table_drive:
            bq, bqd = s0.body_q.numpy(), s0.body_qd.numpy()
            bq[self.table_ids, 0] = self.u_pos[i]
            bqd[self.table_ids] = 0.0
            bqd[self.table_ids, 0] = self.u_vel[i]
            if self.solver_name == "featherstone":   # generalised coordinates: the table's free joint
                jq = s0.joint_q.numpy().reshape(self.worlds, -1)
                jqd = s0.joint_qd.numpy().reshape(self.worlds, -1)
                jq[:, 0], jqd[:, :6], jqd[:, 0] = self.u_pos[i], 0.0, self.u_vel[i]
        else:
            self.gravity[: self.worlds, 0] = self.acc[i]
        s0.clear_forces()
        self.pipe.collide(s0, self.contacts)
        self.solver.step(s0, self.s1, self.control, self.contacts, self.dt)
        self.s0, self.s1 = self.s1, s0
        if self.project:
            self._project()

    def _project(self) -> None:
        """Keep free blocks in the x–z plane: y, the tilt about x and z, and their rates set to zero."""
        bq, bqd = self.s0.body_q.numpy(), self.s0.body_qd.numpy()
        i = self.block_ids
        qy, qw = bq[i, 4], bq[i, 6]
        norm = np.sqrt(qy * qy + qw * qw)
        bq[i, 1], bq[i, 3], bq[i, 5] = 0.0, 0.0, 0.0
        bq[i, 4], bq[i, 6] = qy / norm, qw / norm
        bqd[i, 1], bqd[i, 3], bqd[i, 5] = 0.0, 0.0, 0.0

    def rows(self) -> np.ndarray:
        """The blocks' state now, ``(worlds, 13)`` (:data:`_ROW`)."""
        i = self.block_ids
        return np.concatenate([self.s0.body_q.numpy()[i], self.s0.body_qd.numpy()[i]], axis=1).astype(float)

    def advance(self, n_from: int, n_to: int) -> np.ndarray:
        """Steps ``n_from`` to ``n_to``; the blocks' states after each, ``(n_to − n_from, worlds, 13)``."""
        out = np.empty((n_to - n_from, self.worlds, _ROW))
        with self.wp.ScopedDevice("cpu"):
            for k, i in enumerate(range(n_from, n_to)):
                self.step(i)
                out[k] = self.rows()
        return out


class NewtonAdapter(ContactEngine):
    """The rocking block in Newton (see the module docstring for the model).

    Settings
    --------
    solver : {"xpbd", "semi_implicit", "featherstone", "vbd"}
        Newton's solver.
    settings : {"calibrated", "shipped"}
        Settings calibrated to the case's η, or the solver as shipped.
    drive : {"inertial", "table"}
        The inertial force at the centre of mass (gravity tilt), or a kinematic table.
    planar : bool
        Keep the block in the x–z plane (a D6 joint; ``semi_implicit``: a projection), or a free body.
    friction : float
        Friction coefficient of block and table [-] (Newton averages the two; both get it).
    sticky_contacts : bool
        Newton's sticky contact matching (a persisting contact keeps its anchor points).
    iterations : int or None
        Solver iterations per step (``xpbd``, ``vbd``); None: Newton's default (XPBD 2), or the
        calibration's.
    contact_relaxation : float or None
        XPBD's rigid-contact relaxation (Newton's default 0.8) [-].
    contact_stiffness_n_m, contact_damping_n_s_m, friction_gain_n_s_m : float or None
        The contact material's ``ke`` [N/m], ``kd`` [N s/m] and ``kf`` [N s/m] (the penalty solvers
        ``semi_implicit``, ``featherstone``, and VBD's ``ke``/``kd``); None: Newton's defaults
        (2500, 100, 1000), or the calibration's.
    tail_s, min_tail_s : float
        Longest and shortest simulated time after the pulse [s].
    """

    name = "newton"
    module = "newton"
    install_hint = ("install it with `pip install 'rockbench[newton]'` (Newton and warp-lang; Warp's CPU device "
                    "runs it without a GPU).")
    #: none: Newton has no default step (its examples each choose a frame rate and substeps), so as
    #: shipped it runs at fixed_dt_s
    own_dt_s = None
    batching = "native"
    max_worlds = MAX_WORLDS
    SETTINGS = {"solver": "xpbd", "sticky_contacts": True, "tail_s": 2.0, "min_tail_s": 0.25}
    #: Newton's own contact, every value its solver's default (None: unstated, per solver)
    SHIPPED = {"iterations": None, "contact_relaxation": None, "contact_stiffness_n_m": None,
               "contact_damping_n_s_m": None, "friction_gain_n_s_m": None}
    #: the solver is the model: every variant's name says which ran, XPBD (the default) included
    MODEL_SETTINGS = ("solver",)
    CALIBRATION_VERSION = 3

    @classmethod
    def device_note(cls) -> str:
        """Where the worlds run: always Warp's CPU device (the drive writes NumPy views of its arrays)."""
        return "CPU only (Warp's CPU device, one thread)"

    def validate(self, s: dict) -> None:
        self.choice_setting(s, "solver", SOLVERS, allow_none=False)
        self.bool_setting(s, "sticky_contacts")
        self.whole_setting(s, "iterations", minimum=1)
        self.number_setting(s, "contact_relaxation")
        self.number_setting(s, "contact_stiffness_n_m", "N/m")
        self.number_setting(s, "contact_damping_n_s_m", "N s/m", allow_zero=True)
        self.number_setting(s, "friction_gain_n_s_m", "N s/m", allow_zero=True)
        if s["solver"] != "xpbd" and s["contact_relaxation"] is not None:
            raise ConfigError("newton setting 'contact_relaxation' is XPBD's; it needs solver=xpbd.")
        if s["solver"] in ("semi_implicit", "featherstone") and s["iterations"] is not None:
            raise ConfigError(f"newton setting 'iterations' does not apply to solver={s['solver']} (it steps once).")

    def build(self, block: Block, s: dict, dt_s: float) -> dict:
        """What a run's scene needs; :meth:`start` builds it once it knows how many worlds."""
        return {"scene": None}

    def start(self, w: dict, block: Block, s: dict, dt_s: float, pulses: list, theta0_rad: float,
              n_steps: int) -> np.ndarray:
        """A fresh model of one world per pulse, every block at rest at ``theta0_rad``, the drives loaded;
        the blocks' states, ``(worlds, 1, 13)``."""
        sc = w["scene"] = _Scene(block, s, dt_s, len(pulses))
        sc.place(block, np.full(len(pulses), float(theta0_rad)))
        sc.load_drive(pulses, n_steps)
        return sc.rows()[:, None]

    def advance(self, w: dict, n_from: int, n_to: int) -> np.ndarray:
        return w["scene"].advance(n_from, n_to).transpose(1, 0, 2)

    def read(self, w: dict, block: Block, s: dict, rows: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        table = pulse is not None and s["drive"] == "table"
        qx, qy, qz, qw = rows[:, 3], rows[:, 4], rows[:, 5], rows[:, 6]
        roll = np.arcsin(np.clip(2.0 * (qw * qx - qy * qz), -1.0, 1.0))
        diag = {"solver": s["solver"], "max_lateral_drift_m": float(np.max(np.abs(rows[:, 1]))),
                "max_out_of_plane_tilt_rad": float(np.max(np.abs(roll)))}
        return Motion(x_m=rows[:, 0], z_m=rows[:, 2], theta_rad=theta_of_quat(qw, qx, qy, qz), vx_m_s=rows[:, 7],
                      vz_m_s=rows[:, 9], theta_dot_rad_s=rows[:, 11], table_x_m=pulse.disp(t_s) if table else None,
                      table_vx_m_s=pulse.vel(t_s) if table else None, diagnostics=diag)

    @property
    def KNOBS(self) -> tuple:  # noqa: N802 - the declaration, per solver
        """The solver's knobs; unset, each is Newton's own, as shipped.

        * ``xpbd``: Newton's defaults (2 iterations, contact relaxation 0.8) first, kept within
          :data:`_CLOSE_RTOL`; below the target, more iterations at relaxation 1 (:data:`_XPBD_UP`:
          XPBD's η rises towards Housner's as its contact converges); above it, fewer iterations and
          less relaxation (:data:`_XPBD_DOWN`); pair by pair until one is within :data:`_CLOSE_RTOL`.
        * ``semi_implicit``, ``featherstone``: a penalty contact at damping ratio
          :data:`_PENALTY_ZETA` (``kd = 2ζ√(ke·m)``) and friction gain ``kf = 0.1·m/Δt`` (the stiffest
          sticking the explicit step keeps stable), ``log10 ke`` bisected from the softest contact
          that keeps the block standing below the uplift threshold (:func:`_penalty_ke_min`) up to
          ``0.1·m/Δt²``: a softer contact gives a higher η here.
        * ``vbd``: the contact stiffness :data:`_VBD_KE_FACTORS` × :func:`_penalty_ke_min` (a stiffer
          contact gives a lower η), at each the damping :data:`_VBD_KD_N_S_M` (less damping, a higher
          η), until one rocks regularly within :data:`_CLOSE_RTOL`. Newton's material is not tried:
          its ``ke`` (2500 N/m) is below that bound for every preset, and a B6M block on it tips
          over under 0.9·g·tanα (docs/newton.md).
        """
        solver = self.settings["solver"]
        if solver == "xpbd":
            return _xpbd_knobs("below", _XPBD_UP) + _xpbd_knobs("above", _XPBD_DOWN)
        if solver == "vbd":
            return (Knob("contact_stiffness_n_m", "N/m", lambda block, dt: tuple(f * _penalty_ke_min(block)
                                                                                  for f in _VBD_KE_FACTORS),
                         until="close", bisect_rtol=_CLOSE_RTOL),
                    Knob("contact_damping_n_s_m", "N s/m", _VBD_KD_N_S_M, until="close", bisect_rtol=_CLOSE_RTOL))
        return (Knob("contact_stiffness_n_m", "N/m", span=_penalty_span, log10=True, rising=False,
                     bisect_steps=10, bisect_regular=False, along=_penalty_along),)

    @property
    def START_KEEP_RTOL(self) -> float | None:  # noqa: N802 - the declaration, per solver
        """XPBD as shipped is measured first and kept within :data:`_CLOSE_RTOL`; the other solvers'
        searches start from their knobs."""
        return _CLOSE_RTOL if self.settings["solver"] == "xpbd" else None


#: A candidate this close to the target, as a fraction of it, keeps XPBD as shipped and ends XPBD's
#: and VBD's ladders [-]
_CLOSE_RTOL = 0.0025

#: XPBD below the target: (iterations, contact relaxation) tried in turn
_XPBD_UP = ((2, 1.0), (4, 1.0), (8, 1.0))

#: XPBD above the target: (iterations, contact relaxation) tried in turn
_XPBD_DOWN = ((2, 0.6), (1, 0.8), (1, 0.6), (1, 0.4))

#: Stiffest penalty contact a calibration tries, as a fraction of m/Δt² (B3M at Δt = 0.5 ms: 1e6 N/m
#: diverges, 3e5 N/m does not) [-]
_PENALTY_KE_MAX = 0.1

#: Damping ratio of the penalty contact a calibration of semi_implicit / featherstone uses [-]
_PENALTY_ZETA = 0.2


#: VBD: contact stiffnesses tried, as multiples of :func:`_penalty_ke_min` [-]
_VBD_KE_FACTORS = (1.5, 3.0, 8.0)

#: VBD: contact damping tried at each stiffness, Newton's material's first [N s/m]
_VBD_KD_N_S_M = (100.0, 30.0, 10.0)


def _xpbd_knobs(side: str, pairs: tuple) -> tuple:
    """XPBD's iterations and contact relaxation walked pair by pair (``paired``) when XPBD as shipped
    lies more than :data:`_CLOSE_RTOL` on ``side`` of the target, until one is that close."""
    iterations, relaxations = tuple(p[0] for p in pairs), tuple(p[1] for p in pairs)
    return (Knob("iterations", "", iterations, when=side, when_rtol=_CLOSE_RTOL, until="close", bisect_rtol=_CLOSE_RTOL,
                 bisect_regular=False),
            Knob("contact_relaxation", "", relaxations, when=side, when_rtol=_CLOSE_RTOL, paired=True))


def _penalty_ke_min(block: Block) -> float:
    """The softest penalty contact a calibration tries [N/m]: four corner springs ``ke`` hold a block
    under a lateral ``a`` at a tilt ``m·a·h/(2·ke·b²)``; at ``a = 0.9·g·tanα`` that is
    ``0.9·m·g/(2·ke·b)``, kept below half the uplift tolerance (2 % of α) so that a
    dynamic overshoot does not pass it either (a softer contact reaches higher η but rocks below the
    uplift threshold)."""
    tol = 0.5 * 0.02 * block.alpha_rad
    return max(1e3, 0.9 * block.mass_kg * G / (2.0 * block.width_m * tol))


def _penalty_span(block: Block, dt: float) -> tuple[float, float]:
    """The penalty solvers' ``log10 ke`` range: :func:`_penalty_ke_min` to :data:`_PENALTY_KE_MAX`·m/Δt²
    [log10 N/m]."""
    return math.log10(_penalty_ke_min(block)), math.log10(_PENALTY_KE_MAX * block.mass_kg / dt**2)


def _penalty_along(ke: float, block: Block, dt: float) -> dict:
    """What a penalty contact of stiffness ``ke`` [N/m] sets with it: damping at ratio
    :data:`_PENALTY_ZETA` [N s/m] and the friction gain ``0.1·m/Δt`` [N s/m]."""
    return {"contact_damping_n_s_m": 2.0 * _PENALTY_ZETA * math.sqrt(ke * block.mass_kg),
            "friction_gain_n_s_m": 0.1 * block.mass_kg / dt}
