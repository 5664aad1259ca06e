"""Scores of one stability map against another (pure numpy; no plotting, no file format).

A stability map is a grid of outcomes over the normalised axes ``w_ratio = ω/p`` (columns) and
``a_ratio = a₀/(g·tanα)`` (rows), both increasing. Each cell holds an outcome code
(:data:`~rockbench.reference_solver.classify.OUTCOME_CODES`: 0 rest, 1 rocking, 2 overturn) or
:data:`FAILED` (-1: no outcome, the simulation failed or the cell is missing), a validity flag
(False when the run broke the model's assumptions: an engine's slip, jump or energy gain, or a
reference trajectory that needs the table to pull the block down or more friction than μ; such a
cell still has the classifier's outcome), and whether the run left the rigid model through its
contact (an engine's ``slip`` or ``jump``, the reference's ``lift-required`` or ``slip-required``).

:func:`score` compares an *engine* map with a *reference* map over the same axes and returns the
metrics of :data:`METRICS` (:data:`METRICS_VERSION`). The rules, chosen so a gate cannot be passed by
failing and no engine is blamed for physics the reference cannot do:

- **The domain.** The headline metrics (agreement, IoU, boundary and critical-amplitude errors) are
  computed over the cells where the reference has an outcome *and is valid*: where the rigid
  model's own assumptions hold along its trajectory. Cells outside it are unknown to those
  metrics (like a failed cell: no located crossing lies on an edge to them).
- **Honesty outside the domain.** Where the reference needs lift-off or sliding, an engine is
  right to flag ``jump`` or ``slip``: ``consistency`` is the share of those cells where it does.
  ``spurious_invalid`` counts the engine's invalid cells inside the domain, where the rigid
  model says nothing should break.
- A reference cell that failed says nothing about the engine and is not judged.
- An engine cell that failed counts as wrong in every metric that compares outcomes.
- An invalid engine cell inside the domain is still judged by its outcome.
- The overturn region is a set of cells, not "everything above a curve": the thin safe band above
  the first overturn and the one-impact overturning tongue below it are handled by working on
  cells and cell edges only. The boundary between them is located below the cell on each edge by
  the map stage's bisection (:mod:`rockbench.benchmark.maps.bisection`), and the distances are
  from each located crossing to the other boundary's polyline (:func:`boundary_distance`).

``score(x, x)`` is perfect for every map ``x`` (tested).
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable, Iterable, Mapping

import numpy as np

from rockbench.reference_solver.classify import OUTCOME_CODES, Outcome
from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.errors import IncomparableError
from rockbench.benchmark.maps.bisection import ALONG_A, FAILED_EDGE, MULTIPLE, UNFINISHED
from rockbench.benchmark.maps.boundary import LocatedBoundary
from rockbench.benchmark.maps.result import FAILED, MapResult

#: Version of the metric definitions; bump when any definition below changes meaning.
METRICS_VERSION = "9"

REST = OUTCOME_CODES[Outcome.REST]
ROCKING = OUTCOME_CODES[Outcome.ROCKING]
OVERTURN = OUTCOME_CODES[Outcome.OVERTURN]


#: The direction of a signed metric: its size, not its sign, is how far from perfect it is.
NEARER_ZERO = "nearer zero"


@dataclass(frozen=True)
class Metric:
    """One score, as recorded in score.json.

    Attributes
    ----------
    name : str
        Key in the score dictionaries.
    definition : str
        What it measures, in one or two sentences.
    direction : str
        ``"higher"`` or ``"lower"`` is better, or :data:`NEARER_ZERO` for a signed metric (its absolute
        value lower is better).
    perfect : float
        The value of ``score(x, x)``.
    unit : str
        ``"-"`` for fractions and counts, ``"w/a units"`` for distances in the normalised plane
        (ω/p, a₀/(g·tanα)), ``"a units"`` for differences of a₀/(g·tanα).
    tolerance : float
        Default change in the worse direction that ``rockbench compare`` still accepts.
    question : str
        The question it answers, in one line (the report and ``score --help`` print it).
    role : str
        ``"primary"`` for :data:`PRIMARY_METRIC`, the one measure verdicts, ranks and highlights
        follow; ``"secondary"`` for every other.
    kind : str
        ``"fraction"`` (of cells, 0–1, four decimals), ``"distance"`` (three decimals) or
        ``"count"`` (a whole number): how tables write it and plots draw it.
    short : str
        Its column title on a terminal (narrow).
    title : str
        Its column title in the report, in words.
    cell_unit : str
        What one flipped cell changes it by, for ``compare``'s tolerances in cells
        (:func:`rockbench.benchmark.scoring.score_runs.cell_units` turns it into a number per pair):
        ``"1/judged"``, ``"1/overturn_union"``, ``"1/outside_simulated"``, ``"diagonal"`` (of a
        cell), ``"diagonal/a_lo %"`` (a diagonal in % of the grid's lowest amplitude), ``"a_step"``,
        ``"a_step/columns"`` or ``"one"``.
    value : callable
        How it is computed: ``value(c)`` for a :class:`Compared` pair (an engine map against its
        reference map) [its unit]. Only called when the pair has judged cells, unless ``always``.
    always : bool
        Computed even when the pair has no judged cell (else NaN then).
    axis_label : str
        Its axis title in the speed-against-accuracy picture (default: from its name and kind).
    version : str
        The :data:`METRICS_VERSION` its definition belongs to (a new or changed definition bumps both).

    A new metric is one more entry of :data:`METRICS` (with its ``value``) and a test of it: the
    scores, score.json, tables, the report, ``compare``'s tolerances and the pictures read it from
    here (docs/scores.md).
    """

    name: str
    definition: str
    direction: str
    perfect: float
    unit: str
    tolerance: float
    question: str = ""
    role: str = "secondary"
    kind: str = "distance"
    short: str = ""
    title: str = ""
    cell_unit: str = "one"
    value: Callable[["Compared"], float] | None = field(default=None, compare=False, repr=False)
    always: bool = False
    axis_label: str = ""
    version: str = METRICS_VERSION

    def worse(self, new: float, old: float, tol: float | None = None) -> bool:
        """True when ``new`` is worse than ``old`` by more than ``tol`` (default :attr:`tolerance`).

        NaN is worse than any number, and two NaNs are equal.
        """
        tol = self.tolerance if tol is None else tol
        if _isnan(new) or _isnan(old):
            return _isnan(new) and not _isnan(old)
        if self.direction == NEARER_ZERO:
            new, old = abs(new), abs(old)
        delta = (old - new) if self.direction == "higher" else (new - old)
        return delta > tol + 1e-12

    def format(self, value) -> str:
        """``value`` as tables write it: ``n/a`` when there is none, else by :attr:`kind`."""
        if _isnan(value):
            return "n/a"
        if self.kind == "count":
            return f"{int(round(value))}"
        return f"{value:.4f}" if self.kind == "fraction" else f"{value:.3f}"

    def to_dict(self) -> dict:
        return {"name": self.name, "definition": self.definition, "direction": self.direction,
                "perfect": self.perfect, "unit": self.unit, "tolerance": self.tolerance,
                "question": self.question, "role": self.role, "kind": self.kind, "title": self.title}


def _isnan(x) -> bool:
    return x is None or (isinstance(x, float) and math.isnan(x))


_METRIC_LIST = [
    Metric("agreement",
           "Fraction of judged cells (reference has an outcome) where the engine's outcome (rest, rocking, "
           "overturn) equals the reference's; a failed engine cell counts as a disagreement.",
           "higher", 1.0, "-", 0.005,
           question=("In how many judged cells does the engine give the reference's outcome? (Diluted by the "
                     "many easy cells far from the boundary.)"),
           kind="fraction", short="agree", title="agreement", cell_unit="1/judged",
           axis_label="cells whose outcome differs\nfrom the reference [%]",
           value=lambda c: float(np.count_nonzero(c.judged & (c.ce == c.cr)) / c.n)),
    Metric("overturn_agreement",
           "As agreement, with only two classes: overturn and not overturn.",
           "higher", 1.0, "-", 0.005,
           question="In how many judged cells does the engine get overturn-or-not right?",
           kind="fraction", short="agree O", title="overturn agreement", cell_unit="1/judged",
           value=lambda c: float(np.count_nonzero(c.overturn_agree) / c.n)),
    Metric("iou_overturn",
           "Intersection over union of the overturn regions over judged cells, |E∩R|/|E∪R∪F| with F the "
           "engine's failed cells (a failure never counts as a match); 1 when both regions are empty.",
           "higher", 1.0, "-", 0.01,
           question="How well do the two overturn regions overlap?",
           kind="fraction", short="IoU O", title="IoU of overturn regions", cell_unit="1/overturn_union",
           value=lambda c: c.iou_overturn),
    Metric("boundary_mean",
           "Mean distance, in the normalised plane (ω/p, a0/(g·tanα)), from each located crossing of one "
           "map's overturning boundary to the other map's boundary polyline (point to segment), both maps' "
           "crossings pooled, over the crossings in the reference's domain (judged by its runs right at the "
           "boundary, or by the edge's two cells). A crossing is located by bisecting "
           "a cell edge between a standing and an overturning cell (or inside a thin band) to the map's "
           "locate depth; the polyline joins the crossings by marching squares. 0 when both boundaries are "
           "empty; the map diagonal when only one is.",
           "lower", 0.0, "w/a units", 0.02,
           question="How far, on average, is the engine's overturning boundary from the reference's?",
           role="primary",
           short="bnd mean", title="boundary distance, mean", cell_unit="diagonal",
           axis_label="mean distance between the\noverturning boundaries\n(normalised ω/p, a₀/(g·tanα))",
           value=lambda c: c.boundary[0]),
    Metric("boundary_max",
           "Largest of those distances (the symmetric Hausdorff distance between the boundaries); same "
           "conventions for empty boundaries.",
           "lower", 0.0, "w/a units", 0.05,
           question="How far is the engine's boundary from the reference's at its worst point?",
           short="bnd max", title="boundary distance, max", cell_unit="diagonal",
           value=lambda c: c.boundary[1]),
    Metric("boundary_offset",
           "Mean signed normal offset of the engine's overturning boundary from the reference's, in the "
           "normalised plane, over the same crossings and distances as boundary_mean: each distance is "
           "positive where the engine's boundary lies on the reference's standing side (the engine overturns "
           "at a lower amplitude than the rigid model: less stable, conservative for a design) and negative "
           "on its overturning side (it overturns later); n/a when only one map has a boundary.",
           "nearer zero", 0.0, "w/a units", 0.02,
           question="Does the engine overturn too early (+) or too late (−), and by how much on average?",
           short="bnd offset", title="boundary offset, signed", cell_unit="diagonal",
           value=lambda c: c.offset[0]),
    Metric("boundary_offset_percent",
           "boundary_offset with each signed distance divided by the reference's critical amplitude "
           "a₀/(g·tanα) at its nearest reference crossing, in per cent: how much lower (+) or higher (−) "
           "than the rigid model's the engine's overturning amplitude is.",
           "nearer zero", 0.0, "% of a_crit", 1.0,
           question="By what share of the rigid model's overturning amplitude is the engine early (+) or late (−)?",
           short="offset %", title="boundary offset, % of a_crit", cell_unit="diagonal/a_lo %",
           value=lambda c: c.offset[1]),
    Metric("critical_error_mean",
           "Mean over frequency columns where at least one map overturns of |Δ a_crit|, with a_crit the "
           "LOWEST overturning a0/(g·tanα) of the column, located by the crossing on the edge below its lowest "
           "overturning cell; a column that does not overturn is censored half a grid step above the top of "
           "the axis (so that error is a lower bound).",
           "lower", 0.0, "a units", 0.02,
           question="How wrong is the lowest overturning amplitude, on average over the frequencies?",
           short="a_crit err", title="a_crit error, mean", cell_unit="a_step/columns",
           value=lambda c: c.critical["mean"]),
    Metric("critical_error_max",
           "Largest |Δ a_crit| over those columns (same censoring).",
           "lower", 0.0, "a units", 0.05,
           question="How wrong is the lowest overturning amplitude at the worst frequency?",
           short="a_crit max", title="a_crit error, max", cell_unit="a_step",
           value=lambda c: c.critical["max"]),
    Metric("critical_one_sided",
           "Number of frequency columns where only one of the two maps overturns.",
           "lower", 0.0, "-", 0.0,
           question="At how many frequencies does only one of the two overturn at all?",
           kind="count", short="1-sided", title="one-sided columns",
           value=lambda c: float(c.critical["one_sided"])),
    Metric("consistency",
           "Outside the reference's domain (cells where the rigid model needs the table to pull the block "
           "down or more friction than μ: lift-required, slip-required), the fraction of the engine's "
           "simulated cells where it flags jump or slip, as a real block would; n/a (null) when there is no "
           "such cell.",
           "higher", 1.0, "-", 0.01,
           question="Where the rigid model itself breaks down, does the engine say so (flag jump or slip)?",
           kind="fraction", short="consistent", title="consistency", cell_unit="1/outside_simulated",
           value=lambda c: _consistency(c.eng, c.outside), always=True),
    Metric("spurious_invalid",
           "Number of engine cells with an outcome flagged invalid (slip, jump, energy gain) inside the "
           "reference's domain, where the rigid model says nothing should break.",
           "lower", 0.0, "-", 0.0,
           question="Where the rigid model holds, how often does the engine flag slip, jump or energy gain?",
           kind="count", short="spurious inv", title="spurious invalid cells",
           value=lambda c: float(np.count_nonzero(c.judged & (c.ce != FAILED) & ~c.eng.valid))),
    Metric("failed_cells",
           "Number of cells where the reference has an outcome and the engine produced none (error, "
           "divergence, timeout, missing), inside the domain or outside it.",
           "lower", 0.0, "-", 0.0,
           question="How many cells did the engine fail to simulate?",
           kind="count", short="failed", title="failed cells",
           value=lambda c: float(np.count_nonzero((c.judged | c.outside) & (c.ce == FAILED))), always=True),
]

#: The metrics, by name, in the order tables show them.
METRICS: dict[str, Metric] = {m.name: m for m in _METRIC_LIST}

#: The one measure of how faithful an engine's overturning boundary is (docs/scores.md argues the
#: choice): verdicts, ranks, the summary's order and its highlights follow it.
PRIMARY_METRIC = "boundary_mean"
PRIMARY = METRICS[PRIMARY_METRIC]

#: The signed companions of the primary measure the verdict states beside it (+: the engine overturns
#: at a lower amplitude than the reference).
OFFSET, OFFSET_PERCENT = "boundary_offset", "boundary_offset_percent"


# -- the pieces ------------------------------------------------------------------------------------

def boundary_of(m: MapResult) -> LocatedBoundary:
    """The boundary a map's metrics read: its located boundary (the map stage's bisection), or for a map
    without one the depth-0 boundary of its cells, the midpoints of the edges between a standing and
    an overturning cell (:meth:`~rockbench.benchmark.maps.result.MapResult.boundary`)."""
    return m.boundary()


def boundary_points(m: MapResult) -> np.ndarray:
    """The located crossings of a map's boundary, shape (n, 2), columns (w_ratio, a_ratio) [w/a units].

    Both cells of a crossing's edge have an outcome; edges to failed cells and to the outside of the
    grid are not boundary."""
    return boundary_of(m).points


def point_segment_distances(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """For each point (shape (n, 2)), the distance to the nearest segment (shape (k, 2, 2), k ≥ 1; a
    segment of length 0 is a point) [w/a units]."""
    out = np.empty(points.shape[0])
    a, ab = segments[:, 0, :], segments[:, 1, :] - segments[:, 0, :]
    ab2 = np.einsum("kd,kd->k", ab, ab)
    for s in range(0, points.shape[0], 256):
        p = points[s:s + 256, None, :]
        u = np.einsum("nkd,kd->nk", p - a[None], ab)
        t = np.clip(np.divide(u, ab2, out=np.zeros_like(u), where=ab2 > 0), 0.0, 1.0)
        d = p - (a[None] + t[..., None] * ab[None])
        out[s:s + 256] = np.sqrt(np.min(np.einsum("nkd,nkd->nk", d, d), axis=1))
    return out


def boundary_distances(be: LocatedBoundary, br: LocatedBoundary) -> np.ndarray:
    """Each located crossing's distance to the other boundary's polyline (point to segment), the
    engine's crossings first [w/a units]; both boundaries non-empty."""
    return np.concatenate([point_segment_distances(be.points, br.segments()),
                           point_segment_distances(br.points, be.segments())])


