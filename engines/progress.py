"""What a long engine step is doing, as lines on the ``rockbench.progress`` logger: a calibration (its
candidates measured), the time-step rule (which step of its ladder, its probe cells) and Warp's
first kernel compile.

The engine floor says what it is doing and prints nothing itself: each line is an INFO record of
:data:`LOGGER` (Python :mod:`logging`). The command line routes it to its console
(:func:`rockbench.benchmark.suites.progress.show_engine_progress`), so the lines read like the
other ``rockbench: ...`` lines on stderr; a library user who wants them adds a handler to
``logging.getLogger("rockbench.progress")`` (without one nothing shows: INFO lies below logging's
last-resort level). Worker processes of a map attach none.

The lines are throttled: at most one per :data:`INTERVAL_S` in a process, and the first of an
activity only once it has run that long, so a calibration that ends within seconds says nothing.
:func:`announce` (a wait known before it starts, e.g. a kernel compile) is not throttled.

An activity is opened with :func:`activity` (nested: the time-step rule's step, then the
calibration at it); :func:`plan` adds work to the innermost one, :func:`advance` counts work done
and may say so. A line names every open activity, outermost first, and the time since the
outermost one began.
"""

from __future__ import annotations

import logging
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass

__all__ = ["LOGGER", "INTERVAL_S", "Activity", "activity", "is_open", "plan", "advance", "tick", "announce", "duration", "line"]

#: The logger of the progress lines (a child of ``rockbench``)
LOGGER = logging.getLogger("rockbench.progress")

#: Shortest time between two progress lines, and before the first line of an activity [s]
INTERVAL_S = 5.0

#: The clock the throttle reads [s] (a test may replace it)
clock = time.monotonic

_lock = threading.Lock()
_last_said: list = [None]   # when the last line was said, by :data:`clock` [s]
_local = threading.local()


@dataclass
class Activity:
    """One open activity: what it is, what its work is counted in, when it began [s], work planned
    and done so far (the planned count grows where a search adds candidates as it goes)."""

    label: str
    unit: str
    t0_s: float
    planned: int = 0
    done: int = 0

    def describe(self) -> str:
        """``label`` and ``done of planned unit`` (nothing planned: ``done unit``; nothing done: the label)."""
        if self.planned:
            return f"{self.label}: {self.done} of {self.planned} {self.unit}"
        return f"{self.label}: {self.done} {self.unit}" if self.done else self.label


def _stack() -> list:
    if not hasattr(_local, "stack"):
        _local.stack = []
    return _local.stack


@contextmanager
def activity(label: str, unit: str = "candidates measured"):
    """An activity open while the ``with`` block runs (nested inside any open one); yields its
    :class:`Activity`."""
    a = Activity(label, unit, clock())
    _stack().append(a)
    try:
        yield a
    finally:
        _stack().remove(a)


def is_open() -> bool:
    """Whether an activity is open in this thread (a nested one need not repeat the engine's name)."""
    return bool(_stack())


def plan(n: int) -> None:
    """``n`` more units of work in the innermost open activity (none open: nothing)."""
    if _stack():
        _stack()[-1].planned += int(n)


def advance(n: int = 1) -> None:
    """``n`` units of work done in the innermost open activity (never past what is planned), and a
    line where the throttle allows (none open: nothing)."""
    st = _stack()
    if not st:
        return
    a = st[-1]
    a.done = min(a.done + int(n), a.planned) if a.planned else a.done + int(n)
    _maybe_say(st)


def tick() -> None:
    """A heartbeat from inside a long run (a segment of steps done): the counts stay as they are, and
    a line where the throttle allows (none open: nothing)."""
    st = _stack()
    if st:
        _maybe_say(st)


def _maybe_say(st: list) -> None:
    now = clock()
    with _lock:
        since = max(st[0].t0_s, _last_said[0] if _last_said[0] is not None else st[0].t0_s)
        if now - since < INTERVAL_S:
            return
        _last_said[0] = now
    LOGGER.info(line(st, now))


def line(st: list, now_s: float) -> str:
    """The progress line of the open activities ``st`` (outermost first) at ``now_s`` [s]."""
    return "; ".join(a.describe() for a in st) + f" ({duration(now_s - st[0].t0_s)} so far)"


def announce(message: str) -> None:
    """Say ``message`` now (not throttled): a wait known before it starts."""
    with _lock:
        _last_said[0] = clock()
    LOGGER.info(message)


def duration(s: float) -> str:
    """A duration [s] in words: ``12.3 s`` under a minute, else ``4 min 05 s``."""
    if s < 60:
        return f"{s:.1f} s"
    m, sec = divmod(int(round(s)), 60)
    return f"{m} min {sec:02d} s"
