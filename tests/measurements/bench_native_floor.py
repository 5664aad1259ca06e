"""The native floor: each CPU engine's cells through the product and through a minimal native loop.

What a cell costs through the product against the smallest native loop of the same model, one world
and many worlds in one engine call, and whether both give the same θ history. Measures and prints;
it fails (exit 1) only where the two θ histories disagree, never on time.

    python tests/measurements/bench_native_floor.py [--engines mujoco pybullet dart physx exudyn drake]
        [--cells B3M:sine:3:5 B3M:sine:3:1.5 B8M:sine:3:1.5] [--settings calibrated shipped]
        [--repeats 3] [--warmup 0] [--worlds 1 4 16] [--record NAME [--notes TEXT]] [--table NAME]

For each engine, settings (``calibrated`` at the time-step rule's step, ``shipped`` at the engine's own)
and cell (``BLOCK:PULSE:W_RATIO:A_RATIO``: ω/p and a₀/(g·tanα), restitution Housner), on a warm adapter
(its calibration cached and its scene built before the clock starts):

* *product*: the adapter's batch entry ``run_many`` on the cell alone (one world);
* *native*: the same scene (the adapter's own ``build``, made before the clock starts; the block placed
  by its ``start``), the same step, the same drive (``inertial``: the table fixed, −m·ü on the block,
  ü as the adapter takes it: the step average, PyBullet's at the step's midpoint) and the same simulated
  time, stepped by the engine's own API in the smallest loop it has (MuJoCo: one ``rollout`` call;
  Drake: one ``AdvanceTo``; Exudyn: one ``SolveSteps`` a segment of the product's ``segment_s``, since
  its adaptive step restarts at each call; PyBullet, DART, PhysX: a Python loop of step calls reading θ
  after each).

``--worlds K ...`` adds, for each K, the cell as K copies: through the product (``run_many`` of K
copies, where the adapter runs K worlds a batch) and through a native loop of K worlds in one engine
call (:data:`WORLDS`): PhysX, K blocks at the origin in the adapter's scene, each colliding with its
own table alone (collision groups); Drake, K plants in one diagram, a block each (the
adapter's diagram of K worlds); DART, K tables and blocks in one ``World``, every pair of two worlds on
the collision filter's black list, each block driven by its own force; PyBullet, K tables and blocks in
one client, collision group and mask bit per world, under the one pulse's gravity. It prints the cost
a world and the largest |Δθ| of any world from the product's one-world run and from the same loop's
world alone (0: bit for bit).

The simulated time is the product run's (it stops where floor 1's end-of-run rule stops it). Printed:
CPU seconds per simulated second of each path (``time.process_time``: every thread of this process,
the minimum of ``--repeats``, after ``--warmup`` untimed calls of each path), the ratio product/native single-world and batched (the batched cost per
world over the native single-world loop), the differences of max|θ| and final θ between the paths
(they must agree to ``--theta-tol-rad``), and where one world's ``run_many`` goes (posing the case, the
contact base's loop, the rest). The native loops reach into each adapter's scene for the
engine's own objects (a model, a world, a simulator): an adapter that changes its scene needs its loop
here changed too (a loop that fails is printed and recorded, the other engines go on).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))   # tests/measurements/: the records module beside this script
from records import load, write_record  # noqa: E402

from rockbench.benchmark.blocks.presets import get_preset  # noqa: E402
from rockbench.benchmark.suites.model import restitution_for  # noqa: E402
from rockbench.engines.contract import Case  # noqa: E402
from rockbench.engines.motion import pivot_pose, theta_of_quat  # noqa: E402
from rockbench.engines.registry import get_adapter  # noqa: E402
from rockbench.reference_solver.model import G  # noqa: E402
from rockbench.reference_solver.pulses import make_pulse  # noqa: E402

ENGINES = ("mujoco", "pybullet", "dart", "physx", "exudyn", "drake")
CELLS = ("B3M:sine:3:5", "B3M:sine:3:1.5", "B8M:sine:3:1.5")
MEASURES = ("CPU seconds per simulated second of one cell through the product (the adapter's run_many on a warm "
            "adapter, one world and batched) and through the smallest native loop of the same scene, step, drive "
            "and duration, their ratio, and the differences of the two paths' max|θ| and final θ")


# --- the cells ------------------------------------------------------------------------------------

def case_of(text: str) -> Case:
    """The case of ``BLOCK:PULSE:W_RATIO:A_RATIO`` (restitution Housner); exit 2 on a bad one."""
    try:
        block_name, pulse_kind, w_ratio, a_ratio = text.split(":")
        block = get_preset(block_name).block()
        pulse = make_pulse(pulse_kind, float(a_ratio) * G * math.tan(block.alpha_rad), float(w_ratio) * block.p_rad_s)
    except Exception as e:  # noqa: BLE001 - one line and exit 2
        _refuse(f"bad cell {text!r} ({e}); give BLOCK:PULSE:W_RATIO:A_RATIO, e.g. B3M:sine:3:5")
    return Case(block, pulse, restitution_for("housner", block_name))


def _refuse(message: str) -> None:
    """Bad input: one line on stderr and exit 2."""
    print(f"bench_native_floor: {message}", file=sys.stderr)
    sys.exit(2)


def cpu_times(fn, repeats: int, prepare=lambda: None, warmup: int = 0) -> tuple[list[float], object]:
    """The CPU time of each of ``repeats`` calls ``fn(prepare())`` [s], ``prepare`` untimed, after
    ``warmup`` untimed calls, and the last call's result."""
    for _ in range(warmup):
        fn(prepare())
    times, out = [], None
    for _ in range(repeats):
        given = prepare()
        t0 = time.process_time()
        out = fn(given)
        times.append(time.process_time() - t0)
    return times, out


