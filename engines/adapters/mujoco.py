"""MuJoCo adapter: the rocking block in MuJoCo's soft-contact model.

The model
---------
A box of full width ``b`` (x), depth ``d`` (y) and height ``h`` (z) with the block's mass and
uniform density stands on a table. It touches the table only through MuJoCo's own box–plane
(inertial drive) or box–box (table drive) contact: no constraint and no impact law of ours
replaces the contact, since the contact is what is measured. By default the block moves in the
vertical x–z plane (joints: slide x, slide z, hinge y through the centre of mass, so a positive
hinge angle tilts the top towards +x, the contract's θ); ``planar=False`` gives it a free joint.

Anti-slip: friction coefficient 10 on both geoms (MuJoCo takes the larger of the two). A block
pivoting on a corner needs ``|F_t/N|`` up to a few units at the pulse amplitudes of the maps; 1
lets the paper's blocks slide above about 3–4 g (docs/physics.md §8), 10 keeps the friction cone out of
the way until the normal force itself vanishes (then no coefficient helps and the run is flagged).
``settings="calibrated"`` also uses elliptic friction cones and MuJoCo's no-slip solver
(``noslip_iterations``), which remove the creep that soft friction allows.

Table drive
-----------
``drive="inertial"`` (default): the table is the world's ground plane and the block feels the
inertial force ``−m·ü`` at its centre of mass, through a motor on the slide-x dof (or the free
joint's x dof). That is exact for a rigid table: in the table's frame the only change is that
force. The force applied during step ``[tₙ, tₙ₊₁]`` is ``−m·(u̇(tₙ₊₁) − u̇(tₙ))/Δt``, the step
average of ``−m·ü``, so the impulse per step is exact and the block ends the pulse with the
table's velocity change exactly.

``drive="table"``: the table is a heavy box (``table_mass_ratio`` × the block's mass) on a slide-x
joint, pushed by a motor with ``(M_table + m)·ü`` (step average as above). The table therefore
moves along ``u(t)`` and has the velocity its contacts need (a mocap table would not: MuJoCo's
contacts see no mocap velocity). The block's reaction perturbs the table by about
``m/M_table``; the largest tracking error is recorded as ``table_track_err_rel``.

End of a run
------------
The run is the contact base's loop (:mod:`rockbench.engines.loop`; the cases of one model a batch
of worlds in MuJoCo's multi-threaded rollouts), stepped in segments of ``segment_s``
on one global time grid, with every contact engine's one end-of-run rule
(:func:`~rockbench.reference_solver.classify.run_end`) tested at every sample. The shared
classifier then decides the outcome on the samples; the adapter never does.

Measurements
------------
The adapter decides nothing about validity: it reports θ, θ̇, both bottom edges relative to the
table (x) and their heights (z) at every sample, and the block's centre of mass, from which the base
computes its own mechanical energy (which sees a hop after an impact); the one validity rule of
:mod:`rockbench.reference_solver.validity` turns them into ``slip``, ``jump`` and ``energy-gain``
for this engine exactly as for every other.

Speed
-----
The model is built once per (block, contact settings, drive) with MuJoCo's model-editing API
(``MjSpec``), settled 0.3 s on its contact, and cached; every run starts from that settled state (a
free-rocking release turns it about the +x edge onto the start pose, the sink kept). Cells run
through ``mujoco.rollout``, one world a call on each of the adapter's threads (MuJoCo releases the
GIL), with the drive as an open-loop control sequence: no Python call per step. A world starts from
an explicit state; its solver warm start is zero at each point of the grid of fixed ``segment_s``
segments and carried from its step before elsewhere (read back from the thread's MjData, since the
rollout returns the state without it), so a run is the same bit for bit wherever the loop ends its
segments (``near_segment_s``: at each run's marks) and whichever cells share its batch (tested).
"""

from __future__ import annotations

import math
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import G, Block
from rockbench.engines.calibration.knobs import Knob
from rockbench.engines.calibration.pick import Candidate, pick
from rockbench.engines.contact import ContactEngine
from rockbench.engines.loop import segment_steps
from rockbench.engines.motion import Motion, pivot_pose, quat_matrix, table_track_err_rel, theta_of_quat, theta_rate_of_body

