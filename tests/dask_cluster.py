"""A real Dask cluster on 127.0.0.1 for ``rockbench run --scheduler`` (a ``dask scheduler`` and one-thread
``dask worker`` processes on ephemeral ports, each in a session of its own), and the comparison of two run
folders: the same maps cell for cell and the same score.json. Shared by tests/test_suite_dask.py and
tests/measurements/bench_suite_cluster.py, so that the record measures the cluster the test checks.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

#: bound of the waits for the scheduler and the workers to start [s] (a loaded machine is slow, never stuck this long)
START_S = 120
#: the columns of a cell's cost, which differ between any two runs
TIMING = ("wall_s", "cpu_s")


def suite_env(cache: Path) -> dict:
    """This process's environment with its own calibration cache ``cache`` and no display."""
    return {**os.environ, "ROCKBENCH_CACHE": str(cache), "MPLBACKEND": "Agg"}


def start(args: list[str], env: dict, log: Path) -> subprocess.Popen:
    """A process in a session of its own (killed as a group), its output to ``log``."""
    with open(log, "ab") as f:
        return subprocess.Popen(args, env=env, stdout=f, stderr=subprocess.STDOUT, start_new_session=True)


def kill(p: subprocess.Popen) -> None:
    """``p`` and its session killed (SIGKILL) and waited for."""
    if p.poll() is None:
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    p.wait(timeout=30)


def run_command(suite: str | Path, out: Path, more: list[str]) -> list[str]:
    """``rockbench run SUITE --no-report --out OUT MORE`` as its own interpreter (``suite``: a suite file
    or a flag such as ``--quick``)."""
    # -P keeps the working folder off sys.path (see executors.WORKER_COMMAND)
    return [sys.executable, "-P", "-m", "rockbench.benchmark", "run", str(suite), "--no-report", "--out", str(out),
            *more]


class Cluster:
    """``dask scheduler`` and ``dask worker`` processes on 127.0.0.1 (ephemeral ports), their logs in
    ``tmp``; each worker preloads ``preload`` (a module's path) where one is given."""

    def __init__(self, tmp: Path, env: dict, preload: Path | None = None):
        self.tmp, self.env, self.preload, self.workers = tmp, env, preload, []
        info = tmp / "scheduler.json"
        self.scheduler = start([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port", "0",
                                "--no-dashboard", "--scheduler-file", str(info)], env, tmp / "scheduler.log")
        t0 = time.monotonic()
        while not info.exists() or not info.read_text().strip():
            if time.monotonic() - t0 > START_S or self.scheduler.poll() is not None:
                raise RuntimeError((tmp / "scheduler.log").read_text())
            time.sleep(0.2)
        self.address = json.loads(info.read_text())["address"]

    def add_worker(self) -> subprocess.Popen:
        n = len(self.workers)
        more = ["--preload", str(self.preload)] if self.preload is not None else []
        w = start([sys.executable, "-m", "dask", "worker", self.address, "--nworkers", "1", "--nthreads", "1",
                   "--host", "127.0.0.1", "--no-dashboard", "--local-directory", str(self.tmp / f"w{n}"), *more],
                  self.env, self.tmp / f"worker{n}.log")
        self.workers.append(w)
        return w

    def busy_worker(self, run: subprocess.Popen, timeout_s: float) -> subprocess.Popen | None:
        """One of our worker processes running a task now (None if none does within ``timeout_s`` or
        while ``run`` lasts): the scheduler says which addresses are busy, each worker's log its address."""
        from dask.distributed import Client
        with Client(self.address, timeout=START_S) as c:
            t0 = time.monotonic()
            while time.monotonic() - t0 < timeout_s and run.poll() is None:
                busy = {a for a, keys in c.processing().items() if keys}
                for address, n in self.numbers().items():
                    if self.workers[n].poll() is None and address in busy:
                        return self.workers[n]
                time.sleep(0.1)
        return None

    def numbers(self) -> dict:
        """Each started worker's number (its index in ``workers``) by its address, as its log gives it."""
        found = {}
        for n in range(len(self.workers)):
            log = self.tmp / f"worker{n}.log"
            address = re.search(r"Start worker at:\s+(\S+)", log.read_text()) if log.exists() else None
            if address:
                found[address.group(1)] = n
        return found

    def wait_for(self, n: int) -> None:
        from dask.distributed import Client
        with Client(self.address, timeout=START_S) as c:
            c.wait_for_workers(n, timeout=START_S)

    def close(self) -> None:
        for p in [*self.workers, self.scheduler]:
            kill(p)


def cells(path: Path) -> list[dict]:
    """A cells.csv (or bisection.csv) without its timing columns, in cell order."""
    rows = [{k: v for k, v in r.items() if k not in TIMING} for r in csv.DictReader(io.StringIO(path.read_text()))]
    return sorted(rows, key=lambda r: tuple(sorted(r.items())))


def maps(out: Path) -> dict:
    """Every map of a run folder: its cells, samples and boundary, by map folder."""
    found = {}
    for run_json in sorted((out / "maps").rglob("run.json")):
        d = run_json.parent
        found[str(d.relative_to(out))] = {name: cells(d / name) for name in ("cells.csv", "bisection.csv", "boundary.csv")
                                          if (d / name).exists()}
    return found


def score(out: Path) -> dict:
    """score.json without its timestamp and with the run folder's path replaced."""
    doc = json.loads((out / "score.json").read_text().replace(str(out), "OUT"))
    doc.pop("created_utc", None)
    return doc


def differences(a: Path, b: Path) -> list[str]:
    """What differs between run folders ``a`` and ``b``: the maps only one has, the maps whose cells,
    samples or boundary differ, and ``score.json``; empty when they are the same run."""
    maps_a, maps_b = maps(a), maps(b)
    diff = sorted(set(maps_a) ^ set(maps_b))
    diff += [name for name in sorted(set(maps_a) & set(maps_b)) if maps_a[name] != maps_b[name]]
    if score(a) != score(b):
        diff.append("score.json")
    return diff


def finished(out: Path) -> dict:
    """The maps finished so far (their run.json records a summary): cells.csv's bytes by map folder."""
    done = {}
    for run_json in (out / "maps").rglob("run.json") if (out / "maps").exists() else ():
        try:
            if "summary" in json.loads(run_json.read_text()):
                done[run_json.parent] = (run_json.parent / "cells.csv").read_bytes()
        except (OSError, ValueError):
            continue
    return done
