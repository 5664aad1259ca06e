"""A planted restitution error in a contact engine (its ``planted_eta_factor`` setting, the suite's power
against an engine's own error, docs/scores.md): the calibration aims at the law's η times the factor,
with the contact layout and the time-step rule's step of the engine without it. Functions of the
engine: they read its settings only.
"""

from __future__ import annotations

import weakref

from rockbench.reference_solver.model import Block
from rockbench.reference_solver.restitution import Restitution
from rockbench.engines.contract import PLANTED
from rockbench.engines.calibration import held_out

__all__ = ["factor", "calibration_target", "unplanted"]

#: each planted engine's copy without its planted error (the time-step rule's engine), kept per adapter
_UNPLANTED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def factor(ad) -> float:
    """The factor contact engine ``ad``'s planted error puts on its calibration's target (1: none) [-]."""
    f = ad.settings.get(PLANTED)
    return 1.0 if f is None else float(f)


def calibration_target(ad, block: Block, restitution: Restitution) -> tuple[Block, float]:
    """The block ``ad``'s calibration for ``block`` is made on and the η it aims at there [-]: the law's η
    for that block (:func:`~rockbench.engines.calibration.held_out.calibration_target`, its
    ``calibrate_on`` setting) times :func:`factor` (the calibration cache keys the target)."""
    on, eta = held_out.calibration_target(ad.settings.get("calibrate_on"), block, restitution)
    return on, eta * factor(ad)


def unplanted(ad):
    """``ad``, or with a planted error a copy of it without one (made once per adapter)."""
    if factor(ad) == 1.0:
        return ad
    if ad not in _UNPLANTED:
        _UNPLANTED[ad] = type(ad)(**{**ad.settings, PLANTED: None})
    return _UNPLANTED[ad]
