"""The verdict's statistics: estimates on the fixed suite from each scenario's measured error, paired
differences, Hsu's multiple comparisons with the best, minimal detectable differences, two one-sided
tests, and Student's t over slendernesses for claims about problems in general.

Pure functions of numbers (no score document); :mod:`~rockbench.benchmark.scoring.verdict` and its
helpers apply them. An *item* is ``(value, sd, cluster)``: a scenario's value, its own standard error
(the grid's resolution, :func:`~rockbench.benchmark.scoring.scenarios.resolution_sd`) and its cluster
``(slenderness h/b, pulse)``, one problem of the suite (docs/scores.md, "The verdict").

Two kinds of inference are kept apart:

- **On the fixed suite** ("on these N problems"): the problems are the suite's, not a sample, so a
  value's only error is the measured error of each scenario; the mean over C problems has variance
  Σv_c / C² (v_c the error variance of problem c's value, sizes of one problem averaged first), and
  the quantiles are the normal's. The grid's error is counted once.
- **Across problems** ("across problems"): the problems are a sample of problems like them, so a
  paired difference between two engines errs also by how the engines' errors differ from problem to
  problem (the engine × problem interaction): the class's two-way table of problem values, its
  interaction mean square on (k − 1)(C − 1) degrees of freedom, with the grid's error as a floor
  (:func:`interaction`, :func:`dunnett_t_critical`; applied by
  :func:`~rockbench.benchmark.scoring.comparisons.across_problems`).
- **About problems in general**: the slendernesses are the sample; a value's interval is Student's t
  over the slenderness means (pulses averaged within a slenderness), whose spread already holds the
  grid's error. For a balanced design this is the mixed model with random problem and engine ×
  slenderness effects (tests/test_inference.py checks the equality).
"""

from __future__ import annotations

import functools
import math
from typing import Hashable, Sequence

import numpy as np

#: Confidence of every interval the verdict states, and 1 − the error rate of each family of tests.
CONFIDENCE = 0.95

#: The power at which the minimal detectable difference is stated.
POWER = 0.80


def _stats():
    from scipy import stats  # SciPy on first use (start-up time)
    return stats


def z_two_sided(confidence: float = CONFIDENCE) -> float:
    """The normal quantile of a two-sided ``confidence`` interval (1.96 at 95 %)."""
    return float(_stats().norm.ppf(0.5 + confidence / 2))


def t_quantile(p: float, df: float) -> float:
    """Student's t quantile at probability ``p`` on ``df`` degrees of freedom."""
    return float(_stats().t.ppf(p, df))


def z_one_sided(confidence: float = CONFIDENCE) -> float:
    """The normal quantile of a one-sided ``confidence`` bound (1.645 at 95 %)."""
    return float(_stats().norm.ppf(confidence))


# -- clusters -----------------------------------------------------------------------------------------

def by_cluster(items: Sequence[tuple[float, float, Hashable]]) -> dict:
    """``{cluster: (mean, variance of that mean)}``: a cluster's items averaged, their own variances
    summed over the square of their number."""
    groups: dict = {}
    for x, sd, key in items:
        groups.setdefault(key, []).append((x, sd))
    return {k: (sum(x for x, _ in g) / len(g), sum(sd * sd for _, sd in g) / len(g) ** 2) for k, g in groups.items()}


def fixed(items: Sequence[tuple[float, float, Hashable]]) -> dict:
    """The mean over clusters of ``items`` on the fixed suite, with its standard error from the items'
    own errors only: x̄ = Σx_c/C, se = √(Σv_c)/C; a :data:`CONFIDENCE` interval on the normal and a
    two-sided p-value against 0.

    Returns ``{"mean", "se", "ci95", "p", "clusters", "items"}`` (``mean`` NaN and ``ci95`` None
    without an item).
    """
    cl = list(by_cluster(items).values())
    n = len(cl)
    if n == 0:
        return {"mean": math.nan, "se": math.nan, "ci95": None, "p": math.nan, "clusters": 0, "items": 0}
    mean = sum(x for x, _ in cl) / n
    se = math.sqrt(sum(v for _, v in cl)) / n
    half = z_two_sided() * se
    return {"mean": mean, "se": se, "ci95": [mean - half, mean + half], "p": _p_two_sided(mean, se),
            "clusters": n, "items": len(items)}


