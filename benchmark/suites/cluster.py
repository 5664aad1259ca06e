"""A suite's maps on a Dask cluster (``rockbench run --scheduler ADDRESS|local``): one task per map.

A task carries what a worker needs to compute one map: its spec, how to compute it (the suite's
options), the files the run folder already holds for it (so that a half-done map resumes where it
stopped) and this process's engines and ``sys.path``. The worker computes the map in a folder of its
own with :func:`~rockbench.benchmark.maps.sweep.run_map` (an engine map's cells in a worker process of
its own, :func:`~rockbench.benchmark.maps.executors.make_executor`, so time limits and crash isolation
hold as they do here; a reference map in the task's thread) and returns the folder's files; this
process writes them into the run folder (:func:`write_map`), so the workers need no shared file
system. A map folder is replaced whole by a rename: it holds the map as it was or as the worker
finished it, never half of one. A worker that dies takes with it only the map it was computing, which
Dask gives to another worker; a rerun resumes from the run folder as a local run does.

The calibrations and free-rocking η measurements run as tasks too (:class:`Preparation` with the
client's executor); each worker caches the calibrations it computes where its engine adapters cache
them, so a worker without the cache of the one that computed them computes them again (the same
numbers: they are deterministic).
"""

from __future__ import annotations

import shutil
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from rockbench.reference_solver.errors import EngineUnavailableError
from rockbench.benchmark.maps.executors import NO_WORKER_TIMEOUT_S, make_executor, worker_init
from rockbench.benchmark.maps.grid import MapSpec
from rockbench.benchmark.maps.sweep import run_map
from rockbench.benchmark.suites.preparation import helper_init

#: The folder of the run folder where finished maps from the cluster are put together before they
#: replace their map folder (emptied when a cluster run starts and ends).
STAGING = ".incoming"

#: Files of a map folder that belong to the process writing it, never sent or returned.
_NOT_SENT = frozenset((".lock", ".dask-scratch"))


@dataclass
class MapDone:
    """What a map task returns: the map folder's files, and what the suite records of the map."""

    files: dict
    n_simulated: int
    failures: list
    wall_s: float


def map_files(d: Path) -> dict:
    """The files of map folder ``d`` by name (none when it does not exist)."""
    if not d.is_dir():
        return {}
    return {p.name: p.read_bytes() for p in sorted(d.iterdir()) if p.is_file() and p.name not in _NOT_SENT}


def map_task(spec: MapSpec, files: dict, options: dict, serial: bool, init: dict) -> MapDone:
    """One map on a cluster's worker: resumed from ``files``, computed with ``options``
    (:func:`run_map`'s), returned as its folder's files."""
    helper_init(init["registry"], init["sys_path"])
    with tempfile.TemporaryDirectory(prefix="rockbench-map-") as tmp:
        d = Path(tmp) / "map"
        d.mkdir()
        for name, data in files.items():
            (d / name).write_bytes(data)
        ex = None if serial else make_executor(spec.engine, dict(spec.engine_settings), jobs=1,
                                               log_path=d / "workers.log", threads_per_worker=1)
        try:
            res = run_map(spec, d, jobs=1, serial=serial, executor=ex, **options)
        finally:
            if ex is not None:
                ex.close()
        return MapDone(map_files(d), res.n_simulated, list(res.failures), res.wall_s)


def write_map(d: Path, files: dict, staging: Path) -> None:
    """Put a finished map's ``files`` in map folder ``d``: written whole beside it, then renamed into
    place (a previous, half-done folder is moved aside first and removed after)."""
    staging.mkdir(parents=True, exist_ok=True)
    new = Path(tempfile.mkdtemp(prefix="map-", dir=staging))
    for name, data in files.items():
        (new / name).write_bytes(data)
    old = None
    if d.exists():
        old = new.with_name(new.name + "-old")
        d.rename(old)
    d.parent.mkdir(parents=True, exist_ok=True)
    new.rename(d)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


class ClusterMaps:
    """The suite's maps as tasks: ``run`` is the suite's run (its plan, specs, options, calibrations
    and the record of each map, :meth:`one_map`), ``dask`` a
    :class:`~rockbench.benchmark.maps.executors.DaskConnection`. :meth:`add` submits maps (the
    reference maps at once, the own-η maps when the η are measured); :meth:`run` collects them."""

    def __init__(self, run, dask):
        self.run, self.dask = run, dask
        self.staging = run.out / STAGING
        shutil.rmtree(self.staging, ignore_errors=True)   # what a killed run left half-staged
        self.init = worker_init("", {})
        self.pending: dict = {}    # future → map index
        self.lock = threading.Lock()
        self.all_submitted = threading.Event()
        self.errors: list = []

    def add(self, ks) -> None:
        """Submit maps ``ks`` (indices into the run's plan), in order (Dask runs earlier ones first)."""
        for k in ks:
            job, spec = self.run.todo[k], self.run.specs[k]
            files = map_files(self.run.out / job.subdir)
            fut = self.dask.client.submit(map_task, spec, files, self.run.map_options(job), job.engine == "reference",
                                          self.init, pure=False)
            with self.lock:
                self.pending[fut] = k

    def _then_engine_maps(self, engine_maps) -> None:
        """(A thread.) Wait for the calibrations, submit the own-η reference maps, then the engine maps."""
        try:
            if self.run.prep is not None:
                self.run.own_eta_maps(self)
            self.add(engine_maps)
        except BaseException as e:  # noqa: BLE001 - raised by run() in the main thread
            self.errors.append(e)
        finally:
            self.all_submitted.set()

    def run_all(self, engine_maps: list[int]) -> None:
        """Every map, collected as it finishes and written to the run folder; raises the first error."""
        self.add(k for k, job in enumerate(self.run.todo) if job.engine == "reference")
        helper = threading.Thread(target=self._then_engine_maps, args=(engine_maps,), name="rockbench-cluster",
                                  daemon=True)
        helper.start()
        no_worker_since = time.monotonic()
        try:
            while not (self.all_submitted.is_set() and not self.pending):
                if self.errors:
                    raise self.errors[0]
                with self.lock:
                    done = [(f, self.pending.pop(f)) for f in list(self.pending) if f.done()]
                for fut, k in done:
                    self._collect(fut, k)
                if not done:
                    time.sleep(0.1)
                now = time.monotonic()
                if self.dask.worker_count() or not self.pending:
                    no_worker_since = now
                elif now - no_worker_since > NO_WORKER_TIMEOUT_S:
                    raise EngineUnavailableError(f"the Dask cluster at {self.dask.address!r} has had no worker for "
                                                 f"{NO_WORKER_TIMEOUT_S:g} s; start workers (dask worker ADDRESS) and "
                                                 "rerun to resume.")
            if self.errors:
                raise self.errors[0]
        except BaseException:
            with self.lock:
                for f in self.pending:
                    f.cancel()
            raise
        finally:
            shutil.rmtree(self.staging, ignore_errors=True)

    def _collect(self, fut, k: int) -> None:
        """A finished task: its map written to the run folder and recorded (an engine that cannot
        simulate is recorded so by the run's health check, as in a local run)."""
        d = self.run.out / self.run.todo[k].subdir

        def written() -> MapDone:
            done = fut.result()
            write_map(d, done.files, self.staging)
            return done

        self.run.one_map(k, None, compute=written)
