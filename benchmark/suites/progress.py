"""The console of a suite run (``rockbench run``): one line per finished map, in order.

The total ``N`` of ``[k/N]`` is fixed before the first map starts: every map of the plan, the
reference maps at the engines' own measured η included (one per engine variant, block and pulse;
their η is known only later). ``k`` counts finished maps, whatever order they finish in (the
reference maps and the engine maps run at once), so the lines come out in order. Own-η maps that
turn out not to be needed (two variants measured the same η on a block and share one map, or a
measurement failed) are counted off in one line when that is known. No line is blank.

The engines' own progress lines (a calibration, the time-step rule, Warp's first kernel compile:
:mod:`rockbench.engines.progress`, on the ``rockbench.progress`` logger) reach the same console
through :func:`show_engine_progress`, which the command line calls for every command; the module
imports nothing heavy, so a command that runs no engine pays nothing for it.
"""

from __future__ import annotations

import logging
import os
import sys
import threading

from rockbench.engines import progress as engine_progress


class SuiteConsole:
    """Progress lines and notes of one suite run, safe to call from several threads.

    Parameters
    ----------
    total : int
        Maps planned (``N``).
    log : callable, optional
        Where a line goes (default: stderr with the ``rockbench:`` prefix).
    """

    def __init__(self, total: int, log=None):
        self.total = int(total)
        self.log = log or console_line
        self.done = 0
        self._lock = threading.Lock()

    def line(self, text: str) -> None:
        """Print ``text`` as one line (blank lines and trailing spaces are dropped)."""
        for part in str(text).splitlines():
            if part.strip():
                self.log(part.rstrip())

    def finished(self, label: str, where, wall_s: float) -> None:
        """One map done: ``[k/N] label → where (wall time)``."""
        with self._lock:
            self.done += 1
            self.line(f"[{self.done}/{self.total}] {label} → {where} ({engine_progress.duration(wall_s)})")

    def not_needed(self, n: int, why: str) -> None:
        """``n`` planned maps that will not run: counted off in one line."""
        if n <= 0:
            return
        with self._lock:
            self.done += n
            self.line(f"[{self.done}/{self.total}] {n} planned map(s) not needed: {why}")


#: one writer at a time: the map lanes, the reference thread and the engines' progress records print
#: from different threads, and ``print`` writes a line and its newline in two calls, which two threads
#: could interleave into a joined line and a blank one
_CONSOLE_LOCK = threading.Lock()


def console_line(text: str) -> None:
    """One line on the console: stderr, with the ``rockbench:`` prefix, written whole in one call."""
    with _CONSOLE_LOCK:
        sys.stderr.write(f"rockbench: {text}\n")
        sys.stderr.flush()


class ConsoleHandler(logging.Handler):
    """The engines' progress records (:mod:`rockbench.engines.progress`) as console lines, each through
    :meth:`SuiteConsole.line` (so one that already starts with ``rockbench:`` is not prefixed twice)."""

    def __init__(self, console: SuiteConsole | None = None):
        super().__init__(logging.INFO)
        self.console = console or SuiteConsole(0)

    def emit(self, record: logging.LogRecord) -> None:
        try:
            msg = record.getMessage()
            self.console.line(msg[len("rockbench: "):] if msg.startswith("rockbench: ") else msg)
        except Exception:  # noqa: BLE001 - a console that cannot write loses the line, never the run
            self.handleError(record)


def show_engine_progress(console: SuiteConsole | None = None) -> ConsoleHandler:
    """Route the engines' progress lines to ``console`` (default: stderr, :func:`console_line`) until
    the returned handler is removed (:func:`hide_engine_progress`)."""
    handler = ConsoleHandler(console)
    engine_progress.LOGGER.addHandler(handler)
    engine_progress.LOGGER.setLevel(logging.INFO)
    return handler


def hide_engine_progress(handler: ConsoleHandler) -> None:
    """Stop routing the engines' progress lines through ``handler``."""
    engine_progress.LOGGER.removeHandler(handler)


def say_device_notes(engines, console: SuiteConsole) -> None:
    """One line per engine that runs somewhere a reader should know of (a GPU-first engine on the
    CPU: :meth:`~rockbench.engines.contract.EngineAdapter.device_note`), before the first map; the
    engines' worker processes then stay quiet about it."""
    from rockbench.engines import registry   # the adapters' classes: only where a suite runs
    from rockbench.engines.contract import DEVICE_NOTED_ENV   # with numpy: only where a suite runs
    for e in engines:
        note = registry.adapter_class(e).device_note()
        if note:
            console.line(f"{e}: {note}")
            os.environ[DEVICE_NOTED_ENV] = "1"

