"""The failing rule: a variant whose boundary lies farther than the suite's declared ``fail_distance``
from the reference's in any in-sample scenario fails, whatever its mean, and so does one with nothing
judged; the verdict names where, and what it gets wrong from its cell counts (docs/scores.md, "One
bad scenario fails the variant"). A scenario where the engine's map has no boundary (it never
overturns, or overturns everywhere) fails it too, and is named as such: its distance is a placeholder,
never a number in a mean.
"""

from __future__ import annotations

import math

from rockbench.benchmark.scoring.scenarios import Scenario, Variant, items
from rockbench.benchmark.scoring.statistics import z_one_sided

#: A reason for failing is named when it concerns at least this share of its cells [-].
REASON_SHARE = 0.10


def failing_scenarios(v: Variant, limit: float) -> list[dict]:
    """Every in-sample scenario where the boundary lies farther than ``limit`` [w/a units] from the
    reference's, or where one of the two maps has none (:func:`scenario_failure`), missing boundaries
    first, then worst first."""
    if v.planted_factor is not None:
        return []                        # the suite's yardstick, not an engine (:func:`fails`)
    bad = [scenario_failure(k, s, limit) for k, s in v.scenarios.items()
           if not s.held_out and math.isfinite(s.value) and (s.missing_boundary or s.value > limit)]
    return sorted(bad, key=lambda b: (not b["missing_boundary"], -(b["value"] or 0.0)))


def scenario_failure(key: tuple, s: Scenario, limit: float) -> dict:
    """What failed in one scenario: ``block``, ``pulse``, ``value`` (the distance; None where a map has
    no boundary, whose placeholder is no distance), ``missing_boundary`` (``"engine"``, ``"reference"``
    or ``""``), the ``limit``, the scenario's own error ``sd`` and whether the value lies beyond the limit
    by more than that error can explain (``beyond_error``: value − z₀.₉₅·sd > limit; always for a missing
    boundary), and from its cells the shares it gets wrong: ``missed`` (stays standing where the
    reference overturns, of ``reference_overturn`` cells) and ``extra`` (overturns where the reference
    stays standing, of ``reference_standing`` cells); None where the pair has no such cell."""
    c = s.counts
    value = None if s.missing_boundary else s.value
    return {"block": key[0], "pulse": key[1], "value": value, "missing_boundary": s.missing_boundary,
            "limit": limit if math.isfinite(limit) else None, "sd": s.sd,
            "beyond_error": value is None or value - z_one_sided() * s.sd > limit,
            "missed": _share_or_none(c, "overturn_missed", "reference_overturn"),
            "reference_overturn": c.get("reference_overturn", 0),
            "extra": _share_or_none(c, "overturn_extra", "reference_standing"),
            "reference_standing": c.get("reference_standing", 0)}


def scenario_words(b: dict) -> str:
    """A failing scenario (:func:`scenario_failure`) in words: ``B8M sine at 0.442``, or where a map has
    no boundary what its cells do instead: ``B2M sine: no boundary, overturns in 98 % of the cells
    where the reference stays standing``."""
    head = f"{b['block']} {b['pulse']}"
    if not b["missing_boundary"]:
        return f"{head} at {_distance(b['value'])}"
    if b["missing_boundary"] == "reference":
        return f"{head}: the reference has no boundary there"
    cells = []
    if b["extra"]:
        cells.append(f"overturns in {percent(b['extra'])} of the {b['reference_standing']} cells where the "
                     "reference stays standing")
    if b["missed"]:
        cells.append(f"stays standing in {percent(b['missed'])} of the {b['reference_overturn']} cells where the "
                     "reference overturns")
    return f"{head}: no boundary" + (", " + " and ".join(cells) if cells else "")


def _distance(x: float) -> str:
    return f"{x:.3f}" if abs(x) < 10 else f"{x:.1f}"


def _share_or_none(c: dict, part: str, whole: str) -> float | None:
    return c.get(part, 0) / c[whole] if c.get(whole) else None


def fails(v: Variant, limit: float) -> bool:
    """The one failing rule: no in-sample scenario with a value, or one beyond ``limit``. A variant of
    the held-out check alone (every scenario held out) is judged by its own test instead, and a planted
    restitution is the suite's yardstick, not an engine: neither fails."""
    if v.held_out_only or v.planted_factor is not None:
        return False
    return not (items(v) or v.placeholders()) or bool(failing_scenarios(v, limit))


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
