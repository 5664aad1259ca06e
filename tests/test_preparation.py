"""Ctrl-C during a suite's calibrations stops the helper processes now, not after the calibration each
had begun (a Genesis or Newton calibration takes minutes: the run went on that long after it said it
was interrupted)."""

from __future__ import annotations

import time
from concurrent.futures import ProcessPoolExecutor

import pytest

from rockbench.benchmark.suites.preparation import Preparation


def _all_gone(pids, timeout_s: float = 10.0) -> bool:
    """Whether every process of ``pids`` has ended within ``timeout_s`` [s] (psutil: the pool's own thread
    may reap them before multiprocessing's ``join`` can)."""
    import psutil

    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        alive = [p for p in pids if psutil.pid_exists(p) and psutil.Process(p).status() != psutil.STATUS_ZOMBIE]
        if not alive:
            return True
        time.sleep(0.1)
    return False


def _helpers_busy_for(seconds: float) -> Preparation:
    """A Preparation whose two helpers are each in a task of ``seconds`` [s] (as in a long calibration)."""
    prep = Preparation.__new__(Preparation)
    prep.pool = ProcessPoolExecutor(max_workers=2)
    prep.futs = {k: prep.pool.submit(time.sleep, seconds) for k in range(3)}
    prep.results = {}
    deadline = time.monotonic() + 20
    while len(prep.pool._processes) < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    return prep


def test_abort_stops_the_helpers_mid_task():
    prep = _helpers_busy_for(120)
    pids = list(prep.pool._processes)
    prep.abort()
    assert _all_gone(pids)
    assert prep.pool is None


class _Interrupted:
    """A future whose wait is interrupted by Ctrl-C."""

    def result(self):
        raise KeyboardInterrupt


def test_ctrl_c_while_waiting_for_the_calibrations_stops_the_helpers():
    prep = _helpers_busy_for(120)
    pids = list(prep.pool._processes)
    prep.futs = {0: _Interrupted()}
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        prep.finish()
    assert time.monotonic() - t0 < 10      # not the 120 s the helpers' tasks would take
    assert _all_gone(pids)
