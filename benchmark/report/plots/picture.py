"""A map's picture (``map.png``) drawn by a helper process that loads matplotlib while the map is
being computed.

Importing matplotlib costs about as much CPU as a 200×200 reference map takes to solve on two
cores. :class:`MapPicture`, made when a map starts, forks a helper that imports matplotlib on
another core while this process loads the solver and runs the map; the helper then waits for the
result on a pipe and draws it with :func:`~rockbench.benchmark.report.plots.stability.plot_map_files` (the
same function, so the same picture). The fork adds no start-up of its own (the helper shares what is
imported already) and, on a busy machine, no more work than drawing here would.

The helper is forked only where that is safe and useful: on a POSIX system, with at least two cores
to run on, from a process with no Python thread but the main one and whose numba parallel runtime
has not started (a fork copies only the calling thread: locks held by other threads would stay
locked in the child, and numba's thread pools are not fork-safe; idle native pools such as
OpenBLAS's, which numpy starts at import, take care of a fork themselves). Otherwise, or when the
helper fails, the picture is drawn in this process.
"""

from __future__ import annotations

import os
import pickle
import signal
import time
from pathlib import Path

from rockbench.benchmark.maps.cores import can_fork_helper
from rockbench.benchmark.report.plots import stability

#: Seconds the helper may take to draw once it has the map, before it is stopped and the picture
#: is drawn here.
DRAW_TIMEOUT_S = 120.0


class MapPicture:
    """``map.png`` of one map: a helper forked now (where it can be), handed the result by :meth:`draw`."""

    def __init__(self, helper: bool | None = None):
        self.pid = None
        self.w = None
        if helper is None:
            helper = can_fork_helper()
        if not helper:
            return
        r, w = os.pipe()
        try:
            pid = os.fork()
        except OSError:
            os.close(r)
            os.close(w)
            return
        if pid == 0:   # the helper: never returns
            os.close(w)
            code = 1
            try:
                code = _helper(r)
            except BaseException:  # noqa: BLE001 - the parent draws instead
                code = 1
            finally:
                os._exit(code)
        os.close(r)
        self.pid, self.w = pid, w

    def draw(self, result, stem, formats=("png",), reference=None) -> list[Path]:
        """Draw ``result`` (a MapResult) into ``stem.<format>`` for each of ``formats``, over the
        boundary of ``reference`` (the reference map of the same grid, or None): by the helper if it
        runs, else here. Returns the paths."""
        stem = Path(stem)
        formats = tuple(formats)
        paths = [stem.with_name(f"{stem.name}.{f}") for f in formats]
        pid, w = self.pid, self.w
        self.pid = self.w = None
        if pid is not None:
            ok = False
            try:
                data = pickle.dumps((result, str(stem), formats, reference), protocol=pickle.HIGHEST_PROTOCOL)
                with os.fdopen(w, "wb") as f:
                    w = None
                    f.write(data)
                ok = _wait(pid, DRAW_TIMEOUT_S) == 0 and all(p.is_file() for p in paths)
                pid = None
            except (OSError, pickle.PicklingError):
                pass
            finally:
                _stop(pid, w)
            if ok:
                return paths
        return stability.plot_map_files(result, stem, reference=reference, formats=formats)

    def close(self) -> None:
        """Let the helper go if no picture was asked for (the map failed, or was interrupted)."""
        pid, w = self.pid, self.w
        self.pid = self.w = None
        _stop(pid, w)


def _wait(pid: int, timeout_s: float) -> int | None:
    """The helper's exit status, or None when it is still running after ``timeout_s``."""
    end = time.monotonic() + timeout_s
    delay = 0.001
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done == pid:
            return os.waitstatus_to_exitcode(status)
        if time.monotonic() > end:
            return None
        time.sleep(delay)
        delay = min(2 * delay, 0.02)


def _stop(pid: int | None, w: int | None) -> None:
    if w is not None:
        try:
            os.close(w)   # the helper reads EOF and leaves
        except OSError:
            pass
    if pid is None:
        return
    if _wait(pid, 5.0) is None:
        try:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        except OSError:
            pass


def _helper(r: int) -> int:
    # load what drawing needs before the map arrives: this is the point of the helper
    from matplotlib import figure  # noqa: F401
    from matplotlib.backends import backend_agg  # noqa: F401


    chunks = []
    with os.fdopen(r, "rb") as f:
        while True:
            b = f.read(1 << 20)
            if not b:
                break
            chunks.append(b)
    if not chunks:
        return 0   # no picture wanted after all
    result, stem, formats, reference = pickle.loads(b"".join(chunks))
    stability.plot_map_files(result, stem, reference=reference, formats=formats)
    return 0
