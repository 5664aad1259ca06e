"""Calibration knobs an adapter declares, and the candidates the shared search makes of them.

An adapter whose calibration is a grid over its contact knobs declares them
(:attr:`~rockbench.engines.skeleton.SteppedContactAdapter.CALIBRATION_KNOBS`, a tuple of
:class:`Knob`); the skeleton then runs the search (:meth:`~rockbench.engines.skeleton.SteppedContactAdapter._calibrate_knobs`):
every combination of the knobs' ladders (:func:`grid`), then a finer grid around the pick
(:func:`around`) or, for one knob that asks for it, the one bisection between the ladder's regular
neighbours that bracket the target; each candidate measured in free rocking and chosen by the one
pick (:func:`~rockbench.engines.pick.pick`).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

from ..reference_solver.model import Block

__all__ = ["Knob", "grid", "around"]


@dataclass(frozen=True)
class Knob:
    """One contact knob a calibration searches.

    Attributes
    ----------
    name : str
        The setting it sets (the key in the candidate's settings).
    unit : str
        Its unit (``"s"``, ``"N/m"``, ``""``).
    role : str
        ``"stiffness"``, ``"damping"`` or ``"other"``: what it moves (for the notes; the pick reads
        stiffness from the resting sink and damping from the adapter's ``_damping_ratio``).
    ladder : callable
        ``ladder(block, dt_s)``: the values tried first [unit].
    refine : tuple of float
        Factors applied to the pick's value for the finer grid around it [-].
    shipped : float or None
        The engine's own default [unit] (None: the engine ships none).
    minimum : callable or None
        ``minimum(block, dt_s)``: the smallest value a refined candidate may take [unit].
    bisect_steps : int
        For a calibration of this knob alone: instead of the finer grid, at most this many halvings
        between the first regular neighbours of the ladder that bracket the target (0: the finer grid).
    bisect_rtol : float
        Relative distance to the target that ends that bisection [-].
    """

    name: str
    unit: str
    role: str
    ladder: Callable[[Block, float], tuple]
    refine: tuple = (1.0,)
    shipped: float | None = None
    minimum: Callable[[Block, float], float] | None = None
    bisect_steps: int = 0
    bisect_rtol: float = 0.0025


def grid(knobs: tuple, block: Block, dt_s: float) -> list[dict]:
    """Every combination of the knobs' ladders, the first knob varying slowest."""
    return [dict(zip((k.name for k in knobs), values))
            for values in itertools.product(*(k.ladder(block, dt_s) for k in knobs))]


def around(knobs: tuple, point: dict, block: Block, dt_s: float) -> list[dict]:
    """The finer grid around ``point``: every combination of each knob's ``refine`` factors times its
    value, the point itself and values below a knob's ``minimum`` left out."""
    out = []
    for factors in itertools.product(*(k.refine for k in knobs)):
        if all(f == 1.0 for f in factors):
            continue
        c = {k.name: point[k.name] * f for k, f in zip(knobs, factors)}
        if all(k.minimum is None or c[k.name] >= k.minimum(block, dt_s) for k in knobs):
            out.append(c)
    return out