# --- the native loops: (adapter, scene, case, s, dt, n_steps) -> θ after each step [rad] --------------

def _start(ad, scene, case: Case, s: dict, dt: float, n_steps: int):
    """The block placed at rest in the adapter's scene (its ``build``, made before the clock starts) by
    its ``start``, one world; the first rows."""
    return ad.start(scene, case.block, s, dt, [case.pulse], 0.0, n_steps)


def _step_average(pulse, dt: float, n: int) -> np.ndarray:
    """ü averaged over each of ``n`` steps of ``dt`` [m/s^2]: (u̇(tₙ₊₁) − u̇(tₙ))/Δt."""
    return np.diff(np.asarray(pulse.vel(np.arange(n + 1) * dt), dtype=float)) / dt


def native_mujoco(ad, scene, case, s, dt, n_steps):
    from mujoco import MjData, rollout   # optional engine library

    rows = _start(ad, scene, case, s, dt, n_steps)
    model = scene["bm"].model
    ctrl = (-case.block.mass_kg * _step_average(case.pulse, dt, n_steps))[:, None]
    states, _ = rollout.rollout(model, MjData(model), rows[0, 0], ctrl, initial_warmstart=np.zeros(model.nv))
    return ad.read(scene, case.block, s, states[0], np.arange(1, n_steps + 1) * dt, case.pulse).theta_rad


def native_pybullet(ad, sc, case, s, dt, n_steps):
    _start(ad, sc, case, s, dt, n_steps)
    pb, cid, body = sc.pb, sc.cid, sc.block
    n_pulse = int(math.ceil(case.pulse.duration_s / dt - 1e-9))
    acc = (-case.pulse.accel((np.arange(n_steps) + 0.5) * dt)).tolist()   # ü at each step's midpoint
    theta = np.empty(n_steps)
    for i in range(n_steps):
        if i <= n_pulse:
            pb.setGravity(acc[i], 0.0, -G, physicsClientId=cid)
        pb.stepSimulation(physicsClientId=cid)
        theta[i] = pb.getJointState(body, 2, physicsClientId=cid)[0]
    return theta


def native_dart(ad, scene, case, s, dt, n_steps):
    _start(ad, scene, case, s, dt, n_steps)
    world, block = scene.world, scene.block
    acc = np.zeros(n_steps)
    n_pulse = min(n_steps, int(math.ceil(case.pulse.duration_s / dt - 1e-9)))
    acc[:n_pulse] = _step_average(case.pulse, dt, n_pulse)
    theta = np.empty(n_steps)
    for i in range(n_steps):
        world.setGravity([-acc[i], 0.0, -G])
        world.step()
        theta[i] = block.getPositions()[2]
    return theta


