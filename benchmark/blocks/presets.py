"""The preset blocks: the paper's Table 1 (docs/physics.md §5), and two more medium blocks from the
range its average k was measured over. Aluminium, depth = width.

``k_average`` is the average impulse position of the free-rocking tests of nine blocks of one size
(0.8608 for b = 45 mm, h/b 1.5–9.75; 0.7306 for b = 60 mm); ``k_exact`` is the block's own measured
value, which only Table 1's four blocks have.

B2M, B4M, B5M, B7M and B8M (h/b 1.5, 3.0, 3.75, 5.25 and 6.0) are not in Table 1: they are medium blocks
(b = 45 mm) inside the range of the nine blocks whose average k the paper quotes (its §3.1), so Housner's
η and η_M with the size's average k are defined for them, and nothing else is (no exact k, no
shaking-table points). Their names are inferred: Table 1 numbers the slenderness in steps of 0.75 (B3:
h/b 2.25, B6: 4.5), so 1.5, 3.0, 3.75, 5.25 and 6.0 are steps 2, 4, 5, 7 and 8. Their mass is the mean
density of Table 1's four weighed blocks times the volume.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass

from rockbench.engines.calibration.held_out import NEIGHBOUR, SIBLING, CalibrateOn
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import Block
from rockbench.reference_solver.restitution import Restitution, housner_eta, modified_eta

#: What ``rockbench blocks`` and the docs say of a preset outside Table 1
NOT_IN_TABLE_1 = "not in Table 1 (paper's measured range)"


@dataclass(frozen=True)
class Preset:
    """One preset block.

    Attributes
    ----------
    name : str
        B3M, B6M, B3L, B6L (Table 1); B2M, B4M, B5M, B7M, B8M (the measured range).
    mass_kg, width_m, height_m : float
        As printed (Table 1) or derived (mass from the mean density) [kg], [m], [m].
    k_average : float
        The size's average impulse position for the modified restitution [-].
    k_exact : float or None
        The block's own measured impulse position [-]; None where none was measured.
    in_table_1 : bool
        Whether the block is one of Table 1's four (the paper's experiments and printed values).
    """

    name: str
    mass_kg: float
    width_m: float
    height_m: float
    k_average: float
    k_exact: float | None
    in_table_1: bool = True

    def block(self) -> Block:
        return Block(self.width_m, self.height_m, mass_kg=self.mass_kg, name=self.name)

    @property
    def h_over_b(self) -> float:
        """The slenderness h/b [-]."""
        return self.height_m / self.width_m

    def which_k(self, k: float) -> str | None:
        """``"average"`` or ``"exact"`` when ``k`` is this block's average or exact k (to the 4 decimals
        they are given with), else None."""
        if math.isclose(k, self.k_average, abs_tol=5e-5):
            return "average"
        if self.k_exact is not None and math.isclose(k, self.k_exact, abs_tol=5e-5):
            return "exact"
        return None

    def has_restitution(self, token) -> bool:
        """Whether the restitution spelling ``token`` is defined for this block: every one is but
        ``modified-exact`` on a block without a measured k."""
        return not (self.k_exact is None and str(token).strip().lower() == "modified-exact")

    def restitution(self, token, k: float | None = None, option: str = "--restitution") -> Restitution:
        """The restitution law ``token`` for this block (:meth:`Restitution.parse` with its average and
        exact k; ``k`` the CLI's ``--k``).

        Raises
        ------
        ConfigError
            ``modified-exact`` for a block without a measured k (one line: what to give instead), or
            anything :meth:`Restitution.parse` refuses.
        """
        if k is None and not self.has_restitution(token):
            raise ConfigError(f"{option} modified-exact: block {self.name} is {NOT_IN_TABLE_1} and has no measured k "
                              f"(only Table 1's {', '.join(TABLE_1)} have one); use housner, modified-average "
                              f"(k = {self.k_average:g}) or modified:K.")
        return Restitution.parse(token, k, k_average=self.k_average, k_exact=self.k_exact, option=option)

    def row(self) -> dict:
        """The block's row, with the derived values [SI]; ``k_exact`` and ``eta_modified_exact_k`` None
        where no k was measured, ``note`` saying where a block outside Table 1 comes from."""
        b = self.block()
        return {**b.to_dict(), "h_over_b": self.h_over_b, "k_average": self.k_average, "k_exact": self.k_exact,
                "eta_housner": housner_eta(b.alpha_rad),
                "eta_modified_average_k": modified_eta(b.alpha_rad, self.k_average),
                "eta_modified_exact_k": None if self.k_exact is None else modified_eta(b.alpha_rad, self.k_exact),
                "in_table_1": self.in_table_1, "note": None if self.in_table_1 else NOT_IN_TABLE_1}


#: Table 1 of the paper, by name
_TABLE_1 = (
    Preset("B3M", 0.5444, 0.045, 0.10125, 0.8608, 0.7595),
    Preset("B6M", 1.0896, 0.045, 0.2025, 0.8608, 0.8241),
    Preset("B3L", 1.2843, 0.060, 0.135, 0.7306, 0.7259),
    Preset("B6L", 2.5692, 0.060, 0.270, 0.7306, 0.7214),
)

#: The names of Table 1's blocks, in its order: the blocks of the paper's experiments and printed values
TABLE_1: tuple[str, ...] = tuple(p.name for p in _TABLE_1)

#: The mean density of Table 1's four weighed blocks [kg/m^3] (≈ 2649.5): the density of the blocks
#: outside it
MEAN_DENSITY_KG_M3 = sum(p.mass_kg / (p.width_m ** 2 * p.height_m) for p in _TABLE_1) / len(_TABLE_1)

#: Table 1's step of slenderness between block numbers (B3: 2.25, B6: 4.5) [-]
NAME_STEP_H_OVER_B = 0.75


def measured_range_block(h_over_b: float, size: Preset) -> Preset:
    """A block of slenderness ``h_over_b`` from the range the average k of ``size``'s size was measured
    over (h/b 1.5–9.75): ``size``'s width, depth and average k, named as Table 1 numbers its blocks
    (``B{h/b ÷ 0.75}`` and the size's letter), its mass from :data:`MEAN_DENSITY_KG_M3`, no exact k."""
    width = size.width_m
    height = h_over_b * width
    name = f"B{round(h_over_b / NAME_STEP_H_OVER_B)}{size.name[-1]}"
    return Preset(name, MEAN_DENSITY_KG_M3 * width * width * height, width, height, size.k_average, None,
                  in_table_1=False)


#: The slendernesses of the medium blocks from the measured range: Table 1's steps of 0.75 between 1.5 and
#: 6.0 that Table 1 does not hold (B2M, B4M, B5M, B7M, B8M)
MEASURED_RANGE_H_OVER_B = (1.5, 3.0, 3.75, 5.25, 6.0)

#: Every preset, by name, medium before large and by slenderness: B2M, B3M, B4M, B5M, B6M, B7M, B8M, B3L,
#: B6L (the medium blocks outside Table 1 from the measured range)
PRESETS: dict[str, Preset] = {p.name: p for p in sorted(
    (*_TABLE_1, *(measured_range_block(hb, _TABLE_1[0]) for hb in MEASURED_RANGE_H_OVER_B)),
    key=lambda p: (p.width_m, p.h_over_b))}


def no_exact_k_note(blocks) -> str | None:
    """The note a run, its plan and its report give for the presets among ``blocks`` (names) that have no
    measured k, so no reference map with the exact k's η_M; None when there is none."""
    names = [str(b).upper() for b in blocks]
    without = [n for n in names if n in PRESETS and PRESETS[n].k_exact is None]
    if not without:
        return None
    they, have = ("it is", "has") if len(without) == 1 else ("they are", "have")
    return (f"no modified-exact reference map for {', '.join(without)}: {they} {NOT_IN_TABLE_1} and {have} no "
            f"measured k (only Table 1's {', '.join(TABLE_1)} have one)")


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
    """A ``calibrate_on`` setting as written (``sibling``, ``neighbour`` or a preset's name, any case) as
    the engines take it: a :class:`~rockbench.engines.calibration.held_out.CalibrateOn` (the engines know no names).
    ``sibling`` picks among every preset (the other size of one slenderness), ``neighbour`` among Table
    1's blocks (the nearest other slenderness of the same size: B2M → B3M, B8M → B6M, B3M ↔ B6M,
    B3L ↔ B6L); a name is any preset. None, a Block or a CalibrateOn pass as they are. A ConfigError
    names the presets for anything else."""
    if not isinstance(value, str) or value.strip().lower() in ("", "none"):
        return value
    text = value.strip()
    if text.lower() == SIBLING:
        return CalibrateOn(None, tuple(p.block() for p in PRESETS.values()), SIBLING)
    if text.lower() == NEIGHBOUR:
        return CalibrateOn(None, tuple(PRESETS[n].block() for n in TABLE_1), NEIGHBOUR)
    if text.upper() in PRESETS:
        return CalibrateOn(PRESETS[text.upper()].block(), tuple(p.block() for p in PRESETS.values()))
    raise ConfigError(f"{engine} setting 'calibrate_on' must be {SIBLING!r}, {NEIGHBOUR!r} or a block name "
                      f"({', '.join(PRESETS)}), got {value!r}.")
