"""The suite's power against an engine's own restitution error: an engine calibrated to η·(1 + δ) (its
``planted_eta_factor`` 1 + δ, settings class
:data:`~rockbench.benchmark.scoring.labels.ENGINE_PLANTED_CLASS`) set against the same engine's
calibrated variant (δ = 0), paired per scenario and compared **across problems** by the rule of the
class comparisons (:func:`~rockbench.benchmark.scoring.comparisons.across_problems` of the two
variants: the pair's problem-to-problem spread on C − 1 degrees of freedom, the grid's error as a
floor), by the distance and by the signed offset (docs/scores.md, "The suite's power against an
engine's own restitution error").

Where the reference-planted variants (:mod:`~rockbench.benchmark.scoring.power`) measure what the suite
resolves in the reference solver itself, these measure it in a real engine: its δ = 0 map already errs,
so a restitution error may move its distance either way, while the signed offset moves with the error's
sign.
"""

from __future__ import annotations

import math

from rockbench.benchmark.scoring.comparisons import ACROSS, across_problems
from rockbench.benchmark.scoring.labels import CALIBRATED, ENGINE_PLANTED_CLASS
from rockbench.benchmark.scoring.scenarios import Variant, items

#: The two measures a planted error is judged by: the boundary distance (one-sided: the error moves
#: the boundary away) and the signed offset (two-sided: either sign is a resolved move)
MEASURES = ("distance", "offset")


def offset_items(v: Variant) -> dict:
    """``{(block, pulse): (offset, sd, cluster)}``: a variant's in-sample signed offsets where its
    scenario has a distance, each with the scenario's own error (the offset is located by the same
    boundaries as the distance)."""
    return {k: (s.offset, s.sd, s.cluster) for k, s in v.scenarios.items()
            if not s.held_out and math.isfinite(s.offset) and math.isfinite(s.distance)}


def versus(a: dict, b: dict, two_sided: bool) -> dict | None:
    """``a`` − ``b`` across problems (:func:`~.comparisons.across_problems` of the two): the difference,
    its se, degrees of freedom and two-sided 95 % t interval, and whether it is ``resolved``: two-sided,
    the interval excludes 0; one-sided, ``a`` is out of the best subset (a − b > t₀.₉₅·se). None with
    fewer than two problems in common."""
    res = across_problems({"a": a, "b": b})
    if res is None:
        return None
    ea, eb = res["entries"]["a"], res["entries"]["b"]
    vb = ea["versus_best"] or eb["versus_best"]
    sign = 1.0 if ea["versus_best"] else -1.0
    lo, hi = (sign * x for x in vb["ci95"])
    ci = [min(lo, hi), max(lo, hi)]
    resolved = (ci[0] > 0 or ci[1] < 0) if two_sided else not ea["in_best_subset"]
    return {"difference": ea["value"] - eb["value"], "se": vb["se"], "df": res["df"], "ci95": ci,
            "critical": res["critical"], "problems": res["problems"], "resolved": bool(resolved)}


def base_of(variants: list[Variant], engine: str) -> Variant | None:
    """``engine``'s calibrated variant (δ = 0): in the calibrated class, calibrated on each block itself."""
    return next((v for v in variants if v.engine == engine and v.settings == CALIBRATED and not v.held_out_only
                 and v.planted_factor is None), None)


def engine_planted_power(variants: list[Variant]) -> dict | None:
    """For each engine with engine-planted variants, each δ against its δ = 0 variant across problems, by
    the distance (:func:`versus`, one-sided) and by the signed offset (two-sided), and the |δ| resolved
    by each: an |δ| counts where every variant of that |δ| is resolved. None without such a variant."""
    planted = [v for v in variants if v.settings == ENGINE_PLANTED_CLASS and v.planted_factor is not None]
    if not planted:
        return None
    out = {}
    for engine in dict.fromkeys(v.engine for v in planted):
        base = base_of(variants, engine)
        rows = [_row(v, base) for v in sorted((v for v in planted if v.engine == engine), key=lambda v: v.planted_factor)]
        out[engine] = {"against": None if base is None else base.name, "rows": rows,
                       "resolved_abs_delta": {m: _resolved_abs(rows, m) for m in MEASURES}}
    return {"scope": ACROSS, "engines": out}


def _row(v: Variant, base: Variant | None) -> dict:
    row = {"variant": v.name, "label": v.label, "eta_factor": v.planted_factor,
           "delta": round(v.planted_factor - 1.0, 12), "distance": None, "offset": None}
    if base is not None:
        row["distance"] = versus(items(v), items(base), two_sided=False)
        row["offset"] = versus(offset_items(v), offset_items(base), two_sided=True)
    return row


def _resolved_abs(rows: list[dict], measure: str) -> list[float]:
    """The |δ| every variant of which is resolved by ``measure``, smallest first."""
    by: dict = {}
    for r in rows:
        by.setdefault(round(abs(r["delta"]), 12), []).append(bool((r[measure] or {}).get("resolved")))
    return sorted(d for d, ok in by.items() if all(ok))