def physx_worlds(ad, scene, case, s, dt, n_steps, k: int) -> np.ndarray:
    """PhysX, ``k`` worlds of the cell in the adapter's scene (its ``build``; every block at the origin on
    a table of its own, each world's shapes one bit of the collision groups), placed by its ``start``:
    a Python loop of ``k`` ``add_force_torque`` calls and one step a PhysX step, the packed state of
    every body read after each benchmark step. θ of each world ``(k, n_steps)``."""
    ad.start(scene, case.block, s, dt, [case.pulse] * k, 0.0, n_steps)
    system, sub = scene.system, scene.substeps
    step, pack = system.step, system.pack
    bodies = [scene.worlds[w][0] for w in range(k)]
    order = {c.entity.per_scene_id: i for i, c in enumerate(system.get_rigid_dynamic_components())}
    at = np.array([order[b.entity.per_scene_id] for b in bodies])
    n_pulse = min(n_steps, int(math.ceil(case.pulse.duration_s / dt - 1e-9))) * sub
    forces = []
    for body in bodies:   # each world's own drive, as a world of another cell would need
        f = np.zeros((n_pulse, 3), dtype=np.float32)
        f[:, 0] = -case.block.mass_kg * _step_average(case.pulse, dt / sub, n_pulse)
        forces.append((body.add_force_torque, f))
    zero = np.zeros(3, dtype=np.float32)
    packs = []
    for i in range(n_steps):
        for j in range(i * sub, (i + 1) * sub):
            if j < n_pulse:
                for add, f in forces:
                    add(f[j], zero)
            step()
        packs.append(pack())
    q = np.frombuffer(b"".join(packs), dtype=np.float32).reshape(n_steps, -1, 13)[:, at, :4].astype(float)
    return theta_of_quat(q[..., 0], q[..., 1], q[..., 2], q[..., 3]).T


def native_physx(ad, scene, case, s, dt, n_steps):
    return physx_worlds(ad, scene, case, s, dt, n_steps, 1)[0]


def native_exudyn(ad, scene, case, s, dt, n_steps):
    # Exudyn's adaptive step restarts at each SolveSteps: the product's segments, solved one call each
    _start(ad, scene, case, s, dt, n_steps)
    model = scene.model
    chunk = max(1, int(round(float(s["segment_s"]) / dt)))
    model.solver.SolveSteps(model.mbs, model.ss)
    for _ in range(chunk, n_steps, chunk):
        model.solver.it.endTime = model.mbs.systemData.GetTime() + chunk * dt
        model.solver.SolveSteps(model.mbs, model.ss)
    data = model.mbs.GetSensorStoredData(model.sensors[0])
    keep = np.diff(np.concatenate([[-math.inf], data[:, 0]])) > 0.5 * dt
    keep &= (data[:, 0] > 0.5 * dt) & (data[:, 0] < (n_steps + 0.5) * dt)   # its samples after t = 0 up to the end
    return -data[keep, 3]   # Exudyn's planar angle is −θ


def drake_worlds(ad, run, case, s, dt, n_steps, k: int) -> np.ndarray:
    """Drake, ``k`` worlds of the cell in one diagram (the adapter's diagram of ``k`` plants, one block
    each), the drives loaded into their sources and the blocks placed by its ``start``: one
    ``AdvanceTo`` to the end. θ of each world ``(k, n_steps)``."""
    ad.start(run, case.block, s, dt, [case.pulse] * k, 0.0, n_steps)   # sample 0 read, the logs cleared
    sc = run["scene"]
    sc.simulator.AdvanceTo(n_steps * dt)
    return np.array([w.logger.FindLog(sc.context).data()[w.cols[sc.iq["th"]], :n_steps] for w in sc.worlds])


def native_drake(ad, run, case, s, dt, n_steps):
    return drake_worlds(ad, run, case, s, dt, n_steps, 1)[0]


# --- many worlds in one engine call where the adapter runs one (measured, not in the product) ------

def dart_prepare(ad, case: Case, s: dict, dt: float, n_steps: int, k: int):
    """A DART world of ``k`` worlds: the adapter's one-world scene (a world of its own) and ``k − 1`` more
    tables and blocks (its ``table_skeleton`` and ``block_skeleton``), every pair of body nodes of two
    different worlds on the black list of the solver's collision filter, so each block touches its own table alone."""
    import dartpy as dart   # optional engine library
    from rockbench.engines.adapters.dart import _Scene, block_skeleton, table_skeleton

    if s["drive"] != "inertial" or not s["planar"]:
        raise ValueError("the loop of many DART worlds drives a planar block by a force (drive inertial)")
    scene = _Scene(case.block, s, dt)
    scene.pairs = [(scene.table, scene.block)]
    for w in range(1, k):
        pair = (table_skeleton(dart, s, f"table{w}")[0], block_skeleton(dart, case.block, s, f"block{w}")[0])
        for skeleton in pair:
            scene.world.addSkeleton(skeleton)
        scene.pairs.append(pair)
    # the solver's own filter (dartpy's getCollisionOption returns a copy, which shares the filter)
    apart = scene.world.getConstraintSolver().getCollisionOption().collisionFilter
    nodes = [[sk.getBodyNode(0) for sk in pair] for pair in scene.pairs]
    for i in range(k):
        for j in range(i + 1, k):
            for a in nodes[i]:
                for b in nodes[j]:
                    apart.addBodyNodePairToBlackList(a, b)
    return scene


