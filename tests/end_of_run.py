"""The engine tests' shared check that a run ended where the one end-of-run rule says."""

import numpy as np

from rockbench.engines.motion import run_steps
from rockbench.reference_solver.classify import run_end


def assert_ends_by_run_end(tr, case, dt_s: float, tail_s: float, min_tail_s: float, steps=None) -> str:
    """Assert that trajectory ``tr`` of ``case`` (step ``dt_s`` [s], tails [s]) ends at the first
    sample floor 1's ``run_end`` names, for the reason its ``ended_by`` gives, or, ended by the
    tail, at the run's last step with no sample named; ``steps``: the step number of every sample
    after sample 0 (default one sample per step). Returns how it ended."""
    n_last, n_pulse, n_min = run_steps(dt_s, case.pulse.duration_s, tail_s, min_tail_s)
    k = np.arange(1, tr.t_s.size, dtype=float) if steps is None else np.asarray(steps, dtype=float)
    assert k.size == tr.t_s.size - 1
    end = run_end(k, tr.theta_rad[1:], tr.theta_dot_rad_s[1:], alpha_rad=case.block.alpha_rad,
                  p_rad_s=case.block.p_rad_s, pulse_end_step=n_pulse, min_tail_step=n_min)
    why = tr.diagnostics["ended_by"]
    if why == "tail":
        assert end is None and k[-1] >= n_last - 0.5, (end, k[-1], n_last)
    else:
        assert end == (k.size - 1, why), (end, k.size - 1, why)
    return why