def judged_crossings(eng: MapResult, ref: MapResult) -> tuple[np.ndarray, np.ndarray]:
    """Which located crossings of each map the boundary metrics count: ``(engine's, reference's)``,
    boolean over :func:`boundary_of`'s crossings.

    The domain is the reference's, known at the boundary below the cell: a reference crossing counts
    when both cells of its edge are judged (:func:`judged_cells`), or when the reference's runs on
    both sides of it (the ends of its last bisection interval) are valid and the engine map has both
    cells; an engine crossing counts when both cells of its edge are judged, or when the nearest
    reference crossing, within one cell diagonal, counts. A domain known only to the cell would count
    a stretch of boundary or not by where the grid's nodes fall against lift-off regions thinner than
    a cell (docs/scores.md, "The grid's resolution")."""
    judged, _ = judged_cells(eng, ref)
    have = ~missing(eng)
    be, br = boundary_of(eng), boundary_of(ref)

    def both(b, mask):
        return mask[tuple(b.cell_a.T)] & mask[tuple(b.cell_b.T)] if b.n_crossings else np.zeros(0, bool)

    count_r = both(br, judged) | (br.valid & both(br, have))
    count_e = both(be, judged)
    if be.n_crossings and br.n_crossings:
        w, a = ref.w_ratio, ref.a_ratio
        diag = math.hypot(w[1] - w[0] if w.size > 1 else 0.0, a[1] - a[0] if a.size > 1 else 0.0)
        near, k = _nearest(be.points, br.points)
        count_e |= (near <= diag) & count_r[k]
    return count_e, count_r


