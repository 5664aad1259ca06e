"""Executors: the same map whatever runs it; failing, crashing and hanging cells recorded while the
rest completes; an unreachable scheduler is a clean error within seconds."""

import os
import time

import numpy as np
import pytest

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.maps.executors import DaskExecutor, worker_init
from rockbench.benchmark.maps.grid import MapSpec, make_axis
from rockbench.benchmark.maps.result import FAILED
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.store.loading import load_map
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.reference_solver.errors import ConfigError
from rockbench.engines.errors import EngineError
from rockbench.reference_solver.restitution import Restitution


pytestmark = pytest.mark.usefixtures("fake_engines")


def spec(engine, n=16, **settings):
    return MapSpec(get_preset("B3M").block(), "sine", Restitution(), make_axis("--w-ratio", "w_ratio", 0.5, 8.0, n),
                   make_axis("--a-ratio", "a_ratio", 0.5, 9.0, n), engine=engine, engine_settings=settings)


@pytest.mark.parametrize("engine", ["analytic", "analytic-batch"])
def test_serial_equals_processes(analytic_truth, tmp_path, engine):
    s = spec(engine)
    a = run_map(s, tmp_path / "serial", serial=True)
    b = run_map(s, tmp_path / "proc1", jobs=1)
    c = run_map(s, tmp_path / "proc2", jobs=2)
    assert np.array_equal(a.outcome, analytic_truth(s))
    for r in (b, c):
        assert np.array_equal(r.outcome, a.outcome)
        assert np.array_equal(r.n_impacts, a.n_impacts)
        assert np.array_equal(r.max_abs_theta_rad, a.max_abs_theta_rad)


@pytest.fixture(scope="module")
def cluster():
    """A real Dask LocalCluster on loopback with two single-threaded worker processes."""
    import logging

    from dask.distributed import LocalCluster
    c = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=":0",
                     silence_logs=logging.ERROR)
    yield c.scheduler_address
    c.close()


def test_dask_equals_serial_and_isolates_crashes(analytic_truth, tmp_path, cluster):
    s = spec("analytic-batch", n=12)
    ref = run_map(s, tmp_path / "serial", serial=True)
    d = run_map(s, tmp_path / "dask", scheduler=cluster)
    assert np.array_equal(d.outcome, ref.outcome)
    assert np.array_equal(d.max_abs_theta_rad, ref.max_abs_theta_rad)
    # a segfaulting engine on Dask: its cells are recorded, the rest equals the truth
    s2 = spec("crashing", n=4, bad_above=7.5)
    r = run_map(s2, tmp_path / "dask-crash", scheduler=cluster, cell_timeout_s=30)
    bad = s2.w_ratios() > 7.5
    assert (r.outcome[:, bad] == FAILED).all()
    assert np.array_equal(r.outcome[:, ~bad], analytic_truth(s2)[:, ~bad])
    assert {f["flag"] for f in r.failures} == {"crashed"}


@pytest.mark.parametrize("engine, flag, text", [
    ("raising", "engine-error", "RuntimeError: engine exploded"),
    ("crashing", "crashed", "SIGSEGV"),
    ("diverging", "diverged", "non-finite"),
    ("crashing-batch", "crashed", "SIGSEGV"),   # a native batch that segfaults: only its bad cells fail
])
def test_bad_cells_are_recorded_and_the_map_goes_on(analytic_truth, tmp_path, engine, flag, text):
    s = spec(engine, n=6, bad_above=7.5)
    r = run_map(s, tmp_path / "m", jobs=2)
    bad = s.w_ratios() > 7.5
    assert bad.sum() == 1
    assert (r.outcome[:, bad] == FAILED).all()
    assert np.array_equal(r.outcome[:, ~bad], analytic_truth(s)[:, ~bad])
    assert len(r.failures) == 6
    assert all(f["flag"] == flag and text in f["message"] for f in r.failures)
    back = load_map(tmp_path / "m")
    assert np.array_equal(back.outcome, r.outcome)
    assert not back.valid[:, bad].any()


