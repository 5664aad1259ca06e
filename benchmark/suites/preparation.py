"""Before the engine maps: each engine variant's calibration on each block (cached on disk) and its
free-rocking η, in helper processes while the reference maps run (:func:`prepare_engines`).
"""

from __future__ import annotations

import math
import multiprocessing
import os
import sys
import time
from dataclasses import dataclass
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from rockbench.engines.contract import EngineAdapter
from rockbench.engines.registry import adapter_class, register
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.engine_info.adapters import build_adapter
from rockbench.benchmark.maps.cores import can_fork_helper
from rockbench.benchmark.maps.executors import worker_init
from rockbench.benchmark.store.files import variant_name, write_json
from rockbench.benchmark.store.loading import CALIBRATION_FILE, calibration_rows
from rockbench.benchmark.suites.model import Suite, restitution_for
from rockbench.benchmark.suites.plan import SPEED_SETTINGS, variant_blocks, variant_restitution, variant_settings



def _prepare_one(engine: str, variant: dict, block: str, restitution: str, dt_s, measure: bool,
                 steps: tuple = ()) -> dict:
    """One engine variant on one block: its calibration for the suite's restitution (computed once
    and cached on disk, where the map workers find it), with the time-step rule's choice where it made
    one (``step_rule``: its record's step, whether it converged and its yardstick); the calibrations at
    each of ``steps`` [s] (the speed stage's, after the rule's, which computes those on its ladder); and,
    with ``measure``, its free-rocking η (by a fresh adapter, as measured before the maps always was)."""
    b = get_preset(block).block()
    variant = variant_settings(variant)
    law = restitution_for(restitution, block)
    out: dict = {"measurement": None, "error": None, "step_rule": None}
    try:
        adapter = build_adapter(engine, **variant)
        rule = (adapter.resolve(b, law, dt_s=dt_s).get("calibration") or {}).get("step_rule") or {}
        if rule.get("dt_s") is not None:
            out["step_rule"] = {k: rule.get(k) for k in ("dt_s", "converged", "yardstick_dt_s", "ladder_s")}
        for dt in steps:
            adapter.resolve(b, law, dt_s=dt)
    except Exception:  # noqa: BLE001 - not fatal here: the maps meet it again and record it
        pass
    if measure:
        try:
            m = build_adapter(engine, **variant).measure_restitution(b, dt_s=dt_s)
            out["measurement"] = {"eta_measured": float(m.eta_mean), "eta_std": float(m.eta_std),
                                  "n_impacts": len(m.etas), "method": m.method}
        except Exception as e:  # noqa: BLE001 - a failed measurement drops map (d) only
            out["error"] = f"{type(e).__name__}: {e}"
    return out


def prepare_engines(suite: Suite, engines: list[str], out: Path, log, *, workers: int = 1,
                    own_eta: bool | None = None) -> tuple[list[dict], list[str], float]:
    """Everything the engine maps need before they start, on ``workers`` cores at once: each engine
    variant's calibration on each block (cached on disk) and, with ``own_eta`` (default: the
    suite's), its free-rocking η (kept in OUT/calibration.json and reused).

    The tasks run in helper processes (one per core; forked where that is safe, so they share what
    this process has imported), the costliest engines first; a task that fails is noted, and if the
    helpers themselves cannot run, the rest runs here one task after another. The measurements are
    the same wherever they run (the simulations are deterministic).

    Returns
    -------
    rows, notes, wall_s
        The η measurements in suite order (engine, variant, block), notes on those that failed,
        and the wall time spent [s].
    """
    return Preparation(suite, engines, out, log, workers=workers, own_eta=own_eta).finish()


@dataclass
class _Task:
    """One engine variant on one block to prepare: its calibration (``dt_s``: the suite's step, None for the
    time-step rule's), its free-rocking η when ``measure``, the speed stage's ``steps`` [s]; ``speed_only``:
    a task of the speed stage alone (no variant of the suite maps it: no own-η measurement or map)."""

    engine: str
    variant: dict
    block: str
    measure: bool
    dt_s: float | None
    steps: tuple = ()
    speed_only: bool = False