def dart_worlds(ad, scene, case, s, dt, n_steps, k: int) -> np.ndarray:
    """DART, ``k`` blocks in one ``World`` (:func:`dart_prepare`), each driven by its own generalized force
    −m·ü on its x dof (ü the step average; the adapter tilts gravity, which one world of many cannot):
    one ``World.step`` a step, θ of each world read after it ``(k, n_steps)``."""
    xc, zc = pivot_pose(case.block, 0.0)
    blocks = [block for _, block in scene.pairs]
    for block in blocks:
        block.setPositions([zc, xc, 0.0])
        block.setVelocities(np.zeros(3))
    world = scene.world
    world.setGravity([0.0, 0.0, -G])
    world.setTime(0.0)
    world.getConstraintSolver().setCollisionDetector(scene.detector())
    n_pulse = min(n_steps, int(math.ceil(case.pulse.duration_s / dt - 1e-9)))
    drives = [(block.setForces, [[0.0, f, 0.0] for f in (-case.block.mass_kg * _step_average(case.pulse, dt, n_pulse)).tolist()])
              for block in blocks]
    reads = [block.getPositions for block in blocks]
    theta = np.empty((k, n_steps))
    for i in range(n_steps):
        if i < n_pulse:
            for set_forces, forces in drives:
                set_forces(forces[i])
        world.step()
        for w, read in enumerate(reads):
            theta[w, i] = read()[2]
    return theta


_PYBULLET_CLIENTS: list = []   # the last client pybullet_prepare made, disconnected by the next call


def pybullet_prepare(ad, case: Case, s: dict, dt: float, n_steps: int, k: int):
    """A PyBullet DIRECT client of ``k`` worlds: the adapter's table and block (its ``build`` on a client of
    its own) and ``k − 1`` more (its ``add_bodies`` and ``apply_dynamics``), world ``w``'s table and block
    in collision group and mask bit ``w``, so each block touches its own table alone."""
    from rockbench.engines.adapters.pybullet import _Scene

    if s["drive"] != "inertial" or not s["planar"]:
        raise ValueError("the loop of many PyBullet worlds drives planar blocks through gravity (drive inertial)")
    while _PYBULLET_CLIENTS:
        old = _PYBULLET_CLIENTS.pop()
        old.pb.disconnect(physicsClientId=old.cid)
    sc = ad.build(case.block, s, dt, sc=_Scene())
    _PYBULLET_CLIENTS.append(sc)
    sc.bodies = [(sc.table, sc.block, sc.block_link)]
    for _ in range(1, k):
        sc.bodies.append(sc.add_bodies(case.block, True, ad.points(s)))
        sc.apply_dynamics(s, *sc.bodies[-1])
    for w, (table, body, link) in enumerate(sc.bodies):
        sc.pb.setCollisionFilterGroupMask(table, -1, 1 << w, 1 << w, physicsClientId=sc.cid)
        sc.pb.setCollisionFilterGroupMask(body, link, 1 << w, 1 << w, physicsClientId=sc.cid)
    return sc


def pybullet_worlds(ad, sc, case, s, dt, n_steps, k: int) -> np.ndarray:
    """PyBullet, ``k`` blocks in one client (:func:`pybullet_prepare`), all under the cell's one pulse
    through the gravity vector, as the adapter drives one (cells of different pulses in one client would
    need a force per block: in PyBullet 3.2 a force at a link's centre, ``applyExternalForce`` in either
    frame, does not turn the block on its corner, measured; so this is the cost of copies of one cell, a
    floor for a batch of cells): one ``stepSimulation`` a step, θ of each world read after it."""
    pb, cid = sc.pb, sc.cid
    xc, zc = pivot_pose(case.block, 0.0)
    for _, body, _ in sc.bodies:
        for j, q in ((0, xc), (1, zc - case.block.height_m / 2), (2, 0.0)):
            pb.resetJointState(body, j, q, 0.0, physicsClientId=cid)
    n_pulse = int(math.ceil(case.pulse.duration_s / dt - 1e-9))
    acc = (-case.pulse.accel((np.arange(min(n_steps, n_pulse + 1)) + 0.5) * dt)).tolist()
    bodies = [body for _, body, _ in sc.bodies]
    gravity, step, joint = pb.setGravity, pb.stepSimulation, pb.getJointState
    theta = np.empty((k, n_steps))
    for i in range(n_steps):
        if i < len(acc):
            gravity(acc[i], 0.0, -G, physicsClientId=cid)
        step(physicsClientId=cid)
        for w, body in enumerate(bodies):
            theta[w, i] = joint(body, 2, physicsClientId=cid)[0]
    return theta