#: Calibration grid: contact time constants as multiples of the time step, and damping ratios.
_TC_FACTORS = (2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0, 48.0)
_DR_VALUES = (0.5, 0.7, 1.0, 1.4, 2.0)

_CONES = ("elliptic", "pyramidal")
_INTEGRATORS = ("euler", "implicitfast", "implicit", "rk4")


#: Distributed-contact calibration (docs/contact.md): solimp impedances d (dmin = dmax = d), time
#: constants as multiples of the time step, damping ratios. The probe
#: (tests/measurements/probes/probe_eta_m_mujoco.py) found η rising from about η_H at d = 0.9 to 0.88 (B3M) and
#: 0.97 (B6M) at d = 0.3 with a row of points along the base.
_D_VALUES = (0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
_TC_FACTORS_DIST = (2.0, 4.0, 8.0, 16.0)
_DR_VALUES_DIST = (0.5, 1.0, 2.0)



@dataclass
class BuiltModel:
    """One compiled model and what the adapter needs to drive and read it."""

    model: object
    s0: np.ndarray          # FULLPHYSICS state at t = 0 (block settled on the table)
    drive: str
    planar: bool
    mass_kg: float
    push_mass_kg: float     # the mass the drive force accelerates (m, or M_table + m)
    qi: dict                # indices into the state vector
    #: the rollout threads' MjData, made on a run's first start and reused by every later one:
    #: ``{(process id, threads): datas}`` (a forked worker makes its own)
    datas: dict = field(default_factory=dict)


class MujocoAdapter(ContactEngine):
    """The rocking block in MuJoCo (see the module docstring).

    Settings
    --------
    settings : {"calibrated", "shipped"}
        ``calibrated``: contact time constant and damping ratio searched so that free rocking
        reaches the case's η (cached), elliptic cones, no-slip solver, implicitfast integrator.
        ``shipped``: MuJoCo as shipped (solref 0.02 1, pyramidal cones, Euler, no no-slip);
        only the time step and the friction are set.
    drive : {"inertial", "table"}
        How the table motion reaches the block (module docstring).
    planar : bool
        Motion kept in the x–z plane (default) or a free 3-D body.
    friction : float
        Sliding friction coefficient on block and table [-] (default 10, see module docstring).
    timeconst_s, dampratio : float or None
        Contact ``solref`` [s], [-]; given, they replace calibration (and MuJoCo's defaults).
    noslip_iterations : int or None
        MuJoCo's no-slip solver passes (None: 10 calibrated, 0 shipped).
    cone, integrator : str or None
        ``elliptic``/``pyramidal``; ``euler``/``implicitfast``/``implicit``/``rk4`` (None: by mode).
    impratio : float or None
        Ratio of frictional to normal constraint impedance [-] (None: MuJoCo's 1).
    contact : {"auto", "corners", "distributed"}
        ``corners``: the box's own contact with the table (MuJoCo keeps its corner contacts).
        ``distributed``: the box's contact switched off and ``contact_points`` small spheres
        (radius ``contact_radius_m``) in a row along the base, the outer ones under the bottom
        edges, so the static pivots stay at the edges while an impact's impulse can spread into
        the base; its calibration also searches ``solimp_d``. ``auto`` (default): the
        corners for targets up to 1 % above η_H, the distributed contact above (the modified η_M);
        explicit contact settings (timeconst, dampratio) with ``auto`` use the corners.
    contact_points : int or None
        Points of the distributed contact along the base (≥ 3). None (default): the calibration
        tries 9, then 5, then 17 until one reaches the target at an acceptable price; explicit
        contact settings then use 9.
    contact_radius_m : float
        Radius of those points [m] (default 0.5 mm: the pivot rolls on it, an error of order r/h).
    solimp_d : float or None
        MuJoCo's constraint impedance d of the contacts (``solimp = d d 0.001 0.5 2``), in (0, 1):
        the share of each contact enforced as a hard constraint, the rest being solref's
        spring-damper (None: MuJoCo's default solimp).
    tail_s, min_tail_s, segment_s : float
        Longest and shortest simulated time after the pulse, and the segment length [s].
    table_mass_ratio : float
        Table mass over block mass for ``drive="table"`` [-].
    threads : int
        Rollout threads (0: ``OMP_NUM_THREADS`` when set, as the map executors do per worker,
        else all cores).
    """

    name = "mujoco"
    module = "mujoco"
    install_hint = ("install it with `pip install 'rockbench[mujoco]'` (or `pip install mujoco`: a version "
                    "`rockbench engines` lists as supported; 4.0 tested).")
    #: MuJoCo's own default step (mjOption.timestep), what it runs at as shipped
    own_dt_s = 2e-3
    #: cells run through native multi-threaded rollouts: the base's batch of worlds
    batching = "native"
    max_worlds = 512
    #: segments end at each run's marks: each world's warm start is carried across a segment's end and
    #: zeroed on the grid of fixed ``segment_s`` segments, so runs are those of fixed segments bit for bit
    near_segment_s = 0.04
    SETTINGS = {"contact_radius_m": 5e-4, "solimp_d": None, "segment_s": 0.25, "table_mass_ratio": 1000.0, "threads": 0}
    #: MuJoCo's own contact, solref (0.02 s, 1) (MuJoCo 3.x/4.0 docs)
    SHIPPED = {"timeconst_s": 0.02, "dampratio": 1.0}
    #: its solver as shipped, and as the benchmark calibrates it: elliptic cones, no-slip passes and the
    #: implicitfast integrator remove the creep soft friction allows
    MODE_DEFAULTS = {"cone": ("pyramidal", "elliptic"), "integrator": ("euler", "implicitfast"),
                     "noslip_iterations": (0, 10), "impratio": (1.0, 1.0)}
    SHIPPED_NOTE = ("MuJoCo's default pyramidal friction cone at the benchmark's μ = 10 lets the block sink "
                    "through the table (with the elliptic cone, or μ = 1, it rocks: docs/mujoco.md)")
    CONTACT_ROWS = "points"
    #: the corner calibration's knobs: the contact time constant (2–48 × Δt, the stiffness) and damping
    #: ratio (0.5–2), then a finer grid around the pick (time constants from 2·Δt)
    KNOBS = (Knob("timeconst_s", "s", lambda block, dt: tuple(f * dt for f in _TC_FACTORS),
                  refine=(0.8, 0.9, 1.0, 1.12, 1.25), minimum=lambda block, dt: 2.0 * dt),
             Knob("dampratio", "", _DR_VALUES, zeta="ratio", refine=(0.85, 0.92, 1.0, 1.08, 1.18)))
    CALIBRATION_VERSION = 5

    def validate(self, s: dict) -> None:
        for key, unit in (("timeconst_s", "s"), ("dampratio", ""), ("impratio", "")):
            self.number_setting(s, key, unit)
        self.number_setting(s, "table_mass_ratio", allow_none=False)
        self.whole_setting(s, "noslip_iterations")
        self.whole_setting(s, "threads", allow_none=False)
        if s["contact"] == "distributed" and not self.CONTACT_ROWS:
            raise ConfigError(f"{self.name} setting contact='distributed' is not supported by this adapter "
                              "(its contact along the base was not built or tested); use corners or auto.")
        self.number_setting(s, "contact_radius_m", "m", allow_none=False)
        self.number_setting(s, "solimp_d")
        if s["solimp_d"] is not None and not 0.0 < s["solimp_d"] < 1.0:
            raise ConfigError(f"mujoco setting 'solimp_d' must be in (0, 1), got {s['solimp_d']!r}.")
        self.choice_setting(s, "cone", _CONES)
        self.choice_setting(s, "integrator", _INTEGRATORS)

    # -- the four methods: a batch of worlds in MuJoCo's multi-threaded rollouts --------------------
    def build(self, block: Block, s: dict, dt_s: float) -> dict:
        """The model of the block and settings (built once, settled on its contact)."""
        key = (block.width_m, block.height_m, block.depth_m, block.mass_kg, dt_s,
               *(s[k] for k in ("drive", "planar", "friction", "table_mass_ratio", "timeconst_s", "dampratio", *MODE_KEYS)),
               *_geometry(s).values())
        if key not in self.scenes:
            self.scenes[key] = self._build(block, s, dt_s)
        return {"bm": self.scenes[key]}

    def start(self, world: dict, block: Block, s: dict, dt_s: float, pulses: list, theta0_rad: float,
              n_steps: int) -> np.ndarray:
        """Every world at the settled rest state (turned to ``theta0_rad`` about the +x edge, the sink
        kept), a zero warm start, and the rollout threads: one MjData each (made once per model and
        thread count) and one single-threaded ``Rollout`` each, so that each world's warm start can be
        read back after its segment (``mujoco.rollout`` returns the state without it)."""
        import mujoco   # optional engine library

        bm, n = world["bm"], len(pulses)
        nthread = min(self._threads(), n)
        key = (os.getpid(), nthread)
        if key not in bm.datas:
            bm.datas[key] = [mujoco.MjData(bm.model) for _ in range(nthread)]
        state = bm.s0 if theta0_rad == 0.0 else released_state(bm, block, theta0_rad)
        world.update(pulses=pulses, current=np.tile(state, (n, 1)), active=np.ones(n, dtype=bool),
                     warm=np.zeros((n, bm.model.nv)), frozen=np.zeros(n, dtype=bool),
                     grid=segment_steps(s, dt_s), datas=bm.datas[key], pool=_pool(key))
        return world["current"][:, None].copy()

    def advance(self, world: dict, n_from: int, n_to: int) -> np.ndarray:
        """One segment of the worlds still running (the others' rows are NaN), the drive averaged
        over each step: the force −m·ü (or (M_table + m)·ü on the table) from the pulse's velocity.

        A world's solver warm start is zero at each point of the grid of fixed ``segment_s``
        segments and carried from the world's step before elsewhere, and a world that raised a MuJoCo
        warning holds its state to the next grid point, as one rollout a grid segment does: a run is
        the same bit for bit wherever the loop ends its segments (``near_segment_s``)."""
        bm, grid = world["bm"], world["grid"]
        out = np.full((len(world["pulses"]), n_to - n_from, bm.s0.size), np.nan)
        cuts = [n_from, *range((n_from // grid + 1) * grid, n_to, grid), n_to]
        for a, b in zip(cuts[:-1], cuts[1:]):
            if a % grid == 0:
                world["warm"][:] = 0.0
                world["frozen"][:] = False
            self._piece(world, a, b, out[:, a - n_from:b - n_from])
        return out

    @staticmethod
    def _piece(world: dict, n_from: int, n_to: int, out: np.ndarray) -> None:
        """Steps ``n_from`` to ``n_to`` of the running worlds, within one grid segment, into ``out``."""
        bm = world["bm"]
        dt, nseg = bm.model.opt.timestep, n_to - n_from
        held = world["active"] & world["frozen"]
        out[held] = world["current"][held, None]
        ia = np.nonzero(world["active"] & ~world["frozen"])[0]
        tk = (n_from + np.arange(nseg + 1)) * dt
        ctrl = np.zeros((len(world["pulses"]), nseg, 1))
        for i in ia:
            if world["pulses"][i] is not None:
                v = np.asarray(world["pulses"][i].vel(tk), dtype=float)
                ctrl[i, :, 0] = (-bm.mass_kg if bm.drive == "inertial" else bm.push_mass_kg) * (np.diff(v) / dt)
        rows = np.empty((len(world["pulses"]), nseg, bm.s0.size))
        if len(world["datas"]) == 1 or ia.size * nseg < _THREADED_STEPS:
            _roll(bm.model, world["datas"][0], world, ia, ctrl, rows)
        else:
            chunks = np.array_split(ia, len(world["datas"]))
            list(world["pool"].map(lambda c, d: _roll(bm.model, d, world, c, ctrl, rows), chunks, world["datas"]))
        out[ia] = rows[ia]
        world["current"][ia] = rows[ia, -1]

    def retire(self, world: dict, w: int) -> None:
        world["active"][w] = False

    def read(self, world: dict, block: Block, s: dict, rows: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        """What MuJoCo measured: θ, θ̇, both bottom edges relative to the table, the centre of mass."""
        bm = world["bm"]
        qi = bm.qi
        t, th, thd, (xp, zp, xm, zm), ut = _read(bm, rows, block)
        x, z = rows[:, qi["pos"]], rows[:, qi["pos"] + (1 if bm.planar else 2)] + (0.5 * block.height_m if bm.planar else 0.0)
        vx, vz = rows[:, qi["vel"]], rows[:, qi["vel"] + (1 if bm.planar else 2)]
        diag: dict = {"dt_s": float(bm.model.opt.timestep), "timeconst_s": s["timeconst_s"], "dampratio": s["dampratio"],
                      "steps": int(len(t) - 1), "t_end_s": float(t[-1])}
        if bm.drive == "table" and pulse is not None:
            diag["table_track_err_rel"] = table_track_err_rel(ut, pulse, t)
        vt = rows[:, qi["table_v"]] if qi["table_v"] is not None else None
        return Motion(x_m=x, z_m=z, theta_rad=th, vx_m_s=vx, vz_m_s=vz, theta_dot_rad_s=thd, table_x_m=ut,
                      table_vx_m_s=vt, diagnostics=diag, t_s=t, corner_x_m=np.stack([xp, xm], axis=1),
                      corner_z_m=np.stack([zp, zm], axis=1))

    def stop_angles(self, world: dict, block: Block, s: dict, rows: np.ndarray, t_s: np.ndarray, pulse) -> tuple:
        """θ, θ̇ and the state's own time of a segment's rows for the end-of-run test, as :meth:`read`
        gives them (without the corners and the centre of mass it adds)."""
        th, thd, _ = _angles_of(world["bm"], rows)
        return th, thd, rows[:, 0]

    def candidates(self, block: Block, target: float, dt_s: float, points: int | None, measure) -> list[dict]:
        """The corners: the knobs' search. A row along the base: solimp impedance d (0.3–0.9) × time
        constant (2–16·Δt) × damping ratio (0.5–2), then a finer grid around its pick (d ± 0.05 within
        0.05–0.95, time constants from 2·Δt)."""
        if points is None:
            return super().candidates(block, target, dt_s, points, measure)
        rows = measure([{"timeconst_s": f * dt_s, "dampratio": dr, "solimp_d": dd}
                        for dd in _D_VALUES for f in _TC_FACTORS_DIST for dr in _DR_VALUES_DIST])
        if not any(np.isfinite(r["eta"]) for r in rows):
            return rows
        b = pick([Candidate.of_row(r) for r in rows], target, block).candidate.knobs
        tc, dr, dd = b["timeconst_s"], b["dampratio"], b["solimp_d"]
        return rows + measure([{"timeconst_s": tc * f, "dampratio": dr * g, "solimp_d": min(0.95, max(0.05, dd + e))}
                               for f in (0.7, 1.0, 1.4) for g in (0.8, 1.0, 1.25) for e in (-0.05, 0.0, 0.05)
                               if tc * f >= 2.0 * dt_s and (f, g, e) != (1.0, 1.0, 0.0)])

    # -- the model ----------------------------------------------------------------------------
    def _build(self, block: Block, s: dict, dt: float) -> BuiltModel:
        import mujoco   # optional engine library

        b, h, d, m = block.width_m, block.height_m, block.depth_m, block.mass_kg
        drive, planar = s["drive"], bool(s["planar"])
        spec = mujoco.MjSpec()
        spec.option.timestep = dt
        spec.option.gravity = [0.0, 0.0, -G]
        spec.option.integrator = getattr(mujoco.mjtIntegrator, "mjINT_" + s["integrator"].upper())
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC if s["cone"] == "elliptic" else mujoco.mjtCone.mjCONE_PYRAMIDAL
        spec.option.noslip_iterations = int(s["noslip_iterations"])
        spec.option.impratio = float(s["impratio"])
        solref = [float(s["timeconst_s"]), float(s["dampratio"])]
        if solref[0] < 2.0 * dt:
            # MuJoCo silently stiffens nothing below 2Δt (refsafe clamps it): say so instead
            raise ConfigError(f"mujoco timeconst {solref[0]:g} s is below 2·dt = {2 * dt:g} s, which MuJoCo "
                              "clamps; use a larger timeconst_s or a smaller --dt.")
        world = spec.worldbody
        if drive == "inertial":
            table = world.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.0, 0.0, 1.0])
        else:
            tb = world.add_body(name="table")
            tb.add_joint(name="table_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])
            # a thick slab, wide enough for any motion of the block on it
            table = tb.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[50.0 * b + h, 50.0 * b + h, 0.05],
                                pos=[0.0, 0.0, -0.05], mass=s["table_mass_ratio"] * m)
        body = world.add_body(name="block", pos=[0.0, 0.0, 0.5 * h])
        if planar:
            body.add_joint(name="x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])
            body.add_joint(name="z", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0])
            body.add_joint(name="theta", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 1.0, 0.0])
        else:
            body.add_freejoint(name="free")
        box = body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.5 * b, 0.5 * d, 0.5 * h], mass=m)
        touching = [table, box]
        geo = _geometry(s)
        if geo["contact"] == "distributed":
            # the box carries the mass and inertia only; a row of small spheres along the base
            # touches the table, the outer ones with their lowest points under the bottom edges
            box.contype = 0
            box.conaffinity = 0
            r = float(geo["contact_radius_m"])
            touching = [table]
            # a planar block needs one row; a free block two (front and back), or it tips sideways
            rows = (0.0,) if planar else (-0.5 * d + r, 0.5 * d - r)
            for x in np.linspace(-0.5 * b, 0.5 * b, int(geo["contact_points"])):
                for y in rows:
                    touching.append(body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0.0, 0.0],
                                                 pos=[float(x), y, -0.5 * h + r], mass=0.0))
        for g in touching:
            g.friction = [float(s["friction"]), 0.005, 0.0001]
            g.solref = solref
            if geo["solimp_d"] is not None:
                g.solimp = [float(geo["solimp_d"]), float(geo["solimp_d"]), 0.001, 0.5, 2.0]
        act = spec.add_actuator()
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.target = ("x" if planar else "free") if drive == "inertial" else "table_x"
        act.gear = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        act.ctrllimited = 0
        model = spec.compile()
        # state layout of FULLPHYSICS: [time, qpos, qvel, ...]; the table's slide joint comes first
        jb = 1 if drive == "table" else 0
        qi = {"nq": model.nq, "table": 1 if jb else None, "table_v": 1 + model.nq if jb else None, "pos": 1 + jb,
              "vel": 1 + model.nq + jb}
        push = m if drive == "inertial" else (s["table_mass_ratio"] + 1.0) * m
        return BuiltModel(model, self._settle(model, mujoco), drive, planar, m, push, qi)

    @staticmethod
    def _settle(model, mujoco) -> np.ndarray:
        """The block at rest on its soft contact: 0.3 s of settling, then velocities and time zeroed."""
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        for _ in range(int(round(0.3 / model.opt.timestep))):
            mujoco.mj_step(model, data)
        data.qvel[:] = 0.0
        data.time = 0.0
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        s0 = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, data, s0, spec)
        return s0

    def _threads(self) -> int:
        n = self.settings["threads"]
        if n > 0:
            return n
        # the map executors give each worker process its share of the cores in OMP_NUM_THREADS;
        # honouring it keeps jobs × threads within the machine
        try:
            share = int(os.environ.get("OMP_NUM_THREADS", "0"))
        except ValueError:
            share = 0
        return share if share > 0 else (os.cpu_count() or 1)


