"""Genesis adapter: the rocking block in Genesis's rigid solver (``genesis-world``, CPU backend).

The model
---------
Two entities loaded from MJCF text: a table box whose top is ``z = 0`` and a block box ``b × d × h``
with the case's mass (uniform density). They touch only through Genesis's own contact: its
collision detection finds the corner contacts and its constraint solver (MuJoCo's soft-constraint
formulation: a time constant and a damping ratio, Newton's method, the elliptic friction cone) turns them into forces. No constraint and no impact law of ours.

* **Free body** (default, ``planar=False``): the block has a free joint and stays in the x–z plane
  by symmetry (its drift out of the plane is recorded). ``planar=True``: a slide-x, slide-z,
  hinge-y joint chain through the centre of mass (the MuJoCo adapter's planar model).
* **Anti-slip**: friction 10 on both geoms, from the MJCF (Genesis's ``Rigid`` material caps friction
  at 5; the MJCF value is kept), with the **elliptic** friction cone: with Genesis's default
  pyramidal cone and friction 10 the constraint solver lets a block at rest sink through the table
  (friction 5 already sinks it 4 mm in 0.2 s); the elliptic cone holds it at every friction tried.
* **Drives** (``drive``): ``inertial`` (default) sets each environment's gravity to ``(−ü, 0, −g)``
  for every step, ü the step average ``(u̇(tₙ₊₁) − u̇(tₙ))/Δt`` (the impulse per step is exact);
  ``table`` puts the table on a slide-x joint (its mass ``table_mass_ratio`` × the block's) pushed
  by a force ``(M_table + m)·ü`` (the same step average), as the MuJoCo adapter does;
  ``table_track_err_rel`` records how far the table strays from u(t).
* **Contact softness**: Genesis's ``constraint_timeconst`` (``timeconst_s``; Genesis ships 0.01 s)
  with damping ratio 1. ``settings="calibrated"`` keeps the shipped value where it gives the
  case's η within 0.25 %, else searches the time constant (:attr:`GenesisAdapter.KNOBS`).

Scenes and batches
------------------
The first scene on a machine compiles Genesis's kernels (minutes; then its disk cache serves later
processes in seconds). Genesis takes part in suites of every available engine (a 51 × 51 map runs
in about 90 s on two cores). A scene is built per block, step, contact setting and number of environments and kept
in the process (:func:`_scene`); a run resets it and sets the pose. Cases of one block, setting and
step run as the environments of one scene (``batching = "native"``, :attr:`GenesisAdapter.max_worlds`).
"""

from __future__ import annotations

import functools
import logging
import math
import os
import tempfile

import numpy as np

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import G, Block
from rockbench.engines.calibration.knobs import Knob
from rockbench.engines.contact import ContactEngine
from rockbench.engines.motion import Motion, pivot_pose
from rockbench.engines.adapters.free_body import motion_of

#: Genesis's shipped constraint time constant [s] (``RigidOptions.constraint_timeconst``)
SHIPPED_TIMECONST_S = 0.01

#: Time constants a calibration tries when the shipped one misses the target, as multiples of Δt
_TC_FACTORS = (2.0, 4.0, 8.0, 12.0, 16.0, 32.0, 48.0)

#: Half extents of the table box [m]: wider than any table stroke
_TABLE_HALF_EXTENTS_M = (2.0, 1.0, 0.05)

#: Scenes kept per process; the least recently used goes first
_MAX_SCENES = 8

#: Most environments in one scene
MAX_WORLDS = 1024

_ready = False


def _genesis():
    """The ``genesis`` module, initialised once per process on its CPU backend, quietly."""
    global _ready
    import genesis as gs   # optional engine library
    if not _ready:
        gs.init(backend=gs.cpu, logging_level="warning")
        logging.getLogger("genesis").setLevel(logging.WARNING)
        _ready = True
    return gs


def _table_xml(drive: str, mu: float, mass_kg: float) -> str:
    hx, hy, hz = _TABLE_HALF_EXTENTS_M
    geom = f'<geom type="box" size="{hx} {hy} {hz}" friction="{mu}"'
    if drive == "table":
        return (f'<mujoco><worldbody><body name="table" pos="0 0 {-hz}"><joint name="table_x" type="slide" '
                f'axis="1 0 0"/>{geom} mass="{mass_kg}"/></body></worldbody></mujoco>')
    return f'<mujoco><worldbody><body name="table" pos="0 0 {-hz}">{geom}/></body></worldbody></mujoco>'