NATIVE = {"mujoco": native_mujoco, "pybullet": native_pybullet, "dart": native_dart, "physx": native_physx,
          "exudyn": native_exudyn, "drake": native_drake}


# --- one engine, settings and cell --------------------------------------------------------------

def product_history(ad, case: Case) -> tuple[Case, dict, np.ndarray, np.ndarray]:
    """The posed case, its resolved settings, and the product's θ [rad] and times [s] of one run
    (the contact base's one loop, what ``run_many`` simulates)."""
    posed = ad.posed(case)
    s = ad.resolve(case.block, case.restitution, posed.dt_s)
    tr, _ = ad.run_worlds(case.block, s, posed.dt_s, [case.pulse])[0]
    return posed, s, np.asarray(tr.theta_rad), np.asarray(tr.t_s)


def product_parts(ad, case: Case, posed: Case, s: dict, repeats: int, warmup: int = 0) -> dict:
    """Where one world's ``run_many`` goes [CPU s, least of ``repeats``]: posing the case (its step,
    ``posed``), the contact base's loop (``run_worlds``: the scene, start, advance, read, the end-of-run
    tests, the trajectory); the rest of ``run_many`` (the resolution, the judge) is the difference."""
    posing, _ = cpu_times(lambda _: ad.posed(case), repeats, warmup=warmup)
    loop, _ = cpu_times(lambda _: ad.run_worlds(case.block, s, posed.dt_s, [case.pulse]), repeats, warmup=warmup)
    return {"posed_cpu_s": min(posing), "loop_cpu_s": min(loop)}


def started(ad, case: Case, s: dict, dt: float, n_steps: int, k: int):
    """The adapter's scene of the cell's block, settings and step with ``k`` worlds started in it, so
    that what it builds for ``k`` worlds is built before the clock starts (PhysX, Drake)."""
    scene = ad.build(case.block, s, dt)
    ad.start(scene, case.block, s, dt, [case.pulse] * k, 0.0, n_steps)
    return scene


#: engine → (its scene of ``k`` worlds made before the clock, the loop of ``k`` worlds in one engine
#: call ``(ad, scene, case, s, dt, n_steps, k) -> θ (k, n_steps)``)
WORLDS = {"physx": (started, physx_worlds), "drake": (started, drake_worlds), "dart": (dart_prepare, dart_worlds),
          "pybullet": (pybullet_prepare, pybullet_worlds)}


def measure_worlds(engine: str, ad, case: Case, posed: Case, s: dict, theta: np.ndarray, ks: list, repeats: int,
                   warmup: int = 0) -> list:
    """Per number of worlds ``k`` (copies of the cell): the product's CPU s per simulated s a world
    (``run_many`` of ``k`` copies, where the adapter runs ``k`` worlds a batch) and the native loop's of
    ``k`` worlds in one engine call (where :data:`WORLDS` has one), the largest |Δθ| of any world from
    the product's one-world history, and from the same loop's world alone (0: bit for bit)."""
    dt, n_steps = posed.dt_s, theta.size - 1   # the history's samples after t = 0
    sim_s = n_steps * dt
    out, alone = [], None
    for k in ks:
        entry = {"worlds": k}
        if k == 1 or ad.worlds_per_batch(s) >= k:
            times_p, _ = cpu_times(lambda _: ad.run_many([case] * k), repeats, warmup=warmup)
            entry.update(product_cpu_s_per_sim_s=min(times_p) / k / sim_s, product_cpu_s=times_p)
        if engine in WORLDS:
            prepare, loop = WORLDS[engine]
            times_n, th = cpu_times(lambda scene: loop(ad, scene, posed, s, dt, n_steps, k), repeats,
                                    lambda: prepare(ad, posed, s, dt, n_steps, k), warmup)
            alone = th[0] if k == 1 else alone
            entry.update(native_cpu_s_per_sim_s=min(times_n) / k / sim_s, native_cpu_s=times_n,
                         theta_diff_from_product_rad=float(np.max(np.abs(th - theta[1:]))),
                         theta_diff_from_alone_rad=None if alone is None else float(np.max(np.abs(th - alone))))
        out.append(entry)
    return out