class Preparation:
    """:func:`prepare_engines` in two halves: made, it starts the helpers; :meth:`finish` waits for
    them (the suite computes its reference maps in between). ``speed_engines``: the engines of the
    suite's speed stage, whose calibrations at its steps and the time-step rule's choice on its blocks
    are prepared too (:attr:`rules` after :meth:`finish`). ``pool``: an executor of a cluster (a Dask
    client's :meth:`get_executor`) that runs the tasks instead of helper processes here; a task it loses
    (its workers died) is done here by :meth:`finish`."""

    #: whether the tasks run on a cluster's executor (``pool``), and whether :meth:`abort` stopped them there
    remote = False
    aborted = False

    def __init__(self, suite: Suite, engines: list[str], out: Path, log, *, workers: int = 1,
                 own_eta: bool | None = None, speed_engines: list[str] = (), pool=None):

        self.t0 = time.perf_counter()
        self.suite, self.out = suite, out
        self.own_eta = suite.engines.own_eta if own_eta is None else own_eta
        self.path = out / CALIBRATION_FILE
        self.old = {(r["variant"], r["block"]): r for r in calibration_rows(self.path)}
        self.tasks: list[_Task] = []
        for engine, variant, block in variant_blocks(suite, engines):
            vname = variant_name(engine, variant_settings(variant), suite.engines.dt_s)
            cached = (vname, block) in self.old and self.old[(vname, block)].get("eta_measured") is not None
            # a variant with its own restitution is scored against that restitution's reference
            # maps; its own-η map (d) would measure the Housner calibration, so it has none
            self.tasks.append(_Task(engine, variant, block, self.own_eta and not cached and "restitution" not in variant,
                                    suite.engines.dt_s))
        self._add_speed(speed_engines)
        #: the time-step rule's choice by (engine, block) for the speed stage's engines (after :meth:`finish`)
        self.rules: dict = {}
        self.results: dict = {}
        # work to do: a measurement, or a calibration (an engine with none has nothing to prepare);
        # the costliest engines first (finer default steps), so the last tasks are short
        self.todo = sorted((k for k, t in enumerate(self.tasks) if t.measure or _calibrates(t.engine)),
                           key=lambda k: cost_rank(self.tasks[k].engine))
        for k in self.todo:
            t = self.tasks[k]
            if t.measure:
                log(f"measuring η of {variant_name(t.engine, variant_settings(t.variant), t.dt_s)} on {t.block} "
                    f"(free rocking)")
        self.pool, self.futs, self.remote = None, {}, pool is not None
        if pool is not None:
            self._submit_to(pool)
        elif workers > 1 and len(self.todo) > 1:
            self._start_helpers(workers)

    def _add_speed(self, engines) -> None:
        """The speed stage's calibrations: on the task of the suite's own calibrated variant of that engine
        and block where there is one (the rule's search and its calibrations are then made once), else in a
        task of their own."""
        sp = self.suite.speed
        if sp is None:
            return
        for engine in engines:
            for block in sp.blocks:
                k = next((k for k, t in enumerate(self.tasks) if (t.engine, t.block, t.dt_s) == (engine, block, None)
                          and variant_settings(t.variant) == SPEED_SETTINGS and "restitution" not in t.variant), None)
                if k is not None:
                    self.tasks[k].steps = tuple(sp.steps_s)
                else:
                    self.tasks.append(_Task(engine, dict(SPEED_SETTINGS), block, False, None, tuple(sp.steps_s), True))

    def own_eta_slots(self) -> int:
        """How many (variant, block) pairs get a reference map at their own measured η, at most (per
        pulse): the upper bound of :func:`own_eta_jobs`, known before any η is measured."""
        if not self.own_eta:
            return 0
        return sum(1 for t in self.tasks if "restitution" not in t.variant and not t.speed_only)

    def _args(self, t: _Task) -> tuple:
        return (t.engine, t.variant, t.block, variant_restitution(self.suite, t.variant), t.dt_s, t.measure, t.steps)

    def _start_helpers(self, workers: int) -> None:
        try:
            # a fork shares what this process has imported (the engines: seconds of start-up per
            # helper); it is safe only from a single thread, else a fresh interpreter is spawned
            ctx = multiprocessing.get_context("fork" if can_fork_helper() else "spawn")
            init = worker_init("", {})   # this process's extra engines and sys.path, as map workers get them
            self.pool = ProcessPoolExecutor(max_workers=min(workers, len(self.todo)), mp_context=ctx,
                                            initializer=helper_init, initargs=(init["registry"], init["sys_path"]))
            for k in self.todo:
                self.futs[k] = self.pool.submit(_prepare_one, *self._args(self.tasks[k]))
        except (OSError, RuntimeError, ValueError):
            self._stop()

    def _submit_to(self, pool) -> None:
        """Every task to a cluster's executor, the costliest first (its workers set up the registry and
        ``sys.path`` this process has, as the helpers here do)."""
        init = worker_init("", {})
        self.pool = pool
        for k in self.todo:
            self.futs[k] = pool.submit(_prepare_remote, init["registry"], init["sys_path"], *self._args(self.tasks[k]))

    def _stop(self) -> None:
        if self.pool is not None:
            if self.remote:
                self.pool.shutdown(wait=False)   # a cluster's executor: cancels what has not run
            else:
                self.pool.shutdown(wait=True, cancel_futures=True)
            self.pool = None

    def abort(self) -> None:
        """Stop the helpers now, mid-task (Ctrl-C, SIGTERM): a calibration they finished is cached, one
        they were making is not (the cache writes each entry whole or not at all), and none waits
        minutes for the task it had begun. Before Python 3.14 (``terminate_workers``) concurrent.futures
        has no public way to stop a running task, so the pool's processes are killed directly (SIGKILL,
        not SIGTERM: a forked helper inherits the command's SIGTERM handler, which raises an exception
        that the pool's worker loop catches and outlives)."""
        if self.remote:
            self.aborted = True   # finish() (waiting in another thread) does nothing here either
            self._stop()
        elif self.pool is not None:
            for proc in list((getattr(self.pool, "_processes", None) or {}).values()):
                proc.kill()
            self.pool.shutdown(wait=False, cancel_futures=True)
            self.pool = None

    def finish(self) -> tuple[list[dict], list[str], float]:

        try:
            for k, f in self.futs.items():
                try:
                    self.results[k] = f.result()
                except BrokenProcessPool:
                    break
                except Exception:  # noqa: BLE001 - a cluster lost the task (KilledWorker): done here below
                    if not self.remote or self.aborted:
                        raise
        except BaseException:
            self.abort()
            raise
        finally:
            self._stop()
        for k in self.todo:   # here: one worker, or what the helpers could not do
            if k not in self.results:
                self.results[k] = _prepare_one(*self._args(self.tasks[k]))
        for k, t in enumerate(self.tasks):
            if t.steps:
                self.rules[(t.engine, t.block)] = (self.results.get(k) or {}).get("step_rule")
        rows, notes = self._own_eta_rows() if self.own_eta else ([], [])
        return rows, notes, time.perf_counter() - self.t0

    def _own_eta_rows(self) -> tuple[list[dict], list[str]]:
        """The η measurements (measured now or kept from calibration.json), written to calibration.json."""
        rows, notes = [], []
        for k, t in enumerate(self.tasks):
            vname = variant_name(t.engine, variant_settings(t.variant), t.dt_s)
            if "restitution" in t.variant or t.speed_only:
                continue      # no own-η map for a variant with its own restitution (see above), or the speed stage's
            if not t.measure:
                rows.append(self.old[(vname, t.block)])
                continue
            r = self.results[k]
            if r["measurement"] is not None:
                rows.append({"variant": vname, "engine": t.engine, "settings": dict(t.variant), "block": t.block,
                             **r["measurement"]})
            else:
                notes.append(f"η of {vname} on {t.block} not measured: {r['error']}")
        self.out.mkdir(parents=True, exist_ok=True)
        write_json(self.path, {"kind": "rockbench-calibration", "measurements": rows})
        return rows, notes