def _nearest(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each point of ``src``, the distance to the nearest point of ``dst`` and its index (both non-empty)."""
    dist, idx = np.empty(src.shape[0]), np.empty(src.shape[0], np.int64)
    for s in range(0, src.shape[0], 1024):
        d = src[s:s + 1024, None, :] - dst[None, :, :]
        d2 = np.einsum("ijk,ijk->ij", d, d)
        idx[s:s + 1024] = np.argmin(d2, axis=1)
        dist[s:s + 1024] = np.sqrt(d2[np.arange(d2.shape[0]), idx[s:s + 1024]])
    return dist, idx


def boundary_distance(eng: MapResult, ref: MapResult) -> tuple[float, float]:
    """(mean, max) distance between the overturn boundaries over the crossings both maps' metrics count
    (:func:`judged_crossings`), each to the other map's whole polyline [w/a units].

    See :data:`METRICS` ``boundary_mean`` and ``boundary_max``. Symmetric in its arguments where the
    reference is valid everywhere.
    """
    be, br = boundary_of(eng), boundary_of(ref)
    ce, cr = judged_crossings(eng, ref)
    if not ce.any() and not cr.any():
        return 0.0, 0.0
    if missing_boundary(int(ce.sum()), int(cr.sum())):
        diag = math.hypot(ref.w_ratio[-1] - ref.w_ratio[0], ref.a_ratio[-1] - ref.a_ratio[0])
        return diag, diag
    d = np.concatenate([point_segment_distances(be.points[ce], br.segments()),
                        point_segment_distances(br.points[cr], be.segments())])
    return float(d.mean()), float(d.max())


def overturn_normals(b: LocatedBoundary, m: MapResult) -> np.ndarray:
    """For each crossing of ``m``'s boundary ``b``, the unit vector of the normalised plane along its edge
    pointing from the standing cell to the overturning one, shape (n, 2) (w, a); where both cells of the
    edge stand or both overturn (a thin band inside the edge), +a: overturning lies at higher amplitude."""
    if b.n_crossings == 0:
        return np.zeros((0, 2))
    ov = m.outcome == OVERTURN
    ov_a, ov_b = ov[tuple(b.cell_a.T)], ov[tuple(b.cell_b.T)]
    step = np.column_stack([b.cell_b[:, 1] - b.cell_a[:, 1], b.cell_b[:, 0] - b.cell_a[:, 0]]).astype(float)
    sign = np.where(ov_b & ~ov_a, 1.0, np.where(ov_a & ~ov_b, -1.0, 0.0))
    out = step * sign[:, None]
    out[sign == 0] = (0.0, 1.0)
    return out


def boundary_offset(eng: MapResult, ref: MapResult) -> tuple[float, float]:
    """The signed ``boundary_mean``: (mean [w/a units], mean in % of the reference's critical amplitude).

    Over the crossings :func:`boundary_distance` averages, each point-to-polyline distance gets the sign
    of the side of the other boundary it lies on, read from the nearest crossing of the other map and
    that crossing's :func:`overturn_normals`: an engine crossing on the reference's standing side, or a
    reference crossing on the engine's overturning side, is +, the engine overturning at lower
    amplitude. The per-cent form divides each signed distance by the a₀/(g·tanα) of the nearest
    reference crossing (the reference's critical amplitude there). (0, 0) when neither map has a
    boundary; NaN when only one has (:func:`missing_boundary`)."""
    be, br = boundary_of(eng), boundary_of(ref)
    ce, cr = judged_crossings(eng, ref)
    if not ce.any() and not cr.any():
        return 0.0, 0.0
    if missing_boundary(int(ce.sum()), int(cr.sum())):
        return math.nan, math.nan
    pe, pr = be.points[ce], br.points[cr]
    ne, nr = overturn_normals(be, eng)[ce], overturn_normals(br, ref)[cr]
    _, ke = _nearest(pe, pr)
    _, kr = _nearest(pr, pe)
    side_e = -np.sign(np.einsum("ij,ij->i", pe - pr[ke], nr[ke]))   # on the reference's overturning side: late
    side_r = np.sign(np.einsum("ij,ij->i", pr - pe[kr], ne[kr]))    # on the engine's overturning side: early
    signed = np.concatenate([side_e * point_segment_distances(pe, br.segments()),
                             side_r * point_segment_distances(pr, be.segments())])
    a_crit = np.concatenate([pr[ke, 1], pr[:, 1]])
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(a_crit > 0, signed / a_crit, np.nan)
    percent = 100.0 * float(np.nanmean(share)) if np.isfinite(share).any() else math.nan
    return float(signed.mean()), percent


def missing_boundary(engine_crossings: int, reference_crossings: int) -> str:
    """Which map has no boundary that the metrics count while the other has one: ``"engine"``,
    ``"reference"`` or ``""`` (both have one, or neither). Where one side lacks a boundary,
    ``boundary_mean`` and ``boundary_max`` are the map's diagonal, a placeholder for "no boundary" and
    not a distance: the verdict reports such a scenario as what failed, never in a mean
    (:mod:`rockbench.benchmark.scoring.failing`). The counts are :func:`judged_crossings`' (score.json's
    ``cells.engine_crossings`` and ``cells.reference_crossings``)."""
    if (engine_crossings > 0) == (reference_crossings > 0):
        return ""
    return "engine" if engine_crossings == 0 else "reference"


def critical_amplitude(m: MapResult) -> np.ndarray:
    """The lowest overturning a₀/(g·tanα) of each frequency column [-]; NaN where none overturns.

    The located crossing on the edge below the column's lowest overturning cell (the lowest one when
    a band gives it two), else (the cell is in the bottom row, or that edge has no crossing) the
    cell's own a₀/(g·tanα). This is the lowest overturning cell, not the lower edge of "everything
    above a curve": a column whose overturn region starts with the one-impact tongue reports the tongue.
    """
    ov = m.outcome == OVERTURN
    first = np.argmax(ov, axis=0)
    crit = np.where(ov.any(axis=0), m.a_ratio[first], np.nan)
    b = boundary_of(m)
    below = (b.axis == ALONG_A) & (b.cell_b[:, 0] == first[b.cell_b[:, 1]]) & ov[b.cell_b[:, 0], b.cell_b[:, 1]]
    for k in np.nonzero(below)[0][np.argsort(-b.points[below, 1])]:   # the lowest crossing last
        crit[b.cell_b[k, 1]] = b.points[k, 1]
    return crit


def critical_errors(eng: MapResult, ref: MapResult) -> dict:
    """Per-column critical amplitudes and their errors (see :data:`METRICS`).

    Returns
    -------
    dict
        ``a_crit_engine``, ``a_crit_reference`` (arrays, NaN where a column does not overturn),
        ``abs_error`` (array, NaN where neither overturns), ``mean``, ``max`` and ``one_sided``.
    """
    ce, cr = critical_amplitude(eng), critical_amplitude(ref)
    a = ref.a_ratio
    step = a[-1] - a[-2] if a.size > 1 else 1.0
    censor = a[-1] + 0.5 * step   # where a first overturn one step above the axis would cross at depth 0
    any_ov = ~(np.isnan(ce) & np.isnan(cr))
    err = np.where(any_ov, np.abs(np.nan_to_num(ce, nan=censor) - np.nan_to_num(cr, nan=censor)), np.nan)
    one_sided = int(np.count_nonzero(np.isnan(ce) != np.isnan(cr)))
    if any_ov.any():
        mean, mx = float(np.nanmean(err)), float(np.nanmax(err))
    else:
        mean = mx = 0.0
    return {"a_crit_engine": ce, "a_crit_reference": cr, "abs_error": err, "mean": mean, "max": mx,
            "one_sided": one_sided}


def domain(ref: MapResult) -> tuple[np.ndarray, np.ndarray]:
    """``(inside, outside)``: the reference's cells with an outcome where it is valid, and where it is not."""
    has = ref.outcome != FAILED
    return has & ref.valid, has & ~ref.valid


def missing(m: MapResult) -> np.ndarray:
    """Cells a map does not have at all: neither simulated nor inferred (an unfinished or damaged map,
    scored only with ``--allow-incomplete``). A cell that was simulated and failed is not missing."""
    return (m.outcome == FAILED) & ~m.simulated


def score(eng: MapResult, ref: MapResult) -> dict[str, float]:
    """Every metric of :data:`METRICS` for an engine map against a reference map.

    Cells the engine map does not have (:func:`missing`) are left out of every metric, as if the
    reference had no outcome there; a metric with no cell to judge is NaN (``null`` in score.json,
    "n/a" in tables), never its perfect value.

    Raises
    ------
    IncomparableError
        The maps lie on different grids.
    """
    if not eng.same_axes(ref):
        raise IncomparableError(
            f"the maps lie on different grids (engine {eng.shape[1]}×{eng.shape[0]} cells over ω/p "
            f"{eng.w_ratio[0]:g}..{eng.w_ratio[-1]:g}, a-ratio {eng.a_ratio[0]:g}..{eng.a_ratio[-1]:g}; reference "
            f"{ref.shape[1]}×{ref.shape[0]} over {ref.w_ratio[0]:g}..{ref.w_ratio[-1]:g}, "
            f"{ref.a_ratio[0]:g}..{ref.a_ratio[-1]:g}); compute both with the same --w-ratio and --a-ratio.")
    c = Compared(eng, ref)
    if c.n == 0:
        return {name: m.value(c) if m.always else math.nan for name, m in METRICS.items()}
    return {name: m.value(c) for name, m in METRICS.items()}


class Compared:
    """An engine map against its reference map, as the metrics' ``value`` functions read it: the
    judged cells and those outside the reference's domain (:func:`judged_cells`), their number ``n``,
    both maps' outcome codes (``ce``, ``cr``), and what several metrics share, each computed once
    when first read (the boundary distances, the critical amplitudes' errors)."""

    def __init__(self, eng: MapResult, ref: MapResult):
        self.eng, self.ref = eng, ref
        self.judged, self.outside = judged_cells(eng, ref)
        self.n = int(self.judged.sum())
        self.ce, self.cr = eng.outcome, ref.outcome

    @cached_property
    def eng_failed(self) -> np.ndarray:
        return self.judged & (self.ce == FAILED)

    @cached_property
    def overturn_agree(self) -> np.ndarray:
        """Judged cells where the engine has an outcome and gets overturn-or-not right."""
        return self.judged & ~self.eng_failed & ((self.ce == OVERTURN) == (self.cr == OVERTURN))

    @cached_property
    def iou_overturn(self) -> float:
        oe, orr = self.judged & (self.ce == OVERTURN), self.judged & (self.cr == OVERTURN)
        union = np.count_nonzero(oe | orr | self.eng_failed)
        return 1.0 if union == 0 else float(np.count_nonzero(oe & orr) / union)

    @cached_property
    def inside(self) -> tuple[MapResult, MapResult]:
        """Both maps with only the judged cells known (:func:`within`)."""
        return within(self.eng, self.judged), within(self.ref, self.judged)

    @cached_property
    def boundary(self) -> tuple[float, float]:
        """:func:`boundary_distance` (mean, max) over the crossings in the reference's domain."""
        return boundary_distance(self.eng, self.ref)

    @cached_property
    def offset(self) -> tuple[float, float]:
        """:func:`boundary_offset` (signed mean [w/a units], signed mean in % of a_crit)."""
        return boundary_offset(self.eng, self.ref)

    @cached_property
    def critical(self) -> dict:
        """:func:`critical_errors` of the judged cells."""
        return critical_errors(*self.inside)


def judged_cells(eng: MapResult, ref: MapResult) -> tuple[np.ndarray, np.ndarray]:
    """:func:`domain` less the cells the engine map does not have."""
    inside, outside = domain(ref)
    have = ~missing(eng)
    return inside & have, outside & have


def within(m: MapResult, cells: np.ndarray) -> MapResult:
    """``m`` with only ``cells`` known: boundaries and critical amplitudes see only the domain, since
    outside it both maps are unknown (a located crossing counts when both cells of its edge are in)."""
    out = MapResult.from_outcomes(m.w_ratio, m.a_ratio, np.where(cells, m.outcome, FAILED))
    out.located = boundary_of(m).within(cells)
    return out


def boundary_edges(eng: MapResult, ref: MapResult) -> int:
    """How many located crossings (both maps', :func:`judged_crossings`) ``boundary_mean`` averages over."""
    ce, cr = judged_crossings(eng, ref)
    return int(ce.sum() + cr.sum())


def located_counts(eng: MapResult, ref: MapResult) -> dict[str, int]:
    """What the boundary metrics rest on, for score.json's ``cells``: the bisection depth the pair is
    located to (the smaller of the two maps'), the located crossings the metrics count
    (:func:`judged_crossings`), within the judged cells the edges flagged ``multiple`` (islands,
    tongues inside one edge) or ``failed``, and the distance's error from the bisection's own
    intervals (``location_sd``, :func:`location_sd`; None without a crossing)."""
    judged, _ = judged_cells(eng, ref)
    be, br = boundary_of(eng), boundary_of(ref)
    ie, ir = be.within(judged), br.within(judged)
    ce, cr = judged_crossings(eng, ref)
    return {"locate_depth": int(min(be.depth, br.depth)), "engine_locate_depth": int(be.depth),
            "reference_locate_depth": int(br.depth),
            "located_crossings": int(ce.sum() + cr.sum()),
            "engine_crossings": int(ce.sum()), "reference_crossings": int(cr.sum()),
            "multiple_edges": ie.count(MULTIPLE) + ir.count(MULTIPLE),
            "failed_edges": ie.count(FAILED_EDGE) + ir.count(FAILED_EDGE),
            "location_sd": _or_none(location_sd(eng, ref))}


def _or_none(x: float) -> float | None:
    return None if math.isnan(x) else x


def bracket_widths(b: LocatedBoundary, m: MapResult) -> np.ndarray:
    """Each crossing's last bisection interval along its edge [w/a units]: the edge's step over
    2**depth, or the whole step where its edge's bisection stopped early (flagged ``unfinished`` or
    ``failed``): where inside that interval the boundary lies, the map does not know."""
    if b.n_crossings == 0:
        return np.zeros(0)
    w, a = m.w_ratio, m.a_ratio
    dw = (w[-1] - w[0]) / (w.size - 1) if w.size > 1 else 0.0
    da = (a[-1] - a[0]) / (a.size - 1) if a.size > 1 else 0.0
    step = np.where(b.axis == ALONG_A, da, dw)
    stopped = {tuple(e) for e, f in zip(b.edges.tolist(), b.flags.tolist()) if f in (UNFINISHED, FAILED_EDGE)}
    early = np.array([(int(i), int(j), int(x)) in stopped for (i, j), x in zip(b.cell_a.tolist(), b.axis.tolist())],
                     bool)
    return np.where(early, step, step / 2.0 ** b.depth)


def location_sd(eng: MapResult, ref: MapResult) -> float:
    """The error of a pair's ``boundary_mean`` from where each map's bisection left its crossings,
    measured on the maps themselves [w/a units]: each counted crossing (:func:`judged_crossings`) lies
    uniformly within its last interval (:func:`bracket_widths`, variance width²/12); a distance errs by
    its own crossing's error and the other boundary's at its foot, so by the two maps' mean variances
    summed; along a boundary the crossings share one phase against the grid, so the errors are taken
    as moving together (not divided by the number of crossings). NaN without a crossing counted."""
    be, br = boundary_of(eng), boundary_of(ref)
    ce, cr = judged_crossings(eng, ref)
    if not ce.any() or not cr.any():
        return math.nan
    var_e = float(np.mean(bracket_widths(be, eng)[ce] ** 2)) / 12.0
    var_r = float(np.mean(bracket_widths(br, ref)[cr] ** 2)) / 12.0
    return math.sqrt(var_e + var_r)


def _consistency(eng: MapResult, outside: np.ndarray) -> float:
    """``consistency``: NaN without a simulated engine cell outside the domain (an adaptive map infers
    outcomes, not flags, so only simulated cells can say whether they left the model)."""
    out_sim = outside & eng.simulated
    n_out = int(out_sim.sum())
    return math.nan if n_out == 0 else float(np.count_nonzero(out_sim & eng.left_model) / n_out)


def cell_counts(eng: MapResult, ref: MapResult) -> dict[str, int]:
    """What a pair's numbers rest on, for score.json beside the metrics: the cells judged inside the
    reference's domain and those outside it (and of those, how many the engine simulated, which
    ``consistency`` is computed over), the engine's invalid cells in all, the cells the engine map
    does not have (``cells_missing``), and inside the domain the engine's wrong overturns
    (``overturn_extra``: it overturns, the reference does not, of ``reference_standing`` cells) and
    missed ones (``overturn_missed`` of ``reference_overturn``), its failed and its invalid cells there
    (``failed_in_domain``, ``invalid_in_domain``)."""
    judged, outside = judged_cells(eng, ref)
    ce, cr = eng.outcome, ref.outcome
    ov_ref = judged & (cr == OVERTURN)
    return {"cells_in_domain": int(judged.sum()), "cells_outside_domain": int(outside.sum()),
            "cells_outside_domain_simulated": int(np.count_nonzero(outside & eng.simulated)),
            "invalid_cells": int(np.count_nonzero((ce != FAILED) & ~eng.valid)),
            "cells_missing": int(np.count_nonzero(missing(eng))),
            "reference_overturn": int(ov_ref.sum()), "reference_standing": int(np.count_nonzero(judged & ~ov_ref)),
            "overturn_extra": int(np.count_nonzero(judged & ~ov_ref & (ce == OVERTURN))),
            "overturn_missed": int(np.count_nonzero(ov_ref & (ce != OVERTURN))),
            "failed_in_domain": int(np.count_nonzero(judged & (ce == FAILED))),
            "invalid_in_domain": int(np.count_nonzero(judged & (ce != FAILED) & ~eng.valid))}


def is_perfect(scores: Mapping[str, float]) -> bool:
    """Whether every metric in ``scores`` that has a value has its perfect value (n/a ones say nothing)."""
    return all(scores[k] == METRICS[k].perfect for k in METRICS if k in scores and not _isnan(scores[k]))


def check_gate(scores: Mapping[str, float], thresholds: Mapping[str, float]) -> list[str]:
    """Failed gate conditions, one line each (empty when all pass).

    A threshold on a higher-is-better metric fails when the score is below it; on a
    lower-is-better metric when the score is above it. NaN fails every threshold.
    """
    out = []
    for name, limit in thresholds.items():
        m = METRICS[name]
        v = scores.get(name, math.nan)
        size = abs(v) if m.direction == NEARER_ZERO and not _isnan(v) else v
        bad = _isnan(v) or (v < limit if m.direction == "higher" else size > limit)
        if bad:
            rel = "below" if m.direction == "higher" else "above"
            out.append(f"{name} = {v:.6g} is {rel} the limit {limit:g}")
    return out


def parse_thresholds(items: Iterable[str], direction: str | None = None, option: str = "--fail-under") -> dict:
    """Parse ``METRIC=VALUE`` items into a dict, checking names (and direction when given).

    Raises
    ------
    ConfigError
        Malformed item, unknown metric, non-numeric value, or a metric of the other direction.
    """
    out = {}
    for item in items:
        name, eq, val = str(item).partition("=")
        name = name.strip()
        if not eq or not name:
            raise ConfigError(f"{option} takes METRIC=VALUE, got {item!r}; metrics: {', '.join(METRICS)}.")
        if name not in METRICS:
            close = difflib.get_close_matches(name, list(METRICS), n=1)
            hint = f" Did you mean {close[0]}?" if close else ""
            raise ConfigError(f"{option}: unknown metric {name!r}.{hint} Metrics: {', '.join(METRICS)}.")
        try:
            v = float(val)
        except ValueError:
            raise ConfigError(f"{option} {name}= needs a number, got {val!r}.") from None
        if not math.isfinite(v):
            raise ConfigError(f"{option} {name}= needs a finite number, got {val!r}.")
        own = "lower" if METRICS[name].direction == NEARER_ZERO else METRICS[name].direction  # a limit on its size
        if direction is not None and own != direction:
            other = "--fail-over" if direction == "higher" else "--fail-under"
            raise ConfigError(f"{option} {name}: {name} is {METRICS[name].direction}-is-better; use {other} "
                              f"{name}={val} instead.")
        out[name] = v
    return out
