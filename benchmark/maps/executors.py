"""Where a map's cells run: in this process, in local worker processes, or on a Dask cluster.

Every executor takes a list of ``(key, Case)`` and calls ``on_results([(key, CellResult), ...])``
as cells finish; the map is the same cell for cell whichever executor runs it (adapters must not
depend on batching, contract item 6).

- :class:`SerialExecutor`: this process, one batch after another. No time limit and no protection
  from an engine that crashes the process: for debugging and for trusted in-process batches.
- :class:`ProcessExecutor` (the default): ``jobs`` worker processes
  (:mod:`rockbench.benchmark.maps.worker`), kept for the whole map (``rockbench run`` keeps them for
  all the maps of one engine variant), fed chunks of falling size (:func:`_guided_chunks`). A
  cell past its time limit gets its worker killed and is recorded as ``timeout``; a worker that
  does not start its engine within :attr:`ProcessExecutor.START_TIMEOUT_S` is stopped and counts
  as a failed start (three in a row stop the map with the reason); a worker that
  dies (a segfault in the engine) records its current cell as ``crashed``; the other cells of the
  chunk run again on a fresh worker. Batching adapters get whole chunks in one ``run_many``
  call; if such a batch fails, times out or crashes, its cells are rerun one by one so only the
  culprit is recorded as failed.
- :class:`DaskExecutor`: ``--scheduler ADDRESS`` (an existing cluster) or ``local`` (a
  ``LocalCluster`` on 127.0.0.1). Each Dask task runs its chunk in a short-lived worker process
  (a :class:`ProcessExecutor` with one job), so time limits and crash isolation hold there too.

Worker processes get ``NUMBA_NUM_THREADS``/``OMP_NUM_THREADS`` = cores / jobs (unless set), so
``jobs`` processes with natively parallel batches do not oversubscribe the cores. ``jobs`` is capped
at the cores (:func:`cap_jobs`): more processes than cores only add start-up costs.

Worker processes never outlive the process that started them: each one is told its parent's pid
and stops at once when that parent dies (SIGKILL included; see :mod:`rockbench.benchmark.maps.worker`),
and :meth:`ProcessExecutor.close` kills workers that are still busy (an interrupted map) instead
of waiting for their chunk to end.

Every wait on a Dask cluster is bounded: the scheduler must answer a handshake within
:data:`CONNECT_TIMEOUT_S` (a port that accepts connections but is not a Dask scheduler is refused),
and a map whose tasks make no progress for longer than their cells' time limits allow, or that has
no worker for :data:`NO_WORKER_TIMEOUT_S`, stops with the reason. A ``LocalCluster`` keeps its
scratch space in a folder of its own (inside the run directory when the map gives one) and removes
it when closed.
"""

from __future__ import annotations

import asyncio
import atexit
import collections
import itertools
import logging
import math
import os
import pickle
import queue
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Callable
from urllib.parse import urlsplit

from rockbench.engines import registry
from rockbench.engines.contract import CellResult
from rockbench.engines.registry import adapter_class
from rockbench.reference_solver.errors import ConfigError, EngineError, EngineUnavailableError
from rockbench.benchmark.engine_info.adapters import build_adapter
from rockbench.benchmark.maps import worker as wire
from rockbench.benchmark.maps.cost import run_measured
from rockbench.benchmark.maps.cores import cpu_count

#: Seconds to wait for a Dask scheduler before giving up.
CONNECT_TIMEOUT_S = 5.0
#: Seconds a map on a Dask cluster waits with no worker in the cluster before it stops.
NO_WORKER_TIMEOUT_S = 60.0
#: How a worker process is started: this interpreter with -P (Python 3.11+), which keeps the working
#: folder off sys.path. Without it `python -m` puts that folder first, and run from the repository's
#: root the top-level rockbench/ folder (the package's glue alone, its subpackages mapped from other
#: folders) shadows a regular install: "No module named 'rockbench.benchmark'".
WORKER_COMMAND = [sys.executable, "-P", "-m", "rockbench.benchmark.maps.worker"]