def _p_two_sided(mean: float, se: float) -> float:
    if se > 0:
        return float(2 * _stats().norm.sf(abs(mean) / se))
    return 0.0 if mean else 1.0


def differences(a: dict, b: dict) -> list[tuple[float, float, Hashable]]:
    """Per shared key, the item ``(x − y, √(sd_a² + sd_b²), cluster)`` of ``a`` against ``b``.

    ``a`` and ``b`` map a key (a scenario) to ``(value, sd, cluster)``. The difference needs no floor
    (a perfect 0 is a number like any other) and swapping ``a`` and ``b`` only changes its sign. Its
    own error adds both scenarios' errors as independent, although both maps are scored against the
    same reference map; the located-boundary probe measures that this sum is conservative
    (docs/scores.md, "Comparisons").
    """
    out = []
    for k in sorted(set(a) & set(b), key=str):
        (x, sa, cluster), (y, sb, _) = a[k], b[k]
        out.append((x - y, math.hypot(sa, sb), cluster))
    return out


def paired(a: dict, b: dict) -> dict:
    """``a`` against ``b`` on the fixed suite (:func:`differences`, then :func:`fixed`): ``difference``
    (the mean over shared clusters of a − b), ``se``, its :data:`CONFIDENCE` interval ``ci95``, the
    two-sided ``p``, ``scenarios`` and ``clusters``. ``paired(b, a)`` has the opposite difference and
    interval and the same se and p."""
    e = fixed(differences(a, b))
    if not e["items"]:
        return {"scenarios": 0, "clusters": 0, "difference": None, "se": None, "ci95": None, "p": None}
    return {"scenarios": e["items"], "clusters": e["clusters"], "difference": e["mean"], "se": e["se"],
            "ci95": e["ci95"], "p": e["p"]}


def paired_clusters(a: dict, b: dict) -> dict:
    """As :func:`paired`, but matched by cluster (each side's scenarios of a cluster averaged first):
    two variants mapped on other sizes of the same problems (``in_sample_scope`` "same problems")."""
    ca, cb = by_cluster(list(a.values())), by_cluster(list(b.values()))
    shared = [k for k in ca if k in cb]
    items = [(ca[k][0] - cb[k][0], math.sqrt(ca[k][1] + cb[k][1]), k) for k in shared]
    e = fixed(items)
    if not shared:
        return {"scenarios": 0, "clusters": 0, "difference": None, "se": None, "ci95": None, "p": None}
    n_sc = sum(1 for x in a.values() if x[2] in cb) + sum(1 for x in b.values() if x[2] in ca)
    return {"scenarios": n_sc, "clusters": e["clusters"], "difference": e["mean"], "se": e["se"],
            "ci95": e["ci95"], "p": e["p"]}


# -- Hsu's multiple comparisons with the best -------------------------------------------------------------

def dunnett_critical(lambdas: Sequence[float], confidence: float = CONFIDENCE) -> float:
    """The one-sided critical value q of Dunnett's many-to-one comparisons: P(max_j Z_j ≤ q) =
    ``confidence`` for standard normals Z_j with correlations λ_j·λ_k (one control, ``len(lambdas)``
    comparisons).

    With the control's variance w_0 and the others' w_j, λ_j = √(w_0/(w_0 + w_j)); equal variances
    give λ = √½, Dunnett's equal correlation ½. The probability is the one-dimensional integral
    ∫ φ(y) Π_j Φ((q − λ_j·y)/√(1 − λ_j²)) dy (Z_j = λ_j·Y + √(1 − λ_j²)·E_j), solved for q; one
    comparison gives the normal's one-sided quantile, none gives 0. tests/test_inference.py checks it
    against SciPy's multivariate normal.
    """
    lam = tuple(sorted(round(min(max(float(x), 0.0), 0.999999), 9) for x in lambdas))
    if not lam:
        return 0.0
    if len(lam) == 1:
        return z_one_sided(confidence)
    return _dunnett(lam, float(confidence))


