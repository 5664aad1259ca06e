"""What the verdict counts: each engine variant's scenarios, the clusters they replicate in, its
resolution in each, and which variants give the same answer.

Pure functions of a score document's ``pairs``; the statistics are in
:mod:`~rockbench.benchmark.scoring.statistics`, the verdict in :mod:`~rockbench.benchmark.scoring.verdict`.
docs/scores.md argues each rule:

- **A scenario** is one block × pulse of a variant: its primary value from the like-for-like pair.
- **A cluster** is what differs physically: slenderness (h/b) × pulse. Blocks of one slenderness and
  another size have the same α and η_H and the same reference map in the normalised plane, so they
  repeat a problem rather than pose a new one: the statistics average a cluster's sizes and count the
  cluster once.
- **Resolution.** A boundary is located on its grid to a tolerance (bisected below the cell, or at
  depth 0 known only to its cells), so each scenario's value carries its own error
  (:func:`resolution_sd`, measured against a 401 × 401 truth): a value's only error on the fixed
  suite, and both variants' errors make a paired difference's
  (:mod:`~rockbench.benchmark.scoring.statistics`).
- **Identical answers.** Two variants of one engine whose maps hold the same outcome in every cell of
  every scenario they share (or whose calibration says it picked the shipped settings) are one entry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.benchmark.scoring.labels import AS_SHIPPED, CALIBRATED, settings_class
from rockbench.benchmark.scoring.metrics import OFFSET, OFFSET_PERCENT, PRIMARY_METRIC, missing_boundary


@dataclass
class Scenario:
    """One block × pulse of a variant.

    Attributes
    ----------
    value : float
        Its primary value (NaN when nothing could be judged) [w/a units].
    sd : float
        The value's own error [w/a units]: measured on its two maps from their bisection's last
        intervals (score.json's ``cells.location_sd``,
        :func:`~rockbench.benchmark.scoring.metrics.location_sd`) where the pair has it, else the
        grid's resolution as measured once against a 401 × 401 truth (:func:`resolution_sd`).
    cell : float
        The cell diagonal of its grid [w/a units].
    cluster : tuple
        ``(slenderness h/b, pulse)``: the scenarios one cluster averages.
    gap : float
        Distance between the η_H and η_M (average k) reference boundaries of this block and pulse
        (NaN when the run has no such pair of references) [w/a units].
    cells_id : str or None
        A fingerprint of the engine map's outcomes (equal fingerprints: the same cells).
    held_out : bool
        The variant's calibration was made on another block than this one.
    missing_boundary : str
        ``"engine"`` or ``"reference"`` when that map has no boundary in the judged cells and the other
        has one (:func:`~rockbench.benchmark.scoring.metrics.missing_boundary`): ``value`` is then the
        map's diagonal, a placeholder, not a distance; ``""`` otherwise.
    counts : dict
        Its pair's cell counts (:data:`_SUMMED`): what a failure there gets wrong.
    sd_assumed : float
        :func:`resolution_sd` of its grid, kept beside a measured ``sd`` as a check [w/a units].
    sd_measured : bool
        Whether ``sd`` is the maps' own (``location_sd``) rather than :func:`resolution_sd`.
    offset, offset_percent : float
        Its signed boundary offset [w/a units] and that in % of the reference's critical amplitude
        (``boundary_offset``, ``boundary_offset_percent``: + the engine overturns earlier); NaN where the
        pair has none.
    """

    value: float
    sd: float
    cell: float
    cluster: tuple = ()
    gap: float = math.nan
    cells_id: str | None = None
    held_out: bool = False
    missing_boundary: str = ""
    counts: dict = field(default_factory=dict)
    offset: float = math.nan
    offset_percent: float = math.nan
    sd_assumed: float = math.nan
    sd_measured: bool = False

    @property
    def distance(self) -> float:
        """Its value where it is a distance; NaN for a placeholder (a missing boundary) [w/a units]."""
        return math.nan if self.missing_boundary else self.value


@dataclass
class Variant:
    """A variant's scenarios and what its verdict rests on."""

    name: str
    engine: str
    label: str
    settings: str
    scenarios: dict = field(default_factory=dict)    # (block, pulse) -> Scenario
    counts: dict = field(default_factory=dict)       # summed cell counts of its pairs
    cells_missing: int = 0
    shipped_note: str = ""                           # what its adapter says about its shipped settings
    equals_shipped: bool = False                     # its calibration picked the shipped settings
    in_sample: str = ""                              # held out: the variant calibrated on each block itself
    planted_factor: float | None = None              # planted: the factor on the reference's restitution

    @property
    def held_out_only(self) -> bool:
        """Every scenario is held out (a variant of the held-out check alone: no rank, no failing rule)."""
        return bool(self.scenarios) and all(s.held_out for s in self.scenarios.values())

    def finite(self) -> dict:
        """The in-sample scenarios with a distance (held-out ones are the held-out check's)."""
        return {k: s for k, s in self.scenarios.items() if math.isfinite(s.distance) and not s.held_out}

    def placeholders(self) -> list:
        """The in-sample scenarios (block, pulse) whose value is a placeholder for a missing boundary."""
        return [k for k, s in self.scenarios.items() if s.missing_boundary and not s.held_out]

    @property
    def value(self) -> float:
        """Mean of its scenarios' values (NaN without one) [w/a units]."""
        vals = [s.value for s in self.finite().values()]
        return sum(vals) / len(vals) if vals else math.nan


