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
The run is the contact-engine skeleton's loop (:mod:`rockbench.engines.skeleton`; the cases of one
model a batch of worlds in MuJoCo's multi-threaded rollouts), stepped in segments of ``segment_s``
on one global time grid, with every contact engine's one end-of-run rule
(:func:`~rockbench.reference_solver.classify.run_end`) tested at every sample. The shared
classifier then decides the outcome on the samples; the adapter never does.

Measurements
------------
The adapter decides nothing about validity: it reports θ, θ̇, both bottom edges relative to the
table (x) and their heights (z) at every sample, and the block's own mechanical energy
(``½v_c² + ½(R²/3)θ̇² + g·z_c``, which sees a hop after an impact); the one validity rule of
:mod:`rockbench.reference_solver.validity` turns them into ``slip``, ``jump`` and ``energy-gain``
for this engine exactly as for every other.

Speed
-----
The model is built once per (block, contact settings, drive) with MuJoCo's model-editing API
(``MjSpec``) and cached; cells run through ``mujoco.rollout`` (native, multi-threaded), with the
drive as an open-loop control sequence: no Python call per step. Every segment of every cell
starts from an explicit state and a zero solver warm start, so a cell's result never depends on
which other cells share its batch (tested bit for bit).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..reference_solver.errors import ConfigError
from ..reference_solver.model import G, Block
from ..reference_solver.restitution import Restitution
from .base import CalibrationResult, RestitutionMeasurement
from .contact import POINTS_TRIED, ContactEngineAdapter
from . import price as pricing
from .free_rocking import PEAK_RATIO, contact_figures
from .knobs import Knob
from .pick import Candidate, pick
from .rotation import quat_matrix, theta_rate_of_body
from .skeleton import Motion, SteppedContactAdapter

#: MuJoCo's own defaults for what ``settings="shipped"`` leaves alone (MuJoCo 3.x/4.0 docs).
MUJOCO_SHIPPED = {"timeconst": 0.02, "dampratio": 1.0, "cone": "pyramidal", "integrator": "euler",
                  "noslip_iterations": 0, "impratio": 1.0}

#: Free-rocking release angle used by calibration, as a fraction of α [-].
CALIBRATION_THETA0_FRAC = 0.5

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
    params: dict            # the contact settings in force