#: the rollout thread pools of this process, one per thread count, shared by every model and run:
#: ``{(process id, threads): ThreadPoolExecutor}`` (a forked worker makes its own)
_POOLS: dict = {}


def _pool(key: tuple) -> ThreadPoolExecutor:
    """The thread pool of ``key`` ``(process id, threads)``, made on first use."""
    if key not in _POOLS:
        _POOLS[key] = ThreadPoolExecutor(max_workers=key[1])
    return _POOLS[key]


def _roll(model, data, world: dict, worlds: np.ndarray, ctrl: np.ndarray, out: np.ndarray) -> None:
    """One rollout per world of ``worlds`` on one thread's ``data`` (MuJoCo releases the GIL), each from
    the world's state and warm start, into ``out``; each world's warm start and warnings read back."""
    import mujoco   # optional engine library
    from mujoco import rollout   # optional engine library

    me = threading.get_ident()
    if me not in _SERIAL:
        _SERIAL[me] = rollout.Rollout(nthread=0)
    for i in worlds:
        _SERIAL[me].rollout([model], [data], world["current"][i:i + 1], ctrl[i:i + 1], skip_checks=True,
                            nstep=out.shape[1], initial_warmstart=world["warm"][i:i + 1], state=out[i:i + 1],
                            control_spec=mujoco.mjtState.mjSTATE_CTRL.value)
        world["warm"][i] = data.qacc_warmstart
        world["frozen"][i] = data.warning.number.any()


