"""The one time-step rule of a calibrated contact engine: the coarsest step at which its answer has converged.

A contact engine's answer depends on its time step; the benchmark should run each engine at a step
its answer does not depend on, and no finer (a finer step costs time and changes nothing). The rule,
the same for every engine: walk the ladder :data:`STEP_LADDER_S` from the coarsest step down and keep
the first step at which the engine, calibrated at that step, agrees with itself calibrated at the
yardstick: the finest step of the ladder at which its calibration reaches the target:

* its calibration reaches the target at both steps, and the two calibrated η agree within
  :data:`ETA_STEP_RTOL`;
* every cell of a fixed probe set (:func:`probe_cases`) has the same outcome and the same validity
  at both steps (the maps score both: an invalid cell is a spurious one where the reference holds).

When no coarser step agrees, the yardstick is kept and the record says so. The yardstick is the
finest calibrated step, not the next finer one: two neighbouring steps can share the same error and
agree with each other while both lie off the converged answer (measured: Exudyn B6M sine, calibrated,
at 1 and 0.5 ms its boundary lies 0.25 and 0.39 from the reference, at 0.1 ms 0.07). It is the finest
step *at which the calibration reaches the target*, not the finest step of the ladder: a step at which
the engine cannot be calibrated has no calibrated answer to converge to, and mapping a calibrated
variant there would map a contact that misses its η (measured: Drake reaches η_H's window at 1, 0.5
and 0.2 ms and misses it at 0.1 ms, its pick not regular there; with the ladder's finest step as the
yardstick no step could agree, and its calibrated maps ran uncalibrated at 0.1 ms). When no step of
the ladder reaches the target, the finest step is kept and the record says so.
The probe set is the same for every engine: for each pulse, at :data:`PROBE_W_RATIOS`, the cells just
below and just above the reference's overturning boundary (the lowest amplitude that overturns the
rigid block with the target η), :data:`PROBE_MARGIN` of the amplitude axis to either side, so a step
that moves the engine's boundary by more than that shows in the probes, and a cell
:data:`PROBE_DEEP` above it, where the table's strongest push tests the anti-slip contact. The search is cached
with the calibrations (:mod:`rockbench.engines.calibration.cache`), and its record (each step
compared: η at both steps and the probes that disagree) goes into run.json with the calibration.

The rule runs an engine through two functions it is given, so that it calls nothing that decides a
step itself: ``calibrate(dt_s)``, the calibration at a step, and ``answers(cases)``, the verdicts of
cases whose step is set (the contact base's, :func:`~rockbench.engines.calibration.time_step.step_for`,
hands them over).
"""

from __future__ import annotations

from rockbench.reference_solver.model import Block, a_ratio_to_amplitude, w_ratio_to_omega
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution
from rockbench.engines import progress
from rockbench.engines.contract import Case
from rockbench.engines.calibration.rigid import rigid_answers

__all__ = ["STEP_LADDER_S", "ETA_STEP_RTOL", "PROBE_W_RATIOS", "PROBE_MARGIN", "PROBE_DEEP", "PROBE_PULSES",
           "probe_cases", "converged_step"]

#: The steps tried, coarsest first [s]; 1 ms is the coarsest that follows every pulse of the default
#: maps (20 steps per wave at ω/p = 16 on B3M is 1.7 ms)
STEP_LADDER_S = (1e-3, 5e-4, 2e-4, 1e-4)
#: How far the calibrated η at two steps may lie apart (relative) and still agree [-]
ETA_STEP_RTOL = 0.01
#: Frequencies of the probe cells, ω/p [-], across the default maps' axis; a frequency where the
#: reference's lowest overturning amplitude lies above the axis (a₀/(g·tanα) 12) has no probes
PROBE_W_RATIOS = (1.5, 2.5, 3.5, 4.5, 6.0, 8.0, 10.0, 12.0)
#: Distance of a probe cell from the reference's boundary along a₀/(g·tanα) [-] (the default maps'
#: cells are 0.22 apart)
PROBE_MARGIN = 0.3
#: The pulses of the probe set
PROBE_PULSES = ("sine", "cosine")
#: Distance above the reference's boundary of the deep probe cell, along a₀/(g·tanα) [-]
PROBE_DEEP = 1.0
#: a₀/(g·tanα) searched for the reference's boundary [-]
_A_RANGE = (1.0, 12.0)


def _cell(block: Block, eta: float, pulse: str, w_ratio: float, a_ratio: float, dt_s: float | None = None) -> Case:
    """The case of one map cell (ω/p, a₀/(g·tanα)) with the constant restitution η."""
    return Case(block, make_pulse(pulse, a_ratio_to_amplitude(block, a_ratio), w_ratio_to_omega(block, w_ratio)),
                Restitution("constant", value=eta), dt_s)


def _reference_overturns(block: Block, eta: float, pulse: str, w_ratio: float, a_ratio: float) -> bool:
    return rigid_answers([_cell(block, eta, pulse, w_ratio, a_ratio)], 10.0)[0][0] == "overturn"