#: Name of the folder a LocalCluster keeps its scratch space in (removed when it closes).
DASK_SCRATCH = ".dask-scratch"

_THREAD_VARS = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


class Cancelled(Exception):
    """:meth:`ProcessExecutor.cancel` stopped a run (an interrupt, handled by whoever cancelled it)."""


def worker_init(engine: str, settings: dict) -> dict:
    """What a worker process needs to rebuild the adapter: engine, settings, the registry
    entries added in this process (as ``"module:Class"`` strings) and ``sys.path``."""
    return {"engine": engine, "settings": dict(settings), "registry": registry.registered(),
            "sys_path": [p for p in sys.path if p and os.path.isdir(p)]}


def cap_jobs(jobs: int | None, n_cells: int | None = None) -> tuple[int | None, str | None]:
    """``jobs`` capped at the cores and at the cells that can use them, and a note saying so (None when
    nothing was capped). ``None`` (all cores) stays None."""
    if jobs is None:
        return None, None
    cores = cpu_count()
    limit = cores if n_cells is None else max(1, min(cores, n_cells))
    if jobs <= limit:
        return jobs, None
    why = f"{cores} core{'s' if cores != 1 else ''}" + (f", {n_cells} cell{'s' if n_cells != 1 else ''}"
                                                      if n_cells is not None and n_cells < cores else "")
    return limit, f"--jobs {jobs} capped at {limit} ({why}): more workers would only add start-up time"


def make_executor(engine: str, settings: dict, *, jobs: int | None = None, scheduler: str | None = None,
                  serial: bool = False, log_path=None, scratch_dir=None, threads_per_worker: int | None = None):
    """The executor for the CLI's ``--jobs``/``--scheduler``/``--serial`` choice.

    ``jobs`` is capped at the cores (:func:`cap_jobs`; callers that know the cells cap it there too);
    ``scratch_dir`` is where a ``--scheduler local`` cluster keeps its scratch space (default: a
    temporary folder), removed when the executor closes.

    Raises
    ------
    ConfigError
        ``jobs`` < 1, ``serial`` with a scheduler, or an unreachable scheduler.
    """
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
        raise ConfigError(f"--jobs must be a whole number >= 1, got {jobs!r}.")
    if serial and scheduler:
        raise ConfigError("--serial runs in this process; drop --scheduler (or --serial).")
    jobs, _ = cap_jobs(jobs)
    init = worker_init(engine, settings)
    if serial:
        return SerialExecutor(init)
    if scheduler:
        return DaskExecutor(init, scheduler, jobs=jobs, scratch_dir=scratch_dir)
    if adapter_class(engine).batching == "parallel":
        # the adapter's own batch already uses every core: one call here beats worker processes
        # that would each pay the engine's start-up (for the reference, loading its kernels);
        # --jobs N gives it N threads
        return SerialExecutor(init, kind="in-process batch (the adapter's parallel batching)", threads=jobs)
    return ProcessExecutor(init, jobs=jobs or cpu_count(), log_path=log_path, threads_per_worker=threads_per_worker)


def _chunks(items: list, n_chunks: int, max_size: int | None = None) -> list[list]:
    n_chunks = max(1, min(n_chunks, len(items)))
    size = math.ceil(len(items) / n_chunks)
    if max_size:
        size = max(1, min(size, max_size))
    return [items[k:k + size] for k in range(0, len(items), size)]


def _guided_chunks(items: list, jobs: int, max_size: int | None = None) -> list[list]:
    """``items`` cut into chunks of falling size (guided self-scheduling): each chunk is a
    ``1/(2·jobs)`` share of what is left (at most ``max_size``, at least one item). Handed out in
    order to whichever worker is free, the big chunks keep the per-chunk overhead low and the
    single cells at the end leave no worker idle for long while another finishes a big chunk."""
    out, k, n = [], 0, len(items)
    while k < n:
        size = max(1, math.ceil((n - k) / (2 * max(1, jobs))))
        if max_size:
            size = min(size, max_size)
        out.append(items[k:k + size])
        k += size
    return out