@functools.lru_cache(maxsize=512)
def _dunnett(lam: tuple, confidence: float) -> float:
    """:func:`dunnett_critical` for sorted, rounded correlations (cached: a class's comparisons, or a
    simulation's draws, share them)."""
    from scipy import integrate, optimize  # SciPy on first use (start-up time)
    st = _stats()

    def coverage(q):
        def f(y):
            prod = 1.0
            for x in lam:
                prod *= st.norm.cdf((q - x * y) / math.sqrt(1.0 - x * x))
            return st.norm.pdf(y) * prod
        return integrate.quad(f, -9.0, 9.0, epsabs=1e-11, limit=200)[0]

    return float(optimize.brentq(lambda q: coverage(q) - confidence, 0.0, 10.0, xtol=1e-10))


def mcb(values: dict, se: dict, var: dict, confidence: float = CONFIDENCE) -> dict:
    """Hsu's multiple comparisons with the best, smaller values better.

    ``values``: ``{name: value}``; ``se``: ``{(i, j): standard error of value_i − value_j}`` for every
    ordered pair; ``var``: ``{name: variance of value_i}`` (the share of a pair's variance that the
    comparisons with ``i`` have in common). ``i`` stays in the best subset iff for every ``j ≠ i``,
    value_i − value_j ≤ q_i·se_ij, with q_i :func:`dunnett_critical` for ``i`` as the control; on the
    event that Dunnett's bounds hold for the true best, it is in the subset, so the subset holds the
    true best with probability ≥ ``confidence``. ``behind`` is the upper bound of how much worse than
    the best of the others ``i`` may be, (max_j (value_i − value_j + q_i·se_ij))⁺.

    Returns ``{name: {"in_best_subset", "critical", "behind"}}``.
    """
    out = {}
    for i in values:
        others = [j for j in values if j != i]
        lam = [math.sqrt(var[i]) / se[(i, j)] if se[(i, j)] > 0 else 0.0 for j in others]
        q = dunnett_critical(lam, confidence)
        gaps = [values[i] - values[j] - q * se[(i, j)] for j in others]
        ups = [values[i] - values[j] + q * se[(i, j)] for j in others]
        out[i] = {"in_best_subset": all(g <= 0 for g in gaps), "critical": q,
                  "behind": max(0.0, max(ups)) if ups else 0.0}
    return out


def dunnett_t_critical(comparisons: int, df: float, confidence: float = CONFIDENCE) -> float:
    """The one-sided critical value of Dunnett's many-to-one comparisons on ``df`` degrees of freedom
    (a multivariate t with equal correlation ½: a balanced two-way design, each comparison with the same
    control): P(max_j T_j ≤ q) = ``confidence``. One comparison gives Student's t quantile; infinite
    ``df`` the normal :func:`dunnett_critical`; none 0."""
    if comparisons <= 0:
        return 0.0
    if not math.isfinite(df):
        return dunnett_critical([math.sqrt(0.5)] * comparisons, confidence)
    if comparisons == 1:
        return float(_stats().t.ppf(confidence, df))
    return _dunnett_t(int(comparisons), float(df), float(confidence))


@functools.lru_cache(maxsize=256)
def _dunnett_t(m: int, df: float, confidence: float) -> float:
    from scipy import optimize  # SciPy on first use (start-up time)
    shape = np.full((m, m), 0.5) + 0.5 * np.eye(m)
    dist = _stats().multivariate_t(np.zeros(m), shape, df=df, seed=20261207)   # fixed seed: reproducible
    return float(optimize.brentq(lambda q: dist.cdf(np.full(m, q), random_state=20261207) - confidence,
                                 0.0, 20.0, xtol=1e-6))


