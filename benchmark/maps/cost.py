"""What a map's cell cost: the CPU time of its simulation and the time it simulated (:func:`run_measured`),
and the machine it ran on (:func:`machine`).

Every cell of a map runs through :func:`run_measured`, in a worker process or in the map's own process,
so every engine is timed by one rule:

- **CPU** [s]: the CPU time of the process that runs the engine, its own threads and the child processes
  it waited for (``time.process_time`` and ``getrusage``), over one ``run_many`` call, shared equally among the cases of the call: a
  cell run alone gets the call's CPU time, a batch engine's cell its batch's CPU time divided by its worlds.
  On a shared machine this says more than the wall time, which also counts the neighbours.
- **Simulated time** [s]: how long the engine integrated the block's motion, the span of the trajectory
  it returned (each engine stops a cell by the one end-of-run rule, so the spans differ from cell to
  cell and from engine to engine); taken where the one verdict rule sees the trajectory
  (:meth:`~rockbench.engines.contract.EngineAdapter.judge`), so a native batch that judges its own worlds
  (MuJoCo Warp) is measured the same way.

Both travel with the cell's result in its ``diagnostics`` (which lose everything else before a result
leaves its worker: cells.csv stores none of them) and become the ``cpu_s`` and ``simulated_s`` columns
of cells.csv. A failed cell, and a cell an adapter solves as arrays (the reference solver), has neither.
"""

from __future__ import annotations

import os
import platform
import time
from functools import lru_cache

try:
    import resource   # POSIX: the CPU time of the children a process waited for
except ImportError:  # pragma: no cover - Windows
    resource = None

#: the diagnostics keys :func:`run_measured` sets: the cell's share of the call's CPU time [s] and the time
#: the engine simulated [s]
CELL_CPU, CELL_SIMULATED = "cell_cpu_s", "cell_simulated_s"


def _cpu_now() -> float:
    """CPU seconds of this process (every thread; the kernel's own clock, to the nanosecond) and of the
    children it waited for (user and system, to the microsecond) [s]."""
    own = time.process_time()
    if resource is None:
        return own
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own + ch.ru_utime + ch.ru_stime


def _span_s(tr) -> float | None:
    """The time a trajectory covers [s], None for a failed run (an exception) or an empty one."""
    t = getattr(tr, "t_s", None)
    if isinstance(tr, BaseException) or t is None or len(t) == 0:
        return None
    return float(t[-1] - t[0])


def _stamping(adapter) -> None:
    """Make ``adapter``'s verdicts carry their trajectory's span (once per adapter): its ``judge``, the one
    place every engine's trajectory meets the one classifier, is wrapped on this instance."""
    if getattr(adapter, "_rockbench_stamps_span", False):
        return
    plain = adapter.judge

    def judge(case, tr, wall_s: float = 0.0):
        r = plain(case, tr, wall_s)
        span = _span_s(tr)
        if span is not None:
            r.diagnostics = {**(r.diagnostics or {}), CELL_SIMULATED: span}
        return r

    adapter.judge = judge
    adapter._rockbench_stamps_span = True


def run_measured(adapter, cases: list) -> list:
    """``adapter.run_many(cases)``, each result with its cost (module docstring) in its diagnostics
    (:data:`CELL_CPU`, :data:`CELL_SIMULATED`), and nothing else there; exceptions propagate."""
    _stamping(adapter)
    cases = list(cases)
    t0 = _cpu_now()
    results = adapter.run_many(cases)
    share = (_cpu_now() - t0) / max(len(cases), 1)
    for r in results:
        kept = {CELL_CPU: share}
        span = (r.diagnostics or {}).get(CELL_SIMULATED)
        if span is not None:
            kept[CELL_SIMULATED] = span
        r.diagnostics = kept
    return results


def cost_of(result) -> tuple[float | None, float | None]:
    """``(cpu_s, simulated_s)`` a result carries (None where it carries none) [s]."""
    d = getattr(result, "diagnostics", None) or {}
    return d.get(CELL_CPU), d.get(CELL_SIMULATED)


def machine() -> dict:
    """The machine a map runs on, for run.json: the CPU's model, the cores it has and those this process
    may use, the processor's architecture."""
    return dict(_machine())


@lru_cache(maxsize=1)
def _machine() -> dict:
    try:
        usable = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        usable = os.cpu_count()
    return {"cpu_count": os.cpu_count(), "cores_usable": usable, "cpu_model": cpu_model(),
            "processor": platform.processor() or platform.machine()}


def cpu_model() -> str:
    """The CPU's model name (Linux's /proc/cpuinfo, else the platform's processor, else the architecture)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() in ("model name", "Hardware", "Processor") and value.strip():
                    return " ".join(value.split())
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"
