"""The quick suite on a real Dask cluster on this machine against the local run: the same maps and
score.json, and what each costs. Measures and records; exits 1 if a run differs from the local one.

    python tests/measurements/bench_suite_cluster.py [--workers 1 2] [--together] [--kill]
        [--local RUN_DIR] [--record NAME] [--no-record]

Runs ``rockbench run --quick --no-report`` locally (its lanes) and then, for each ``--workers`` N, on a
cluster of a ``dask scheduler`` and N one-thread ``dask worker`` processes on 127.0.0.1
(tests/dask_cluster.py: the cluster tests/test_suite_dask.py checks), each run with an empty
calibration cache of its own (the cluster's client and workers share it, as on one machine). Every
cluster run's maps are compared with the local run's cell for cell (timing columns aside) and its
score.json with the local one (timestamp aside). ``--together`` runs them all at once (on a loaded
machine: their CPU counts apart, their walls are then not comparable); ``--local`` compares with an
earlier local run's output folder instead of running one.

Per run: wall time and CPU time of every process. The client's (``rockbench run`` and every process it
waited for) comes from ``wait4`` on it; the scheduler's and the workers' (each ``dask worker``, its
worker process and the engine processes it waited for) from their process
trees just before the cluster is torn down (psutil: each live process's own CPU plus that of the
children it reaped), less what the same trees had spent when the workers were ready (start-up, kept
apart). The scheduler's task stream gives each task's kind, start and end: ``prepare_remote`` (a
calibration and free-rocking η of an engine variant on a block) or ``map_task`` (a map); its CPU is
its worker's meanwhile (each worker's tree sampled every 0.25 s: one thread a worker, so one task at
a time, its engine process included, and the worker's own background);
tests/measurements/bench_lanes_replay.py replays it on more cores.

``--kill`` then runs the worker-death path once on a cluster of 2 workers: when the first engine map
is finished, a worker busy with a task is killed (SIGKILL, its session with it); the maps finished before
are checked intact, a worker is added and the suite rerun into the same folder, which must resume and
end equal to the local run.

The figures go to the record ``tests/measurements/results/suite-cluster-quick.json`` (``--record``: another
name), written after the runs and again after the worker death.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import psutil

sys.path.insert(0, str(Path(__file__).resolve().parent))          # records.py beside this script
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))   # tests/: the cluster of tests/test_suite_dask.py
from records import write_record  # noqa: E402
from dask_cluster import Cluster, differences, finished, kill, maps, run_command, start, suite_env  # noqa: E402

RECORD = "suite-cluster-quick"
MEASURES = ("The quick suite (`rockbench run --quick --no-report`) locally and on a real Dask cluster of 1 and 2 "
            "one-thread `dask worker` processes on 127.0.0.1 (with a `dask scheduler`), each run from an empty "
            "calibration cache: wall and CPU time of every process (client, scheduler, workers and their "
            "children), each task's compute time by kind, and whether maps and score.json equal the local run's.")
#: bound of one run's wait [s]
RUN_S = 3600
#: how often each worker's CPU is sampled during a cluster run [s]
SAMPLE_S = 0.25


def tree_cpu_s(pid: int) -> float:
    """CPU [s] of process ``pid`` and its live descendants, each with the children it reaped."""
    try:
        root = psutil.Process(pid)
        procs = [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return 0.0
    total = 0.0
    for p in procs:
        try:
            t = p.cpu_times()
        except psutil.NoSuchProcess:
            continue
        total += t.user + t.system + t.children_user + t.children_system
    return total


def run_client(out: Path, env: dict, more: list[str], log: Path) -> dict:
    """``rockbench run --quick`` into ``out``: its exit code, wall and CPU (with every process it waited for)."""
    t0 = time.perf_counter()
    p = start(run_command("--quick", out, more), env, log)
    _, status, usage = os.wait4(p.pid, 0)   # this child's CPU with that of every process it waited for
    p.returncode = os.waitstatus_to_exitcode(status)
    return {"returncode": p.returncode, "wall_s": round(time.perf_counter() - t0, 1),
            "client_cpu_s": round(usage.ru_utime + usage.ru_stime, 1)}


class WorkerCpu:
    """(A thread.) Each worker's process tree's CPU [s], sampled every :data:`SAMPLE_S` against time since
    ``since_s`` (epoch seconds); :meth:`between` reads it off by linear interpolation."""

    def __init__(self, pids: list[int], since_s: float):
        self.pids, self.since_s, self.samples = pids, since_s, [[] for _ in pids]
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._sample, daemon=True)
        self.thread.start()

    def _sample(self) -> None:
        while not self.done.wait(SAMPLE_S):
            for n, pid in enumerate(self.pids):
                self.samples[n].append((time.time() - self.since_s, tree_cpu_s(pid)))

    def stop(self) -> None:
        self.done.set()
        self.thread.join()

    def between(self, n: int, t0_s: float, t1_s: float) -> float:
        """CPU [s] of worker ``n``'s tree from ``t0_s`` to ``t1_s`` (seconds since ``since_s``)."""
        t, cpu = np.array(self.samples[n]).T
        return float(np.interp(t1_s, t, cpu) - np.interp(t0_s, t, cpu))