def interaction(table) -> tuple[float, int]:
    """The engine × problem interaction of a complete two-way table (rows engines, columns problems) of
    values: its mean square Σ(x − row mean − column mean + grand mean)² / ((k − 1)(C − 1)) and those
    degrees of freedom; (NaN, 0) with fewer than two rows or columns. Its expectation is the variance of
    a single engine-on-problem value about the additive model (engine effect + problem effect): the
    interaction and the measurement error together."""
    x = np.asarray(table, float)
    k, c = x.shape
    if k < 2 or c < 2:
        return math.nan, 0
    r = x - x.mean(axis=1, keepdims=True) - x.mean(axis=0, keepdims=True) + x.mean()
    df = (k - 1) * (c - 1)
    return float((r * r).sum() / df), df


def detectable(critical: float, se: float, power: float = POWER) -> float:
    """The minimal detectable difference of a one-sided comparison with ``critical`` value and standard
    error ``se``: the true difference that exceeds ``critical``·se with probability ``power``,
    (critical + z_power)·se."""
    return (critical + float(_stats().norm.ppf(power))) * se


# -- equivalence ------------------------------------------------------------------------------------

def upper_bound(mean: float, se: float, confidence: float = CONFIDENCE) -> float:
    """The one-sided ``confidence`` upper bound of a mean: mean + z·se (the upper test of a two one-sided
    pair; for a quantity ≥ 0 the lower test always passes)."""
    return mean + z_one_sided(confidence) * se


def tost(difference: float, se: float, margin: float, confidence: float = CONFIDENCE) -> dict:
    """Two one-sided tests that |true difference| < ``margin``: both pass at 1 − ``confidence`` when the
    two-sided (2·confidence − 1) interval lies within ± margin.

    Returns ``{"interval", "p", "equivalent"}``: the interval (90 % at 95 %), the larger of the two
    one-sided p-values, and whether both pass.
    """
    st = _stats()
    z = z_one_sided(confidence)
    lo, hi = difference - z * se, difference + z * se
    if se > 0:
        p = max(float(st.norm.sf((difference + margin) / se)), float(st.norm.cdf((difference - margin) / se)))
    else:
        p = 0.0 if abs(difference) < margin else 1.0
    return {"interval": [lo, hi], "p": p, "equivalent": -margin < lo and hi < margin}


# -- about problems in general ------------------------------------------------------------------------

def slenderness_means(items: Sequence[tuple[float, float, Hashable]]) -> dict:
    """``{h/b: mean}``: sizes of one problem averaged first (:func:`by_cluster`), then the pulses of one
    slenderness; clusters whose slenderness is not a number (a custom block) are left out."""
    per: dict = {}
    for (s, _pulse), (x, _) in by_cluster(items).items():
        if isinstance(s, (int, float)) and not isinstance(s, bool):
            per.setdefault(float(s), []).append(x)
    return {s: sum(xs) / len(xs) for s, xs in per.items()}


def general(items: Sequence[tuple[float, float, Hashable]], comparisons: int = 1) -> dict | None:
    """Student's t over the slenderness means of ``items`` (:func:`slenderness_means`): the mean, its
    :data:`CONFIDENCE` interval on n − 1 degrees of freedom, and the two-sided p against 0 times
    ``comparisons`` (Bonferroni over a family, at most 1). None with fewer than two slendernesses.
    No resolution term is added: the spread between slendernesses already holds it."""
    st = _stats()
    g = list(slenderness_means(items).values())
    n = len(g)
    if n < 2:
        return None
    mean = sum(g) / n
    se = math.sqrt(sum((x - mean) ** 2 for x in g) / (n - 1) / n)
    half = float(st.t.ppf(0.5 + CONFIDENCE / 2, n - 1)) * se
    if se > 0:
        p = float(2 * st.t.sf(abs(mean) / se, n - 1))
    else:
        p = 0.0 if mean else 1.0
    return {"mean": mean, "se": se, "ci95": [mean - half, mean + half], "df": n - 1, "slendernesses": n,
            "p": min(1.0, p * comparisons)}