def measure_cell(engine: str, settings: str, cell: str, repeats: int, ks: tuple = (1,), warmup: int = 0) -> dict:
    """One row: the cell's CPU s per simulated s through each path (the least of ``repeats``, every
    repeat's CPU s kept), their ratio, and the differences of max|θ| and final θ between the paths;
    with ``ks`` beyond 1, the same per world at each number of worlds (:func:`measure_worlds`)."""
    ad = get_adapter(engine, settings=settings)
    case = case_of(cell)
    posed, s, theta, t_s = product_history(ad, case)   # warms the adapter: calibration, step, scene
    dt = posed.dt_s
    n_steps = int(round(t_s[-1] / dt))
    sim_s = n_steps * dt
    row = {"engine": engine, "settings": settings, "cell": cell, "dt_s": dt, "steps": n_steps, "simulated_s": sim_s}
    times, results = cpu_times(lambda _: ad.run_many([case]), repeats, warmup=warmup)
    cpu, r = min(times), results[0]
    row.update(outcome=r.outcome, status=r.status, product_cpu_s_per_sim_s=cpu / sim_s, product_cpu_s=times,
               run_many_max_theta_diff_rad=abs(r.max_abs_theta_rad - float(np.max(np.abs(theta)))),
               product_parts=product_parts(ad, case, posed, s, repeats, warmup))
    if len(ks) > 1:
        row["worlds"] = measure_worlds(engine, ad, case, posed, s, theta, list(ks), repeats, warmup)
        batched = [w for w in row["worlds"] if w["worlds"] > 1 and "product_cpu_s_per_sim_s" in w]
        if batched:   # the largest batch, in the summary's columns
            row.update(batch_worlds=batched[-1]["worlds"],
                       product_batched_cpu_s_per_sim_s=batched[-1]["product_cpu_s_per_sim_s"])
    try:
        times_n, native = cpu_times(lambda scene: NATIVE[engine](ad, scene, posed, s, dt, n_steps), repeats,
                                    lambda: ad.build(case.block, s, dt), warmup)
    except Exception as e:  # noqa: BLE001 - recorded, the other engines go on
        row["native_error"] = f"{type(e).__name__}: {e}"
        return row
    cpu_n = min(times_n)
    row.update(native_cpu_s_per_sim_s=cpu_n / sim_s, ratio=cpu / cpu_n, native_cpu_s=times_n,
               max_theta_diff_rad=abs(float(np.max(np.abs(native))) - float(np.max(np.abs(theta)))),
               final_theta_diff_rad=abs(float(native[-1]) - float(theta[-1])),
               final_theta_rad=float(theta[-1]), max_abs_theta_rad=float(np.max(np.abs(theta))))
    if "product_batched_cpu_s_per_sim_s" in row:
        row["ratio_batched"] = row["product_batched_cpu_s_per_sim_s"] / row["native_cpu_s_per_sim_s"]
    return row


def line(row: dict) -> str:
    head = (f"{row['engine']:9} {row['settings']:10} {row['cell']:15} dt {row['dt_s']:.3g} s, "
            f"{row['simulated_s']:.3g} s simulated, {row['outcome'] or row['status']}")
    if "native_error" in row:
        return f"{head}: product {row['product_cpu_s_per_sim_s']:.3g} CPU s/s; native failed: {row['native_error']}"
    out = (f"{head}: product {row['product_cpu_s_per_sim_s']:.3g}, native "
           f"{row['native_cpu_s_per_sim_s']:.3g} CPU s/s, ratio {row['ratio']:.2f}")
    if "ratio_batched" in row:
        out += (f"; batched ({row['batch_worlds']} worlds) {row['product_batched_cpu_s_per_sim_s']:.3g} a world, "
                f"ratio {row['ratio_batched']:.2f}")
    out += (f"; Δmax|θ| {row['max_theta_diff_rad']:.1e}, Δθ_end {row['final_theta_diff_rad']:.1e} rad "
            f"(run_many vs its loop {row['run_many_max_theta_diff_rad']:.1e})")
    for w in row.get("worlds", []):
        out += f"\n    {w['worlds']:3} worlds: product " + (
            f"{w['product_cpu_s_per_sim_s']:.3g}" if "product_cpu_s_per_sim_s" in w else "(one world a batch)")
        if "native_cpu_s_per_sim_s" in w:
            alone = w["theta_diff_from_alone_rad"]
            out += (f", native {w['native_cpu_s_per_sim_s']:.3g} CPU s/s a world; |Δθ| from the product "
                    f"{w['theta_diff_from_product_rad']:.1e}, from the world alone "
                    + ("–" if alone is None else f"{alone:.1e}") + " rad")
    return out


