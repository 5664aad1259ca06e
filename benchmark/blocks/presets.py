"""The paper's blocks (Table 1, docs/physics.md §5): aluminium, depth = width.

``k_average`` is the average impulse position of the free-rocking tests of nine blocks of one size
(0.8608 for b = 45 mm, 0.7306 for b = 60 mm); ``k_exact`` is the block's own measured value.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass

from ...engines.calibration.held_out import SIBLING, CalibrateOn
from ...reference_solver.errors import ConfigError
from ...reference_solver.model import Block
from ...reference_solver.restitution import housner_eta, modified_eta


@dataclass(frozen=True)
class Preset:
    """One block of Table 1.

    Attributes
    ----------
    name : str
        B3M, B6M, B3L or B6L.
    mass_kg, width_m, height_m : float
        As printed [kg], [m], [m].
    k_average, k_exact : float
        Impulse positions for the modified restitution [-].
    """

    name: str
    mass_kg: float
    width_m: float
    height_m: float
    k_average: float
    k_exact: float

    def block(self) -> Block:
        return Block(self.width_m, self.height_m, mass_kg=self.mass_kg, name=self.name)

    def which_k(self, k: float) -> str | None:
        """``"average"`` or ``"exact"`` when ``k`` is this block's average or exact k (to the 4 decimals
        they are given with), else None."""
        if math.isclose(k, self.k_average, abs_tol=5e-5):
            return "average"
        if math.isclose(k, self.k_exact, abs_tol=5e-5):
            return "exact"
        return None

    def row(self) -> dict:
        """The Table 1 row, with the derived values [SI]."""
        b = self.block()
        return {**b.to_dict(), "k_average": self.k_average, "k_exact": self.k_exact,
                "eta_housner": housner_eta(b.alpha_rad),
                "eta_modified_average_k": modified_eta(b.alpha_rad, self.k_average),
                "eta_modified_exact_k": modified_eta(b.alpha_rad, self.k_exact)}


#: Table 1 of the paper, by name
PRESETS: dict[str, Preset] = {p.name: p for p in (
    Preset("B3M", 0.5444, 0.045, 0.10125, 0.8608, 0.7595),
    Preset("B6M", 1.0896, 0.045, 0.2025, 0.8608, 0.8241),
    Preset("B3L", 1.2843, 0.060, 0.135, 0.7306, 0.7259),
    Preset("B6L", 2.5692, 0.060, 0.270, 0.7306, 0.7214),
)}


def get_preset(name: str) -> Preset:
    """The preset called ``name`` (case-insensitive), with a "did you mean" on a miss."""
    key = str(name).upper()
    if key in PRESETS:
        return PRESETS[key]
    close = difflib.get_close_matches(key, list(PRESETS), n=1, cutoff=0.3)
    hint = f" Did you mean {close[0]}?" if close else ""
    raise ConfigError(f"unknown block {name!r}; the presets are {', '.join(PRESETS)}.{hint} "
                      "Or give --width and --height for a custom block.")


def calibrate_on(value, engine: str):
    """A ``calibrate_on`` setting as written (``sibling`` or a preset's name, any case) as the engines take
    it: a :class:`~rockbench.engines.calibration.held_out.CalibrateOn` among the presets' blocks (the engines know no
    names); None, a Block or a CalibrateOn pass as they are. A ConfigError names the presets for
    anything else."""
    if not isinstance(value, str) or value.strip().lower() in ("", "none"):
        return value
    text = value.strip()
    among = tuple(p.block() for p in PRESETS.values())
    if text.lower() == SIBLING:
        return CalibrateOn(None, among)
    if text.upper() in PRESETS:
        return CalibrateOn(PRESETS[text.upper()].block(), among)
    raise ConfigError(f"{engine} setting 'calibrate_on' must be {SIBLING!r} or a block name ({', '.join(PRESETS)}), "
                      f"got {value!r}.")
