"""MuJoCo Warp adapter: the CPU MuJoCo adapter's rocking block, every cell a world of one batch.

The model
---------
The MJCF model is the CPU MuJoCo adapter's own (:class:`~rockbench.engines.adapters.mujoco.MujocoAdapter`
builds it with ``MjSpec``; this adapter reuses the builder and the settled initial state) and is
moved to the device with ``mujoco_warp.put_model``. What differs, because MuJoCo Warp allows no
other (``docs/mujoco_warp.md``):

* arithmetic in float32 on the device (the CPU engine computes in float64); the table drive is
  evaluated in float64 and rounded once per step;
* the constraint solver is Newton (MuJoCo's default, also on the CPU) or CG; PGS does not exist
  in MuJoCo Warp. On a CUDA device the solver stops each world at its own convergence (a graph
  conditional); on the CPU device it launches ``iterations`` passes, converged worlds skipping them;
* the no-slip solver exists (``noslip_iterations``), as on the CPU.

One batch of worlds
-------------------
``_simulate_many`` puts every case that shares a model into one ``mujoco_warp.Data`` with
``nworld`` worlds (``nconmax``/``njmax`` sized for one block on one table, per world). Each world
has its own table pulse: a kernel evaluates the pulse's table velocity ``u̇`` at both ends of the
step (in float64, on the device) and writes the step-averaged inertial force
``−m·(u̇(tₙ₊₁) − u̇(tₙ))/Δt`` into that world's ``ctrl`` (the motor on the slide-x dof of the CPU
adapter). Record pulses, which have no closed form, read ``u̇`` from a table computed on the host.
A step is: drive kernel, ``mujoco_warp.step``, a kernel copying ``qpos``/``qvel`` into the segment
buffer, the end-of-run kernel (below), a step counter. On a CUDA device up to ten such steps are
captured once in a CUDA graph and the graph is launched for the rest of the run (no Python per
step); on the CPU device the same launches run in a plain loop. Each world's samples come back once per segment; trajectories and the
verdicts (the one judge, :meth:`EngineAdapter.judge`) are then made per cell, for a large batch in
forked processes (the ``_native_verdicts`` hook).

End of a run
------------
The one end-of-run rule of every contact engine (floor 1's
:func:`~rockbench.reference_solver.classify.run_end`), evaluated on the device at every sample: a
kernel after each step reads the world's θ and θ̇ (in float64, from the float32 state, as the host
reads them) and stops the world at the first sample where they are not finite, the block lies flat,
after the pulse |θ| > α moving outward, or from ``min_tail_s`` after the pulse on its free-rocking
energy is trapped below the barrier (the same ``TRAPPED_MARGIN``); else at ``tail_s`` after the
pulse. Time is counted in steps exactly as on the CPU (:func:`~rockbench.engines.motion.run_steps`).
The batch runs in segments of ``segment_s``; after each segment a running world's rows come back,
up to its stop sample for a world that stopped in it. A world that has stopped keeps being stepped
with the others (a world cannot leave a batch cheaply) but its samples are no longer kept; the
batch stops when every world has stopped. A world's trajectory depends only on its own state, so a
cell's result does not depend on the other cells of its batch: on the CPU device bit for bit
(tested); on an H100 ``check-adapter`` found batches equal to single runs and reruns bit-identical,
though MuJoCo Warp does not promise it (contacts are gathered with atomic counters, so their order
inside a world could change the last float32 bits).

Kernel cache
------------
Warp compiles its kernels on first use (about a minute on a CPU, more on a GPU) and keeps them in
``<rockbench cache>/warp`` (``$ROCKBENCH_CACHE``, default ``~/.cache/rockbench``), unless
``WARP_CACHE_PATH`` names another folder, so reruns and CI reuse them.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import time

import numpy as np

from rockbench.reference_solver.classify import END_REASONS, trapped_energy
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import FLAT_ANGLE_RAD, Block
from rockbench.engines.calibration.free_rocking import PEAK_RATIO, measured
from rockbench.engines import progress
from rockbench.engines.contract import Case, Trajectory
from rockbench.engines.loop import trajectory
from rockbench.engines.motion import run_steps
from rockbench.engines.adapters.mujoco import BuiltModel, MujocoAdapter, released_state
from rockbench.engines.adapters.warp_start import cuda_driver_present, say_first_compile, start_warp

#: Contacts allocated per world: MuJoCo Warp's box–plane test makes a contact of every corner below
#: the plane, so up to 8 (CPU MuJoCo keeps 4): a block standing on its base has 4, one sunk into a
#: soft contact deeper than its own height (MuJoCo's shipped contact, ``settings=shipped``) all 8;
#: a box on a box (the table drive) also up to 8. Constraint rows per world follow (an elliptic
#: contact of condim 3 has 3 rows, a pyramidal one 4). A world that needs more stops its batch with
#: an error rather than losing contacts (:meth:`MujocoWarpAdapter._check_capacity`).
NCONMAX_PLANE, NCONMAX_BOX = 8, 8

#: Steps captured in one CUDA graph: the largest of these that divides a segment's steps (fewer
#: launches from Python; the device work is the same)
STEPS_PER_GRAPH = (10, 8, 5, 4, 2, 1)

#: Most worlds in one ``Data`` (larger batches run as several, each independent).
MAX_WORLDS = 65536

#: How a world's run ended, by the code the device's end-of-run kernel writes (0: the tail, then
#: floor 1's reasons in their order: ``_mujoco_warp_kernels.TAIL`` … ``TRAPPED``)
ENDED_BY = ("tail",) + END_REASONS

#: A step no run reaches: the device's "never" for a free-rocking run's pulse end and trapped rule
_NEVER = 2**31 - 1

_SOLVERS = ("newton", "cg")
_DEVICES = ("auto", "cpu", "cuda")

#: What rockbench says, once per run, where Warp starts without a CUDA driver (instead of Warp's
#: own warning).
CPU_LINE = "rockbench: mujoco_warp runs on the CPU here (no NVIDIA CUDA driver found): expect it to be slow"


def _warp():
    """``(warp, mujoco_warp)``, Warp started once (:func:`~rockbench.engines.warp_start.start_warp`)."""
    wp = start_warp(CPU_LINE)
    import mujoco_warp as mjw   # optional engine library
    return wp, mjw


def _kernels():
    """The adapter's own kernels (:mod:`rockbench.engines.adapters.mujoco_warp_kernels`, imported once Warp is set up);
    asked for before the first launch, so the line of a first compile comes here."""
    _warp()
    say_first_compile("mujoco_warp", "mujoco_warp.")
    from rockbench.engines.adapters import mujoco_warp_kernels as k   # Warp's kernels: the optional engine library, once Warp is set up
    return {"drive": k.drive, "record": k.record, "end_of_run": k.end_of_run, "advance": k.advance}


#: pulse kinds the drive kernel evaluates in closed form (3: a velocity table, 4: no pulse)
_KIND_CODES = {"sine": 0, "cosine": 1, "half-sine": 2}
_KIND_TABLE, _KIND_STILL = 3, 4


class _Samples:
    """Each world's samples of one batch: ``[t, qpos, qvel]`` rows in float64, made world by world
    when asked for (``samples[i]``), from the float32 rows the device recorded; and how each run
    ended (``ended[i]``)."""

    def __init__(self, parts: list, dt: float, ended: list):
        self.parts = parts
        self.dt = dt
        #: how each world's run ended (:data:`ENDED_BY`)
        self.ended = ended

    def __len__(self) -> int:
        return len(self.parts)

    def __getitem__(self, i: int) -> np.ndarray:
        h = np.concatenate(self.parts[i])
        st = np.empty((h.shape[0], 1 + h.shape[1]))
        st[:, 0] = np.arange(h.shape[0]) * self.dt
        st[:, 1:] = h
        return st

    def __iter__(self):
        return (self[i] for i in range(len(self)))


def _drive_arrays(pulses: list, max_steps: int, dt: float) -> tuple:
    """What the drive kernel reads per world: the pulse kind code, amplitude [m/s²], ω [rad/s] and
    duration [s] of a closed-form pulse, and for a record pulse its row in a table of the table
    velocity at every step ``k·dt`` up to ``max_steps`` [m/s] (a dummy ``(1, 1)`` table when none)."""
    kind = np.array([_KIND_STILL if p is None else _KIND_CODES.get(p.kind, _KIND_TABLE) for p in pulses],
                    dtype=np.int32)
    closed = kind < _KIND_TABLE
    amp = np.array([float(p.amplitude_mps2) if c else 0.0 for p, c in zip(pulses, closed)])
    omega = np.array([float(p.omega_rad_s) if c else 1.0 for p, c in zip(pulses, closed)])
    dur = np.array([0.0 if p is None else float(p.duration_s) for p in pulses])
    rec = np.nonzero(kind == _KIND_TABLE)[0]
    row = np.zeros(len(pulses), dtype=np.int32)
    row[rec] = np.arange(rec.size, dtype=np.int32)
    if rec.size:
        tk = np.arange(max_steps + 1) * dt
        vtab = np.stack([np.asarray(pulses[i].vel(tk), dtype=float) for i in rec])
    else:
        vtab = np.zeros((1, 1))
    return kind, amp, omega, dur, row, vtab


def _judge_slice(bounds):
    """Judge cases ``bounds[0]:bounds[1]`` of the batch a forked judge worker inherited."""
    ad, cases, raw, wall = _JUDGE_JOB
    return [ad.judge(cases[k], ad._make_trajectory(cases[k], raw[k]), wall) for k in range(*bounds)]


#: the batch forked judge workers read (set only while a pool runs)
_JUDGE_JOB = None


class MujocoWarpAdapter(MujocoAdapter):
    """The rocking block in MuJoCo Warp, a map's cells as worlds of one batch (module docstring).

    Settings
    --------
    All the CPU MuJoCo adapter's settings but ``threads`` (same meaning, same defaults:
    ``settings``, ``drive``, ``planar``, ``friction``, ``timeconst_s``, ``dampratio``,
    ``noslip_iterations``, ``cone``, ``integrator``, ``impratio``, ``tail_s``, ``min_tail_s``,
    ``segment_s``, ``table_mass_ratio``), and:

    device : {"auto", "cpu", "cuda"} or a Warp device name such as ``"cuda:1"``
        Where the worlds run (``auto``: the first CUDA device when there is one, else the CPU).
    solver : {"newton", "cg"}
        MuJoCo Warp's constraint solver (Newton is MuJoCo's default).
    iterations, ls_iterations : int
        Solver and line-search iteration limits (MuJoCo's defaults 100 and 50).
    judge_workers : int
        Forked processes that judge a large batch (0: one per core, at most 32; 1: in this process).
    """

    name = "mujoco_warp"
    module = "mujoco_warp"
    install_hint = ("install it with `pip install 'rockbench[warp]'` (mujoco-warp 4.0 and warp-lang 1.19; "
                    "a CUDA GPU is optional, Warp's CPU device runs small maps).")
    #: a native batch (every cell a world) judged in forked processes: maps run it in their own process
    batching = "parallel"
    #: a map in this process hands up to this many cells to one ``run_many`` (one batch of worlds):
    #: a GPU steps 40 000 worlds in little more time than 10 000
    max_batch = MAX_WORLDS
    #: the contact along the base is the CPU adapter's only: not built or tested here
    CONTACT_ROWS = None
    SETTINGS = {**{k: v for k, v in MujocoAdapter.SETTINGS.items() if k != "threads"},
                "device": "auto", "solver": "newton", "iterations": 100, "ls_iterations": 50,
                "judge_workers": 0}

    #: world-steps stepped by this adapter, and the wall time of the stepping itself [s] (device work and the
    #: per-segment read-back; the judge and the rest of the map are not in it)
    world_steps_run = 0
    stepping_s = 0.0
    #: wall time spent making trajectories and judging them (``_native_verdicts``) [s]
    judging_s = 0.0

    # -- settings ----------------------------------------------------------------------------
    def validate(self, s: dict) -> None:
        s["threads"] = 0                      # the CPU validator expects it; dropped again below
        try:
            super().validate(s)
        finally:
            s.pop("threads", None)
        dev = s["device"]
        if not isinstance(dev, str) or not (dev in _DEVICES or dev.startswith("cuda:")):
            raise ConfigError(f"mujoco_warp setting 'device' must be auto, cpu, cuda or cuda:N, got {dev!r}.")
        if dev.startswith("cuda"):
            self._device_available(dev)
        if s["solver"] not in _SOLVERS:
            raise ConfigError(f"mujoco_warp setting 'solver' must be newton or cg (MuJoCo Warp has no PGS), "
                              f"got {s['solver']!r}.")
        self.whole_setting(s, "iterations", minimum=1, allow_none=False)
        self.whole_setting(s, "judge_workers", allow_none=False)
        self.whole_setting(s, "ls_iterations", minimum=1, allow_none=False)

    def _threads(self) -> int:
        return 1   # only the CPU engine's settle and its calibration helpers use threads here

    @classmethod
    def default_suite_exclusion(cls) -> str | None:
        """Why the default suite leaves this engine out here (None: it is included).

        Warp's CPU device runs its kernels on one thread: a whole suite there takes hours, so the
        default suite runs ``mujoco_warp`` only where a CUDA device is present. Asked for by name
        (``--engines mujoco_warp``, ``rockbench map --engine mujoco_warp``) it runs anywhere.
        """
        if cuda_driver_present():   # else Warp is not started at all: there is nothing to find
            try:
                wp, _ = _warp()
                if wp.is_cuda_available():
                    return None
            except Exception as e:  # noqa: BLE001 - unavailable engines are reported elsewhere
                return f"Warp could not start ({e})"
        return ("no CUDA device here (Warp's CPU device is single-threaded: too slow for a whole suite); "
                "ask for it by name with --engines mujoco_warp")

    @classmethod
    def device_note(cls) -> str:
        """"CPU only (slow)" where Warp finds no CUDA device (its CPU device runs on one thread)."""
        return "" if cls.default_suite_exclusion() is None else "CPU only (slow): no CUDA device here"

    @staticmethod
    def _device_available(dev: str) -> None:
        """ConfigError (one line, exit 2 in the CLI) when ``dev`` names a CUDA device Warp does not find."""
        wp, _ = _warp()
        name = "cuda:0" if dev == "cuda" else dev
        if not wp.is_cuda_available() or name not in [str(d) for d in wp.get_cuda_devices()]:
            found = ", ".join(str(d) for d in wp.get_cuda_devices()) or "none"
            raise ConfigError(f"mujoco_warp setting device={dev!r}, but Warp finds no such CUDA device here "
                              f"(CUDA devices: {found}); use device=auto or device=cpu.")

    def device_name(self) -> str:
        """The Warp device the worlds run on."""
        wp, _ = _warp()
        dev = self.settings["device"]
        if dev == "auto":
            return "cuda:0" if wp.is_cuda_available() else "cpu"
        return "cuda:0" if dev == "cuda" else dev

    # -- model -------------------------------------------------------------------------------
    def _build(self, block: Block, s: dict, dt: float) -> BuiltModel:
        import mujoco   # optional engine library

        bm = super()._build(block, s, dt)
        opt = bm.model.opt
        opt.solver = mujoco.mjtSolver.mjSOL_NEWTON if s["solver"] == "newton" else mujoco.mjtSolver.mjSOL_CG
        opt.iterations = int(s["iterations"])
        opt.ls_iterations = int(s["ls_iterations"])
        bm.s0 = self._settle(bm.model, mujoco)   # settled again with the solver in force
        return bm

    def _device_model(self, bm: BuiltModel, dev: str, nsolref: int = 0):
        """``mujoco_warp.put_model`` of a built model on ``dev`` (cached; ``nsolref`` > 0 gives
        ``geom_solref`` one row per world, for calibration grids)."""
        wp, mjw = _warp()
        key = ("device", id(bm), dev, nsolref)
        if key not in self.scenes:
            with wp.ScopedDevice(dev):
                self.scenes[key] = (bm, mjw.put_model(bm.model, batch_sizes={"geom_solref": nsolref}
                                                      if nsolref else None))
        return self.scenes[key][1]

    # -- the batch ---------------------------------------------------------------------------
    def _cases_by_model(self, cases: list[Case]) -> tuple[list, list]:
        """The cases grouped by the model they run on: ``(out, groups)`` where ``groups`` lists
        ``(built model, indices of its cases)`` and ``out`` holds, per case, the exception that kept
        it from getting a model (recorded per cell, the sweep goes on), else None. A ConfigError
        (bad user input) is raised."""
        out: list = [None] * len(cases)
        groups: dict = {}
        for i, c in enumerate(cases):
            try:
                s = self.resolve(c.block, c.restitution, c.dt_s)
                bm = self.build(c.block, s, c.dt_s)["bm"]
            except ConfigError:
                raise
            except Exception as e:  # noqa: BLE001 - recorded per cell, the sweep goes on
                out[i] = e
                continue
            groups.setdefault(id(bm), (bm, s, []))[2].append(i)
        return out, list(groups.values())

    def _seg_steps(self, bm: BuiltModel) -> int:
        return max(1, int(round(self.settings["segment_s"] / bm.model.opt.timestep)))

    def _simulate_raw(self, cases: list[Case]) -> list:
        """Run the cases as batches of worlds; per case the exception that stopped it, or
        ``(built model, the batch's samples, index in the batch)``."""
        out, groups = self._cases_by_model(cases)
        for bm, s, idx in groups:
            for k in range(0, len(idx), MAX_WORLDS):
                part = idx[k:k + MAX_WORLDS]
                try:
                    states = self._run_batch(bm, [cases[i].pulse for i in part],
                                             [self._stop_rule(cases[i]) for i in part])
                    res = [(bm, s, states, j) for j in range(len(part))]
                except ConfigError:
                    raise
                except Exception as e:  # noqa: BLE001 - the whole batch failed inside the engine
                    res = [e] * len(part)
                for i, r in zip(part, res):
                    out[i] = r
        return out

    def _make_trajectory(self, case: Case, raw):
        """The trajectory of one case from :meth:`_simulate_raw`'s entry (or the exception)."""
        if isinstance(raw, BaseException):
            return raw
        bm, s, states, j = raw
        try:
            return self._trajectory(bm, s, case, states[j], states.ended[j])
        except Exception as e:  # noqa: BLE001 - recorded for this cell
            return e

    def _simulate_many(self, cases: list[Case]) -> list:
        raw = self._simulate_raw(cases)
        out = []
        for c, r in zip(cases, raw):
            out.append(self._make_trajectory(c, r))
            if not isinstance(r, BaseException):
                r[2].parts[r[3]] = None      # the float32 rows are no longer needed
        return out

    def _native_verdicts(self, cases: list[Case]) -> list:
        """Every case's verdict: the batch simulated, then each cell's trajectory made and judged
        with the one classifier and validity rule (:meth:`judge`), for a large batch in forked
        processes (``judge_workers``): on a GPU that takes longer than the stepping itself."""
        global _JUDGE_JOB

        cases = list(cases)
        t0 = time.perf_counter()
        raw = self._simulate_raw(cases)
        n = len(cases)
        wall = (time.perf_counter() - t0) / max(n, 1)
        t1 = time.perf_counter()
        workers = self.settings["judge_workers"] or min(os.cpu_count() or 1, 32)
        workers = min(workers, n // 256)
        if workers < 2 or "fork" not in mp.get_all_start_methods():
            res = [self.judge(c, self._make_trajectory(c, r), wall) for c, r in zip(cases, raw)]
        else:
            _JUDGE_JOB = (self, cases, raw, wall)
            try:
                bounds = np.linspace(0, n, 4 * workers + 1).astype(int)
                with mp.get_context("fork").Pool(workers) as pool:
                    parts = pool.map(_judge_slice, list(zip(bounds[:-1].tolist(), bounds[1:].tolist())))
            finally:
                _JUDGE_JOB = None
            res = [r for p in parts for r in p]
        self.judging_s += time.perf_counter() - t1
        return res

    def _stop_rule(self, case: Case) -> dict:
        """What the end-of-run rule needs of one case (its step posed): its steps
        (:func:`~rockbench.engines.motion.run_steps`: the last, the pulse's and the first at which the
        trapped rule applies) and its block."""
        tail_s, min_tail_s = self.settings["tail_s"], self.settings["min_tail_s"]
        return {"steps": run_steps(case.dt_s, case.pulse.duration_s, tail_s, min_tail_s),
                "alpha_rad": case.block.alpha_rad, "p_rad_s": case.block.p_rad_s}

    def _end_args(self, bm: BuiltModel, step, d, stops: list | None, n: int, n_steps: int | None) -> list:
        """The inputs of the device's end-of-run kernel (:func:`~rockbench.engines.adapters.mujoco_warp_kernels.end_of_run`) for
        ``n`` worlds: ``stops`` (:meth:`_stop_rule`), or None: free rocking of ``n_steps`` steps
        (stopped early only where θ or θ̇ is not finite or the block lies flat, as the loop's
        free-rocking test). The last two are the arrays it writes: the stop step (−1 while the world
        runs) and why."""
        wp, _ = _warp()
        if stops is None:
            stops = [{"steps": (n_steps, _NEVER, _NEVER), "alpha_rad": 0.0, "p_rad_s": 0.0}] * n
        steps = np.minimum(np.array([st["steps"] for st in stops], dtype=float), _NEVER).astype(np.int32)
        alpha = np.array([st["alpha_rad"] for st in stops])
        p = np.array([st["p_rad_s"] for st in stops])
        trap = np.array([trapped_energy(a, q) for a, q in zip(alpha, p)])
        ith, iom = bm.qi["pos"] - 1 + (2 if bm.planar else 3), bm.qi["vel"] - 1 - bm.model.nq + (2 if bm.planar else 3)
        f64 = [wp.array(x, dtype=wp.float64) for x in (alpha, p * p, trap)]
        i32 = [wp.array(np.ascontiguousarray(steps[:, c]), dtype=wp.int32) for c in (1, 2, 0)]
        return [step, d.qpos, d.qvel, int(bm.planar), int(ith), int(iom), *f64, float(FLAT_ANGLE_RAD), *i32,
                wp.full(n, -1, dtype=wp.int32), wp.zeros(n, dtype=wp.int32)]

    def _run_batch(self, bm: BuiltModel, pulses: list, stops: list | None, *, init: np.ndarray | None = None,
                   solref: np.ndarray | None = None, n_steps: int | None = None) -> _Samples:
        """Step one batch of worlds; each world's samples ``[t, qpos, qvel]`` (float64) and how its
        run ended.

        Each world's run ends by floor 1's end-of-run rule evaluated on the device at every sample
        (module docstring): ``stops`` gives each world's steps and block (:meth:`_stop_rule`); None
        runs every world ``n_steps`` steps (free rocking). ``init`` gives each world its own initial
        ``[t, qpos, qvel]`` row (default: the settled state), ``solref`` its own contact
        ``(timeconst, dampratio)``.
        """
        wp, mjw = _warp()
        k = _kernels()
        dev = self.device_name()
        model = bm.model
        dt = float(model.opt.timestep)
        nq, nv = model.nq, model.nv
        n = len(pulses)
        ncol = 1 + nq + nv
        s0 = bm.s0[:ncol]
        x0 = np.tile(s0, (n, 1)) if init is None else np.asarray(init, dtype=float).reshape(n, ncol)
        nseg = self._seg_steps(bm)
        last = int(n_steps) if stops is None else max(st["steps"][0] for st in stops)
        kind, amp, omega, dur, row, vtab = _drive_arrays(pulses, last, dt)

        with wp.ScopedDevice(dev):
            m = self._device_model(bm, dev, n if solref is not None else 0)
            if solref is not None:
                sr = np.repeat(np.asarray(solref, dtype=np.float32)[:, None, :], model.ngeom, axis=1)
                m.geom_solref.assign(sr)
            ncon, njmax = self._capacity(bm)
            d = mjw.make_data(model, nworld=n, nconmax=ncon, njmax=njmax)
            d.qpos.assign(x0[:, 1:1 + nq].astype(np.float32))
            d.qvel.assign(x0[:, 1 + nq:].astype(np.float32))
            step = wp.zeros(1, dtype=wp.int32)
            hist = wp.zeros((n, nseg, nq + nv), dtype=wp.float32)
            peak = wp.zeros(n + 1, dtype=wp.int32)
            dargs = [step, wp.array(kind, dtype=wp.int32), wp.array(amp, dtype=wp.float64),
                     wp.array(omega, dtype=wp.float64), wp.array(dur, dtype=wp.float64),
                     wp.array(row, dtype=wp.int32), wp.array(vtab, dtype=wp.float64),
                     # the kernel's −mass·Δu̇/Δt: the inertial force −m·ü, or (table, a negative mass, as
                     # the MuJoCo adapter's +M·ü) the force that moves the table along u(t)
                     float(bm.mass_kg if bm.drive == "inertial" else -bm.push_mass_kg), dt, d.ctrl]
            eargs = self._end_args(bm, step, d, stops, n, n_steps)
            stop, why = eargs[-2:]

            def one_step():
                wp.launch(k["drive"], dim=n, inputs=dargs)
                mjw.step(m, d)
                wp.launch(k["record"], dim=n, inputs=[step, nseg, d.qpos, d.qvel, d.nefc, d.nacon, hist, peak])
                wp.launch(k["end_of_run"], dim=n, inputs=eargs)
                wp.launch(k["advance"], dim=1, inputs=[step])

            graph = None
            per_graph = next(g for g in STEPS_PER_GRAPH if nseg % g == 0)
            if wp.get_device(dev).is_cuda:
                self._warm_up(m, model, dev, ncon, njmax)
                with wp.ScopedCapture(device=dev) as cap:
                    for _ in range(per_graph):
                        one_step()
                graph = cap.graph
                wp.synchronize_device(dev)

            t_start = time.perf_counter()
            # each world's samples as float32 [qpos, qvel] rows (what the device computed); the
            # times are k·Δt, added in float64 when the trajectory is made
            x0_32 = x0[:, 1:].astype(np.float32)
            parts: list[list[np.ndarray]] = [[x0_32[i][None, :]] for i in range(n)]
            # on a GPU the segment comes back through a pinned host buffer (faster copies); either
            # way the host buffer is reused, so each segment's rows are copied out of it
            host = (wp.empty((n, nseg, nq + nv), dtype=wp.float32, device="cpu", pinned=True)
                    if wp.get_device(dev).is_cuda else hist)
            running = np.ones(n, dtype=bool)
            k0 = 0
            while running.any():
                if graph is not None:
                    for _ in range(nseg // per_graph):
                        wp.capture_launch(graph)
                else:
                    for _ in range(nseg):
                        one_step()
                if host is not hist:
                    wp.copy(host, hist)
                self._check_capacity(peak.numpy(), d)     # (waits for the device)
                progress.tick()
                h = host.numpy()                          # (n, nseg, nq + nv), float32, a view
                stopped = stop.numpy().copy()             # the sample each world stopped at, −1: running
                ia = np.nonzero(running)[0]
                ha = h[ia]                                # a copy: the buffer is reused
                for j, i in enumerate(ia):
                    # a world that stopped in this segment keeps its rows up to the stop sample
                    parts[i].append(ha[j] if stopped[i] < 0 else ha[j, :stopped[i] - k0])
                k0 += nseg
                running &= stopped < 0
            self.world_steps_run += n * k0
            self.stepping_s += time.perf_counter() - t_start
        self._last_device = dev
        return _Samples(parts, dt, [ENDED_BY[c] for c in why.numpy()])

    @staticmethod
    def _capacity(bm: BuiltModel) -> tuple[int, int]:
        """``(nconmax, njmax)`` per world for this model."""
        import mujoco   # optional engine library
        ncon = NCONMAX_PLANE if bm.drive == "inertial" else NCONMAX_BOX
        rows = 3 if bm.model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC else 4
        return ncon, ncon * rows

    @staticmethod
    def _warm_up(m, model, dev, ncon: int, njmax: int) -> None:
        """One step of a throwaway one-world batch and the adapter's kernels: every kernel loaded
        (compiled or read from the cache) before a CUDA graph is captured, since a capture cannot load."""
        wp, mjw = _warp()
        k = _kernels()
        d = mjw.make_data(model, nworld=1, nconmax=ncon, njmax=njmax)
        step = wp.zeros(1, dtype=wp.int32)
        hist = wp.zeros((1, 1, model.nq + model.nv), dtype=wp.float32)
        peak = wp.zeros(2, dtype=wp.int32)
        one = [wp.zeros(1, dtype=wp.int32), wp.zeros(1, dtype=wp.float64)]
        wp.launch(k["drive"], dim=1, inputs=[step, one[0], one[1], one[1], one[1], one[0],
                                             wp.zeros((1, 1), dtype=wp.float64), 1.0, 1.0, d.ctrl])
        mjw.step(m, d)
        wp.launch(k["record"], dim=1, inputs=[step, 1, d.qpos, d.qvel, d.nefc, d.nacon, hist, peak])
        wp.launch(k["advance"], dim=1, inputs=[step])
        wp.synchronize_device(dev)

    @staticmethod
    def _check_capacity(peak: np.ndarray, d) -> None:
        """A RuntimeError (the batch's cells fail) if, at any step so far, a world needed more
        constraint rows or the batch more contacts than allocated (MuJoCo Warp drops the excess)."""
        if int(peak[-1]) > d.naconmax:
            raise RuntimeError(f"mujoco_warp: {int(peak[-1])} contacts exceed the {d.naconmax} allocated")
        worst = int(peak[:-1].max())
        if worst > d.njmax:
            raise RuntimeError(f"mujoco_warp: {worst} constraint rows exceed the {d.njmax} allocated per world")

    def _trajectory(self, bm: BuiltModel, s: dict, case: Case, st: np.ndarray, ended_by: str) -> Trajectory:
        """The trajectory of one world's samples ``st`` (the contact base's read-out)."""
        run = {"wall_s": 0.0, "cpu_s": 0.0, "ended_by": ended_by}
        tr = trajectory(self, {"bm": bm}, case.block, s, bm.model.opt.timestep, case.pulse, case.pulse.duration_s,
                        st, run)[0]
        tr.diagnostics.update(device=getattr(self, "_last_device", None), precision="float32",
                              solver=self.settings["solver"])
        return tr

    # -- free rocking: every setting a world of one batch --------------------------------------------
    def run_worlds(self, block: Block, s: dict, dt: float, pulses: list, theta0: float = 0.0,
                   duration_s: float | None = None) -> list:
        """The free-rocking runs of the contact base's test, on the device (pulse runs go through
        :meth:`_native_verdicts`, whose batches hold up to 65 536 worlds)."""
        if duration_s is None or any(p is not None for p in pulses):
            raise NotImplementedError("mujoco_warp runs its pulse runs in _native_verdicts' device batches")
        return self._free_rocking_runs(block, [s] * len(pulses), dt, theta0, duration_s)

    def measure_many(self, block: Block, settings: list[dict], dt: float, theta0_frac: float = 0.5) -> list:
        """Free rocking of every one of ``settings`` as a world of one device batch (per-world contact
        ``solref``), measured as the contact base measures it."""
        theta0 = float(theta0_frac) * block.alpha_rad
        runs = self._free_rocking_runs(block, settings, dt, theta0, PEAK_RATIO.duration_s(block, theta0_frac))
        out = []
        for s, (tr, m) in zip(settings, runs):
            try:
                out.append(measured(self, block, s, dt, theta0, tr, m))
            except Exception as e:  # noqa: BLE001 - recorded for this setting, the search goes on
                out.append(e)
        return out

    def _free_rocking_runs(self, block: Block, settings: list[dict], dt: float, theta0: float,
                           duration_s: float) -> list:
        """Free-rocking runs from rest at ``theta0`` [rad] on the +x edge, ``duration_s`` [s] long, one
        world per resolved settings; worlds that share their solver settings share a batch."""
        built = [self.build(block, s, dt)["bm"] for s in settings]
        groups: dict = {}
        for j, s in enumerate(settings):
            groups.setdefault(tuple((k, s[k]) for k in ("cone", "integrator", "noslip_iterations", "impratio")),
                              []).append(j)
        nstep = run_steps(dt, 0.0, 0.0, 0.0, duration_s)[0]
        out: list = [None] * len(built)
        for idx in groups.values():
            init = [released_state(built[j], block, theta0)[:1 + built[j].model.nq + built[j].model.nv] for j in idx]
            solref = [[settings[j]["timeconst_s"], settings[j]["dampratio"]] for j in idx]
            states = self._run_batch(built[idx[0]], [None] * len(idx), None, init=np.array(init),
                                     solref=np.array(solref), n_steps=nstep)
            for j, full, why in zip(idx, states, states.ended):
                run = {"wall_s": 0.0, "cpu_s": 0.0, "ended_by": why}
                out[j] = trajectory(self, {"bm": built[j]}, block, settings[j], dt, None, 0.0, full, run)
        return out
