"""The one calibration pick: which of the contact settings a search measured becomes the calibration.

Every contact engine's calibration measures candidate contact settings in free rocking (the
contact base's test, η read by :data:`~rockbench.engines.calibration.free_rocking.PEAK_RATIO`) and hands them here
as :class:`Candidate` records. The rule (:func:`pick`, argued in docs/engines.md):

1. **Regular**: a candidate counts only if it rocks like a block with one restitution coefficient:
   a finite η from at least two impacts whose spread (standard deviation) is at most
   :data:`CAL_MAX_SPREAD` of the target, and no hop: its lower bottom corner never rises more than
   :func:`hop_tol_m` above the table top (both corners in the air at once).
2. **Reached**: a regular candidate whose mean η lies within the reader's resolution of the target,
   :data:`ETA_RESOLUTION` (1 %): with four impacts whose spread may reach 2 % of the target, the mean
   is known to about 2 %/√4, so a closer η is not a better contact.
3. Among the reached, **the stiffest**: the least resting sink (the pivot's penetration while it
   carries the block, measured from the run's corners the same way for every engine,
   :func:`~rockbench.engines.calibration.free_rocking.contact_figures`); sinks within :func:`sink_tie_m` of the
   least count as equally stiff. Among those, **damping closest to critical** (the candidate's
   damping ratio ζ, 1 critical, ``|ln ζ|``; a candidate without a damping knob counts as critical),
   then the stiffer, then the closer η.
4. If none is reached: the regular candidate closest to the target, not reached; if none is regular,
   the finite one closest to it, not reached.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

from rockbench.reference_solver.model import Block
from rockbench.engines.calibration.free_rocking import FREE_ROCKING_IMPACTS

__all__ = ["Candidate", "Pick", "pick", "ranked", "regular", "irregular", "hops", "hop_tol_m", "sink_tie_m", "CAL_MAX_SPREAD",
           "ETA_RESOLUTION", "HOP_TOL_FRAC", "SINK_TIE_FRAC", "damping_ratio_of_restitution"]

#: Largest spread (standard deviation) of the per-impact η, as a fraction of the target, that a
#: calibrated setting may show: beyond it the block has no single restitution coefficient [-].
CAL_MAX_SPREAD = 0.02

#: The reader's resolution as a fraction of the target [-]: the mean of
#: :data:`~rockbench.engines.calibration.free_rocking.FREE_ROCKING_IMPACTS` impacts whose spread may reach
#: :data:`CAL_MAX_SPREAD` is known to ``CAL_MAX_SPREAD/√n`` (the reader's own error on the reference's
#: exact trajectories is below 2e-4 at Δt ≤ 2 ms, tests/engines/test_eta_reader.py).
ETA_RESOLUTION = CAL_MAX_SPREAD / math.sqrt(FREE_ROCKING_IMPACTS)

#: A hop in free rocking: the lower bottom corner higher than this fraction of b above the table
#: top [-]; a tenth of the validity rule's jump tolerance (0.5 % of b), since a contact that lets the
#: block fly in free rocking, the gentlest motion it has, flies further under a pulse.
HOP_TOL_FRAC = 5e-4

#: Resting sinks closer than this fraction of b count as equally stiff [-]: a fiftieth of the jump
#: tolerance, below anything the validity rule or the outcome can see.
SINK_TIE_FRAC = 1e-4


@dataclass(frozen=True)
class Candidate:
    """One contact setting a calibration measured in free rocking.

    Attributes
    ----------
    knobs : dict
        The contact settings tried (what the calibration records when it is picked).
    eta, eta_std : float
        Mean and spread of the per-impact η [-] (NaN: no impact measured).
    n_impacts : int
        Impacts measured [-].
    sink_m : float or None
        Resting sink: the pivot's median penetration over the release swing [m]; None: not measured.
    hop_m : float or None
        Highest clearance of the lower bottom corner above the table top over the run [m]; None:
        not measured.
    damping_ratio : float or None
        The contact's damping as a ratio to critical [-] (1: critical); None: the engine has no
        damping knob.
    extra : dict
        What the search records beside (not used by the pick).
    """

    knobs: dict
    eta: float
    eta_std: float
    n_impacts: int
    sink_m: float | None = None
    hop_m: float | None = None
    damping_ratio: float | None = None
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def of_row(cls, row: dict) -> "Candidate":
        """A search's row (the knobs and what free rocking measured: ``eta``, ``eta_std``, ``n``,
        ``sink_m``, ``hop_m``, ``damping_ratio``; the last three may be absent) as a candidate, the row
        its knobs."""
        return cls(row, row["eta"], row["eta_std"], row["n"], row.get("sink_m"), row.get("hop_m"),
                   row.get("damping_ratio"))


@dataclass(frozen=True)
class Pick:
    """The pick: the candidate, whether it reaches the target, and why (in words)."""

    candidate: Candidate
    reached: bool
    why: str


def hop_tol_m(block: Block) -> float:
    """Clearance of the lower bottom corner above which free rocking hops [m] (:data:`HOP_TOL_FRAC` of b)."""
    return HOP_TOL_FRAC * block.width_m


def sink_tie_m(block: Block) -> float:
    """Difference of resting sinks below which two contacts are equally stiff [m] (:data:`SINK_TIE_FRAC` of b)."""
    return SINK_TIE_FRAC * block.width_m


def hops(c: Candidate, block: Block | None) -> bool:
    """Whether the candidate's free rocking hops (False where its hop was not measured)."""
    return block is not None and c.hop_m is not None and c.hop_m > hop_tol_m(block)


