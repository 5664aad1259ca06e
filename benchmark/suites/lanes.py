"""How a suite's maps run at once: the reference maps on one thread (:class:`ReferenceThread`) and the
engine maps on lanes, one worker process per lane and engine variant (:func:`run_lanes`).
"""

from __future__ import annotations

import json
import queue
import threading
from collections import deque
from pathlib import Path

from rockbench.benchmark.maps import executors as ex_mod
from rockbench.benchmark.suites.plan import MapJob



def _variant_key(job: MapJob):
    return None if job.engine == "reference" else (job.engine, json.dumps(dict(job.settings), sort_keys=True))


class ReferenceThread:
    """The suite's reference maps, computed one after another by one thread while the calibrations
    and the engine maps run (:func:`run_suite`): ``add`` hands it maps, ``close`` says no more will
    come, ``abort`` lets it start no more, ``join`` waits for the last and raises what stopped it."""

    def __init__(self, announce, one_map):
        self.q = queue.Queue()
        self.error: list = []
        self.closed = False
        self.aborted = False

        def work():
            while True:
                k = self.q.get()
                if k is None or self.error or self.aborted:
                    return
                try:
                    announce(k)
                    one_map(k, None)
                except BaseException as e:  # noqa: BLE001 - raised by join() in the main thread
                    self.error.append(e)
                    return

        self.thread = threading.Thread(target=work, name="rockbench-reference", daemon=True)
        self.thread.start()

    def add(self, ks) -> None:
        for k in ks:
            self.q.put(k)

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.q.put(None)

    def abort(self) -> None:
        self.aborted = True
        self.close()

    def failed(self) -> bool:
        return bool(self.error)

    def join(self) -> None:
        while self.thread.is_alive():
            self.thread.join(0.2)
        if self.error:
            raise self.error[0]


def run_lanes(order: list[int], todo: list[MapJob], out: Path, lanes: int, announce, one_map, stop=None) -> None:
    """Run the engine maps ``todo[k]`` for ``k`` in ``order`` on ``lanes`` lanes at once.

    Each lane is a thread that takes the next map from the shared queue and runs it with its own
    worker process for that engine variant (kept for the variant's maps it runs; the workers' stderr
    goes to one workers.log beside the variant's maps). One worker per map and several maps at a
    time keep every core busy: within a map, adaptive refinement waits at the end of each round for
    its last cells, and one worker never waits for another. A lane stops its worker as soon as the
    queue holds no more maps of that variant. When the queue is empty, a lane that finishes lends its
    core to a lane still running a map (that map's executor starts a second worker), so the last
    maps do not run on one core while the other waits. On an interrupt every lane's workers are
    stopped and nothing more is recorded; finished cells stay, and a rerun resumes.
    """
    _Lanes(order, todo, out, lanes, announce, one_map, stop).run()


class _Lanes:
    """:func:`run_lanes`' shared state: the queue of maps, the executors alive and running, the errors."""

    def __init__(self, order, todo, out: Path, lanes: int, announce, one_map, stop):
        self.queue = deque(order)
        self.todo, self.out, self.lanes = todo, out, lanes
        self.announce, self.one_map, self.stop = announce, one_map, stop
        self.lock = threading.Lock()
        self.live: list = []
        self.running: dict = {}   # lane → the executor running its map now
        self.errors: list = []
        self.cores = ex_mod.cpu_count()

    def run(self) -> None:
        if self.lanes <= 1:
            self.lane(0)
        else:
            threads = [threading.Thread(target=self.lane, args=(n,), name=f"rockbench-lane-{n}", daemon=True)
                       for n in range(self.lanes)]
            for t in threads:
                t.start()
            try:
                while any(t.is_alive() for t in threads):
                    for t in threads:
                        t.join(0.2)
            except BaseException:
                # Ctrl-C (delivered to this thread only): stop every lane's workers, record nothing more
                with self.lock:
                    self.queue.clear()
                    for e in list(self.live):
                        if hasattr(e, "cancel"):
                            e.cancel()
                for t in threads:
                    t.join(10.0)
                raise
        if self.errors:
            raise self.errors[0]

    def lend(self, n: int) -> None:
        """Nothing left to start: this lane's core goes to the lane running with the fewest workers
        (its executor starts one more worker for the rest of that map's rounds)."""
        others = [e for m, e in self.running.items() if m != n and isinstance(e, ex_mod.ProcessExecutor)]
        if others:
            e = min(others, key=lambda e: e.jobs)
            e.jobs += 1

    def _next(self, n: int) -> int | None:
        """The next map for lane ``n``, or None when the lane stops (lending its core if all went well)."""
        with self.lock:
            if self.stop is not None and self.stop():
                return None
            if self.errors or not self.queue:
                if not self.errors:
                    self.lend(n)
                return None
            return self.queue.popleft()

    def _executor(self, job: MapJob):
        """A fresh one-worker executor for the job's engine variant."""
        d = self.out / job.subdir
        d.parent.mkdir(parents=True, exist_ok=True)
        ex = ex_mod.make_executor(job.engine, dict(job.settings), jobs=1, log_path=d.parent / "workers.log",
                                  threads_per_worker=max(1, self.cores // self.lanes))
        with self.lock:
            self.live.append(ex)
        return ex

    def _run_one(self, n: int, k: int, ex) -> None:
        with self.lock:
            self.running[n] = ex
        try:
            self.one_map(k, ex)
        finally:
            with self.lock:
                self.running.pop(n, None)

    def lane(self, n: int) -> None:
        key, ex = None, None
        try:
            while (k := self._next(n)) is not None:
                job = self.todo[k]
                self.announce(k)
                if _variant_key(job) != key:
                    if ex is not None:
                        ex.close()
                    key, ex = _variant_key(job), self._executor(job)
                self._run_one(n, k, ex)
                with self.lock:
                    more = any(_variant_key(self.todo[q]) == key for q in self.queue)
                if not more:
                    # a variant's worker stops after its last map, so idle engines do not hold their memory
                    ex.close()
                    key, ex = None, None
        except ex_mod.Cancelled:
            pass
        except BaseException as e:  # noqa: BLE001 - handed to the main thread, which raises it
            with self.lock:
                self.errors.append(e)
            for other in list(self.live):
                if other is not ex and hasattr(other, "cancel"):
                    other.cancel()
        finally:
            if ex is not None:
                ex.close()