def agrees(row: dict, tol_rad: float) -> bool:
    """Whether the paths' θ histories agree to ``tol_rad`` (a cell the judge failed has no max|θ| of run_many's)."""
    diffs = [row.get(k, math.nan) for k in ("max_theta_diff_rad", "final_theta_diff_rad")]
    if row["status"] == "ok":
        diffs.append(row["run_many_max_theta_diff_rad"])
    return "native_error" not in row and max(diffs) <= tol_rad


def summary(rows: list[dict]) -> list[dict]:
    """Per engine and settings, over its cells (those whose native loop ran): the step [s], CPU seconds
    per simulated second of each path (total CPU over total simulated time), their ratio, the worst
    cell's ratio, and the batched cost per world and its ratio where the adapter batches."""
    out: dict = {}
    for r in rows:
        if "native_error" in r:
            continue
        g = out.setdefault((r["engine"], r["settings"]),
                           {"engine": r["engine"], "settings": r["settings"], "dt_s": set(), "sim_s": 0.0,
                            "product": 0.0, "native": 0.0, "batched": 0.0, "worst_ratio": 0.0, "worlds": None})
        g["dt_s"].add((r["cell"].split(":")[0], r["dt_s"]))
        g["sim_s"] += r["simulated_s"]
        g["product"] += r["product_cpu_s_per_sim_s"] * r["simulated_s"]
        g["native"] += r["native_cpu_s_per_sim_s"] * r["simulated_s"]
        g["worst_ratio"] = max(g["worst_ratio"], r["ratio"])
        if "batch_worlds" in r:
            g["worlds"] = r["batch_worlds"]
            g["batched"] += r["product_batched_cpu_s_per_sim_s"] * r["simulated_s"]
    for g in out.values():
        sim = g.pop("sim_s")
        g.update(dt_s=sorted(g["dt_s"]), product=g["product"] / sim, native=g["native"] / sim)
        g["ratio"] = g["product"] / g["native"]
        g["batched"] = g["batched"] / sim if g["worlds"] else None
    return list(out.values())


def markdown_table(figures: dict) -> str:
    """The record's summary (:func:`summary`) as a Markdown table: CPU s per simulated s."""
    lines = ["| engine | settings | step | product | native | ratio (worst cell) | batched a world | ratio batched |",
             "|---|---|---|---|---|---|---|---|"]
    for g in summary(figures["rows"]):
        steps = {dt for _, dt in g["dt_s"]}
        step = (f"{1e3 * steps.pop():.3g} ms" if len(steps) == 1 else
                ", ".join(f"{1e3 * dt:.3g} ms ({block})" for block, dt in g["dt_s"]))
        batched = (f"{g['batched']:.3g} ({g['worlds']} worlds) | {g['batched'] / g['native']:.2f}"
                   if g["worlds"] else "– (one world at a time) | –")
        lines.append(f"| {g['engine']} | {g['settings']} | {step} | {g['product']:.3g} | {g['native']:.3g} | "
                     f"{g['ratio']:.2f} ({g['worst_ratio']:.2f}) | {batched} |")
    return "\n".join(lines)


def parts_table(figures: dict) -> str:
    """Where one world's ``run_many`` goes (:func:`product_parts`), per engine and settings, as a Markdown
    table: mean CPU ms a cell over the cells whose native loop ran."""
    groups: dict = {}
    for r in figures["rows"]:
        if "native_error" not in r and "product_parts" in r:
            groups.setdefault((r["engine"], r["settings"]), []).append(r)
    lines = ["| engine | settings | run_many | posing the case | the loop (run_worlds) | the rest | native loop |",
             "|---|---|---|---|---|---|---|"]
    for (engine, settings), rows in groups.items():
        product = np.mean([min(r["product_cpu_s"]) for r in rows])
        posed = np.mean([r["product_parts"]["posed_cpu_s"] for r in rows])
        loop = np.mean([r["product_parts"]["loop_cpu_s"] for r in rows])
        native = np.mean([min(r["native_cpu_s"]) for r in rows])
        lines.append(f"| {engine} | {settings} | {1e3 * product:.2f} | {1e3 * posed:.2f} | {1e3 * loop:.2f} | "
                     f"{1e3 * (product - posed - loop):.2f} | {1e3 * native:.2f} |")
    return "\n".join(lines)