#: A scenario's own error from the grid at depth 0 (the boundary known only to its cells), as a share of
#: its cell diagonal [-]: the measured root mean square error of the cell-level boundary distance
#: against a grid eight times finer was 0.02–0.09 diagonals (metrics version 6); 0.1 is the largest,
#: rounded up. Also taken for depths 1–3, which were not measured.
RESOLUTION_SD_CELLS = 0.1

#: A scenario's own error from the grid for boundaries located below the cell, as a share of its cell
#: diagonal [-], by the bisection depth its pair is located to (the smaller of its two maps'): the
#: largest root mean square error measured against the 401 × 401 truth at that depth, over B3M and B6M ×
#: sine and cosine × η 0.5, 1 and 2 % below η_H and the grids measured at that depth, rounded up
#: (docs/scores.md, "The grid's resolution"; ``tests/measurements/probes/probe_resolution.py truth``).
#: Measured 0.0066 at depth 4 (51 × 51), 0.0082 at depth 5 (26 × 26 and 36 × 36), 0.0083 at depth 6
#: (26 × 26). A depth beyond the deepest measured takes the deepest's share.
RESOLUTION_SD_LOCATED = {4: 0.01, 5: 0.01, 6: 0.01}


def resolution_share(locate_depth: int = 0) -> float:
    """The share of the cell diagonal :func:`resolution_sd` takes at ``locate_depth`` [-]."""
    measured = [d for d in RESOLUTION_SD_LOCATED if d <= locate_depth]
    return RESOLUTION_SD_LOCATED[max(measured)] if measured else RESOLUTION_SD_CELLS


def resolution_sd(cell: float, locate_depth: int = 0) -> float:
    """The standard error of a scenario's boundary distance from the grid alone [w/a units]: a measured
    share of its cell diagonal ``cell`` at the bisection depth its boundaries are located to
    (:func:`resolution_share`).

    At depth 0 each boundary is known only to lie inside its cells, and where inside differs from map
    to map, so the distance between two maps' boundaries errs by up to a cell whatever their true
    distance; the error does not average out over a boundary's edges (along a stretch of boundary the
    edges share one phase against the grid and move together). Located below the cell, what is left
    is mostly what the grid still cannot see: the tip of a tongue between two nodes, a feature thinner
    than a cell that no node falls in, and where the reference's domain is decided by cells.
    """
    return max(cell, _TINY) * resolution_share(locate_depth)


#: The cell of a grid without one (one row or column), so that its error and failing limit are not 0.
_TINY = 1e-12


def items(v: Variant, held_out: bool = False) -> dict:
    """``{(block, pulse): (value, sd, cluster)}`` of a variant's scenarios with a distance (not a
    placeholder for a missing boundary), in-sample or held-out: the items of
    :mod:`~rockbench.benchmark.scoring.statistics`."""
    return {k: (s.value, s.sd, s.cluster) for k, s in v.scenarios.items()
            if math.isfinite(s.distance) and s.held_out == held_out}


def cluster_of(p: dict) -> tuple:
    """``(h/b, pulse)`` of a pair: its ``slenderness`` when score.json has it, else the Table 1 block's,
    else the block's name (a block of its own)."""
    s = p.get("slenderness")
    if s is None:
        pre = PRESETS.get(str(p["block"]).upper())
        s = round(pre.height_m / pre.width_m, 4) if pre else str(p["block"])
    return (s, p["pulse"])


