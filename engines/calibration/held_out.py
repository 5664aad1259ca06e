"""Calibrate on one block, run another: the held-out check of calibration.

A contact engine calibrated on the block it maps is judged on the block it was fitted on. The setting
``calibrate_on`` of every contact engine names another block; the calibration (the contact knobs and
the time-step rule's step) runs on that block's geometry, aimed at the restitution law's η *for that
block* (:func:`calibration_target`), and the settings it chooses are applied to the mapped block. Any
other block qualifies. One of the same slenderness h/b has the same α, Housner's η and reference map
in the normalised plane, and differs in size alone: that tests a change of size. One of another
slenderness has another α and so another Housner's η: the mapped block's η is then whatever the
calibrated contact gives it, which tests whether the contact model carries over to a new problem.

This floor knows no block names: an adapter's ``calibrate_on`` is a :class:`CalibrateOn` (or a
:class:`~rockbench.reference_solver.model.Block`, the block to calibrate on), which carries the blocks
themselves. The names (``sibling``, ``neighbour``, ``B3M``) are the benchmark's block presets, on the
floor above: it turns them into a :class:`CalibrateOn` before they reach an adapter
(:mod:`rockbench.benchmark.engine_info.adapters`). Two rules pick the block among those a
:class:`CalibrateOn` offers:

- :data:`SIBLING`: the one other block of the mapped block's slenderness (B3M ↔ B3L, B6M ↔ B6L);
- :data:`NEIGHBOUR`: among the blocks of the mapped block's width, the one of the nearest *other*
  slenderness (with Table 1's blocks offered: B2M → B3M, B3M → B6M, B6M → B3M, B8M → B6M;
  B3L ↔ B6L). A tie is refused: name the block.

A block never calibrates on itself: naming the mapped block is refused (leave ``calibrate_on`` out).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import Block

__all__ = ["SIBLING", "NEIGHBOUR", "RULES", "CalibrateOn", "check_setting", "calibration_block",
           "calibration_target", "slenderness"]

#: ``calibrate_on`` as written: the other named block of the mapped block's slenderness
SIBLING = "sibling"

#: ``calibrate_on`` as written: the named block of the mapped block's width and the nearest other slenderness
NEIGHBOUR = "neighbour"

#: The rules a :class:`CalibrateOn` without a block follows
RULES = (SIBLING, NEIGHBOUR)

#: Relative tolerance of two lengths or slendernesses that are one [-]
_RTOL = 1e-6


@dataclass(frozen=True)
class CalibrateOn:
    """What an adapter's ``calibrate_on`` holds: the block the calibration is made on (``block``), or,
    ``block`` None, a ``rule`` (:data:`SIBLING`, :data:`NEIGHBOUR`) that picks it among ``among``, the
    named blocks (the benchmark's presets), which also name the blocks that would do in a refusal.
    ``str()`` gives the setting as written (``sibling``, ``neighbour``, ``B3M``): what run.json records."""

    block: Block | None = None
    among: tuple[Block, ...] = ()
    rule: str = SIBLING

    def __post_init__(self):
        if self.block is None and self.rule not in RULES:
            raise ConfigError(f"calibrate_on rule must be one of {', '.join(RULES)}, got {self.rule!r}.")

    def __str__(self) -> str:
        return self.rule if self.block is None else str(self.block.name).upper()


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
                      f"got {value!r}; a name (sibling, neighbour, B3M) is the benchmark's: "
                      "rockbench.benchmark.engine_info.adapters.build_adapter resolves it, or pass "
                      "get_preset(NAME).block().")


def _close(x: float, y: float) -> bool:
    return math.isclose(x, y, rel_tol=_RTOL)


def _same(a: Block, b: Block) -> bool:
    return all(_close(x, y) for x, y in ((a.width_m, b.width_m), (a.height_m, b.height_m),
                                         (a.depth_m, b.depth_m), (a.mass_kg, b.mass_kg)))


def _one_slenderness(a: Block, b: Block) -> bool:
    return _close(slenderness(a), slenderness(b))


def _sibling(among: tuple[Block, ...], block: Block, here: str) -> Block:
    others = [b for b in among if _one_slenderness(b, block) and not _same(b, block)]
    if len(others) != 1:
        which = f"{len(others)} ({', '.join(b.name for b in others)})" if others else "none"
        raise ConfigError(f"calibrate_on = {SIBLING}: {here} needs exactly one other named block of its "
                          f"slenderness, found {which}; name the block to calibrate on.")
    return others[0]


def _neighbour(among: tuple[Block, ...], block: Block, here: str) -> Block:
    """The block of ``among`` of ``block``'s width whose slenderness is the nearest other one."""
    others = [b for b in among if _close(b.width_m, block.width_m) and not _one_slenderness(b, block)]
    if not others:
        raise ConfigError(f"calibrate_on = {NEIGHBOUR}: {here} has no named block of its width "
                          f"({block.width_m * 1e3:g} mm) and another slenderness; name the block to calibrate on.")
    gap = [abs(slenderness(b) - slenderness(block)) for b in others]
    nearest = [b for b, g in zip(others, gap) if _close(g, min(gap))]
    if len({round(slenderness(b), 6) for b in nearest}) > 1:
        raise ConfigError(f"calibrate_on = {NEIGHBOUR}: {here} lies as near to {nearest[0].name} as to "
                          f"{nearest[1].name}; name the block to calibrate on.")
    return nearest[0]


def calibration_block(calibrate_on: CalibrateOn | None, block: Block) -> Block:
    """The block whose geometry the calibration of ``block``'s runs is made on: ``block`` itself when
    ``calibrate_on`` is None, else the block it names or its rule picks (:class:`CalibrateOn`).

    Raises
    ------
    ConfigError
        The named block is ``block`` itself, or the rule finds no block (or, :data:`SIBLING`, more
        than one; :data:`NEIGHBOUR`, two at the same distance).
    """
    if calibrate_on is None:
        return block
    here = f"block {block.name} (h/b {slenderness(block):.4g})"
    if calibrate_on.block is None:
        pick = _sibling if calibrate_on.rule == SIBLING else _neighbour
        return pick(calibrate_on.among, block, here)
    on = calibrate_on.block
    if _same(on, block):
        raise ConfigError(f"calibrate_on = {calibrate_on}: that is the mapped {here} itself; a held-out "
                          f"calibration is made on another block (leave calibrate_on out to calibrate on "
                          f"the block itself).")
    return on


def calibration_target(calibrate_on: CalibrateOn | None, block: Block, restitution) -> tuple[Block, float]:
    """The block the calibration of ``block``'s runs is made on (:func:`calibration_block`) and the η
    it aims at there [-]: the restitution law's η for *that* block's α (Housner's η of the block
    calibrated on, not of the mapped one), so that a held-out calibration is the very calibration of
    the block it names."""
    on = calibration_block(calibrate_on, block)
    return on, restitution.eta(on.alpha_rad)
