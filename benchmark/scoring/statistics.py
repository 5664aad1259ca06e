"""The verdict's statistics: intervals over clusters of scenarios with each scenario's own error,
paired differences antisymmetric in their arguments, Holm's correction, and tie groups that are transitive.

Pure functions of numbers (no score document); :mod:`~rockbench.benchmark.scoring.verdict` applies
them. An *item* is ``(value, sd, cluster)``: a scenario's value, its own standard error (the grid's
resolution, :func:`~rockbench.benchmark.scoring.scenarios.resolution_sd`) and the cluster it replicates
in (docs/scores.md, "The verdict").
"""

from __future__ import annotations

import math
from typing import Callable, Hashable, Sequence

#: Confidence of every interval the verdict states, and 1 − the family-wise error rate of its ties.
CONFIDENCE = 0.95


def t_quantile(df: int) -> float:
    """The two-sided :data:`CONFIDENCE` quantile of Student's t with ``df`` degrees of freedom (the
    normal's for ``df`` < 1)."""
    from scipy import stats  # SciPy on first use (start-up time)
    q = 0.5 + CONFIDENCE / 2
    return float(stats.norm.ppf(q) if df < 1 else stats.t.ppf(q, df))


def by_cluster(items: Sequence[tuple[float, float, Hashable]]) -> list[tuple[float, float]]:
    """``(mean, variance of that mean)`` of each cluster: its items averaged, their own variances summed
    over the square of their number."""
    groups: dict = {}
    for x, sd, key in items:
        groups.setdefault(key, []).append((x, sd))
    return [(sum(x for x, _ in g) / len(g), sum(sd * sd for _, sd in g) / len(g) ** 2) for g in groups.values()]


def estimate(items: Sequence[tuple[float, float, Hashable]]) -> dict:
    """The mean over clusters of ``items`` with its :data:`CONFIDENCE` interval and two-sided p-value
    against 0.

    The clusters are the replicates: with C clusters of means x_c and own variances v_c, the mean is
    x̄ = Σx_c/C and its variance s²/C + Σv_c/C² (s² the spread of the x_c; the items' own error is
    added, not floored, so it widens an interval without deciding it), with Student's t on C − 1
    degrees of freedom. One cluster has no spread: its own error alone, on the normal.

    Returns ``{"mean", "half", "p", "clusters", "items", "basis"}``; ``half`` and ``p`` are NaN without
    any item.
    """
    from scipy import stats  # SciPy on first use (start-up time)

    cl = by_cluster(items)
    n = len(cl)
    if n == 0:
        return {"mean": math.nan, "half": math.nan, "p": math.nan, "clusters": 0, "items": 0, "basis": ""}
    mean = sum(x for x, _ in cl) / n
    own = sum(v for _, v in cl) / n ** 2
    spread = sum((x - mean) ** 2 for x, _ in cl) / (n - 1) / n if n > 1 else 0.0
    se = math.sqrt(spread + own)
    df = n - 1
    z = abs(mean) / se if se > 0 else (math.inf if mean else 0.0)
    p = float(2 * (stats.norm.sf(z) if df < 1 else stats.t.sf(z, df)))
    basis = (f"Student's t over {n} clusters (slenderness × pulse) of {len(items)} scenarios, with the grid's "
             "resolution" if n > 1 else f"one cluster of {len(items)} scenario{'s' if len(items) > 1 else ''}: "
             "the grid's resolution only")
    return {"mean": mean, "half": t_quantile(df) * se, "p": p, "clusters": n, "items": len(items), "basis": basis}


def differences(a: dict, b: dict) -> list[tuple[float, float, Hashable]]:
    """Per shared key, the item ``(x − y, √(sd_a² + sd_b²), cluster)`` of ``a`` against ``b``.

    ``a`` and ``b`` map a key to ``(value, sd, cluster)``. The difference needs no floor (a perfect 0
    is a number like any other) and swapping ``a`` and ``b`` only changes its sign. Its own error adds
    both scenarios' resolution errors, which are independent: each map's boundary falls inside its
    cells wherever its own dynamics put it.
    """
    out = []
    for k in sorted(set(a) & set(b), key=str):
        (x, sa, cluster), (y, sb, _) = a[k], b[k]
        out.append((x - y, math.hypot(sa, sb), cluster))
    return out


def paired(a: dict, b: dict) -> dict:
    """``a`` against ``b`` (as :func:`differences`): ``difference`` (the mean over clusters of a − b),
    its :data:`CONFIDENCE` interval ``ci95``, ``p`` (against no difference), ``scenarios`` and
    ``clusters``. ``paired(b, a)`` has the opposite difference and interval and the same p."""
    e = estimate(differences(a, b))
    if not e["items"]:
        return {"scenarios": 0, "clusters": 0, "difference": None, "ci95": None, "p": None}
    m, h = e["mean"], e["half"]
    return {"scenarios": e["items"], "clusters": e["clusters"], "difference": m, "ci95": [m - h, m + h],
            "p": e["p"]}


def holm(p: dict) -> dict:
    """Holm's step-down adjustment of the p-values ``{key: p}`` (None stays None): the family of
    comparisons keeps its error rate at 1 − :data:`CONFIDENCE` whatever its size."""
    known = sorted(((v, k) for k, v in p.items() if v is not None), key=lambda x: x[0])
    m, out, run = len(known), {k: None for k in p}, 0.0
    for i, (v, k) in enumerate(known):
        run = max(run, min(1.0, (m - i) * v))
        out[k] = run
    return out


def tie_groups(order: Sequence, resolved: Callable[[object, object], bool]) -> list[list]:
    """Transitive ties: ``order`` (best first) cut into consecutive groups.

    Each item joins the current group unless a comparison resolves it from a member of that group;
    then it opens the next. Inside a group no difference is resolved, and two items share a group or
    not (an equivalence, unlike "not resolved", which chains)."""
    groups: list[list] = []
    for x in order:
        if groups and not any(resolved(g, x) for g in groups[-1]):
            groups[-1].append(x)
        else:
            groups.append([x])
    return groups