def _run_in_process(adapter, items, batch: bool) -> list:
    """Run ``items`` with ``adapter`` here; a failing batch falls back to one cell at a time."""
    if batch:
        try:
            rs = run_measured(adapter, [c for _, c in items])
            return [(k, wire.without_diagnostics(r)) for (k, _), r in zip(items, rs)]
        except Exception:  # noqa: BLE001 - find the culprit cell by cell
            pass
    out = []
    for k, c in items:
        t0 = time.perf_counter()
        try:
            r = run_measured(adapter, [c])[0]
        except Exception as e:  # noqa: BLE001 - recorded per cell, the map goes on
            r = CellResult.failed("engine-error", f"{type(e).__name__}: {e}", time.perf_counter() - t0)
        out.append((k, wire.without_diagnostics(r)))
    return out


class SerialExecutor:
    """Cells in this process (whole batches for batching adapters: one ``run_many`` per round)."""

    def __init__(self, init: dict, kind: str = "serial", threads: int | None = None):
        self.init = init
        self.kind = kind
        self.adapter = build_adapter(init["engine"], **init["settings"])
        self.log_path = None
        self.n_threads = threads
        self.parallel = self.adapter.batching == "parallel"

    def describe(self) -> dict:
        d = {"kind": self.kind, "jobs": 1}
        if self.n_threads is not None:
            d["threads"] = self.n_threads
        return d

    def threads(self) -> "_NumbaThreads":
        """A context in which a parallel batch in this process runs on the executor's threads
        (``threads``, default: every core this process may use)."""
        return _NumbaThreads(self.n_threads)

    #: largest native batch per call: big enough that a whole 100×100 map is one call, small
    #: enough that a 200×200 map reaches cells.csv (and the progress bar) in four steps, so a
    #: killed run keeps most of its work
    MAX_BATCH = 10_000

    def run(self, items, on_results, *, cell_timeout_s: float, batch: bool) -> None:
        if not items:
            return
        # an adapter whose batch gains from size (worlds on a GPU) may ask for more per call
        size = max(self.MAX_BATCH, int(getattr(type(self.adapter), "max_batch", 0))) if batch else 64
        for chunk in _chunks(items, math.ceil(len(items) / size)):
            if self.parallel:
                with self.threads():
                    res = _run_in_process(self.adapter, chunk, batch)
            else:
                res = _run_in_process(self.adapter, chunk, batch)
            on_results(res)

    def close(self) -> None:
        pass


class _NumbaThreads:
    """Inside it numba's parallel kernels use ``n`` threads (default: ``NUMBA_NUM_THREADS`` if set,
    else the cores this process may run on, which numba's own default, the machine's core count,
    ignores); outside, what was set before."""

    def __init__(self, n: int | None):
        self.n = n
        self.old = None

    def __enter__(self):
        nb = sys.modules.get("numba")
        if nb is None:
            import numba as nb  # numba on first use (start-up time)
        want = self.n if self.n is not None else int(os.environ.get("NUMBA_NUM_THREADS") or cpu_count())
        want = max(1, min(int(want), nb.config.NUMBA_NUM_THREADS))
        self.old = nb.get_num_threads()
        if want != self.old:
            nb.set_num_threads(want)
        return self

    def __exit__(self, *exc):
        import numba as nb  # numba on first use (start-up time)
        if self.old is not None and nb.get_num_threads() != self.old:
            nb.set_num_threads(self.old)
        return False


class _Chunk:
    _ids = itertools.count()

    def __init__(self, items, batch: bool):
        self.id = next(self._ids)
        self.items = list(items)
        self.batch = batch
        self.remaining = dict(self.items)
        self.deaths = 0      # workers lost on this chunk before they started one of its cells