def task_costs(address: str, since_s: float, numbers: dict, cpu: WorkerCpu) -> dict:
    """The tasks of the scheduler's task stream (begun just before the run), by kind: count, total compute
    time and the CPU of their workers meanwhile [s]; and ``stream``: each task's kind, compute start and end
    [s after ``since_s``, epoch seconds], worker (its number, ``numbers``: by address) and that worker's CPU
    from start to end (its tree: the task's engine process included), in order of start."""
    from dask.distributed import Client
    from dask.utils import key_split
    with Client(address, timeout=60) as c:
        messages = c.get_task_stream()   # the stream began (start_task_stream) on this fresh cluster just before the run
    stream = []
    for msg in messages:
        for s in msg.get("startstops", ()):
            if s.get("action") == "compute":
                w, t0, t1 = numbers.get(msg.get("worker"), -1), s["start"] - since_s, s["stop"] - since_s
                stream.append([key_split(msg["key"]), round(t0, 2), round(t1, 2), w,
                               round(cpu.between(w, t0, t1), 2) if w >= 0 else None])
    stream.sort(key=lambda t: t[1])
    kinds: dict = {}
    for kind, t0, t1, _, cpu_s in stream:
        k = kinds.setdefault(kind, {"n": 0, "compute_s": 0.0, "cpu_s": 0.0})
        k["n"] += 1
        k["compute_s"] = round(k["compute_s"] + t1 - t0, 2)
        k["cpu_s"] = round(k["cpu_s"] + (cpu_s or 0.0), 2)
    return {"by_kind": kinds, "stream": stream}


def start_task_stream(address: str) -> None:
    """Have the scheduler record its task stream from now on (its plugin is added on first request)."""
    from dask.distributed import Client
    with Client(address, timeout=60) as c:
        c.get_task_stream(count=1)


def cluster_run(tmp: Path, n_workers: int, local: Path, compare: bool = True) -> dict:
    """The quick suite on a fresh cluster of ``n_workers``: costs and the comparison with ``local``."""
    tmp.mkdir(parents=True)
    env = suite_env(tmp / "cache")
    cluster = Cluster(tmp, env)
    try:
        for _ in range(n_workers):
            cluster.add_worker()
        cluster.wait_for(n_workers)
        start_task_stream(cluster.address)
        pids = {"scheduler": cluster.scheduler.pid, "workers": [w.pid for w in cluster.workers]}
        startup = {"scheduler": tree_cpu_s(pids["scheduler"]), "workers": sum(map(tree_cpu_s, pids["workers"]))}
        since = time.time()
        cpu = WorkerCpu(pids["workers"], since)
        r = run_client(tmp / "out", env, ["--scheduler", cluster.address], tmp / "client.log")
        end = {"scheduler": tree_cpu_s(pids["scheduler"]), "workers": sum(map(tree_cpu_s, pids["workers"]))}
        cpu.stop()
        r["tasks"] = task_costs(cluster.address, since, cluster.numbers(), cpu)
    finally:
        cluster.close()
    r["scheduler_cpu_s"] = round(end["scheduler"] - startup["scheduler"], 1)
    r["workers_cpu_s"] = round(end["workers"] - startup["workers"], 1)
    r["cpu_s"] = round(r["client_cpu_s"] + r["scheduler_cpu_s"] + r["workers_cpu_s"], 1)
    r["startup_cpu_s"] = {k: round(v, 1) for k, v in startup.items()}
    return {**r, **_compare(local, tmp / "out")} if compare else r


def _compare(local: Path, out: Path) -> dict:
    diff = differences(local, out) if (out / "score.json").exists() else ["score.json missing"]
    return {"n_maps": len(maps(out)), "same_as_local": not diff, "differences": diff[:20]}