def _block_xml(block: Block, mu: float, planar: bool) -> str:
    b, d, h = block.width_m, block.depth_m, block.height_m
    joints = ('<joint name="x" type="slide" axis="1 0 0"/><joint name="z" type="slide" axis="0 0 1"/>'
              '<joint name="theta" type="hinge" axis="0 1 0"/>') if planar else '<freejoint/>'
    return (f'<mujoco><worldbody><body name="block" pos="0 0 {h / 2}">{joints}'
            f'<geom type="box" size="{b / 2} {d / 2} {h / 2}" mass="{block.mass_kg}" friction="{mu}"/>'
            '</body></worldbody></mujoco>')



def _mjcf_file(text: str) -> str:
    """A file holding ``text`` (Genesis loads MJCF from a path), named by its content."""
    path = os.path.join(tempfile.gettempdir(), f"rockbench-genesis-{abs(hash(text)):x}.xml")
    if not os.path.exists(path):
        with open(path, "w") as f:
            f.write(text)
    return path


class _Scene:
    """One Genesis scene of ``worlds`` environments: the table and the block, contact as in ``s``."""

    def __init__(self, block: Block, s: dict, dt_s: float, worlds: int):
        gs = _genesis()
        self.dt, self.worlds, self.table_drive = dt_s, worlds, s["drive"] == "table"
        self.planar, self.half_h = bool(s["planar"]), block.height_m / 2
        mu = float(s["friction"])
        self.table_mass_kg = float(s["table_mass_ratio"]) * block.mass_kg
        self.push_mass_kg = self.table_mass_kg + block.mass_kg
        scene = gs.Scene(sim_options=gs.options.SimOptions(dt=dt_s, gravity=(0.0, 0.0, -G)),
                         rigid_options=gs.options.RigidOptions(constraint_timeconst=float(s["timeconst_s"]),
                                                              friction_cone=gs.friction_cone.elliptic),
                         show_viewer=False)
        self.table = scene.add_entity(gs.morphs.MJCF(file=_mjcf_file(_table_xml(s["drive"], mu, self.table_mass_kg))))
        self.block = scene.add_entity(gs.morphs.MJCF(file=_mjcf_file(_block_xml(block, mu, self.planar))))
        scene.build(n_envs=worlds)
        self.scene = scene
        self.acc = np.zeros((0, worlds))

    def place(self, block: Block, theta0_rad: np.ndarray) -> None:
        """Every block at rest at its ``theta0_rad`` pivoting on its lower corner, the table at 0."""
        self.scene.reset()
        q = np.zeros((self.worlds, 7))
        for w, th in enumerate(np.asarray(theta0_rad, dtype=float)):
            x, z = pivot_pose(block, float(th))
            q[w] = (x, 0.0, z, math.cos(th / 2), 0.0, math.sin(th / 2), 0.0)
        if self.planar:   # the chain's coordinates: x, z above the body's rest height, θ
            q = np.stack([q[:, 0], q[:, 2] - self.half_h, np.asarray(theta0_rad, dtype=float)], axis=1)
        self.block.set_qpos(q, zero_velocity=True)
        if self.table_drive:
            self.table.set_qpos(np.zeros((self.worlds, 1)), zero_velocity=True)
            self.table.control_dofs_force(np.zeros((self.worlds, 1)))
        self.scene.sim.set_gravity(np.tile([0.0, 0.0, -G], (self.worlds, 1)))

    def load(self, pulses: list, dt_s: float, n_steps: int) -> None:
        """Each world's drive for ``n_steps`` steps: the step average of ü (zero after its pulse)."""
        acc = np.zeros((n_steps, len(pulses)))
        for j, p in enumerate(pulses):
            if p is not None:
                n_pulse = min(n_steps, int(math.ceil(p.duration_s / dt_s - 1e-9)))
                vel = np.asarray(p.vel(np.arange(n_pulse + 1) * dt_s), dtype=float)
                acc[:n_pulse, j] = np.diff(vel) / dt_s
        self.acc = acc

    def rows(self) -> np.ndarray:
        """The state now, ``(worlds, k)``: the block's position (3) and quaternion w, x, y, z (4), its
        velocity (3) and angular velocity (3) (the planar chain's state written so), then the table's x
        and ẋ (table drive)."""
        n = 3 if self.planar else 7
        q = self.block.get_qpos().cpu().numpy().reshape(self.worlds, n).astype(float)
        v = self.block.get_dofs_velocity().cpu().numpy().reshape(self.worlds, n - 1 if n == 7 else 3).astype(float)
        if self.planar:
            zero, th = np.zeros(self.worlds), q[:, 2]
            q = np.stack([q[:, 0], zero, q[:, 1] + self.half_h, np.cos(th / 2), zero, np.sin(th / 2), zero], axis=1)
            v = np.stack([v[:, 0], zero, v[:, 1], zero, v[:, 2], zero], axis=1)
        out = [q, v]
        if self.table_drive:
            out += [self.table.get_qpos().cpu().numpy().reshape(self.worlds, 1).astype(float),
                    self.table.get_dofs_velocity().cpu().numpy().reshape(self.worlds, 1).astype(float)]
        return np.concatenate(out, axis=1)

    def advance(self, n_from: int, n_to: int) -> np.ndarray:
        """Steps ``n_from … n_to − 1`` (each step's drive from :attr:`acc`); the states after each,
        ``(worlds, n_to − n_from, k)``."""
        out = []
        n_acc = self.acc.shape[0]
        grav = np.tile([0.0, 0.0, -G], (self.worlds, 1))
        for i in range(n_from, n_to):
            a = self.acc[i] if i < n_acc else np.zeros(self.worlds)
            if self.table_drive:
                self.table.control_dofs_force((self.push_mass_kg * a)[:, None])
            else:
                grav[:, 0] = -a
                self.scene.sim.set_gravity(grav)
            self.scene.step()
            out.append(self.rows())
        return np.stack(out, axis=1)


