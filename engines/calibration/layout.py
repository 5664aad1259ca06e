"""The contact a calibration builds in a contact engine: at its corners or a row of points along the base
(:func:`contact_layout`, docs/contact.md), and the engine with a calibration's contact given
(:func:`with_contact`). Functions of the engine: they read its settings and declarations only.
"""

from __future__ import annotations

from typing import Mapping

from rockbench.reference_solver.model import Block
from rockbench.reference_solver.restitution import housner_eta

__all__ = ["contact_layout", "with_contact"]


def contact_layout(ad, block: Block, target: float) -> str:
    """``corners`` or ``distributed``: the contact a calibration of contact engine ``ad`` to ``target``
    builds: its ``contact`` setting where it builds a row along the base (``CONTACT_ROWS``), else the
    corners; ``auto``: the corners up to 1 % above Housner's η_H, a row of points along the base above."""
    kind = ad.settings.get("contact") if ad.CONTACT_ROWS else "corners"
    if kind == "auto":
        kind = "corners" if target <= 1.01 * housner_eta(block.alpha_rad) else "distributed"
    return "distributed" if kind == "distributed" else "corners"


def with_contact(ad, contact: Mapping):
    """A copy of contact engine ``ad`` with the contact ``contact`` given (a calibration's settings: no
    calibration behind its runs; those that are no setting of the engine left out)."""
    given = {k: v for k, v in contact.items() if k in ad.SETTINGS}
    return type(ad)(**{**ad.settings, **given, "calibrate_on": None})