class _Worker:
    def __init__(self, init: dict, env: dict, log, q: queue.Queue):
        # WORKER_COMMAND's -P: run from the repository's root, the top-level rockbench/ folder
        # would otherwise shadow a regular install in the worker
        self.proc = subprocess.Popen(WORKER_COMMAND, stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=log if log is not None else subprocess.DEVNULL,
                                     env=env)
        self.ready = False
        self.chunk: _Chunk | None = None
        self.current = None          # key of the cell running (per-cell mode)
        self.deadline = math.inf
        self.killed: str | None = None
        self.dead = False
        self.init_error: str | None = None
        self.spawned = time.monotonic()
        wire.send(self.proc.stdin, ("init", init))
        threading.Thread(target=self._read, args=(q,), daemon=True).start()

    def _read(self, q):
        out = self.proc.stdout
        while True:
            try:
                msg = wire.recv(out)
            except Exception:  # noqa: BLE001 - a torn message means the process died mid-write
                msg = None
            if msg is None:
                q.put((self, ("eof",)))
                return
            q.put((self, msg))

    def give(self, chunk: _Chunk, cell_timeout_s: float) -> None:
        self.chunk = chunk
        self.current = None
        items = [(k, chunk.remaining[k]) for k, _ in chunk.items if k in chunk.remaining]
        # a batch has the time of all its cells; one cell at a time, each "start" renews the
        # limit, and until the first one comes the worker has one cell's time to get there
        self.deadline = time.monotonic() + cell_timeout_s * (len(items) if chunk.batch else 1)
        wire.send(self.proc.stdin, ("chunk", chunk.id, items, chunk.batch))

    def kill(self, why: str) -> None:
        if self.killed is None:
            self.killed = why
            try:
                self.proc.kill()
            except OSError:
                pass

    def stop(self) -> None:
        """End the process: an idle worker is asked to stop, a busy one (an interrupted map) is killed
        at once rather than waited for until its chunk ends."""
        if self.chunk is not None or not self.ready:
            self.kill("stopped")
            self.proc.wait()
            return
        try:
            if self.proc.poll() is None:
                wire.send(self.proc.stdin, ("stop",))
                self.proc.stdin.close()
                self.proc.wait(timeout=5)
        except (OSError, ValueError, subprocess.TimeoutExpired):
            self.proc.kill()
            self.proc.wait()


def _death_reason(code: int | None) -> str:
    if code is not None and code < 0:
        try:
            return f"the worker process died with signal {signal.Signals(-code).name}"
        except ValueError:
            return f"the worker process died with signal {-code}"
    return f"the worker process exited with code {code}"


@dataclass
class _RunState:
    """What one :meth:`ProcessExecutor.run` tracks: chunks not yet given out, chunks being worked on."""

    pending: collections.deque
    on_results: Callable
    cell_timeout_s: float
    busy: int = 0


