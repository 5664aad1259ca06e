"""Whether an engine can simulate at all, and how many of its cells failed and why.

A map with failed cells is scored as it is (a failed cell is the engine's answer), but an engine
whose every cell of a map fails with one and the same error, or whose workers cannot start it,
cannot simulate here: a version outside the supported range, a broken install. `rockbench run`
stops such an engine after its first map (:class:`EngineHealth`), skips its other maps, and ends
with one line per such engine (:func:`cannot_simulate_line`) and exit code 3; `rockbench map`
exits 3 with the same line. :func:`failure_lines` is the run's one line per engine of failed cells.
"""

from __future__ import annotations

import collections
import threading

from rockbench.engines.registry import adapter_class
from rockbench.engines.support import install_advice, installed_label, outside_range, supported_range
from rockbench.reference_solver.errors import RockbenchError
from rockbench.engines.errors import EngineError, EngineUnavailableError

#: longest error text quoted in a line [characters]
MAX_REASON = 160


class EngineCannotSimulate(EngineUnavailableError):
    """An engine that cannot simulate (every cell of a map failed with one error, or its workers could
    not start it). The CLI exits with code 3, "a requested engine cannot start"."""


def _short(text: str) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= MAX_REASON else text[:MAX_REASON - 1] + "…"


def reason_of(failure: dict) -> str:
    """What a failed cell's row says went wrong: its message, else its flag (``timeout``, ``crashed``)."""
    return _short(failure.get("message") or failure.get("flag") or "failed")


def common_error(failures: list[dict], n_simulated: int) -> str | None:
    """The one error every simulated cell of a map failed with; None when a cell succeeded, none was
    simulated, or the cells failed for different reasons."""
    if n_simulated <= 0 or len(failures) < n_simulated:
        return None
    reasons = {reason_of(f) for f in failures}
    return reasons.pop() if len(reasons) == 1 else None


def _declaring(engine: str):
    """``engine``'s adapter class where it loads (a plugin declares its supported range there), else its name."""
    try:
        return adapter_class(engine)
    except RockbenchError:
        return engine


def cannot_simulate_line(engine: str, error: str, where: str) -> str:
    """The one line for an engine that cannot simulate: the engine, its installed version, the error,
    the supported range and what to do. ``where`` says what failed ("every one of the 16 cells of its
    map", "its workers could not start it")."""
    declaring = _declaring(engine)
    label = installed_label(declaring)
    rng = supported_range(declaring)
    outside = outside_range(declaring)
    version = f" ({label})" if label else ""
    supported = (f"; {outside}" if outside else f"; supported: {rng}") if rng else ""
    advice = install_advice(declaring)
    todo = f"; install a supported version ({advice})" if advice and outside else ""
    return f"engine {engine!r}{version} cannot simulate: {where} failed with {_short(error)}{supported}{todo}."


def refuse_outside_range(engine: str, error: BaseException, where: str) -> None:
    """Raise :class:`EngineCannotSimulate` (exit 3, one line) for an error an engine raised when its
    installed version is outside the supported range; return (the caller re-raises) otherwise."""
    if outside_range(_declaring(engine)):
        raise EngineCannotSimulate(cannot_simulate_line(engine, f"{type(error).__name__}: {error}", where)) from None


class EngineHealth:
    """Which engines of a run cannot simulate, and every engine's failed cells (thread-safe: the
    run's lanes report to it from their threads)."""

    def __init__(self):
        self._lock = threading.Lock()
        self.broken: dict[str, str] = {}              # engine → its cannot-simulate line
        self.skipped: collections.Counter = collections.Counter()
        self.cells: collections.Counter = collections.Counter()
        self.failed: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)

    def guard(self, engine: str, run_map):
        """``run_map()`` for one map of ``engine``, watched: None (nothing run) when the engine cannot
        simulate, or when its workers could not start it (recorded; the run goes on); otherwise the
        map's result, its failures recorded. The reference is run as it is."""
        if engine == "reference":
            return run_map()
        if self.skip(engine):
            return None
        try:
            res = run_map()
        except (EngineError, EngineUnavailableError) as e:
            self.record_start_error(engine, e)
            return None
        self.record_map(engine, res.failures, res.n_simulated)
        return res

    def skip(self, engine: str) -> bool:
        """True (and counted) when ``engine``'s map should not run: the engine cannot simulate."""
        with self._lock:
            if engine in self.broken:
                self.skipped[engine] += 1
                return True
            return False

    def record_map(self, engine: str, failures: list[dict], n_simulated: int) -> None:
        """One finished map of ``engine``: counts its failures; all failed with one error → broken."""
        with self._lock:
            self.cells[engine] += n_simulated
            self.failed[engine].update(reason_of(f) for f in failures)
            err = common_error(failures, n_simulated)
            if err is not None and engine not in self.broken:
                self.broken[engine] = cannot_simulate_line(
                    engine, err, f"every one of the {n_simulated} simulated cells of its first map")

    def record_start_error(self, engine: str, error: BaseException) -> None:
        """``engine``'s workers could not start it (its adapter's start-up failed)."""
        with self._lock:
            self.broken.setdefault(engine, cannot_simulate_line(engine, str(error), "starting it"))

    def broken_lines(self) -> list[str]:
        """One line per engine that cannot simulate, with how many of its maps were skipped."""
        out = []
        for engine, line in sorted(self.broken.items()):
            n = self.skipped[engine]
            skipped = "Its other map was skipped." if n == 1 else f"Its other {n} maps were skipped."
            out.append(line + (f" {skipped}" if n else ""))
        return out

    def failure_lines(self) -> list[str]:
        """One line per engine that ran: how many of its simulated cells failed, and the commonest reasons."""
        out = []
        for engine in sorted(self.cells):
            n, c = self.cells[engine], self.failed[engine]
            total = sum(c.values())
            why = "; ".join(f"{k} × {r}" for r, k in c.most_common(2))
            more = f"; {len(c) - 2} other reasons" if len(c) > 2 else ""
            out.append(f"{engine}: {total} of {n} simulated cells failed" + (f" ({why}{more})" if total else ""))
        return out