def worker_death(tmp: Path, local: Path) -> dict:
    """Kill a busy worker of 2 mid-suite, then rerun into the same folder (see the module docstring)."""
    tmp.mkdir(parents=True)
    env = suite_env(tmp / "cache")
    out = tmp / "out"
    cluster = Cluster(tmp, env)
    try:
        cluster.add_worker()
        cluster.add_worker()
        cluster.wait_for(2)
        t0 = time.perf_counter()
        run = start(run_command("--quick", out, ["--scheduler", cluster.address]), env, tmp / "killed.log")
        try:
            while not _an_engine_map(before := finished(out)) and run.poll() is None:
                if time.perf_counter() - t0 > RUN_S:
                    break
                time.sleep(0.2)
            busy = cluster.busy_worker(run, RUN_S)
            if busy is None:
                return {"killed": False, "why": "the suite ended before a busy worker could be killed"}
            killed_at_s, running = time.perf_counter() - t0, _running_on(cluster, busy)
            kill(busy)
            code = run.wait(timeout=RUN_S)
        finally:
            kill(run)
        intact = all((d / "cells.csv").read_bytes() == cells for d, cells in before.items())
        n_after_kill = len(finished(out))
        cluster.add_worker()
        cluster.wait_for(2)
        rerun = run_client(out, env, ["--scheduler", cluster.address], tmp / "rerun.log")
    finally:
        cluster.close()
    return {"killed": True, "killed_after_s": round(killed_at_s, 1), "killed_worker_was_running": running,
            "maps_finished_before_kill": len(before),
            "finished_maps_intact": intact, "killed_run_returncode": code, "maps_finished_after_killed_run": n_after_kill,
            "rerun": rerun, **_compare(local, out)}


def _an_engine_map(done: dict) -> bool:
    """Whether the finished maps (:func:`finished`) include an engine's (its variant's folder not the reference's)."""
    return any(not d.parent.name.startswith("reference") for d in done)


def _running_on(cluster: Cluster, worker) -> list[str]:
    """The kinds of the tasks the scheduler has ``worker`` (one of ``cluster.workers``) running now."""
    from dask.distributed import Client
    from dask.utils import key_split
    address = next((a for a, n in cluster.numbers().items() if cluster.workers[n] is worker), None)
    with Client(cluster.address, timeout=60) as c:
        return sorted(key_split(k) for k in c.processing().get(address, ()))


def local_run(tmp: Path) -> dict:
    """The quick suite on this machine's lanes."""
    tmp.mkdir(parents=True)
    r = {"run": "local lanes", **run_client(tmp / "out", suite_env(tmp / "cache"), [], tmp / "client.log")}
    r["cpu_s"], r["n_maps"] = r["client_cpu_s"], len(maps(tmp / "out"))
    return r


def measure_runs(tmp: Path, workers: list[int], together: bool, local_out: Path | None) -> list[dict]:
    """The local run (unless ``local_out``, an earlier local run's folder, stands in for it) and a
    cluster run per entry of ``workers``, one after another or all at once."""
    local = local_out or tmp / "local" / "out"
    jobs = [lambda: local_run(local.parent)] if local_out is None else []
    jobs += [lambda n=n: {"run": f"cluster, {n} worker{'s' if n > 1 else ''}", "workers": n,
                          **cluster_run(tmp / f"cluster{n}", n, local, compare=not together)} for n in workers]
    if together:
        with ThreadPoolExecutor(len(jobs)) as pool:
            runs = list(pool.map(lambda job: job(), jobs))
        for r in runs:   # compared once the local run has ended
            if "workers" in r:
                r.update(_compare(local, tmp / f"cluster{r['workers']}" / "out"))
    else:
        runs = [job() for job in jobs]
    for r in runs:
        print({k: v for k, v in r.items() if k != "tasks"}, flush=True)
    return runs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, nargs="*", default=[1, 2],
                    help="cluster sizes to run (default 1 2; none with --local: the worker death alone)")
    ap.add_argument("--together", action="store_true",
                    help="run the local and cluster runs at the same time (a loaded machine: their CPU still "
                         "counts apart, their wall times are not comparable)")
    ap.add_argument("--kill", action="store_true", help="then kill a worker mid-suite and rerun (2 workers)")
    ap.add_argument("--local", type=Path, help="compare with this earlier local run's folder instead of running one")
    ap.add_argument("--record", default=RECORD, help=f"the record's name (default {RECORD})")
    ap.add_argument("--no-record", action="store_true", help="print the figures, write no record")
    a = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="rb-suite-cluster-"))
    print(f"working in {tmp}", flush=True)
    command = ("python tests/measurements/bench_suite_cluster.py "
               + " ".join(argv if argv is not None else sys.argv[1:])).strip()
    runs = measure_runs(tmp, a.workers, a.together, a.local)
    figures = {"suite": "quick", "cores": len(os.sched_getaffinity(0)), "together": a.together, "runs": runs}
    ok = all(r.get("same_as_local", True) and r["returncode"] == 0 for r in runs)
    if not a.no_record:   # written now and again with the worker death, so that a long run keeps its first part
        print(write_record(a.record, MEASURES, command, figures, packages=("dask", "distributed", "psutil")), flush=True)
    if a.kill:
        figures["worker_death"] = worker_death(tmp / "killed", a.local or tmp / "local" / "out")
        print(figures["worker_death"], flush=True)
        ok = ok and figures["worker_death"].get("same_as_local", False)
        if not a.no_record:
            print(write_record(a.record, MEASURES, command, figures, packages=("dask", "distributed", "psutil")))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