class ProcessExecutor:
    """``jobs`` worker processes; time limits and crash isolation per cell (module docstring)."""

    #: how many times in a row a fresh worker may fail to start before the map stops
    MAX_START_FAILURES = 3
    #: seconds a fresh worker may take to import and set up its engine before it is stopped
    START_TIMEOUT_S = 120.0

    def __init__(self, init: dict, jobs: int, log_path=None, threads_per_worker: int | None = None):
        self.init = init
        self.jobs = max(1, int(jobs))
        self.log_path = log_path
        self._log = None
        self.workers: list[_Worker] = []
        self.q: queue.Queue = queue.Queue()
        tpw = threads_per_worker or max(1, cpu_count() // self.jobs)
        self.env = dict(os.environ)
        for v in _THREAD_VARS:
            self.env.setdefault(v, str(tpw))
        self.env[wire.PARENT_ENV] = str(os.getpid())   # the worker stops when this process dies
        self._start_failures = 0
        self._cancelled = False

    def describe(self) -> dict:
        """run.json's ``options.executor``: the worker processes and each one's threads (the thread
        variables it was given, :data:`_THREAD_VARS`)."""
        threads = str(self.env.get(_THREAD_VARS[0], ""))
        return {"kind": "processes", "jobs": self.jobs, "threads_per_worker": int(threads) if threads.isdigit() else threads}

    def cancel(self) -> None:
        """Stop a :meth:`run` in progress from another thread: its workers are killed, nothing more
        is recorded, and :meth:`run` raises :class:`Cancelled` (within its 50 ms poll)."""
        self._cancelled = True
        for w in list(self.workers):
            w.kill("cancelled")

    def _spawn(self) -> _Worker:
        if self._log is None and self.log_path is not None:
            self._log = open(Path(self.log_path), "ab")
        w = _Worker(self.init, self.env, self._log, self.q)
        self.workers.append(w)
        return w

    def run(self, items, on_results: Callable, *, cell_timeout_s: float, batch: bool) -> None:
        if not items:
            return
        self._drop_stale_workers()
        chunks = [_Chunk(c, batch) for c in _guided_chunks(items, self.jobs, None if batch else 64)]
        st = _RunState(collections.deque(chunks), on_results, cell_timeout_s)
        while len(self.workers) < min(self.jobs, len(st.pending)):
            self._spawn()
        while st.pending or st.busy:
            if self._cancelled:
                raise Cancelled("the run was cancelled")
            self._hand_out(st)
            try:
                w, msg = self.q.get(timeout=0.05)
            except queue.Empty:
                msg = None
            if msg is not None:
                handler = self._HANDLERS.get(msg[0])
                if handler is not None:
                    handler(self, st, w, msg)
            self._enforce_time_limits()
            self._top_up(st)

    def _drop_stale_workers(self) -> None:
        for w in list(self.workers):
            if w.chunk is not None:   # left busy by an earlier run that raised: start clean
                w.kill("stale")
                w.proc.wait()
                w.dead = True
                self.workers.remove(w)

    def _hand_out(self, st: "_RunState") -> None:
        for w in self.workers:
            if w.ready and w.chunk is None and not w.dead and st.pending:
                w.give(st.pending.popleft(), st.cell_timeout_s)
                st.busy += 1

    def _enforce_time_limits(self) -> None:
        now = time.monotonic()
        for w in self.workers:
            if w.dead:
                continue
            if not w.ready and now > w.spawned + self.START_TIMEOUT_S:
                w.kill("start-timeout")
            elif w.chunk is not None and now > w.deadline:
                w.kill("timeout")

    def _top_up(self, st: "_RunState") -> None:
        """Replace dead workers while work is left, up to ``jobs``."""
        alive = sum(not w.dead for w in self.workers)
        if st.pending and (alive == 0 or alive < min(self.jobs, len(st.pending) + st.busy)):
            self._spawn()

    # -- one handler per message a worker sends (worker.py) --
    def _on_ready(self, st, w, msg) -> None:
        w.ready = True
        self._start_failures = 0

    def _on_init_error(self, st, w, msg) -> None:
        w.init_error = msg[1]

    def _on_start(self, st, w, msg) -> None:
        w.current = msg[1]
        w.deadline = time.monotonic() + st.cell_timeout_s

    def _on_result(self, st, w, msg) -> None:
        self._deliver(w.chunk, [(msg[1], msg[2])], st.on_results)
        w.current = None
        w.deadline = time.monotonic() + st.cell_timeout_s   # until the next "start"

    def _on_results(self, st, w, msg) -> None:
        self._deliver(w.chunk, msg[2], st.on_results)

    def _on_batch_failed(self, st, w, msg) -> None:
        st.pending.appendleft(_Chunk(list(w.chunk.remaining.items()), False))
        w.chunk.remaining.clear()

    def _on_done(self, st, w, msg) -> None:
        w.chunk, w.current, w.deadline = None, None, math.inf
        st.busy -= 1

    def _on_eof(self, st, w, msg) -> None:
        st.busy -= self._bury(w, st.pending, st.on_results)

    _HANDLERS = {"ready": _on_ready, "init-error": _on_init_error, "start": _on_start, "result": _on_result,
                 "results": _on_results, "batch-failed": _on_batch_failed, "done": _on_done, "eof": _on_eof}

    def _deliver(self, chunk: _Chunk | None, pairs, on_results) -> None:
        if chunk is None or self._cancelled:
            return
        fresh = [(k, r) for k, r in pairs if chunk.remaining.pop(k, None) is not None]
        if fresh:
            on_results(fresh)

    def _bury(self, w: _Worker, pending, on_results) -> int:
        """Handle a worker whose output ended; returns 1 if it held a chunk (no longer busy)."""
        if self._cancelled:
            raise Cancelled("the run was cancelled")
        w.dead = True
        try:
            code = w.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            w.proc.kill()
            code = w.proc.wait()
        self.workers.remove(w)
        if not w.ready:
            self._start_failures += 1
            if w.init_error:
                if w.init_error.startswith(("ConfigError", "EngineUnavailableError")):
                    err = EngineUnavailableError if w.init_error.startswith("EngineUnavailable") else ConfigError
                    raise err(w.init_error.split(": ", 1)[-1])
                raise EngineError(f"a worker could not start the engine {self.init['engine']!r}: {w.init_error}")
            if self._start_failures >= self.MAX_START_FAILURES:
                why = (f"did not start within {self.START_TIMEOUT_S:g} s" if w.killed == "start-timeout"
                       else _death_reason(code))
                raise EngineError(f"worker processes for engine {self.init['engine']!r} keep dying at start "
                                  f"({why}); see {self.log_path or 'their stderr'}.")
            return 0
        chunk = w.chunk
        if chunk is None:
            return 0
        if w.current is not None and w.current in chunk.remaining and not chunk.batch:
            key = w.current
            if w.killed == "timeout":
                r = CellResult.failed("timeout", "the cell ran past the per-cell time limit and was stopped")
            else:
                r = CellResult.failed("crashed", _death_reason(code))
            self._deliver(chunk, [(key, r)], on_results)
        elif not chunk.batch and chunk.remaining:
            # died between cells (unpickling, engine teardown...): after three such deaths the
            # next cell is blamed, so a worker that always dies cannot stall the map
            chunk.deaths += 1
            if chunk.deaths >= 3:
                key = next(iter(chunk.remaining))
                why = ("the worker was stopped at the time limit" if w.killed == "timeout" else _death_reason(code))
                self._deliver(chunk, [(key, CellResult.failed("crashed", why + " three times before this cell "
                                                              "started"))], on_results)
        if chunk.remaining:
            # the rest of the chunk (all of it for a batch) runs again, one cell at a time
            rest = _Chunk(list(chunk.remaining.items()), False)
            rest.deaths = chunk.deaths if not chunk.batch else 0
            pending.appendleft(rest)
        return 1

    def close(self) -> None:
        for w in list(self.workers):
            w.stop()
        self.workers.clear()
        if self._log is not None:
            self._log.close()
            self._log = None


_DASK_POOLS: dict = {}
_DASK_LOCK = threading.Lock()


def _dask_pool(init: dict) -> ProcessExecutor:
    """The worker process this Dask worker thread keeps for one engine (started on first use).

    Kept across tasks so the engine's start-up is paid once per Dask worker, not once per chunk;
    it dies with the Dask worker (its stdin closes) or is replaced when it crashes.
    """
    key = (pickle.dumps(sorted(init.items())), threading.get_ident())
    with _DASK_LOCK:
        ex = _DASK_POOLS.get(key)
        if ex is None:
            ex = _DASK_POOLS[key] = ProcessExecutor(init, jobs=1, threads_per_worker=1)
            if len(_DASK_POOLS) == 1:
                atexit.register(lambda: [p.close() for p in _DASK_POOLS.values()])
    return ex


def _dask_task(init: dict, items: list, batch: bool, cell_timeout_s: float) -> list:
    """One Dask task: run a chunk in this Dask worker's own worker process (time limits and crash
    isolation as in :class:`ProcessExecutor`)."""
    out: list = []
    _dask_pool(init).run(items, out.extend, cell_timeout_s=cell_timeout_s, batch=batch)
    return out


class DaskConnection:
    """A client of a Dask cluster (``address``), or of a LocalCluster on loopback that it starts
    (``"local"``, ``jobs`` workers of one thread each, default two or the cores if fewer), checked
    within :data:`CONNECT_TIMEOUT_S`; ``scratch_dir`` is where a local cluster keeps its scratch space
    (default: a temporary folder), removed by :meth:`close`. :class:`DaskExecutor` runs a map's chunks
    through one; ``rockbench run --scheduler`` runs a suite's maps through one.

    Raises
    ------
    ConfigError
        A malformed address, or no Dask scheduler at it.
    """

    def __init__(self, address: str, jobs: int | None = None, scratch_dir=None):
        try:
            from dask.distributed import Client  # Dask only with --scheduler (start-up time)
        except ImportError as e:  # pragma: no cover - a declared dependency
            raise EngineUnavailableError(f"--scheduler needs dask[distributed] ({e}); pip install 'dask[distributed]'.")
        self.address = address
        self.cluster = None
        self.client = None
        self.scratch = None
        if address == "local":
            self._start_local(jobs, scratch_dir)
        else:
            if "://" not in address and ":" not in address:
                raise ConfigError(f"--scheduler takes a Dask scheduler address such as tcp://host:8786 or 'local', "
                                  f"got {address!r}.")
            _probe(address)
            _handshake(address)
            try:
                self.client = Client(address, timeout=CONNECT_TIMEOUT_S)
            except Exception as e:  # noqa: BLE001 - any failure to connect is the user's address
                msg = " ".join(str(e).split())[:200]
                raise ConfigError(f"cannot reach the Dask scheduler at {address!r} within {CONNECT_TIMEOUT_S:g} s "
                                  f"({type(e).__name__}: {msg}); start it (dask scheduler) or use --scheduler "
                                  "local.") from None

    def _start_local(self, jobs: int | None, scratch_dir) -> None:
        import dask  # Dask only with --scheduler (start-up time)
        from dask.distributed import Client, LocalCluster  # Dask only with --scheduler (start-up time)
        n = jobs or min(cpu_count(), 2) or 1
        if scratch_dir is not None:
            Path(scratch_dir).mkdir(parents=True, exist_ok=True)
            self.scratch = Path(scratch_dir)
        else:
            self.scratch = Path(tempfile.mkdtemp(prefix="rockbench-dask-"))
        try:
            # the scheduler (in this process) takes its scratch folder from the configuration, the
            # workers from local_directory: both go to ours, removed by close()
            with dask.config.set({"temporary-directory": str(self.scratch)}):
                self.cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                            dashboard_address=":0", silence_logs=logging.ERROR,
                                            local_directory=str(self.scratch))
            self.client = Client(self.cluster, timeout=CONNECT_TIMEOUT_S)
        except BaseException:
            self.close()
            raise

    def worker_count(self) -> int:
        """The workers in the cluster, as the client last heard (it refreshes this in the background
        every few seconds: ``scheduler_info()`` would ask the scheduler and wait without a limit)."""
        info = getattr(self.client, "_scheduler_identity", None) or {}
        # recent Dask sends the count (``n_workers``) and no longer every worker's entry
        return int(info.get("n_workers", len(info.get("workers") or {})))

    def close(self) -> None:
        try:
            if self.client is not None:
                self.client.close(timeout=CONNECT_TIMEOUT_S)
        except Exception:  # noqa: BLE001 - closing a broken connection must not hide the first error
            pass
        finally:
            try:
                if self.cluster is not None:
                    self.cluster.close(timeout=2 * CONNECT_TIMEOUT_S)
            finally:
                if self.scratch is not None:
                    shutil.rmtree(self.scratch, ignore_errors=True)
                    self.scratch = None