class MujocoAdapter(SteppedContactAdapter):
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
        (``timeconst`` is the old name of ``timeconst_s``, accepted for one release.)
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
    default_dt_s = 5e-4
    #: MuJoCo's own default step (mjOption.timestep), what it runs at as shipped
    shipped_dt_s = 2e-3
    #: cells run through native multi-threaded rollouts: the skeleton's batch of worlds
    batching = "native"
    max_worlds = 512
    SETTINGS = {
        **ContactEngineAdapter.SHARED_SETTINGS,
        "timeconst_s": None,
        "dampratio": None,
        "noslip_iterations": None,
        "cone": None,
        "integrator": None,
        "impratio": None,
        "contact": "auto",
        "contact_points": None,
        "contact_radius_m": 5e-4,
        "solimp_d": None,
        "segment_s": 0.25,
        "table_mass_ratio": 1000.0,
        "threads": 0,
    }

    SHIPPED_NOTE = ("MuJoCo's default pyramidal friction cone at the benchmark's μ = 10 lets the block sink "
                    "through the table (with the elliptic cone, or μ = 1, it rocks: docs/mujoco.md)")
    #: whether this adapter builds the contact along the base; a subclass that does not
    #: (MuJoCo Warp) sets it False: ``auto`` then keeps the corners for every target
    distributed_contact = True
    #: the corner calibration's knobs: the contact time constant (2–48 × Δt, the stiffness) and
    #: damping ratio (0.5–2), then a finer grid around the pick (time constants from 2·Δt)
    CALIBRATION_KNOBS = (
        Knob("timeconst", "s", "stiffness", lambda block, dt: tuple(f * dt for f in _TC_FACTORS),
             refine=(0.8, 0.9, 1.0, 1.12, 1.25), shipped=MUJOCO_SHIPPED["timeconst"],
             minimum=lambda block, dt: 2.0 * dt),
        Knob("dampratio", "", "damping", lambda block, dt: _DR_VALUES, refine=(0.85, 0.92, 1.0, 1.08, 1.18),
             shipped=MUJOCO_SHIPPED["dampratio"]),
    )
    #: versions of the corner and distributed calibrations (part of their cache keys)
    CALIBRATION_VERSION = 4
    CALIBRATION_VERSION_DIST = 3

    def __init__(self, **settings):
        super().__init__(**settings)
        self._models: dict = {}

    # -- settings ----------------------------------------------------------------------------
    def _validate_engine_settings(self, s: dict) -> None:
        for key, unit in (("timeconst_s", "s"), ("dampratio", ""), ("impratio", "")):
            self._number_setting(s, key, unit)
        self._number_setting(s, "table_mass_ratio", allow_none=False)
        self._whole_setting(s, "noslip_iterations", 0)
        self._whole_setting(s, "threads", 0, allow_none=False)
        self._contact_layout_settings(s)
        if s["contact"] == "distributed" and not self.distributed_contact:
            raise ConfigError(f"{self.name} setting contact='distributed' is not supported by this adapter "
                              "(its contact along the base was not built or tested); use corners or auto.")
        self._number_setting(s, "contact_radius_m", "m", allow_none=False)
        self._number_setting(s, "solimp_d", "")
        if s["solimp_d"] is not None and not 0.0 < s["solimp_d"] < 1.0:
            raise ConfigError(f"mujoco setting 'solimp_d' must be in (0, 1), got {s['solimp_d']!r}.")
        for key, allowed in (("cone", _CONES), ("integrator", _INTEGRATORS)):
            if s[key] is not None and s[key] not in allowed:
                raise ConfigError(f"mujoco setting {key!r} must be one of {', '.join(allowed)}, got {s[key]!r}.")

    def _solver_params(self) -> dict:
        """Cone, integrator, no-slip passes and impratio for this mode (explicit settings win)."""
        s = self.settings
        calibrated = s["settings"] == "calibrated"
        base = ({"cone": "elliptic", "integrator": "implicitfast", "noslip_iterations": 10, "impratio": 1.0}
                if calibrated else {k: MUJOCO_SHIPPED[k] for k in ("cone", "integrator", "noslip_iterations", "impratio")})
        for k in base:
            if s[k] is not None:
                base[k] = s[k]
        return base

    def explicit_contact(self) -> bool:
        """Whether ``timeconst_s`` or ``dampratio`` was given (then nothing is calibrated)."""
        return self.settings["timeconst_s"] is not None or self.settings["dampratio"] is not None

    def _resolved_settings(self, block: Block, dt: float, cal: CalibrationResult | None) -> dict:
        """The mode's solver settings and the contact ``solref``: calibrated, or explicit with
        MuJoCo's shipped value for what is not given. ``timeconst`` is the resolved contact time
        constant [s] (the key MuJoCo's calibration records and the model cache use)."""
        s = self.settings
        out = {"settings": s["settings"], "drive": s["drive"], "planar": s["planar"], "friction": s["friction"],
               "dt_s": dt, **self._solver_params()}
        if cal is None:
            out["timeconst"] = s["timeconst_s"] if s["timeconst_s"] is not None else MUJOCO_SHIPPED["timeconst"]
            out["dampratio"] = s["dampratio"] if s["dampratio"] is not None else MUJOCO_SHIPPED["dampratio"]
            out.update(self._contact_geometry())
            out["calibration"] = None
        else:
            out["timeconst"] = cal.settings["timeconst"]
            out["dampratio"] = cal.settings["dampratio"]
            out.update(_contact_of(cal.settings))
        return out

    @staticmethod
    def _calibration_summary(cal: CalibrationResult) -> dict:
        return {**ContactEngineAdapter._calibration_summary(cal), "note": cal.note,
                "rest_sink_m": cal.settings.get("rest_sink_m")}

    def _contact_geometry(self) -> dict:
        """The contact geometry for explicit (uncalibrated) contact settings."""
        s = self.settings
        kind = "distributed" if s["contact"] == "distributed" else "corners"
        n = s["contact_points"] if s["contact_points"] is not None else POINTS_TRIED[0]
        return {"contact": kind, "contact_points": n if kind == "distributed" else None,
                "contact_radius_m": s["contact_radius_m"] if kind == "distributed" else None,
                "solimp_d": s["solimp_d"]}

    # -- model -------------------------------------------------------------------------------
    def _model(self, block: Block, p: dict, dt: float, drive: str | None = None) -> BuiltModel:
        drive = self.settings["drive"] if drive is None else drive
        planar = self.settings["planar"]
        key = (block.width_m, block.height_m, block.depth_m, block.mass_kg, dt, drive, planar,
               self.settings["friction"], self.settings["table_mass_ratio"],
               tuple(sorted((k, p[k]) for k in ("timeconst", "dampratio", "cone", "integrator",
                                                 "noslip_iterations", "impratio"))),
               tuple(sorted(_contact_of(p).items())))
        if key not in self._models:
            self._models[key] = self._build(block, p, dt, drive, planar)
        return self._models[key]

    def _build(self, block: Block, p: dict, dt: float, drive: str, planar: bool) -> BuiltModel:
        import mujoco   # optional engine library

        b, h, d, m = block.width_m, block.height_m, block.depth_m, block.mass_kg
        mu = self.settings["friction"]
        spec = mujoco.MjSpec()
        spec.option.timestep = dt
        spec.option.gravity = [0.0, 0.0, -G]
        spec.option.integrator = getattr(mujoco.mjtIntegrator, "mjINT_" + p["integrator"].upper())
        spec.option.cone = (mujoco.mjtCone.mjCONE_ELLIPTIC if p["cone"] == "elliptic"
                            else mujoco.mjtCone.mjCONE_PYRAMIDAL)
        spec.option.noslip_iterations = int(p["noslip_iterations"])
        spec.option.impratio = float(p["impratio"])
        solref = [float(p["timeconst"]), float(p["dampratio"])]
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
                                pos=[0.0, 0.0, -0.05], mass=self.settings["table_mass_ratio"] * m)
        body = world.add_body(name="block", pos=[0.0, 0.0, 0.5 * h])
        if planar:
            body.add_joint(name="x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])
            body.add_joint(name="z", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0])
            body.add_joint(name="theta", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 1.0, 0.0])
        else:
            body.add_freejoint(name="free")
        box = body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.5 * b, 0.5 * d, 0.5 * h], mass=m)
        touching = [table, box]
        contact = _contact_of(p)
        if contact["contact"] == "distributed":
            # the box carries the mass and inertia only; a row of small spheres along the base
            # touches the table, the outer ones with their lowest points under the bottom edges
            box.contype = 0
            box.conaffinity = 0
            r = float(contact["contact_radius_m"])
            touching = [table]
            # a planar block needs one row; a free block two (front and back), or it tips sideways
            rows = (0.0,) if planar else (-0.5 * d + r, 0.5 * d - r)
            for x in np.linspace(-0.5 * b, 0.5 * b, int(contact["contact_points"])):
                for y in rows:
                    touching.append(body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0.0, 0.0],
                                                 pos=[float(x), y, -0.5 * h + r], mass=0.0))
        for g in touching:
            g.friction = [mu, 0.005, 0.0001]
            g.solref = solref
            if contact["solimp_d"] is not None:
                g.solimp = [float(contact["solimp_d"]), float(contact["solimp_d"]), 0.001, 0.5, 2.0]
        act = spec.add_actuator()
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.target = ("x" if planar else "free") if drive == "inertial" else "table_x"
        act.gear = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        act.ctrllimited = 0
        model = spec.compile()

        # state layout of FULLPHYSICS: [time, qpos, qvel, ...]
        nq = model.nq
        qi = {"nq": nq}
        jb = 1 if drive == "table" else 0          # the table's slide joint comes first
        qi["table"] = 1 if drive == "table" else None
        qi["table_v"] = 1 + nq if drive == "table" else None
        qi["pos"] = 1 + jb                           # x, (y), z of the block's joint coordinates
        qi["vel"] = 1 + nq + jb

        push = m if drive == "inertial" else (self.settings["table_mass_ratio"] + 1.0) * m
        s0 = self._settle(model, mujoco)
        return BuiltModel(model, s0, drive, planar, m, push, qi, dict(p))

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

    # -- reading the state -------------------------------------------------------------------
    def _read(self, bm: BuiltModel, st: np.ndarray, block: Block):
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

    # -- the skeleton's hooks: a batch of worlds in MuJoCo's multi-threaded rollouts ---------------
    def _world(self, block: Block, s: dict, dt_s: float) -> dict:
        return {"bm": self._model(block, s, dt_s), "block": block}

    def _start(self, world, block: Block, s: dict, dt_s: float, pulses, theta0_rad: float,
               n_steps: int) -> np.ndarray:
        """Every world at the settled rest state; the rollout threads (one MjData each)."""
        import mujoco   # optional engine library
        from mujoco import rollout   # optional engine library

        bm, n = world["bm"], len(pulses)
        nthread = min(self._threads(), n)
        world.update(pulses=pulses, current=np.tile(bm.s0, (n, 1)), active=np.ones(n, dtype=bool),
                     datas=[mujoco.MjData(bm.model) for _ in range(nthread)], ro=rollout.Rollout(nthread=nthread))
        return world["current"][:, None].copy()

    def _advance(self, world, n_from: int, n_to: int) -> np.ndarray:
        """One segment of the worlds still running (the others' rows are NaN), the drive averaged
        over each step: the force −m·ü (or (M_table + m)·ü on the table) from the pulse's velocity."""
        bm = world["bm"]
        model, dt, nseg = bm.model, bm.model.opt.timestep, n_to - n_from
        ia = np.nonzero(world["active"])[0]
        tk = (n_from + np.arange(nseg + 1)) * dt
        ctrl = np.empty((ia.size, nseg, 1))
        for j, i in enumerate(ia):
            v = np.asarray(world["pulses"][i].vel(tk), dtype=float)
            ctrl[j, :, 0] = (-bm.mass_kg if bm.drive == "inertial" else bm.push_mass_kg) * (np.diff(v) / dt)
        st, _ = world["ro"].rollout([model] * ia.size, world["datas"], world["current"][ia], ctrl,
                                    initial_warmstart=np.zeros((ia.size, model.nv)))
        out = np.full((len(world["pulses"]), nseg, bm.s0.size), np.nan)
        out[ia] = st
        world["current"][ia] = st[:, -1]
        return out

    def _retire(self, world, w: int) -> None:
        world["active"][w] = False

    def _angles(self, world, rows: np.ndarray):
        _, th, thd, _, _ = self._read(world["bm"], rows, world["block"])
        return th, thd

    def _motion(self, world, block: Block, s: dict, data: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        """What MuJoCo measured: θ, θ̇, both bottom edges relative to the table, the block's energy,
        up to the first non-finite sample."""
        if "ro" in world:
            world.pop("ro").close()
        bm = world["bm"]
        qi = bm.qi
        t, th, thd, (xp, zp, xm, zm), ut = self._read(bm, data, block)
        z_off = 0.5 * block.height_m if bm.planar else 0.0
        x, z = data[:, qi["pos"]], data[:, qi["pos"] + (1 if bm.planar else 2)] + z_off
        vx, vz = data[:, qi["vel"]], data[:, qi["vel"] + (1 if bm.planar else 2)]
        # the block's own energy: ½v_c² (relative to the table) + ½(R²/3)θ̇² + g·z_c [J/kg]
        vx_rel = vx - data[:, qi["table_v"]] if qi["table_v"] is not None else vx
        energy = 0.5 * (vx_rel**2 + vz**2) + 0.5 * block.half_diagonal_m**2 / 3.0 * thd**2 + G * z
        diag: dict = {"dt_s": float(bm.model.opt.timestep), "timeconst": bm.params["timeconst"],
                      "dampratio": bm.params["dampratio"]}
        arrays = (t, th, thd, xp, zp, xm, zm, ut, energy, x, z, vx, vz)
        good = np.isfinite(th) & np.isfinite(thd)
        if not good.all():
            t, th, thd, xp, zp, xm, zm, ut, energy, x, z, vx, vz = (v[:max(int(np.argmin(good)), 1)] for v in arrays)
        if bm.drive == "table":
            u = np.asarray(pulse.disp(t), dtype=float)
            scale = max(float(np.max(np.abs(u))), 1e-12)
            diag["table_track_err_rel"] = float(np.max(np.abs(ut - ut[0] - u)) / scale)
        diag.update(steps=int(len(t) - 1), t_end_s=float(t[-1]))
        return Motion(x_m=x, z_m=z, theta_rad=th, vx_m_s=vx, vz_m_s=vz, theta_dot_rad_s=thd, table_x_m=ut,
                      diagnostics=diag, t_s=t, corner_x_m=np.stack([xp, xm], axis=1),
                      corner_z_m=np.stack([zp, zm], axis=1), energy_j_kg=energy)

    # -- restitution -------------------------------------------------------------------------
    def _free_rocking(self, block: Block, params_list: list[dict], dt: float,
                      theta0_frac: float) -> list[RestitutionMeasurement]:
        """Free rocking from rest at ``theta0_frac·α`` about the +x edge, one native batch, as long
        as the one reader's test (:data:`~rockbench.engines.free_rocking.PEAK_RATIO`)."""
        import mujoco   # optional engine library
        from mujoco import rollout   # optional engine library

        built = [self._model(block, p, dt) for p in params_list]
        groups: dict = {}
        for i, bm in enumerate(built):
            # one native batch per model structure (the rollout's data must fit every model)
            groups.setdefault((bm.model.ngeom, bm.model.nv), []).append(i)
        if len(groups) > 1:
            out: list = [None] * len(built)
            for idx in groups.values():
                res = self._free_rocking(block, [params_list[i] for i in idx], dt, theta0_frac)
                for i, r in zip(idx, res):
                    out[i] = r
            return out
        th0 = theta0_frac * block.alpha_rad
        init = [self._release_state(bm, block, th0) for bm in built]
        nstep = int(round(PEAK_RATIO.duration_s(block, theta0_frac) / dt))
        nthread = min(self._threads(), len(built))
        datas = [mujoco.MjData(built[0].model) for _ in range(nthread)]
        with rollout.Rollout(nthread=nthread) as ro:
            st, _ = ro.rollout([bm.model for bm in built], datas, np.array(init),
                               np.zeros((len(built), nstep, 1)),
                               initial_warmstart=np.zeros((len(built), built[0].model.nv)))
        return [self._measurement(bm, p, np.concatenate([s_init[None], traj]), block, th0, dt)
                for bm, p, s_init, traj in zip(built, params_list, init, st)]

    @staticmethod
    def _release_state(bm: BuiltModel, block: Block, th0: float) -> np.ndarray:
        """The settled state turned to ``th0`` [rad] about the +x edge, which stays where it rests
        (settled sink included)."""
        s = bm.s0.copy()
        b, h = block.width_m, block.height_m
        sink = s[bm.qi["pos"] + 1] if bm.planar else s[bm.qi["pos"] + 2] - 0.5 * h
        cx = 0.5 * b - 0.5 * b * math.cos(th0) + 0.5 * h * math.sin(th0)
        cz = 0.5 * b * math.sin(th0) + 0.5 * h * math.cos(th0)
        if bm.planar:
            s[bm.qi["pos"]: bm.qi["pos"] + 3] = [cx, cz - 0.5 * h + sink, th0]
        else:
            s[bm.qi["pos"]: bm.qi["pos"] + 3] = [cx, 0.0, cz + sink]
            s[bm.qi["pos"] + 3: bm.qi["pos"] + 7] = [math.cos(0.5 * th0), 0.0, math.sin(0.5 * th0), 0.0]
        return s

    def _measured_settings(self, p: dict) -> dict:
        """The settings a free-rocking measurement records."""
        return ({k: p[k] for k in ("timeconst", "dampratio", "cone", "integrator", "noslip_iterations", "impratio")}
                | _contact_of(p) | {"friction": self.settings["friction"]})

    def _measurement(self, bm: BuiltModel, p: dict, full: np.ndarray, block: Block, th0: float,
                     dt: float) -> RestitutionMeasurement:
        """η impact by impact (the one reader), the resting sink and the hop from one free-rocking
        run's states ``full`` (settings ``p``)."""
        _, th, _, (_, zp, _, zm), _ = self._read(bm, full, block)
        etas = PEAK_RATIO.etas(block, th, th0)
        sink, hop = contact_figures(block, th, np.stack([zp, zm], axis=1))
        arr = np.array(etas) if etas else np.array([math.nan])
        zc = np.nonzero(np.sign(th[1:]) != np.sign(th[:-1]))[0]
        quarter = float(zc[0] + th[zc[0]] / (th[zc[0]] - th[zc[0] + 1])) * dt if zc.size else None
        return RestitutionMeasurement(
            etas=[float(e) for e in etas], eta_mean=float(np.mean(arr)),
            eta_std=float(np.std(arr)) if etas else math.nan, theta0_rad=th0, dt_s=dt,
            settings=self._measured_settings(p), method=PEAK_RATIO.method, first_quarter_s=quarter,
            sink_m=sink, hop_m=hop)

    def measure_restitution(self, block: Block, *, theta0_frac: float = CALIBRATION_THETA0_FRAC,
                            dt_s: float | None = None) -> RestitutionMeasurement:
        """Free rocking from rest at ``theta0_frac·α``, no excitation: η impact by impact.

        Uses the settings in force (for ``calibrated`` without explicit contact settings: the
        calibration to Housner's η of this block).
        """
        dt = self.time_step_s(dt_s)
        p = self.resolve(block, Restitution("housner"), dt)
        return self._free_rocking(block, [p], dt, theta0_frac)[0]

    # -- the distributed contact: the skeleton's search over MuJoCo's batched grid -------------
    def _geometry(self, n: int) -> dict:
        """The contact geometry of a row of ``n`` points along the base."""
        return {"contact": "distributed", "contact_points": n, "contact_radius_m": self.settings["contact_radius_m"]}

    def _distributed_key(self, block: Block, t: float, n: int, dt: float) -> str:
        """MuJoCo's cache key of a distributed calibration (its solver settings and geometry)."""

        return self._cache_key(block, t, dt, self.CALIBRATION_VERSION_DIST, contact=self._geometry(n),
                               drive=self.settings["drive"], planar=self.settings["planar"],
                               friction=self.settings["friction"], solver=self._solver_params(),
                               price_cells=list(pricing.PRICE_CELLS))

    def _distributed_rows(self, block: Block, t: float, n: int, dt: float) -> tuple[list[dict], str]:
        """A grid of solimp impedance d (0.3–0.9) × time constant (2–16·Δt) × damping ratio (0.5–2)
        in native batches, then a finer grid around its closest measurable row (:meth:`_grid_search`)."""
        grid = [(f * dt, dr, dd) for dd in _D_VALUES for f in _TC_FACTORS_DIST for dr in _DR_VALUES_DIST]
        rows = self._grid_search(block, dt, self._solver_params(), grid, t,
                                 lambda b: [(b[0] * f, b[1] * g, min(0.95, max(0.05, b[2] + e)))
                                            for f in (0.7, 1.0, 1.4) for g in (0.8, 1.0, 1.25)
                                            for e in (-0.05, 0.0, 0.05)
                                            if b[0] * f >= 2.0 * dt and (f, g, e) != (1.0, 1.0, 0.0)],
                                 self._geometry(n))
        return rows, (f"solimp d {min(_D_VALUES):g}–{max(_D_VALUES):g} × time constants "
                      f"{_TC_FACTORS_DIST[0]:g}–{_TC_FACTORS_DIST[-1]:g}·dt × damping ratios "
                      f"{_DR_VALUES_DIST[0]:g}–{_DR_VALUES_DIST[-1]:g}, refined around the closest")

    def _distributed_contact(self, row: dict, n: int) -> dict:
        """A candidate row's contact with ``n`` points, as :meth:`_fixed` takes it."""
        return {"timeconst": row["timeconst"], "dampratio": row["dampratio"], "solimp_d": row["solimp_d"],
                **self._geometry(n)}

    def _distributed_settings(self, block: Block, dt: float, row: dict, n: int) -> dict:
        """The settings record of a row (:meth:`_settings_record`: solver, geometry, step, rest depth)."""
        return self._settings_record(block, dt, {"timeconst": row["timeconst"], "dampratio": row["dampratio"],
                                                 **self._solver_params(), **self._geometry(n),
                                                 "solimp_d": row["solimp_d"]})[0]

    def _describe_contact(self, row: dict) -> str:
        return f"solref ({row['timeconst']:.4g} s, {row['dampratio']:.3g}), solimp d {row['solimp_d']:.3g}"

    def contact_price(self, block: Block, c: CalibrationResult, dt_s: float | None = None) -> dict:
        """The price of a calibration's contact (the skeleton's), at the step it was calibrated at."""
        return super().contact_price(block, c, c.settings.get("dt_s") or dt_s)

    def _fixed(self, contact: dict) -> "MujocoAdapter":
        """A copy of this adapter with explicit contact settings (no calibration behind its runs):
        a calibration's ``timeconst``, ``dampratio`` and contact geometry (:func:`_contact_of`)."""
        geo = _contact_of(contact)
        s = {**self.settings, "timeconst_s": contact["timeconst"], "dampratio": contact["dampratio"],
             "solimp_d": geo["solimp_d"], "contact": geo["contact"]}
        if geo["contact"] == "distributed":
            s["contact_points"], s["contact_radius_m"] = geo["contact_points"], geo["contact_radius_m"]
        return type(self)(**s)

    # -- the corner calibration: the skeleton's grid of the declared knobs (CALIBRATION_KNOBS) ----
    def _knobs_key(self, block: Block, target: float, dt: float) -> str:
        return self._cache_key(block, target, dt, self.CALIBRATION_VERSION, drive=self.settings["drive"],
                               planar=self.settings["planar"], friction=self.settings["friction"],
                               solver=self._solver_params())

    def _evaluate(self, block: Block, dt: float, candidates: list[dict]) -> list[dict]:
        """The candidates in native batches (:meth:`_eval_grid`)."""
        return self._eval_grid(block, dt, self._solver_params(), [(c["timeconst"], c["dampratio"]) for c in candidates])

    def _knobs_settings(self, block: Block, dt: float, values: dict) -> dict:
        """The solref found with the solver settings, friction, step and resting depth (:meth:`_settings_record`)."""
        return self._settings_record(block, dt, {**values, **self._solver_params()})[0]

    def _knobs_note(self, block: Block, dt: float, target: float, chosen, rows: list, settings: dict) -> str:
        r, tc, dr = chosen.candidate.knobs, settings["timeconst"], settings["dampratio"]
        finite = [x["eta"] for x in rows if math.isfinite(x["eta"])]
        lo, hi = min(finite), max(finite)
        if chosen.reached:
            return (f"reached with solref ({tc:.4g} s, {dr:.3g}) at dt {dt:g} s, {r['n']} impacts measured "
                    f"({chosen.why}); the block rests {1e3 * settings['rest_sink_m']:.3g} mm deep in its contact; "
                    f"η over the searched settings spans {lo:.4f}–{hi:.4f}.")
        return (f"not reached ({chosen.why}): η = {r['eta']:.4f} ({100 * (r['eta'] - target) / target:+.2f} %), "
                f"solref ({tc:.4g} s, {dr:.3g}). "
                f"Over time constants {_TC_FACTORS[0]:g}–{_TC_FACTORS[-1]:g}·dt and damping ratios "
                f"{_DR_VALUES[0]:g}–{_DR_VALUES[-1]:g} MuJoCo's free-rocking η spans {lo:.4f}–{hi:.4f}: "
                "the corner contact of a box dissipates about what Housner's impact predicts "
                "(η_H follows from the impact at the far edge), and the contact's softness and damping "
                "move η only a few per cent; lower damping ratios make the corner bounce rather than "
                "rock, and moving the contact inwards would change the pivots (docs/physics.md §8).")

    def _cache_identity(self) -> dict:
        """MuJoCo and its version name the calibrations in the cache (MuJoCo Warp names its own)."""
        import mujoco   # optional engine library
        return {"engine": "mujoco", "version": mujoco.__version__}

    def _grid_search(self, block: Block, dt: float, solver: dict, grid: list, target: float, around,
                     geo: dict | None = None) -> list[dict]:
        """Free rocking over ``grid`` (:meth:`_eval_grid`), then over ``around`` the pick's point
        (``(tc, dr)``, or ``(tc, dr, d)`` with ``geo``); every row (a ConfigError when none measured η)."""
        rows = self._eval_grid(block, dt, solver, grid, geo)
        if any(math.isfinite(r["eta"]) for r in rows):
            b = pick([Candidate.of_row(r) for r in rows], target, block).candidate.knobs
            rows += self._eval_grid(block, dt, solver, around(_point(b)), geo)
        else:
            raise ConfigError(f"mujoco calibration: no {'distributed ' if geo else ''}contact setting gave a "
                              "measurable free rocking (fewer than two impacts); try a smaller --dt.")
        return rows

    def _settings_record(self, block: Block, dt: float, params: dict) -> tuple[dict, float]:
        """A calibration's settings: the contact ``params``, friction, step and how deep the block
        rests in its contact; and that depth [mm]."""
        sink_mm = 1e3 * self._rest_sink_m(block, params, dt)
        return {**params, "friction": self.settings["friction"], "dt_s": dt, "rest_sink_m": sink_mm * 1e-3}, sink_mm

    def _rest_sink_m(self, block: Block, params: dict, dt: float) -> float:
        """How deep the block at rest sinks into its soft contact [m] (a measure of the softness)."""
        bm = self._model(block, params, dt)
        z = bm.s0[bm.qi["pos"] + 1] if bm.planar else bm.s0[bm.qi["pos"] + 2] - 0.5 * block.height_m
        return float(-z)

    def _eval_grid(self, block: Block, dt: float, solver: dict, grid: list, geo: dict | None = None) -> list[dict]:
        """Free rocking for each grid point (``(tc, dr)`` for the corners, ``(tc, dr, d)`` with ``geo``):
        one row each, the point's settings with what the pick reads (``eta``, ``eta_std``, ``n``,
        ``sink_m``, ``hop_m``, ``damping_ratio``: MuJoCo's dampratio)."""
        if geo is None:
            params = [{"timeconst": float(tc), "dampratio": float(dr), **solver} for tc, dr in grid]
        else:
            params = [{"timeconst": float(g[0]), "dampratio": float(g[1]), **solver, **geo, "solimp_d": float(g[2])}
                      for g in grid]
        ms = []
        for k in range(0, len(params), 64):          # bounded native batches
            ms += self._free_rocking(block, params[k:k + 64], dt, CALIBRATION_THETA0_FRAC)
        keys = ("timeconst", "dampratio") if geo is None else ("timeconst", "dampratio", "solimp_d")
        return [{**{k: p[k] for k in keys}, "eta": m.eta_mean, "eta_std": m.eta_std, "n": len(m.etas),
                 "sink_m": m.sink_m, "hop_m": m.hop_m, "damping_ratio": p["dampratio"]} for p, m in zip(params, ms)]


def _point(row: dict) -> tuple:
    """A grid row's point: ``(tc, dr)``, or ``(tc, dr, d)`` for the distributed contact."""
    return tuple(row[k] for k in ("timeconst", "dampratio", "solimp_d") if k in row)


def _angles_of(bm: BuiltModel, st: np.ndarray, skip: int = 0):
    """θ and θ̇ from state rows ``(..., k)`` of a built model (``skip``: leading columns of the
    FULLPHYSICS layout the rows leave out), and the block's rotation matrices (None: planar)."""
    p, v = bm.qi["pos"] - skip, bm.qi["vel"] - skip
    if bm.planar:
        return st[..., p + 2], st[..., v + 2], None
    r = quat_matrix(*(st[..., p + 3 + k] for k in range(4)))
    # free-joint angular velocity is in the body frame: rotate it to the world, take y
    return np.arctan2(r[..., 0, 2], r[..., 2, 2]), theta_rate_of_body(r, st[..., v + 3:v + 6]), r


def _contact_of(p: dict) -> dict:
    """The contact geometry keys of a settings dict (records without them are the corners)."""
    kind = p.get("contact") or "corners"
    if kind == "auto":
        kind = "corners"
    dist = kind == "distributed"
    return {"contact": kind, "contact_points": int(p["contact_points"]) if dist else None,
            "contact_radius_m": float(p["contact_radius_m"]) if dist else None,
            "solimp_d": None if p.get("solimp_d") is None else float(p["solimp_d"])}
