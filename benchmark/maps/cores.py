"""The cores this process may run on, and whether it may fork a helper process now."""

from __future__ import annotations

import os
import sys
import threading


def cpu_count() -> int:
    """The cores this process may run on (its affinity where the system tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def can_fork_helper() -> bool:
    """Whether a helper process may be forked here and now: on a POSIX system, with at least two
    cores to run on, from a process with no Python thread but the main one (a fork copies only the
    calling thread: locks held by other threads would stay locked in the child) and whose numba
    parallel runtime has not started (numba's thread pools are not fork-safe). A map's picture
    (:class:`~rockbench.benchmark.report.plots.picture.MapPicture`) and the suite's preparation of the
    engines ask."""
    return hasattr(os, "fork") and cpu_count() >= 2 and _fork_safe()


def _fork_safe() -> bool:
    if threading.active_count() > 1:
        return False
    par = sys.modules.get("numba.np.ufunc.parallel")
    return not getattr(par, "_is_initialized", False)
