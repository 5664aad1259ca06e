"""The rigid block's answers a calibration measures an engine against: floor 1's solver on harmonic
cases, at the paper's step, as the reference engine answers them.

The time-step rule (:mod:`.step_rule`) places its probe cells around the rigid block's overturning
boundary, and the contact's price (:mod:`.price`) keeps the anti-slip cells where the rigid model
itself needs neither lift nor slip. Both read the rigid model here, from
:func:`~rockbench.reference_solver.solver.solve_batch` (the reference engine's own batch, its
classifier's rule compiled in) at :data:`~rockbench.reference_solver.solver.PAPER_DT_S`, so the
calibration floor needs no adapter.
"""

from __future__ import annotations

import numpy as np

from rockbench.reference_solver.classify import OUTCOME_FROM_CODE
from rockbench.reference_solver.validity import contact_flags
from rockbench.engines.contract import Case

__all__ = ["rigid_answers"]


def rigid_answers(cases: list[Case], friction: float) -> list[tuple[str, list[str]]]:
    """``(outcome, domain flags)`` of the rigid block for harmonic ``cases`` (sine, cosine or
    half-sine): the outcome (``rest``, ``rocking``, ``overturn``) and ``lift-required`` /
    ``slip-required`` with the friction coefficient μ ``friction`` [-] (:func:`contact_flags`), each
    case at the paper's step and the exact energy decision after its pulse."""
    from rockbench.reference_solver.solver import PAPER_DT_S, solve_batch   # numba on first use (start-up time)

    out: list = [None] * len(cases)
    groups: dict[tuple, list[int]] = {}
    for i, c in enumerate(cases):
        groups.setdefault((c.pulse.kind, bool(c.linearized)), []).append(i)
    for (kind, lin), idx in groups.items():
        sel = [cases[i] for i in idx]
        dts = np.array([c.pulse.check_dt(PAPER_DT_S) for c in sel])
        r = solve_batch(np.array([c.block.alpha_rad for c in sel]), np.array([c.block.p_rad_s for c in sel]),
                        np.array([c.eta for c in sel]), kind, np.array([c.pulse.omega_rad_s for c in sel]),
                        np.array([c.pulse.amplitude_mps2 for c in sel]), dt_s=dts, linearized=lin, mode="energy")
        for j, i in enumerate(idx):
            flags = contact_flags(float(r.min_normal_mg[j]), float(r.max_friction_ratio[j]), friction)
            out[i] = (OUTCOME_FROM_CODE[int(r.outcome[j])].value, flags)
    return out
