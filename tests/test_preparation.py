"""Ctrl-C during a suite's calibrations stops the helper processes now, not after the calibration each
had begun (a Genesis or Newton calibration takes minutes: the run went on that long after it said it
was interrupted)."""

from __future__ import annotations

import time
from concurrent.futures import ProcessPoolExecutor

import pytest

from rockbench.benchmark.suites.preparation import Preparation


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
    procs = list(prep.pool._processes.values())
    t0 = time.monotonic()
    prep.abort()
    for p in procs:
        p.join(timeout=10)
    assert time.monotonic() - t0 < 10
    assert not any(p.is_alive() for p in procs)
    assert prep.pool is None


class _Interrupted:
    """A future whose wait is interrupted by Ctrl-C."""

    def result(self):
        raise KeyboardInterrupt


def test_ctrl_c_while_waiting_for_the_calibrations_stops_the_helpers():
    prep = _helpers_busy_for(120)
    procs = list(prep.pool._processes.values())
    prep.futs = {0: _Interrupted()}
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        prep.finish()
    for p in procs:
        p.join(timeout=10)
    assert time.monotonic() - t0 < 10
    assert not any(p.is_alive() for p in procs)