@functools.lru_cache(maxsize=_MAX_SCENES)
def _scene(pid: int, block: Block, dt_s: float, settings: tuple, worlds: int) -> _Scene:
    """This process's scene for a block, step [s], the settings it depends on (``(name, value)``
    pairs) and number of environments; ``pid`` keys it by process, so a forked worker builds its own."""
    return _Scene(block, dict(settings), dt_s, worlds)


class GenesisAdapter(ContactEngine):
    """The rocking block in Genesis (see the module docstring for the model).

    Settings
    --------
    settings : {"calibrated", "shipped"}
        The constraint time constant calibrated to the case's η, or Genesis as shipped (0.01 s).
    drive : {"inertial", "table"}
        Gravity tilted by −ü per environment, or a table on a slide joint pushed along u(t).
    planar : bool
        A slide-x, slide-z, hinge-y joint chain, or (default) a free body, in the x–z plane by symmetry.
    friction : float
        Coulomb friction block–table [-] (anti-slip: 10).
    timeconst_s : float or None
        Genesis's ``constraint_timeconst`` [s] (at least 2·Δt); given, it replaces calibration.
    table_mass_ratio : float
        The table's mass over the block's (table drive) [-].
    tail_s, min_tail_s : float
        Longest and shortest simulated time after the pulse [s].
    """

    name = "genesis"
    module = "genesis"
    install_hint = ("install torch's CPU wheel first (pip install torch --index-url https://download.pytorch.org/whl/cpu), "
                    "then `pip install 'rockbench[genesis]'`.")
    #: Genesis's own default step (SimOptions.dt), what it runs at as shipped
    own_dt_s = 1e-2
    batching = "native"
    max_worlds = MAX_WORLDS
    SETTINGS = {"planar": False, "table_mass_ratio": 100.0, "tail_s": 2.0, "min_tail_s": 0.25}
    SHIPPED = {"timeconst_s": SHIPPED_TIMECONST_S}
    #: Genesis as shipped (0.01 s) first, kept within 0.25 % of the target; otherwise the time constants
    #: :data:`_TC_FACTORS` × Δt
    KNOBS = (Knob("timeconst_s", "s", lambda block, dt: tuple(f * dt for f in _TC_FACTORS)),)
    START_KEEP_RTOL = 0.0025

    @classmethod
    def device_note(cls) -> str:
        return "CPU only (Genesis's CPU backend)"

    def validate(self, s: dict) -> None:
        self.number_setting(s, "timeconst_s", "s")
        self.number_setting(s, "table_mass_ratio", allow_none=False)

    def build(self, block: Block, s: dict, dt_s: float) -> dict:
        """What a run's scene needs; :meth:`start` takes the scene once it knows how many worlds."""
        if s["timeconst_s"] < 2.0 * dt_s:
            raise ConfigError(f"genesis setting 'timeconst_s' must be at least 2·dt = {2 * dt_s:g} s, "
                              f"got {s['timeconst_s']!r}.")
        return {"scene": None}

    def start(self, w: dict, block: Block, s: dict, dt_s: float, pulses: list, theta0_rad: float,
              n_steps: int) -> np.ndarray:
        keys = ("drive", "planar", "friction", "timeconst_s", "table_mass_ratio")
        sc = w["scene"] = _scene(os.getpid(), block, dt_s, tuple((k, s[k]) for k in keys), len(pulses))
        sc.place(block, np.full(len(pulses), float(theta0_rad)))
        sc.load(pulses, dt_s, n_steps)
        return sc.rows()[:, None]

    def advance(self, w: dict, n_from: int, n_to: int) -> np.ndarray:
        return w["scene"].advance(n_from, n_to)

    def read(self, w: dict, block: Block, s: dict, rows: np.ndarray, t_s: np.ndarray, pulse) -> Motion:
        return motion_of(rows, t_s, pulse, s["drive"] == "table", {"timeconst_s": float(s["timeconst_s"])})
