"""The one time-step resolver of a contact engine: :func:`step_for`, and the time-step rule's step, :func:`rule_step`.

Both are functions of the engine, not methods it inherits: an adapter declares its steps
(``own_dt_s``, ``fixed_dt_s``) and the contact base poses every case with :func:`step_for`
(:meth:`~rockbench.engines.contact.ContactEngine.posed`). The rule itself, the coarsest step at which a
calibrated engine's answer has converged, is :mod:`rockbench.engines.calibration.step_rule`'s; here it
is run on the engine (its calibration at a step, its verdicts of probe cases), cached on disk with
the calibrations (:mod:`rockbench.engines.calibration.cache`) and remembered per adapter, block, η
and settings.
"""

from __future__ import annotations

import weakref

from rockbench.reference_solver.errors import check_positive
from rockbench.reference_solver.model import Block
from rockbench.reference_solver.restitution import Restitution
from rockbench.reference_solver.rules import RULES_VERSION
from rockbench.engines import progress
from rockbench.engines.contract import CONTRACT_VERSION
from rockbench.engines.calibration import cache, held_out, layout, routine, step_rule

__all__ = ["step_for", "rule_step"]

#: the rule's records already read, per adapter: ``{adapter: {(block, η, settings): record}}`` (the
#: disk key, the engine's version among its parts, costs more to make than a short run, and a
#: calibrated cell asks for its step)
_RULE_STEPS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def step_for(ad, block: Block, eta: float, pulse=None, dt_s: float | None = None,
             restitution: Restitution | None = None) -> float:
    """The one time-step resolver of contact engine ``ad`` [s]: ``dt_s`` where given; as shipped the
    engine's own step (``own_dt_s``), never coarser than the pulse accepts, or where it ships none
    ``fixed_dt_s``; calibrated at the corners, the time-step rule's step (:func:`rule_step`) for the
    block the calibration is made on at the η it aims at there (its ``calibrate_on`` setting,
    :func:`~rockbench.engines.calibration.held_out.calibration_target` where
    ``restitution``, the law behind ``eta``, is given; else ``eta``), never coarser than the pulse
    accepts; otherwise (a contact given, a row along the base) ``fixed_dt_s``, the row's never coarser
    than the pulse accepts. Checked against ``pulse`` where one is given."""
    if dt_s is not None:
        dt = check_positive("--dt", dt_s, "s")
    elif ad.as_shipped():
        dt = ad.fixed_dt_s if ad.own_dt_s is None else _capped(ad.own_dt_s, pulse)
    elif not ad.calibrated():
        dt = ad.fixed_dt_s
    else:
        calibrate_on = ad.settings["calibrate_on"]
        on, target = (held_out.calibration_target(calibrate_on, block, restitution) if restitution is not None
                      else (held_out.calibration_block(calibrate_on, block), eta))
        rowed = layout.contact_layout(ad, on, target) == "distributed"
        dt = _capped(ad.fixed_dt_s if rowed else rule_step(ad, on, target)[0], pulse)
    return dt if pulse is None else pulse.check_dt(dt)


def rule_step(ad, block: Block, eta: float) -> tuple[float, dict]:
    """The time-step rule's step for ``block`` at η [s] in contact engine ``ad`` and its record
    (:func:`~rockbench.engines.calibration.step_rule.converged_step`), cached on disk with the
    calibrations; the search runs on ``block`` itself (``calibrate_on`` left out: its probe runs are of
    the block the step is for), so a held-out calibration shares the step of the block it names."""
    memo = (block.width_m, block.height_m, block.depth_m, block.mass_kg, round(float(eta), 12),
            tuple(sorted((k, str(v)) for k, v in ad.settings.items())))
    mine = _RULE_STEPS.setdefault(ad, {})
    if memo not in mine:
        mine[memo] = _searched(ad, block, eta)
    return float(mine[memo]["dt_s"]), mine[memo]


def _searched(ad, block: Block, eta: float) -> dict:
    """The record of the rule's search for ``block`` at η in ``ad``: the cached one, else searched
    (on the adapter without ``calibrate_on``) and cached."""
    key = cache.adapter_key(ad, contract=CONTRACT_VERSION, kind="step-rule", rules_version=RULES_VERSION,
                            block=[block.width_m, block.height_m, block.depth_m, block.mass_kg],
                            target=round(float(eta), 12), ladder=list(step_rule.STEP_LADDER_S),
                            probes=[step_rule.PROBE_W_RATIOS, step_rule.PROBE_MARGIN, step_rule.PROBE_DEEP,
                                    step_rule.PROBE_PULSES, step_rule.ETA_STEP_RTOL],
                            settings=sorted((k, str(v)) for k, v in ad.settings.items() if k != "calibrate_on"))
    rec = cache.load(key)
    if rec is None:
        on = ad._on_itself()   # noqa: SLF001 - the contact base's copy without calibrate_on
        with progress.activity(f"{ad.name}: time-step rule for {block.name} at η {eta:.4f}"):
            rec = step_rule.converged_step(lambda dt: routine.calibrate(on, block, eta, dt_s=dt), on._judged,
                                            block, eta)[1]
        cache.store(key, rec, ad.name)
    return rec


def _capped(dt: float, pulse) -> float:
    """``dt`` [s], never coarser than ``pulse`` accepts (:meth:`~rockbench.reference_solver.pulses.Pulse.max_dt_s`)."""
    return float(dt) if pulse is None else min(float(dt), pulse.max_dt_s())