def _reference_boundary(block: Block, eta: float, pulse: str, w_ratio: float) -> float | None:
    """The lowest a₀/(g·tanα) of :data:`_A_RANGE` at which the rigid block with η overturns (a scan
    in steps of 0.5, then 8 halvings), None when none does."""
    lo, hi = _A_RANGE
    a = lo
    while a <= hi and not _reference_overturns(block, eta, pulse, w_ratio, a):
        a += 0.5
    if a > hi:
        return None
    below = max(lo, a - 0.5)
    if below == a:
        return a
    for _ in range(8):
        mid = 0.5 * (below + a)
        below, a = (below, mid) if _reference_overturns(block, eta, pulse, w_ratio, mid) else (mid, a)
    return a


def probe_cases(block: Block, eta: float) -> list[tuple[str, float, float]]:
    """The probe set for ``block`` and η: ``(pulse, ω/p, a₀/(g·tanα))`` just below, just above and
    well above the reference's boundary at each of :data:`PROBE_W_RATIOS` (module docstring)."""
    out = []
    for pulse in PROBE_PULSES:
        for w in PROBE_W_RATIOS:
            a_c = _reference_boundary(block, eta, pulse, w)
            if a_c is not None:
                out += [(pulse, w, max(_A_RANGE[0], a_c - PROBE_MARGIN)), (pulse, w, a_c + PROBE_MARGIN),
                        (pulse, w, a_c + PROBE_DEEP)]
    return out


def _answers(answers, block: Block, eta: float, probes: list, dt_s: float) -> list[tuple]:
    """Outcome (``failed`` for a cell the engine could not run) and validity of every probe cell,
    run calibrated at ``dt_s``."""
    cases = [_cell(block, eta, p, w, a, dt_s) for p, w, a in probes]
    with progress.activity("probe cells", unit="run"):
        progress.plan(len(cases))
        out = answers(cases)
        progress.advance(len(cases))
    return [(r.outcome or "failed", "valid" if r.valid else "invalid") for r in out]


def _run_at(calibrate, answers, block: Block, eta: float, probes: list, dt_s: float, runs: dict) -> tuple:
    """``(calibration, probe answers or None when it is not reached)`` at ``dt_s``, computed once
    and memoised in ``runs``."""
    if dt_s not in runs:
        rung = STEP_LADDER_S.index(dt_s) + 1 if dt_s in STEP_LADDER_S else "?"
        with progress.activity(f"ladder step {rung} of {len(STEP_LADDER_S)} ({1e3 * dt_s:g} ms)"):
            cal = calibrate(dt_s)
            runs[dt_s] = (cal, _answers(answers, block, eta, probes, dt_s) if cal.reached else None)
    return runs[dt_s]


def _compare(run_at, eta: float, probes: list, coarse: float, fine: float) -> dict:
    """One rung of the ladder: the calibrations at ``coarse`` and ``fine`` [s] and the probes that
    disagree (``run_at(dt)``: the calibration and the answers at a step, memoised)."""
    (c_cal, c_ans), (f_cal, f_ans) = (run_at(dt) for dt in (coarse, fine))
    differ = ([] if c_ans is None or f_ans is None else
              [f"{p} ω/p {w:g} a {a:.3g}: {' '.join(x)} vs {' '.join(y)}"
               for (p, w, a), x, y in zip(probes, c_ans, f_ans) if x != y])
    eta_ok = c_cal.reached and f_cal.reached and abs(c_cal.eta_measured - f_cal.eta_measured) <= ETA_STEP_RTOL * eta
    return {"dt_s": coarse, "finer_dt_s": fine, "eta": c_cal.eta_measured, "finer_eta": f_cal.eta_measured,
            "reached": bool(c_cal.reached and f_cal.reached), "probes_differ": differ,
            "agrees": bool(eta_ok and c_ans is not None and f_ans is not None and not differ)}


def converged_step(calibrate, answers, block: Block, eta: float) -> tuple[float, dict]:
    """The coarsest step of :data:`STEP_LADDER_S` at which an engine, calibrated to ``eta``, agrees
    with itself at the yardstick, the finest step at which its calibration is reached (module
    docstring), and the record of the search.

    Parameters
    ----------
    calibrate : callable
        ``calibrate(dt_s) -> CalibrationResult``: the engine's calibration of ``block`` to ``eta`` at a step.
    answers : callable
        ``answers(cases) -> list[CellResult]``: the engine's verdicts of cases whose step is set.
    block : Block
    eta : float
        The target η [-].
    """
    probes = probe_cases(block, eta)
    runs: dict = {}

    def run_at(dt_s: float) -> tuple:
        return _run_at(calibrate, answers, block, eta, probes, dt_s, runs)

    yardstick = next((dt for dt in reversed(STEP_LADDER_S) if run_at(dt)[0].reached), None)
    rungs = []
    for coarse in STEP_LADDER_S:
        if yardstick is None or coarse <= yardstick:
            break
        rungs.append(_compare(run_at, eta, probes, coarse, yardstick))
        if rungs[-1]["agrees"]:
            break
    agreed = bool(rungs and rungs[-1]["agrees"])
    chosen = rungs[-1]["dt_s"] if agreed else (yardstick or STEP_LADDER_S[-1])
    record = {"rule": "coarsest step agreeing with the finest calibrated step (calibrated η, probe outcomes and "
                      "validity)",
              "ladder_s": list(STEP_LADDER_S), "yardstick_dt_s": yardstick, "probes": len(probes),
              "compared": rungs, "dt_s": chosen, "converged": agreed}
    return chosen, record
