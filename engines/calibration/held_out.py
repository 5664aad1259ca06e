"""Calibrate on one block, run another of the same slenderness: the held-out check of calibration.

A contact engine calibrated on the block it maps is judged on the block it was fitted on. The setting
``calibrate_on`` of every contact engine names another block; the calibration (the contact knobs and
the time-step rule's step) runs on that block's geometry, and the settings it chooses are applied to
the mapped block. Only a block of the same slenderness h/b qualifies: it has the same α, hence the
same Housner η and the same reference map in the normalised plane, and differs in size alone, which is
what the check tests.

This floor knows no block names: an adapter's ``calibrate_on`` is a :class:`CalibrateOn` (or a
:class:`~rockbench.reference_solver.model.Block`, the block to calibrate on), which carries the blocks
themselves. The names (``sibling``, ``B3M``) are the benchmark's block presets (Table 1), on the floor
above: it turns them into a :class:`CalibrateOn` before they reach an adapter
(:mod:`rockbench.benchmark.engine_info.adapters`). :data:`SIBLING` asks for the one other block of the
mapped block's slenderness among those the :class:`CalibrateOn` offers (B3M ↔ B3L, B6M ↔ B6L).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ...reference_solver.errors import ConfigError
from ...reference_solver.model import Block

__all__ = ["SIBLING", "CalibrateOn", "check_setting", "calibration_block", "slenderness"]

#: ``calibrate_on`` as written: the other named block of the mapped block's slenderness
SIBLING = "sibling"

#: Relative tolerance of two slendernesses h/b that are one [-]
_RTOL = 1e-6


@dataclass(frozen=True)
class CalibrateOn:
    """What an adapter's ``calibrate_on`` holds: the block the calibration is made on (``block``), or,
    ``block`` None, the sibling: the one block of ``among`` of the mapped block's slenderness other than
    the mapped block. ``among`` are the named blocks (the benchmark's presets), which also name the
    blocks that would do in a refusal. ``str()`` gives the setting as written (``sibling``, ``B3M``):
    what run.json records."""

    block: Block | None = None
    among: tuple[Block, ...] = ()

    def __str__(self) -> str:
        return SIBLING if self.block is None else str(self.block.name).upper()


def slenderness(block: Block) -> float:
    """h/b of ``block`` [-]."""
    return block.height_m / block.width_m


def check_setting(value, engine: str) -> CalibrateOn | None:
    """A ``calibrate_on`` value as an adapter keeps it: None (calibrate on the mapped block itself), or a
    :class:`CalibrateOn` (a :class:`Block` is the block to calibrate on); a ConfigError for anything
    else, a block's name among them: names are resolved above this floor."""
    if value is None or (isinstance(value, str) and value.strip().lower() in ("", "none")):
        return None
    if isinstance(value, CalibrateOn):
        return value
    if isinstance(value, Block):
        return CalibrateOn(value)
    raise ConfigError(f"{engine} setting 'calibrate_on' takes a Block (the block to calibrate on) or a CalibrateOn, "
                      f"got {value!r}; a name (sibling, B3M) is the benchmark's: "
                      "rockbench.benchmark.engine_info.adapters.build_adapter resolves it, or pass "
                      "get_preset(NAME).block().")


def _same(a: Block, b: Block) -> bool:
    return all(math.isclose(x, y, rel_tol=_RTOL) for x, y in ((a.width_m, b.width_m), (a.height_m, b.height_m),
                                                              (a.depth_m, b.depth_m), (a.mass_kg, b.mass_kg)))


def _one_slenderness(a: Block, b: Block) -> bool:
    return math.isclose(slenderness(a), slenderness(b), rel_tol=_RTOL)


def calibration_block(calibrate_on: CalibrateOn | None, block: Block) -> Block:
    """The block whose geometry the calibration of ``block``'s runs is made on: ``block`` itself when
    ``calibrate_on`` is None, else the block it names (:class:`CalibrateOn`).

    Raises
    ------
    ConfigError
        The named block has another slenderness than ``block``, or :data:`SIBLING` finds no other named
        block of its slenderness, or more than one.
    """
    if calibrate_on is None:
        return block
    here = f"block {block.name} (h/b {slenderness(block):.4g})"
    others = [b for b in calibrate_on.among if _one_slenderness(b, block) and not _same(b, block)]
    if calibrate_on.block is None:
        if len(others) != 1:
            which = f"{len(others)} ({', '.join(b.name for b in others)})" if others else "none"
            raise ConfigError(f"calibrate_on = {SIBLING}: {here} needs exactly one other named block of its "
                              f"slenderness, found {which}; name the block to calibrate on.")
        return others[0]
    on, name = calibrate_on.block, str(calibrate_on)
    if not _one_slenderness(on, block):
        hint = f" ({', '.join(b.name for b in others)})" if others else ""
        raise ConfigError(f"calibrate_on = {name}: {name} has h/b {slenderness(on):.4g}, the mapped "
                          f"{here}; a held-out calibration needs a block of the same slenderness{hint}.")
    return on