def helper_init(registry: dict, sys_path: list) -> None:
    """A helper process or a cluster's worker learns the engines registered and the ``sys.path`` of the
    process that runs the suite (:func:`~rockbench.benchmark.maps.executors.worker_init`)."""
    for p in sys_path:
        if p not in sys.path and os.path.isdir(p):
            sys.path.append(p)
    for name, target in registry.items():
        register(name, target)


def _prepare_remote(registry: dict, sys_path: list, *args) -> dict:
    """:func:`_prepare_one` on a cluster's worker, which first learns this process's engines and path."""
    helper_init(registry, sys_path)
    return _prepare_one(*args)


def _calibrates(engine: str) -> bool:
    """Whether the engine's adapter has a calibration of its own to compute (and cache)."""
    try:
        return adapter_class(engine).calibrate is not EngineAdapter.calibrate
    except Exception:  # noqa: BLE001 - an adapter that cannot load has nothing to prepare here
        return False


def cost_rank(engine: str) -> tuple:
    """How costly an engine's cells are, roughly, for ordering work (smaller: costlier, first): a
    finer default time step costs more, and an engine with a native batch (MuJoCo's rollouts) less
    per cell than one stepped from Python at the same step. Lanes then end on the cheapest maps,
    when one core may have to wait for the other."""
    try:
        cls = adapter_class(engine)
    except Exception:  # noqa: BLE001 - an engine that cannot even load its adapter class goes last
        return (math.inf, 1)
    step = getattr(cls, "fixed_dt_s", None) or cls.own_dt_s or 1.0   # the benchmark's step for it, else its own
    return (float(step), 1 if cls.batching != "none" else 0)
