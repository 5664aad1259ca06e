"""The suite's power, measured: the reference solver run as an engine with a restitution planted below
its target, η × (1 − δ), through the same grids and scoring as every engine, each δ against δ = 0
by the rule the class comparisons use (docs/scores.md, "What the suite could have seen").

A planted variant is one whose pairs carry ``planted_eta_factor`` (its settings class is
:data:`~rockbench.benchmark.scoring.labels.PLANTED`); a score document without them has no power
measurement, only the minimal detectable differences of its classes.
"""

from __future__ import annotations

import math

from rockbench.benchmark.scoring.labels import PLANTED_CLASS
from rockbench.benchmark.scoring.scenarios import Variant, items
from rockbench.benchmark.scoring.statistics import fixed, paired, z_one_sided


def planted_variants(variants: list[Variant]) -> list[Variant]:
    """The reference solver's planted variants (class ``planted``), smallest δ first (an engine's own planted
    error is :mod:`~rockbench.benchmark.scoring.engine_power`'s)."""
    return sorted((v for v in variants if v.planted_factor is not None and v.settings == PLANTED_CLASS),
                  key=lambda v: -v.planted_factor)


def planted_power(variants: list[Variant], critical: float, critical_from: str) -> dict | None:
    """Each planted δ against δ = 0: its distance from the reference, the difference from δ = 0 with its
    95 % interval, the one-sided p, and whether it is resolved (difference > ``critical`` × se, the
    rule by which a variant is resolved behind the best of its class); and the smallest δ resolved.
    Without a δ = 0 variant each δ is set against a distance of 0 with its own error. None without a
    planted variant."""
    from scipy import stats  # SciPy on first use (start-up time)

    planted = planted_variants(variants)
    if not planted:
        return None
    base = next((v for v in planted if abs(v.planted_factor - 1.0) < 1e-9), None)
    rows = []
    for v in planted:
        own = fixed(list(items(v).values()))
        if v is base:
            d = {"difference": 0.0, "se": 0.0, "ci95": [0.0, 0.0]}
        elif base is not None:
            d = paired(items(v), items(base))
        else:
            d = {"difference": own["mean"], "se": own["se"], "ci95": own["ci95"]}
        diff, se = d["difference"], d["se"]
        ok = diff is not None and math.isfinite(diff)
        p = float(stats.norm.sf(diff / se)) if ok and se and se > 0 else None
        rows.append({"variant": v.name, "delta": 1.0 - v.planted_factor, "eta_factor": v.planted_factor,
                     "distance": own["mean"], "distance_ci95": own["ci95"], "difference": diff, "se": se,
                     "difference_ci95": d["ci95"], "p": p,
                     "resolved": bool(ok and v is not base and se is not None and diff > critical * se)})
    resolved = [r["delta"] for r in rows if r["resolved"]]
    return {"against": None if base is None else base.name, "critical": critical, "critical_from": critical_from,
            "planted": rows, "smallest_resolved_delta": min(resolved) if resolved else None,
            "largest_unresolved_delta": max((r["delta"] for r in rows if not r["resolved"] and r["delta"] > 0),
                                            default=None)}


def restitution_response(variants: list[Variant]) -> dict | None:
    """Per scenario, whether its boundary responds to the restitution: the largest planted δ's distance
    exceeds δ = 0's there by more than z₀.₉₅ times their summed errors (``{(block, pulse): bool}``, the
    largest δ with the word). None without a planted δ > 0 and a δ = 0 variant: then nothing is known."""
    planted = planted_variants(variants)
    base = next((v for v in planted if abs(v.planted_factor - 1.0) < 1e-9), None)
    top = planted[-1] if planted else None
    if base is None or top is None or top is base:
        return None
    z = z_one_sided()
    out = {}
    for k, s in top.scenarios.items():
        b = base.scenarios.get(k)
        if b is not None and math.isfinite(s.distance) and math.isfinite(b.distance):
            out[k] = s.distance - b.distance > z * math.hypot(s.sd, b.sd)
    return {"delta": 1.0 - top.planted_factor, "responds": out}