class DaskExecutor:
    """Chunks as Dask tasks on a cluster (``address``) or on a LocalCluster on loopback (``"local"``)."""

    def __init__(self, init: dict, address: str, jobs: int | None = None, scratch_dir=None):
        self.init = init
        self.address = address
        self.log_path = None
        self.dask = DaskConnection(address, jobs=jobs, scratch_dir=scratch_dir)
        self.client = self.dask.client
        self.n_workers = max(1, self._worker_count() or (jobs or 1))

    def _worker_count(self) -> int:
        return self.dask.worker_count()

    def describe(self) -> dict:
        return {"kind": "dask", "scheduler": self.address, "workers": self.n_workers}

    def run(self, items, on_results, *, cell_timeout_s: float, batch: bool) -> None:
        if not items:
            return
        chunks = _chunks(items, 4 * self.n_workers, None if batch else 256)
        futs = [self.client.submit(_dask_task, self.init, c, batch, cell_timeout_s, pure=False) for c in chunks]
        # Every wait is bounded: a task holds at most its cells' time limits plus a worker's start, so
        # with no result for longer than the biggest task may take, the cluster is stuck (or gone).
        stall_s = max(len(c) for c in chunks) * cell_timeout_s + ProcessExecutor.START_TIMEOUT_S + 30.0
        pending = set(futs)
        last = no_worker_since = time.monotonic()
        try:
            while pending:
                done = [f for f in futs if f in pending and f.done()]   # a local look, never a wait
                now = time.monotonic()
                for fut in done:
                    pending.discard(fut)
                    on_results(fut.result(timeout=CONNECT_TIMEOUT_S))
                    last = now
                if not pending:
                    break
                if not done:
                    time.sleep(0.1)
                if self._worker_count():
                    no_worker_since = now
                elif now - no_worker_since > NO_WORKER_TIMEOUT_S:
                    raise EngineUnavailableError(f"the Dask cluster at {self.address!r} has had no worker for "
                                      f"{NO_WORKER_TIMEOUT_S:g} s; start workers (dask worker ADDRESS) and rerun "
                                      "to resume.")
                if now - last > stall_s:
                    raise EngineUnavailableError(f"no result from the Dask cluster at {self.address!r} for {stall_s:g} s, longer "
                                      "than any task may take; check its workers and rerun to resume.")
        finally:
            for f in futs:
                f.cancel()

    def close(self) -> None:
        self.dask.close()


