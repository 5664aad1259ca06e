"""Calibrate on one block, run another of the same slenderness: the held-out check of calibration.

A contact engine calibrated on the block it maps is judged on the block it was fitted on. The setting
``calibrate_on`` of every contact engine names another block; the calibration (the contact knobs and
the time-step rule's step) runs on that block's geometry, and the settings it chooses are applied to
the mapped block. Only a block of the same slenderness h/b qualifies: it has the same α, hence the
same Housner η and the same reference map in the normalised plane, and differs in size alone, which is
what the check tests.

The names are those of the benchmark's block presets (Table 1), which live on the floor above
(:mod:`rockbench.benchmark.blocks.presets`); it hands them down with :func:`name_blocks` when it is
imported, so that this floor imports nothing above it. :data:`SIBLING` is the one other named block of
the mapped block's slenderness (B3M ↔ B3L, B6M ↔ B6L).
"""

from __future__ import annotations

import math
from typing import Mapping

from ..reference_solver.errors import ConfigError
from ..reference_solver.model import Block

__all__ = ["SIBLING", "name_blocks", "check_name", "calibration_block", "slenderness"]

#: ``calibrate_on`` value: the other named block of the mapped block's slenderness
SIBLING = "sibling"

#: The blocks ``calibrate_on`` may name, by upper-case name (filled by :func:`name_blocks`)
_NAMED: dict[str, Block] = {}

#: Relative tolerance of two slendernesses h/b that are one [-]
_RTOL = 1e-6


def name_blocks(blocks: Mapping[str, Block]) -> None:
    """Make ``blocks`` (name → block) the blocks ``calibrate_on`` may name."""
    _NAMED.update({str(k).upper(): b for k, b in blocks.items()})


def slenderness(block: Block) -> float:
    """h/b of ``block`` [-]."""
    return block.height_m / block.width_m


def check_name(value, engine: str) -> str | None:
    """A ``calibrate_on`` value as stored: None (calibrate on the mapped block itself), :data:`SIBLING`,
    or a known block name in upper case; a ConfigError for anything else."""
    if value is None or (isinstance(value, str) and value.strip().lower() in ("", "none")):
        return None
    text = str(value).strip()
    if text.lower() == SIBLING:
        return SIBLING
    if text.upper() in _NAMED:
        return text.upper()
    known = ", ".join(_NAMED) or "none known yet (they are the presets of rockbench.benchmark)"
    raise ConfigError(f"{engine} setting 'calibrate_on' must be {SIBLING!r} or a block name ({known}), got {value!r}.")


def _same(a: Block, b: Block) -> bool:
    return all(math.isclose(x, y, rel_tol=_RTOL) for x, y in ((a.width_m, b.width_m), (a.height_m, b.height_m),
                                                              (a.depth_m, b.depth_m), (a.mass_kg, b.mass_kg)))


def _one_slenderness(a: Block, b: Block) -> bool:
    return math.isclose(slenderness(a), slenderness(b), rel_tol=_RTOL)


def calibration_block(calibrate_on: str | None, block: Block) -> Block:
    """The block whose geometry the calibration of ``block``'s runs is made on: ``block`` itself when
    ``calibrate_on`` is None, else the block it names (:func:`check_name`).

    Raises
    ------
    ConfigError
        The named block has another slenderness than ``block``, or :data:`SIBLING` finds no other named
        block of its slenderness, or more than one.
    """
    if calibrate_on is None:
        return block
    here = f"block {block.name} (h/b {slenderness(block):.4g})"
    if calibrate_on == SIBLING:
        found = [b for b in _NAMED.values() if _one_slenderness(b, block) and not _same(b, block)]
        if len(found) != 1:
            which = f"{len(found)} ({', '.join(b.name for b in found)})" if found else "none"
            raise ConfigError(f"calibrate_on = {SIBLING}: {here} needs exactly one other named block of its "
                              f"slenderness, found {which}; name the block to calibrate on.")
        return found[0]
    on = _NAMED[calibrate_on]
    if not _one_slenderness(on, block):
        same = [n for n, b in _NAMED.items() if _one_slenderness(b, block) and not _same(b, block)]
        hint = f" ({', '.join(same)})" if same else ""
        raise ConfigError(f"calibrate_on = {calibrate_on}: {calibrate_on} has h/b {slenderness(on):.4g}, the mapped "
                          f"{here}; a held-out calibration needs a block of the same slenderness{hint}.")
    return on