def worlds_table(figures: dict) -> str:
    """Cost a world at each number of worlds (:func:`measure_worlds`), per engine and settings, as a
    Markdown table: CPU s per simulated s totalled over the cells, each over the native loop's one world,
    and the largest |Δθ| of any world from the same loop's world alone (0: bit for bit)."""
    groups: dict = {}
    for r in figures["rows"]:
        for w in r.get("worlds", []):
            g = groups.setdefault((r["engine"], r["settings"], w["worlds"]), {"sim": 0.0, "product": 0.0, "native": 0.0,
                                                                              "alone": 0.0, "has_product": True})
            g["sim"] += r["simulated_s"]
            g["has_product"] &= "product_cpu_s_per_sim_s" in w
            g["product"] += w.get("product_cpu_s_per_sim_s", math.nan) * r["simulated_s"]
            g["native"] += w.get("native_cpu_s_per_sim_s", math.nan) * r["simulated_s"]
            g["alone"] = max(g["alone"], w.get("theta_diff_from_alone_rad") or 0.0)
    lines = ["| engine | settings | worlds | product a world | native a world | product / native one world | "
             "native / native one world | max \\|Δθ\\| from alone [rad] |", "|---|---|---|---|---|---|---|---|"]
    for (engine, settings, k), g in groups.items():
        one = groups[(engine, settings, 1)]["native"] / groups[(engine, settings, 1)]["sim"]
        product, native = g["product"] / g["sim"], g["native"] / g["sim"]
        shown = f"{product:.3g} | " if g["has_product"] else "one world a batch | "
        ratio = f"{product / one:.2f} | " if g["has_product"] else "– | "
        lines.append(f"| {engine} | {settings} | {k} | {shown}{native:.3g} | {ratio}{native / one:.2f} | {g['alone']:.1g} |")
    return "\n".join(lines)

def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", nargs="+", default=list(ENGINES), choices=list(ENGINES))
    ap.add_argument("--cells", nargs="+", default=list(CELLS), help="BLOCK:PULSE:W_RATIO:A_RATIO each")
    ap.add_argument("--settings", nargs="+", default=["calibrated", "shipped"], choices=["calibrated", "shipped"])
    ap.add_argument("--repeats", type=int, default=3, help="timed repeats of each path; the least CPU time counts")
    ap.add_argument("--warmup", type=int, default=0,
                    help="untimed calls of each path before its timed repeats (Python specialises a function's "
                         "code after a few calls: the native loop's one function within its first call, the "
                         "product's many after several runs, as in a map's worker)")
    ap.add_argument("--worlds", type=int, nargs="+", default=[1],
                    help="numbers of worlds: beyond 1, each cell also runs as that many copies, through the product "
                         "and where the engine has one through its native loop of many worlds in one call")
    ap.add_argument("--theta-tol-rad", type=float, default=1e-4,
                    help="largest difference of max|θ| and final θ [rad]")
    ap.add_argument("--record", help="write the rows as this benchmark record (tests/measurements/records.py)")
    ap.add_argument("--notes", help="the record's notes: the machine's load, what code was measured")
    ap.add_argument("--table", metavar="NAME", help="print the record NAME's summary and where run_many's time goes "
                    "as Markdown tables, run nothing")
    a = ap.parse_args(argv)
    if a.table:
        figures = load(a.table)["figures"]
        print(markdown_table(figures) + "\n\n" + parts_table(figures)
              + ("\n\n" + worlds_table(figures) if any("worlds" in r for r in figures["rows"]) else ""))
        return 0
    if a.repeats < 1 or min(a.worlds) < 1 or a.warmup < 0:
        _refuse(f"--repeats and --worlds must be at least 1 and --warmup at least 0, got {a.repeats}, {a.worlds} "
                f"and {a.warmup}")
    ks = sorted({1, *a.worlds})
    cells = [(c, case_of(c)) for c in a.cells]   # a bad cell stops here, before anything runs
    rows = []
    for engine in a.engines:
        for settings in a.settings:
            for cell, _ in cells:
                rows.append(measure_cell(engine, settings, cell, a.repeats, tuple(ks), a.warmup))
                print(line(rows[-1]), flush=True)
        if a.record:   # rewritten after each engine, so a stopped run keeps what it measured
            command = "python tests/measurements/bench_native_floor.py " + " ".join(argv or sys.argv[1:])
            write_record(a.record, MEASURES, command,
                         {"rows": rows, "repeats": a.repeats, "warmup": a.warmup, "theta_tol_rad": a.theta_tol_rad},
                         packages=("mujoco", "pybullet", "dartpy", "sapien", "exudyn", "drake"), notes=a.notes)
    bad = [r for r in rows if not agrees(r, a.theta_tol_rad)]
    for r in bad:
        print(f"DISAGREE: {r['engine']} {r['settings']} {r['cell']}", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