#: one single-threaded rollout per thread that runs them: ``{thread id: mujoco.rollout.Rollout}``
_SERIAL: dict = {}
#: world-steps of a segment below which its worlds run on the calling thread: about 20 ms of MuJoCo's
#: steps, against about 0.1 ms of handing work to the pool's threads (results are the same either way)
_THREADED_STEPS = 5000


#: the solver settings a model is built with (:attr:`MujocoAdapter.MODE_DEFAULTS`)
MODE_KEYS = ("cone", "integrator", "noslip_iterations", "impratio")


def _geometry(s: dict) -> dict:
    """The contact geometry of resolved settings: the box's own corner contact, or a row of points
    along the base (its number and radius), and the contacts' solimp impedance."""
    dist = s["contact"] == "distributed"
    return {"contact": "distributed" if dist else "corners", "contact_points": int(s["contact_points"]) if dist else None,
            "contact_radius_m": float(s["contact_radius_m"]) if dist else None,
            "solimp_d": None if s["solimp_d"] is None else float(s["solimp_d"])}


def released_state(bm: BuiltModel, block: Block, th0: float) -> np.ndarray:
    """The settled state turned to ``th0`` [rad] about the +x edge onto the start pose
    (:func:`~rockbench.engines.motion.pivot_pose`), the settled sink kept."""
    s = bm.s0.copy()
    h, p = block.height_m, bm.qi["pos"]
    sink = s[p + 1] if bm.planar else s[p + 2] - 0.5 * h
    cx, cz = pivot_pose(block, th0)
    if bm.planar:
        s[p: p + 3] = [cx, cz - 0.5 * h + sink, th0]
    else:
        s[p: p + 3] = [cx, 0.0, cz + sink]
        s[p + 3: p + 7] = [math.cos(0.5 * th0), 0.0, math.sin(0.5 * th0), 0.0]
    return s


