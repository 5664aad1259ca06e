"""A stability map scored against the shaking-table experiments of its block and pulse (the points
of :mod:`rockbench.benchmark.blocks.experiments`)."""

from __future__ import annotations

import math
from typing import Iterable

import numpy as np

from rockbench.benchmark.blocks.experiments import OUTCOME_LETTERS, OutcomePoint
from rockbench.benchmark.maps.result import FAILED, MapResult
from rockbench.benchmark.scoring.metrics import OVERTURN


def _nearest_index(axis: np.ndarray, x: float) -> int | None:
    """Index of the grid cell whose centre is nearest ``x``, or None outside the grid's cells.

    A cell extends half-way to its neighbours; the outer cells extend by half their own step
    (a single-value axis accepts only that value).
    """
    if axis.size == 1:
        return 0 if math.isclose(x, axis[0], rel_tol=1e-9) else None
    lo = axis[0] - 0.5 * (axis[1] - axis[0])
    hi = axis[-1] + 0.5 * (axis[-1] - axis[-2])
    if not lo <= x <= hi:
        return None
    mids = 0.5 * (axis[1:] + axis[:-1])
    return int(np.searchsorted(mids, x, side="left"))


def score_outcomes(points: Iterable[OutcomePoint], m: MapResult, block: str, pulse: str) -> dict:
    """Score a stability map against the experimental points of its block and pulse.

    Each point is placed at its (ω/p, a₀/(g·tanα)) for ``block`` and judged by the map cell it
    falls in; points outside the map are counted, not judged. Every repetition counts once.

    Returns
    -------
    dict
        ``points`` (rows used), ``runs`` (repetitions judged), ``outside`` (repetitions outside the
        map), ``accuracy`` (fraction of judged runs where T/R/O equals rest/rocking/overturn; NaN
        with no judged run), ``overturn_accuracy`` (overturn vs not), ``confusion`` (rows T, R, O;
        columns rest, rocking, overturn, failed: run counts).
    """
    block, pulse = block.upper(), pulse.lower()
    cols = ("rest", "rocking", "overturn", "failed")
    conf = {letter: {c: 0 for c in cols} for letter in OUTCOME_LETTERS}
    n_points = runs = outside = hit = hit_ov = 0
    for pt in points:
        if pt.block != block or pt.pulse != pulse:
            continue
        n_points += 1
        j = _nearest_index(m.w_ratio, pt.w_ratio)
        i = _nearest_index(m.a_ratio, pt.a_ratio)
        if i is None or j is None:
            outside += pt.repetitions
            continue
        code = int(m.outcome[i, j])
        col = cols[3] if code == FAILED else cols[code]
        conf[pt.outcome][col] += pt.repetitions
        runs += pt.repetitions
        want = OUTCOME_LETTERS[pt.outcome]
        if code == want:
            hit += pt.repetitions
        if code != FAILED and (code == OVERTURN) == (want == OVERTURN):
            hit_ov += pt.repetitions
    return {"block": block, "pulse": pulse, "points": n_points, "runs": runs, "outside": outside,
            "accuracy": hit / runs if runs else math.nan,
            "overturn_accuracy": hit_ov / runs if runs else math.nan, "confusion": conf}
