"""The console of a suite run (``rockbench run``): one line per finished map, in order.

The total ``N`` of ``[k/N]`` is fixed before the first map starts: every map of the plan, the
reference maps at the engines' own measured η included (one per engine variant, block and pulse;
their η is known only later). ``k`` counts finished maps, whatever order they finish in (the
reference maps and the engine maps run at once), so the lines come out in order. Own-η maps that
turn out not to be needed (two variants measured the same η on a block and share one map, or a
measurement failed) are counted off in one line when that is known. No line is blank.
"""

from __future__ import annotations

import os
import sys
import threading

from ...engines import registry
from ...engines.contract import DEVICE_NOTED_ENV


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
        self.log = log or (lambda m: print(f"rockbench: {m}", file=sys.stderr))
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
            self.line(f"[{self.done}/{self.total}] {label} → {where} ({_duration(wall_s)})")

    def not_needed(self, n: int, why: str) -> None:
        """``n`` planned maps that will not run: counted off in one line."""
        if n <= 0:
            return
        with self._lock:
            self.done += n
            self.line(f"[{self.done}/{self.total}] {n} planned map(s) not needed: {why}")


def _duration(s: float) -> str:
    if s < 60:
        return f"{s:.1f} s"
    m, sec = divmod(int(round(s)), 60)
    return f"{m} min {sec:02d} s"


def say_device_notes(engines, console: SuiteConsole) -> None:
    """One line per engine that runs somewhere a reader should know of (a GPU-first engine on the
    CPU: :meth:`~rockbench.engines.contract.EngineAdapter.device_note`), before the first map; the
    engines' worker processes then stay quiet about it."""
    for e in engines:
        note = registry.adapter_class(e).device_note()
        if note:
            console.line(f"{e}: {note}")
            os.environ[DEVICE_NOTED_ENV] = "1"

