"""Why Exudyn's results move with where its segments end, and what a per-step Python hook costs
(issue 49). Measures and prints; it passes or fails nothing.

    python tests/measurements/probes/probe_exudyn_segments.py [--record NAME]

1. Calibrated B3M sine cells (ω/p 2–5, a₀/(g·tanα) 1.5–5) run as the adapter runs them (``_Model``:
   InitializeSolver once, then ``SolveSteps`` per segment with ``it.endTime`` moved on), with segments
   of 500 steps (0.05 s, today's) and of 250, 400, 333 steps, and 500 steps with one segment of 237
   (an end at a non-multiple). Each against the 500-step run: the largest |Δθ| before that run's stop
   (floor 1's rule) and the first step that differs. Four variants, to tell the causes apart: the
   adapter's (a segment ends at ``t + n·Δt``, modified Newton), the end snapped to ``n·Δt``, the
   Jacobian refreshed at every step (``modifiedNewtonJacUpdatePerStep``, so the refresh
   ``SolveSteps`` forces at its entry changes nothing), and both.
2. The CPU cost of a per-step Python hook (``SetPostStepUserFunction``) returning True, per step, on
   a rocking cell, against none.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))   # tests/: the shared cell helper
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # tests/measurements/: records
from cells import cell_case  # noqa: E402
from records import write_record  # noqa: E402

from rockbench.engines.adapters import exudyn as X  # noqa: E402
from rockbench.engines.motion import run_steps, steps_of_times  # noqa: E402
from rockbench.engines.registry import get_adapter  # noqa: E402
from rockbench.reference_solver.classify import run_end  # noqa: E402

CELLS = [(w, a) for w in (2.0, 3.0, 4.0, 5.0) for a in (1.5, 2.5, 3.5, 5.0)]
SCHEDULES = {"250": [250], "400": [400], "333": [333], "500 with one of 237": [500, 500, 237, 500]}
VARIANTS = {"adapter": (False, False), "end at n·dt": (True, False), "Jacobian every step": (False, True),
            "both": (True, True)}
TOTAL_STEPS = 8000
#: the adapter's longest and shortest tails [s]
_TAILS = (X.ExudynAdapter.SETTINGS["tail_s"], X.ExudynAdapter.SETTINGS["min_tail_s"])


def _model(ad, case, jac_every_step: bool):
    res = ad.resolve(case.block, case.restitution, case.dt_s)
    m = X._Model(case.block, ad._contact(case.block, res), "inertial", True, case.dt_s, None)
    m.set_pulse(case.pulse)
    m.ss.timeIntegration.newton.modifiedNewtonJacUpdatePerStep = jac_every_step
    return m


def _run(m, schedule: list[int], snap: bool) -> np.ndarray:
    """The rows of ``TOTAL_STEPS`` steps in segments of ``schedule`` (its last length repeated)."""
    m.start(schedule[0], False)
    rows, done, i = [], 0, 0
    while done < TOTAL_STEPS:
        n = schedule[min(i, len(schedule) - 1)]
        if i:
            m.solver.it.endTime = ((done + n) * m.dt_s if snap else m.mbs.systemData.GetTime() + n * m.dt_s)
        m.solver.SolveSteps(m.mbs, m.ss)
        rows.append(m.rows())
        done, i = done + n, i + 1
    return np.concatenate(rows)


def _stop_row(rows: np.ndarray, case) -> int:
    """The row floor 1's end-of-run rule names (the run's last row where none)."""
    n_last, n_pulse, n_min = run_steps(case.dt_s, case.pulse.duration_s, *_TAILS)
    th, thd = -rows[1:, 3], -rows[1:, 6]
    end = run_end(steps_of_times(rows[1:, 0], case.dt_s), th, thd, alpha_rad=case.block.alpha_rad,
                  p_rad_s=case.block.p_rad_s, pulse_end_step=n_pulse, min_tail_step=n_min)
    return rows.shape[0] - 1 if end is None else end[0] + 1


def _difference(ref: np.ndarray, rows: np.ndarray, dt_s: float) -> dict:
    """``rows`` against ``ref`` (up to its stop) at the samples of the same step (t/Δt within 1e-6): the
    largest |Δθ| [rad], the first step whose time or θ is not bit-identical, and the largest |Δt| [s]."""
    key_ref, key = (np.round(r[:, 0] / dt_s, 6) for r in (ref, rows))
    common, i, j = np.intersect1d(key_ref, key, return_indices=True)
    d_theta, d_t = np.abs(rows[j, 3] - ref[i, 3]), np.abs(rows[j, 0] - ref[i, 0])
    differs = (d_theta > 0) | (d_t > 0)
    return {"max_dtheta_rad": float(d_theta.max()), "max_dt_s": float(d_t.max()), "samples": int(common.size),
            "first_differing_step": float(common[np.argmax(differs)]) if differs.any() else None}


def compare(ad) -> list[dict]:
    out = []
    for w, a in CELLS:
        case = ad.posed(cell_case("B3M", "sine", w, a))
        for variant, (snap, jac) in VARIANTS.items():
            m = _model(ad, case, jac)
            ref = _run(m, [500], snap)
            k = _stop_row(ref, case)
            fractional = int(np.sum(np.abs(ref[:k, 0] / case.dt_s - np.rint(ref[:k, 0] / case.dt_s)) > 1e-6))
            row = {"w_ratio": w, "a_ratio": a, "variant": variant, "stop_step": float(ref[k, 0] / case.dt_s),
                   "rows_at_reduced_steps": fractional}
            for name, sched in SCHEDULES.items():
                row[name] = _difference(ref[:k + 1], _run(m, sched, snap), case.dt_s)
            out.append(row)
            print(row, flush=True)
    return out


def hook_cost(ad) -> dict:
    case = ad.posed(cell_case("B3M", "sine", 4.0, 1.5))
    m = _model(ad, case, False)

    def best(hook) -> float:
        m.mbs.SetPostStepUserFunction(hook)
        out = min(_timed(m) for _ in range(3))
        m.mbs.SetPostStepUserFunction(0)
        return out
    none, trivial = best(0), best(lambda mbs, t: True)
    return {"cell": "B3M sine 4.0 1.5", "steps": TOTAL_STEPS, "us_per_step_without": 1e6 * none / TOTAL_STEPS,
            "us_per_step_with_hook": 1e6 * trivial / TOTAL_STEPS}


def _timed(m) -> float:
    c = time.process_time()
    _run(m, [500], False)
    return time.process_time() - c


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--record", help="write the figures as this benchmark record")
    args = ap.parse_args(argv)
    ad = get_adapter("exudyn")
    figures = {"segments": compare(ad), "hook": hook_cost(ad)}
    print(figures["hook"])
    if args.record:
        write_record(args.record, "Exudyn's θ with its segments ending elsewhere, against 500-step segments, per "
                     "cause removed; the CPU cost of a per-step Python post-step hook",
                     "python tests/measurements/probes/probe_exudyn_segments.py " + " ".join(argv or sys.argv[1:]),
                     figures, packages=("exudyn",))
    return 0


if __name__ == "__main__":
    sys.exit(main())