def scenario_of(p: dict, gaps: dict | None = None) -> Scenario:
    """A pair of score.json as a scenario (``gaps``: :func:`reference_gaps` of the document)."""
    value = p["scores"].get(PRIMARY_METRIC)
    c = p.get("cells") or {}
    cell = math.hypot(float(c.get("w_step", 0.0)), float(c.get("a_step", 0.0)))
    depth = c.get("locate_depth", 0)
    assumed = resolution_sd(cell, int(depth or 0))
    measured = c.get("location_sd")
    missing = (missing_boundary(int(c["engine_crossings"]), int(c["reference_crossings"]))
               if "engine_crossings" in c and "reference_crossings" in c else "")
    sd = float(measured) if measured is not None and float(measured) > 0 else assumed
    return Scenario(math.nan if value is None else float(value), sd, max(cell, _TINY),
                    cluster_of(p), (gaps or {}).get((p["block"], p["pulse"]), math.nan),
                    p.get("engine_cells"), bool(p.get("held_out")), missing,
                    {k: int(p.get(k) or 0) for k in _SUMMED}, _float(p["scores"].get(OFFSET)),
                    _float(p["scores"].get(OFFSET_PERCENT)), assumed, measured is not None and float(measured) > 0)


def _float(x) -> float:
    return math.nan if x is None else float(x)


def reference_gaps(doc: dict) -> dict:
    """``{(block, pulse): distance}`` from score.json's ``reference_gaps``."""
    return {(g["block"], g["pulse"]): float(g["boundary_mean"]) for g in doc.get("reference_gaps", [])
            if g.get("boundary_mean") is not None}


_SUMMED = ("cells_in_domain", "reference_standing", "reference_overturn", "overturn_extra", "overturn_missed",
           "failed_in_domain", "invalid_in_domain")


def variants_of(doc: dict) -> list[Variant]:
    """The engine variants of a score document, each with its like-for-like pairs (all its pairs when
    it has none) as scenarios, in the document's order."""
    gaps = reference_gaps(doc)
    groups: dict[str, list[dict]] = {}
    for p in doc.get("pairs", []):
        groups.setdefault(p["variant"], []).append(p)
    out = []
    for name, ps in groups.items():
        use = [p for p in ps if p.get("like_for_like")] or ps
        first = use[0]
        v = Variant(name, first.get("engine", name), first.get("label") or name,
                    first.get("settings") or settings_class(None, name),
                    shipped_note=next((p["shipped_note"] for p in use if p.get("shipped_note")), ""),
                    equals_shipped=bool(use) and all(p.get("equals_shipped") is True for p in use),
                    in_sample=next((p["in_sample_variant"] for p in use if p.get("in_sample_variant")), ""),
                    planted_factor=_planted_factor(use))
        for p in use:
            v.scenarios[(p["block"], p["pulse"])] = scenario_of(p, gaps)
            for k in _SUMMED:
                v.counts[k] = v.counts.get(k, 0) + int(p.get(k) or 0)
            v.cells_missing += int(p.get("cells_missing") or 0)
        out.append(v)
    return out


def _planted_factor(pairs: list[dict]) -> float | None:
    """The restitution factor a planted variant's pairs record (``planted_eta_factor``), else None."""
    for p in pairs:
        f = p.get("planted_eta_factor")
        if isinstance(f, (int, float)) and not isinstance(f, bool) and math.isfinite(f):
            return float(f)
    return None


def identical(a: Variant, b: Variant) -> bool:
    """Whether two variants give one answer: one engine, the same scenarios, and in each the same cells
    (equal fingerprints), or one is the other's calibration that picked the shipped settings."""
    if a.engine != b.engine or set(a.scenarios) != set(b.scenarios) or not a.scenarios:
        return False
    if {a.settings, b.settings} == {CALIBRATED, AS_SHIPPED} and (a.equals_shipped or b.equals_shipped):
        return True
    return all(a.scenarios[k].cells_id is not None and a.scenarios[k].cells_id == b.scenarios[k].cells_id
               for k in a.scenarios)


def entries(variants: list[Variant]) -> list[list[Variant]]:
    """The variants grouped into entries of identical answers (:func:`identical`), in their order; an
    entry's first variant speaks for it."""
    out: list[list[Variant]] = []
    for v in variants:
        home = next((e for e in out if identical(e[0], v)), None)
        if home is None:
            out.append([v])
        else:
            home.append(v)
    return out
