"""``rockbench run --scheduler``: a suite on a real Dask cluster (a ``dask scheduler`` and two ``dask worker``
processes of one thread each on 127.0.0.1, ephemeral ports, started and torn down here) writes the same
maps, cell for cell, and the same score.json as the local run; a worker killed mid-suite loses no
finished map, and a rerun completes and equals the uninterrupted run; a bad address is one line and exit 2.

The suite is reduced to keep the cost low: one block and pulse, a 6 × 5 adaptive grid, MuJoCo and
PyBullet calibrated at a fixed 1 ms step (their calibrations cached once for every run here), the reference and two planted
variants. Every wait is bounded.
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

import pytest

from rockbench.benchmark.cli.main import main

pytest.importorskip("distributed")
pytest.importorskip("mujoco")
pytest.importorskip("pybullet")

pytestmark = pytest.mark.slow

SUITE = """
[suite]
name = "dask-test"
description = "a reduced suite for the Dask tests"

[grid]
w_ratio = "1:16:6"
a_ratio = "1:12:5"
adaptive = true
coarse_stride = 2
locate_depth = 2

[cases]
blocks = ["B3M"]
pulses = ["sine"]

[reference]
restitutions = ["housner"]

[engines]
names = ["mujoco", "pybullet"]
variants = [{ settings = "calibrated" }]
restitution = "housner"
own_eta = true
dt_s = 0.001

[power]
eta_reductions = [0.0, 0.01]

[run]
cell_timeout_s = 60

[report]
cases = []
"""

#: bounds of every wait [s] (a loaded CI machine is slow, never stuck this long)
START_S = 120
RUN_S = 900
#: the columns of a cell's cost, which differ between any two runs
TIMING = ("wall_s", "cpu_s")


def _env(cache: Path) -> dict:
    return {**os.environ, "ROCKBENCH_CACHE": str(cache), "MPLBACKEND": "Agg"}


def _start(args: list[str], env: dict, log: Path) -> subprocess.Popen:
    """A process in a session of its own (killed as a group), its output to ``log``."""
    with open(log, "ab") as f:
        return subprocess.Popen(args, env=env, stdout=f, stderr=subprocess.STDOUT, start_new_session=True)


def _kill(p: subprocess.Popen) -> None:
    if p.poll() is None:
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    p.wait(timeout=30)


class _Cluster:
    """``dask scheduler`` and ``dask worker`` processes on 127.0.0.1 (ephemeral ports)."""

    def __init__(self, tmp: Path, env: dict):
        self.tmp, self.env, self.workers = tmp, env, []
        info = tmp / "scheduler.json"
        self.scheduler = _start([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port", "0",
                                 "--no-dashboard", "--scheduler-file", str(info)], env, tmp / "scheduler.log")
        t0 = time.monotonic()
        while not info.exists() or not info.read_text().strip():
            assert time.monotonic() - t0 < START_S and self.scheduler.poll() is None, (tmp / "scheduler.log").read_text()
            time.sleep(0.2)
        self.address = json.loads(info.read_text())["address"]

    def add_worker(self) -> subprocess.Popen:
        n = len(self.workers)
        w = _start([sys.executable, "-m", "dask", "worker", self.address, "--nworkers", "1", "--nthreads", "1",
                    "--host", "127.0.0.1", "--no-dashboard", "--local-directory", str(self.tmp / f"w{n}")],
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
                for n, w in enumerate(self.workers):
                    found = re.search(r"Start worker at:\s+(\S+)", (self.tmp / f"worker{n}.log").read_text())
                    if w.poll() is None and found and found.group(1) in busy:
                        return w
                time.sleep(0.1)
        return None

    def wait_for(self, n: int) -> None:
        from dask.distributed import Client
        with Client(self.address, timeout=START_S) as c:
            c.wait_for_workers(n, timeout=START_S)

    def close(self) -> None:
        for p in [*self.workers, self.scheduler]:
            _kill(p)


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    """The suite file, a shared calibration cache, the local run, and a cluster of two workers."""
    tmp = tmp_path_factory.mktemp("suite-dask")
    suite = tmp / "suite.toml"
    suite.write_text(SUITE)
    env = _env(tmp / "cache")
    local = tmp / "local"
    _run_suite(suite, local, env, [])   # also fills the cache the cluster's workers read
    cluster = _Cluster(tmp, env)
    try:
        cluster.add_worker()
        cluster.add_worker()
        cluster.wait_for(2)
        yield {"tmp": tmp, "suite": suite, "env": env, "local": local, "cluster": cluster}
    finally:
        cluster.close()


def _command(suite: Path, out: Path, more: list[str]) -> list[str]:
    # -P keeps the working folder off sys.path (see executors.WORKER_COMMAND)
    return [sys.executable, "-P", "-m", "rockbench.benchmark", "run", str(suite), "--no-report", "--out", str(out),
            *more]


def _run_suite(suite: Path, out: Path, env: dict, more: list[str]) -> None:
    r = subprocess.run(_command(suite, out, more), env=env, capture_output=True, text=True, timeout=RUN_S)
    assert r.returncode == 0, r.stderr[-3000:]


def _cells(path: Path) -> list[dict]:
    """A cells.csv (or bisection.csv) without its timing columns, in cell order."""
    rows = [{k: v for k, v in r.items() if k not in TIMING} for r in csv.DictReader(io.StringIO(path.read_text()))]
    return sorted(rows, key=lambda r: tuple(sorted(r.items())))


def _maps(out: Path) -> dict:
    """Every map of a run folder: its cells, samples and boundary, by map folder."""
    maps = {}
    for run_json in sorted((out / "maps").rglob("run.json")):
        d = run_json.parent
        maps[str(d.relative_to(out))] = {name: _cells(d / name) for name in ("cells.csv", "bisection.csv", "boundary.csv")
                                         if (d / name).exists()}
    return maps


def _score(out: Path) -> dict:
    """score.json without its timestamp and with the run folder's path replaced."""
    doc = json.loads((out / "score.json").read_text().replace(str(out), "OUT"))
    doc.pop("created_utc", None)
    return doc


