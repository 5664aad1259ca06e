"""The cases whose θ(t) a benchmark run stores and its report draws: one block, pulse, ω/p and
a₀/(g·tanα) each, with the reference's impulse positions k (the paper's Fig. 17 case by default).

A case is written ``BLOCK:PULSE:W_RATIO:A_RATIO`` (``B3M:sine:6:6.1``) on the command line
(``rockbench report --case``) and in a suite file (``[report] cases``); :func:`parse_case` is the one
reader of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.blocks.presets import get_preset


@dataclass(frozen=True)
class TrajectoryCase:
    """One case whose θ(t) the report draws for the reference and every engine.

    Attributes
    ----------
    block : str
        A preset name.
    pulse : str
        ``sine``, ``cosine`` or ``half-sine``.
    w_ratio, a_ratio : float
        ω/p and a₀/(g·tanα) [-].
    reference_k : tuple of float
        Impulse positions k of the modified restitution for the reference curves [-] (besides the
        restitution laws of the engines' maps): the block's average k, and its exact k where it has one.
    title : str
        Caption.
    """

    block: str
    pulse: str
    w_ratio: float
    a_ratio: float
    reference_k: tuple = ()
    title: str = ""


#: The paper's Fig. 17: B3M, sine, ω/p = 6, a₀/(g·tanα) = 6.1 rocks with k = 0.8608 and
#: overturns with k = 0.7595 (paper §5.2, docs/physics.md §6).
FIG17 = TrajectoryCase("B3M", "sine", 6.0, 6.1, (0.8608, 0.7595),
                       "Fig. 17 case: B3M, sine, ω/p = 6, a₀/(g·tanα) = 6.1")

def parse_case(text: str, where: str = "--case"):
    """``BLOCK:PULSE:W_RATIO:A_RATIO`` into a TrajectoryCase (ConfigError when malformed).

    ``where`` names the option or suite key the text came from, for messages. The reference
    curves use the modified η with the block's average and exact k.
    """
    parts = str(text).split(":")
    if len(parts) != 4:
        raise ConfigError(f"{where} takes BLOCK:PULSE:W_RATIO:A_RATIO, got {text!r}; e.g. B3M:sine:6:6.1.")
    try:
        pre = get_preset(parts[0])
    except ConfigError as e:
        raise ConfigError(f"{where} {text!r}: {e}") from None
    block = pre.name
    pulse = parts[1].strip().lower()
    if pulse not in ("sine", "cosine", "half-sine"):
        raise ConfigError(f"{where} pulse must be sine, cosine or half-sine, got {parts[1]!r} in {text!r}.")
    try:
        w, a = float(parts[2]), float(parts[3])
    except ValueError:
        raise ConfigError(f"{where} W_RATIO and A_RATIO must be numbers, got {text!r}.") from None
    if not (0 < w < math.inf and 0 < a < math.inf):
        raise ConfigError(f"{where} W_RATIO and A_RATIO must be finite numbers > 0, got {text!r}.")
    # the reference is drawn with the block's average and exact k (where measured), as in the paper's Fig. 17
    return TrajectoryCase(block, pulse, w, a, tuple(k for k in (pre.k_average, pre.k_exact) if k is not None),
                          f"{block}, {pulse}, ω/p = {w:g}, a₀/(g·tanα) = {a:g}")