def test_hanging_cell_times_out(analytic_truth, tmp_path):
    s = spec("hanging", n=4, bad_above=7.5)      # one column: four hanging cells
    t0 = time.monotonic()
    r = run_map(s, tmp_path / "m", jobs=2, cell_timeout_s=1.0)
    assert time.monotonic() - t0 < 30
    bad = s.w_ratios() > 7.5
    assert (r.outcome[:, bad] == FAILED).all()
    assert {f["flag"] for f in r.failures} == {"timeout"} and len(r.failures) == 4
    assert np.array_equal(r.outcome[:, ~bad], analytic_truth(s)[:, ~bad])


def test_worker_that_never_starts_stops_the_map_with_the_reason(tmp_path, monkeypatch):
    from rockbench.benchmark.maps.executors import ProcessExecutor
    monkeypatch.setattr(ProcessExecutor, "START_TIMEOUT_S", 1.0)
    monkeypatch.setenv("RB_TEST_PARENT_PID", str(os.getpid()))
    t0 = time.monotonic()
    with pytest.raises(EngineError, match="did not start within 1 s"):
        run_map(spec("hanging-start", n=4), tmp_path / "m", jobs=2)
    assert time.monotonic() - t0 < 60


def test_unreachable_scheduler_fails_fast():
    t0 = time.monotonic()
    with pytest.raises(ConfigError, match="cannot reach the Dask scheduler"):
        DaskExecutor(worker_init("analytic", {}), "tcp://127.0.0.1:9")
    assert time.monotonic() - t0 < 15