def _assert_same_run(a: Path, b: Path) -> None:
    maps_a, maps_b = _maps(a), _maps(b)
    assert sorted(maps_a) == sorted(maps_b) and len(maps_a) >= 5
    for name in maps_a:
        assert maps_a[name] == maps_b[name], name
    assert _score(a) == _score(b)


def test_suite_on_cluster_equals_local(setup):
    out = setup["tmp"] / "cluster"
    _run_suite(setup["suite"], out, setup["env"], ["--scheduler", setup["cluster"].address])
    _assert_same_run(setup["local"], out)
    assert not (out / ".incoming").exists()


def _finished(out: Path) -> dict:
    """The maps finished so far (their run.json records a summary): cells.csv's bytes by map folder."""
    done = {}
    for run_json in (out / "maps").rglob("run.json") if (out / "maps").exists() else ():
        try:
            if "summary" in json.loads(run_json.read_text()):
                done[run_json.parent] = (run_json.parent / "cells.csv").read_bytes()
        except (OSError, ValueError):
            continue
    return done


def test_worker_killed_mid_suite_loses_no_finished_map(setup):
    tmp, cluster = setup["tmp"], setup["cluster"]
    out = tmp / "killed"
    run = _start(_command(setup["suite"], out, ["--scheduler", cluster.address]), setup["env"], tmp / "killed.log")
    try:
        t0 = time.monotonic()
        while not (before := _finished(out)):
            assert run.poll() is None, (tmp / "killed.log").read_text()[-3000:]
            assert time.monotonic() - t0 < RUN_S
            time.sleep(0.2)
        busy = cluster.busy_worker(run, RUN_S)
        assert busy is not None and run.poll() is None, "the suite ended before a busy worker could be killed"
        _kill(busy)   # with the task it was running
        run.wait(timeout=RUN_S)
    finally:
        _kill(run)
    for d, cells in before.items():   # what was finished is intact, whatever became of the run
        assert (d / "cells.csv").read_bytes() == cells, d
    cluster.add_worker()
    cluster.wait_for(2)
    _run_suite(setup["suite"], out, setup["env"], ["--scheduler", cluster.address])   # completes (resumes)
    _assert_same_run(setup["local"], out)


@pytest.mark.parametrize("address, why", [("tcp://127.0.0.1:9", "cannot reach the Dask scheduler"),
                                          ("nonsense", "takes a Dask scheduler address")])
def test_bad_scheduler_is_one_line_and_exit_2(tmp_path, capsys, address, why):
    suite = tmp_path / "suite.toml"
    suite.write_text(SUITE)
    code = main(["run", str(suite), "--no-report", "--out", str(tmp_path / "out"), "--scheduler", address])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and why in err, err
    assert not (tmp_path / "out" / "maps").exists()


def test_a_map_from_the_cluster_replaces_its_folder_whole(tmp_path):
    """A half-done map folder is replaced by the finished one in one rename; nothing is left staged."""
    from rockbench.benchmark.suites.cluster import map_files, write_map
    d = tmp_path / "maps" / "mujoco" / "B3M-sine-housner"
    d.mkdir(parents=True)
    (d / "cells.csv").write_text("half\n")
    (d / ".lock").write_text("")
    assert map_files(d) == {"cells.csv": b"half\n"}   # the lock stays with its writer
    write_map(d, {"cells.csv": b"whole\n", "run.json": b"{}"}, tmp_path / ".incoming")
    assert map_files(d) == {"cells.csv": b"whole\n", "run.json": b"{}"} and not (d / ".lock").exists()
    assert list((tmp_path / ".incoming").iterdir()) == []
