"""``rockbench run --scheduler``: a suite on a real Dask cluster (a ``dask scheduler`` and two ``dask worker``
processes of one thread each on 127.0.0.1, ephemeral ports, started and torn down here) writes the same
maps, cell for cell, and the same score.json as the local run; a worker killed mid-suite loses no
finished map, and a rerun completes and equals the uninterrupted run; a bad address is one line and exit 2.

The suite is reduced to keep the cost low: one block and pulse, a 6 × 5 adaptive grid, MuJoCo and
PyBullet calibrated at a fixed 1 ms step (their calibrations cached once for every run here), the reference and two planted
variants. Every wait is bounded. The workers preload tests/dask_slow_maps.py, which makes each map task last at
least two seconds, so that the kill finds a busy worker on any machine.

The cluster is tests/dask_cluster.py's, which tests/measurements/bench_suite_cluster.py also runs the quick
suite on (its record: the quick suite on the cluster equals the local quick suite, and what each costs).
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest

from rockbench.benchmark.cli.main import main
from dask_cluster import Cluster, differences, finished, kill, maps, run_command, start, suite_env

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

#: bound of a run's wait [s] (a loaded CI machine is slow, never stuck this long)
RUN_S = 900
#: the preload that makes every map task last a while (see the module docstring)
SLOW_MAPS = Path(__file__).with_name("dask_slow_maps.py")


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    """The suite file, a shared calibration cache, the local run, and a cluster of two workers."""
    tmp = tmp_path_factory.mktemp("suite-dask")
    suite = tmp / "suite.toml"
    suite.write_text(SUITE)
    env = suite_env(tmp / "cache")
    local = tmp / "local"
    _run_suite(suite, local, env, [])   # also fills the cache the cluster's workers read
    cluster = Cluster(tmp, env, preload=SLOW_MAPS)
    try:
        cluster.add_worker()
        cluster.add_worker()
        cluster.wait_for(2)
        yield {"tmp": tmp, "suite": suite, "env": env, "local": local, "cluster": cluster}
    finally:
        cluster.close()


def _run_suite(suite: Path, out: Path, env: dict, more: list[str]) -> None:
    r = subprocess.run(run_command(suite, out, more), env=env, capture_output=True, text=True, timeout=RUN_S)
    assert r.returncode == 0, r.stderr[-3000:]


def _assert_same_run(a: Path, b: Path) -> None:
    assert len(maps(a)) >= 5 and differences(a, b) == []


def test_suite_on_cluster_equals_local(setup):
    out = setup["tmp"] / "cluster"
    _run_suite(setup["suite"], out, setup["env"], ["--scheduler", setup["cluster"].address])
    _assert_same_run(setup["local"], out)
    assert not (out / ".incoming").exists()


def test_worker_killed_mid_suite_loses_no_finished_map(setup):
    tmp, cluster = setup["tmp"], setup["cluster"]
    out = tmp / "killed"
    run = start(run_command(setup["suite"], out, ["--scheduler", cluster.address]), setup["env"], tmp / "killed.log")
    try:
        t0 = time.monotonic()
        while not (before := finished(out)):
            assert run.poll() is None, (tmp / "killed.log").read_text()[-3000:]
            assert time.monotonic() - t0 < RUN_S
            time.sleep(0.2)
        busy = cluster.busy_worker(run, RUN_S)
        assert busy is not None and run.poll() is None, "the suite ended before a busy worker could be killed"
        kill(busy)   # with the task it was running
        run.wait(timeout=RUN_S)
    finally:
        kill(run)
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
