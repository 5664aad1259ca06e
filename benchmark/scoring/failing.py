"""The failing rule: a variant whose boundary lies farther than the suite's declared ``fail_distance``
from the reference's in any in-sample scenario fails, whatever its mean, and so does one with nothing
judged; the verdict names where, and what it gets wrong from its cell counts (docs/scores.md, "One
bad scenario fails the variant").
"""

from __future__ import annotations

import math

from rockbench.benchmark.scoring.scenarios import Variant, items
from rockbench.benchmark.scoring.statistics import z_one_sided

#: A reason for failing is named when it concerns at least this share of its cells [-].
REASON_SHARE = 0.10


def failing_scenarios(v: Variant, limit: float) -> list[dict]:
    """Every in-sample scenario where the boundary lies farther than ``limit`` [w/a units] from the
    reference's, worst first, with its own error ``sd`` and whether it lies beyond the limit by more than
    that error can explain (``beyond_error``: value − z₀.₉₅·sd > limit). The rule is on the value;
    ``beyond_error`` only says, in the verdict's words, when a grid too coarse for the limit decided it."""
    if v.planted_factor is not None:
        return []                        # the suite's yardstick, not an engine (:func:`fails`)
    z = z_one_sided()
    bad = [{"block": k[0], "pulse": k[1], "value": s.value, "limit": limit, "sd": s.sd,
            "beyond_error": s.value - z * s.sd > limit}
           for k, s in v.scenarios.items() if not s.held_out and math.isfinite(s.value) and s.value > limit]
    return sorted(bad, key=lambda b: -b["value"])


def fails(v: Variant, limit: float) -> bool:
    """The one failing rule: no in-sample scenario with a value, or one beyond ``limit``. A variant of
    the held-out check alone (every scenario held out) is judged by its own test instead, and a planted
    restitution is the suite's yardstick, not an engine: neither fails."""
    if v.held_out_only or v.planted_factor is not None:
        return False
    return not items(v) or bool(failing_scenarios(v, limit))


#: The kinds of error a failure is read from: (kind, part, whole or None for the judged cells, words).
_KINDS = (("overturn_extra", "overturn_extra", "reference_standing",
           "overturns in {} of the cells where the reference stays standing"),
          ("overturn_missed", "overturn_missed", "reference_overturn",
           "stays standing in {} of the cells where the reference overturns"),
          ("failed", "failed_in_domain", None, "fails to simulate {} of the judged cells"),
          ("invalid", "invalid_in_domain", None,
           "flags slip, jump or energy gain in {} of the cells where the rigid model holds"))


def reason_kinds(v: Variant) -> list[dict]:
    """What the variant gets wrong, from its summed cell counts: ``{"kind", "share"}`` for each kind of
    error that concerns at least :data:`REASON_SHARE` of its cells, largest first (at most two)."""
    c = v.counts
    found = [(_share(c, part, whole or "cells_in_domain"), kind) for kind, part, whole, _ in _KINDS]
    found = sorted((x for x in found if x[0] >= REASON_SHARE), key=lambda x: -x[0])[:2]
    return [{"kind": kind, "share": share} for share, kind in found]


def reasons(v: Variant) -> list[str]:
    """:func:`reason_kinds` in words."""
    words = {kind: text for kind, _, _, text in _KINDS}
    return [words[r["kind"]].format(percent(r["share"])) for r in reason_kinds(v)]


def percent(share: float) -> str:
    """``0.87`` → ``87 %`` (the project writes a space before %)."""
    return f"{100 * share:.0f} %"


def _share(c: dict, part: str, whole: str) -> float:
    return c.get(part, 0) / c[whole] if c.get(whole) else 0.0