def regular(c: Candidate, target: float, block: Block | None) -> bool:
    """Whether the candidate rocks regularly: a finite η from ≥ 2 impacts, spread within
    :data:`CAL_MAX_SPREAD` of the target, no hop."""
    return (math.isfinite(c.eta) and c.n_impacts >= 2 and math.isfinite(c.eta_std)
            and c.eta_std <= CAL_MAX_SPREAD * target and not hops(c, block))


def _damping_off(c: Candidate) -> float:
    return 0.0 if c.damping_ratio is None or not c.damping_ratio > 0 else abs(math.log(c.damping_ratio))


def ranked(candidates: list[Candidate], target: float, block: Block | None) -> list[Candidate]:
    """The reached candidates (regular, η within :data:`ETA_RESOLUTION` of the target) in the pick's
    order: the stiffest band first (sinks within :func:`sink_tie_m` of the least), inside a band
    damping closest to critical, then the least sink, then the closest η."""
    ok = [c for c in candidates if regular(c, target, block) and abs(c.eta - target) <= ETA_RESOLUTION * target]
    tie = sink_tie_m(block) if block is not None else 0.0
    out: list[Candidate] = []
    while ok:
        s_min = min(_sink(c) for c in ok)
        band = [c for c in ok if _sink(c) <= s_min + tie]
        out += sorted(band, key=lambda c: (_damping_off(c), _sink(c), abs(c.eta - target)))
        ok = [c for c in ok if not any(c is x for x in band)]
    return out


def _sink(c: Candidate) -> float:
    return 0.0 if c.sink_m is None or not math.isfinite(c.sink_m) else max(c.sink_m, 0.0)


def pick(candidates: list[Candidate], target: float, block: Block | None) -> Pick:
    """The calibration's pick among the measured ``candidates`` (module docstring); a ValueError
    when there are none."""
    if not candidates:
        raise ValueError("no candidate to pick from")
    best = ranked(candidates, target, block)
    if best:
        return Pick(best[0], True, "the stiffest regular setting within the reader's resolution")
    reg = [c for c in candidates if regular(c, target, block)]
    if reg:
        return Pick(min(reg, key=lambda c: abs(c.eta - target)), False, "the closest regular setting")
    finite = [c for c in candidates if math.isfinite(c.eta)]
    closest = min(finite or candidates, key=lambda c: abs(c.eta - target) if math.isfinite(c.eta) else math.inf)
    return Pick(closest, False, f"no regular setting: the closest ({irregular(closest, target, block)})")


def irregular(c: Candidate, target: float, block: Block | None) -> str:
    """Which of :func:`regular`'s tests the candidate fails, in words (each one it fails, joined by
    "and"; "" where it is regular): fewer than two impacts, a spread above :data:`CAL_MAX_SPREAD` of
    the target, a hop above :func:`hop_tol_m`."""
    failed = []
    if not (math.isfinite(c.eta) and c.n_impacts >= 2):
        failed.append(f"fewer than two impacts: {c.n_impacts}")
    elif not (math.isfinite(c.eta_std) and c.eta_std <= CAL_MAX_SPREAD * target):
        failed.append(f"spread above the bound: η std {c.eta_std:.4f} > {CAL_MAX_SPREAD:g} × target "
                      f"{CAL_MAX_SPREAD * target:.4f}")
    if hops(c, block):
        failed.append(f"a hop: {1e3 * c.hop_m:.3g} mm > {1e3 * hop_tol_m(block):.3g} mm")
    return " and ".join(failed)


def damping_ratio_of_restitution(e: float) -> float:
    """The damping ratio of a linear spring-dashpot whose bounce has restitution ``e`` [-]:
    ``e = exp(−πζ/√(1 − ζ²))``, so ``ζ = −ln e/√(π² + ln² e)`` (e → 0: critical)."""
    if not e > 0:
        return 1.0
    ln = math.log(min(e, 1.0))
    return -ln / math.sqrt(math.pi**2 + ln * ln)