def _handshake(address: str) -> None:
    """Fail within :data:`CONNECT_TIMEOUT_S` unless a Dask scheduler answers at ``address`` (Dask's own
    connect waits for the peer's handshake without a limit, so a port that accepts connections but
    speaks another protocol would hang it)."""
    async def ask():
        from distributed.comm import connect  # Dask only with --scheduler (start-up time)
        comm = await connect(address, timeout=CONNECT_TIMEOUT_S)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    def probe():   # in a thread of its own: the caller may be inside an event loop (a notebook)
        return asyncio.run(asyncio.wait_for(ask(), CONNECT_TIMEOUT_S))

    try:
        with ThreadPoolExecutor(1) as pool:
            ident = pool.submit(probe).result()
    except (asyncio.TimeoutError, TimeoutError):
        ident = None
        why = f"nothing answered the Dask handshake within {CONNECT_TIMEOUT_S:g} s"
    except Exception as e:  # noqa: BLE001 - anything the peer does wrong is the address's fault
        ident = None
        why = f"{type(e).__name__}: {' '.join(str(e).split())[:160]}"
    else:
        why = f"it answered as {ident.get('type')!r}" if isinstance(ident, dict) else "it answered something else"
    if not (isinstance(ident, dict) and ident.get("type") == "Scheduler"):
        raise ConfigError(f"{address!r} is not a Dask scheduler ({why}); give the scheduler's address "
                          "(tcp://host:8786) or use --scheduler local.")


def _probe(address: str) -> None:
    """Fail at once (not after Dask's retries) when nothing listens at a tcp:// address."""
    u = urlsplit(address if "://" in address else "tcp://" + address)
    try:
        port = u.port
    except ValueError:
        raise ConfigError(f"--scheduler {address!r}: the port must be a number from 1 to 65535; e.g. "
                          "tcp://127.0.0.1:8786.") from None
    if u.scheme not in ("tcp", "tls") or not u.hostname or port is None:
        return   # other transports (inproc, ucx, ws) are left to Dask
    try:
        socket.create_connection((u.hostname, u.port), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as e:
        raise ConfigError(f"cannot reach the Dask scheduler at {address!r} ({e.strerror or e}); start it "
                          "(dask scheduler) or use --scheduler local.") from None