def test_unreachable_scheduler_cli_exit_2(tmp_path, capsys):
    code = main(["map", "--engine", "analytic", "--block", "B6M", "--w-ratio", "1:5:3", "--a-ratio", "1:4:3",
                 "--out", str(tmp_path / "m"), "--scheduler", "tcp://127.0.0.1:9", "--json"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "cannot reach the Dask scheduler" in err
    assert not (tmp_path / "m").exists()       # nothing half-written


def test_one_executor_serves_many_maps(analytic_truth, tmp_path):
    from rockbench.benchmark.maps.executors import make_executor
    ex = make_executor("analytic", {}, jobs=2)
    try:
        for k, pulse in enumerate(("sine", "cosine")):
            s = MapSpec(get_preset("B6L").block(), pulse, Restitution(), make_axis("--w-ratio", "w_ratio", 0.5, 8, 9),
                        make_axis("--a-ratio", "a_ratio", 0.5, 9, 9), engine="analytic")
            r = run_map(s, tmp_path / f"m{k}", executor=ex)
            assert np.array_equal(r.outcome, analytic_truth(s))
        pids = {w.proc.pid for w in ex.workers}
        assert len(pids) == 2                         # the same two workers did both maps
        with pytest.raises(ConfigError, match="the executor given runs engine 'analytic'"):
            run_map(spec("raising"), tmp_path / "other", executor=ex)
    finally:
        ex.close()


# -- bounded waits, no orphans, a cap on --jobs -----------------------------------------------

def test_jobs_are_capped_at_cores_and_cells(analytic_truth, tmp_path):
    from rockbench.benchmark.maps.executors import cap_jobs, cpu_count
    assert cap_jobs(None) == (None, None)
    n, note = cap_jobs(1000, 4)
    assert n == min(cpu_count(), 4) and "--jobs 1000 capped at" in note
    assert cap_jobs(1, 4) == (1, None)
    logs = []
    s = spec("analytic", n=2)
    t0 = time.monotonic()
    r = run_map(s, tmp_path / "m", jobs=1000, log=logs.append)
    assert np.array_equal(r.outcome, analytic_truth(s))
    assert any("--jobs 1000 capped at" in m for m in logs), logs
    import json
    jobs = json.loads((tmp_path / "m" / "run.json").read_text())["options"]["executor"]["jobs"]
    assert jobs <= min(cpu_count(), 4)
    assert time.monotonic() - t0 < 60


def _map_process(tmp_path, *extra):
    """A `rockbench map` process with the test adapters, whose workers hang in their cells."""
    import subprocess
    import sys
    from pathlib import Path
    here = Path(__file__).resolve().parent
    cmd = [sys.executable, "-c",
           "import sys, maps_helpers as mh; mh.register_all(); from rockbench.benchmark.cli.main import main; "
           "sys.exit(main(sys.argv[1:]))",
           "map", "--engine", "hanging", "--set", "bad_above=4", "--block", "B6M", "--w-ratio", "0.5:8:6",
           "--a-ratio", "0.5:9:4", "--out", str(tmp_path / "m"), "--jobs", "2", "--no-plot", "--cell-timeout", "600",
           *extra]
    env = dict(os.environ, PYTHONPATH=str(here) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.Popen(cmd, cwd=here, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True, text=True)


def _busy_workers(proc, out, timeout=120.0):
    """The two worker processes of ``proc`` once they have started on the cells (the first rows are in
    cells.csv; the good cells come first, then each worker hangs in a bad one)."""
    import psutil
    parent = psutil.Process(proc.pid)

    def cmdline(k):
        try:
            return " ".join(k.cmdline())
        except psutil.Error:        # a child that ended between the listing and the question
            return ""

    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        try:
            kids = [k for k in parent.children(recursive=True) if "rockbench.benchmark.maps.worker" in cmdline(k)]
        except psutil.NoSuchProcess:
            kids = []
        csv_path = out / "cells.csv"
        if len(kids) == 2 and csv_path.exists() and csv_path.read_text().count("\n") > 1:
            time.sleep(2.0)
            return kids
        if proc.poll() is not None:
            raise AssertionError(f"the map ended: {proc.communicate()[1][-2000:]}")
        time.sleep(0.1)
    raise AssertionError("the workers did not start")


def _gone(procs, timeout=10.0):
    import psutil
    _, alive = psutil.wait_procs(procs, timeout=timeout)
    return not alive


def test_workers_die_with_their_parent_on_sigkill(tmp_path):
    import signal
    proc = _map_process(tmp_path)
    kids = []
    try:
        kids = _busy_workers(proc, tmp_path / "m")
        os.kill(proc.pid, signal.SIGKILL)          # the map process only, not its group
        proc.wait(timeout=10)
        assert _gone(kids, timeout=5.0), "workers outlived their parent"
    finally:
        for p in [proc] + kids:                    # never leave a hanging worker behind, pass or fail
            try:
                os.kill(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


def test_sigterm_is_handled_like_ctrl_c(tmp_path):
    import json
    import signal
    proc = _map_process(tmp_path)
    kids = []
    try:
        kids = _busy_workers(proc, tmp_path / "m")
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
        assert proc.returncode == 143, err
        assert time.monotonic() - t0 < 15
        assert "interrupted by SIGTERM" in err and "Traceback" not in err
        assert _gone(kids, timeout=5.0)
    finally:
        for p in [proc] + kids:
            try:
                os.kill(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    # the finished cells were kept and a rerun resumes from them
    rows = (tmp_path / "m" / "cells.csv").read_text().splitlines()
    assert len(rows) > 1
    meta = json.loads((tmp_path / "m" / "run.json").read_text())
    assert meta["summary"] is None and len(meta["runs"]) == 1


def test_a_port_that_is_not_a_dask_scheduler_is_refused_within_seconds(tmp_path, capsys):
    import socket
    import threading
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(16)
    port = srv.getsockname()[1]
    conns, stop = [], threading.Event()

    def accept():               # accepts every connection and never says a word
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                conns.append(srv.accept()[0])
            except OSError:
                pass
    threading.Thread(target=accept, daemon=True).start()
    try:
        t0 = time.monotonic()
        code = main(["map", "--engine", "analytic", "--block", "B6M", "--w-ratio", "1:5:3", "--a-ratio", "1:4:3",
                     "--out", str(tmp_path / "m"), "--scheduler", f"tcp://127.0.0.1:{port}", "--json"])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and "not a Dask scheduler" in err, err
        assert time.monotonic() - t0 < 20
    finally:
        stop.set()
        srv.close()
        for c in conns:
            c.close()


def test_local_cluster_leaves_no_scratch_space(analytic_truth, tmp_path, monkeypatch):
    import tempfile
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    tempfile.tempdir = None        # let tempfile see the new TMPDIR
    try:
        s = spec("analytic-batch", n=4)
        r = run_map(s, tmp_path / "m", scheduler="local", jobs=1)
        assert np.array_equal(r.outcome, analytic_truth(s))
    finally:
        tempfile.tempdir = None
    assert list((tmp_path / "tmp").iterdir()) == []
    assert sorted(p.name for p in (tmp_path / "m").iterdir()) == [".lock", "bisection.csv", "boundary.csv", "cells.csv",
                                                                   "run.json"]