def _angles_of(bm: BuiltModel, st: np.ndarray, skip: int = 0):
    """θ and θ̇ from state rows ``(..., k)`` of a built model (``skip``: leading columns of the
    FULLPHYSICS layout the rows leave out), and the block's rotation matrices (None: planar)."""
    p, v = bm.qi["pos"] - skip, bm.qi["vel"] - skip
    if bm.planar:
        return st[..., p + 2], st[..., v + 2], None
    q = [st[..., p + 3 + k] for k in range(4)]
    r = quat_matrix(*q)
    # free-joint angular velocity is in the body frame: rotate it to the world, take y
    return theta_of_quat(*q), theta_rate_of_body(r, st[..., v + 3:v + 6]), r


def _read(bm: BuiltModel, st: np.ndarray, block: Block):
    """θ, θ̇, the two bottom edges' (x, z) relative to the table, and the table's x, per sample."""
    qi = bm.qi
    b, h = block.width_m, block.height_m
    t = st[:, 0]
    th, thd, r = _angles_of(bm, st)
    if bm.planar:
        cx, cz = st[:, qi["pos"]], st[:, qi["pos"] + 1] + 0.5 * h
        c, s = np.cos(th), np.sin(th)
        # rotation about +y: local (lx, lz) -> (lx c + lz s, −lx s + lz c)
        r00, r02, r20, r22 = c, s, -s, c
    else:
        cx, cz = st[:, qi["pos"]], st[:, qi["pos"] + 2]
        r00, r02, r20, r22 = r[:, 0, 0], r[:, 0, 2], r[:, 2, 0], r[:, 2, 2]
    ut = st[:, qi["table"]] if qi["table"] is not None else np.zeros_like(t)
    # bottom edges at local (±b/2, 0, −h/2)
    ex_p = cx + r00 * 0.5 * b - r02 * 0.5 * h - ut
    ez_p = cz + r20 * 0.5 * b - r22 * 0.5 * h
    ex_m = cx - r00 * 0.5 * b - r02 * 0.5 * h - ut
    ez_m = cz - r20 * 0.5 * b - r22 * 0.5 * h
    return t, th, thd, (ex_p, ez_p, ex_m, ez_m), ut
