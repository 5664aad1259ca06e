"""What a suite declares before its verdict is computed: the failing limit, the equivalence margins and
the slenderness range a claim about problems in general may cover (the suite file's ``[verdict]``
table; docs/scores.md, "What a suite declares"), and the numbers the declared rules give on a run
(:func:`fail_limit`, :func:`held_out_margin_of`): the fail limit and the held-out margin are rules on
each scenario's η_H–η_M reference gap, computed from the run, or numbers a suite states.

One rule per key (:data:`KEY_RULES`), used by the suite file's model
(:mod:`rockbench.benchmark.suites.model`) and by :func:`declared_from_table`, which reads the table
back from a run's suite.json when ``rockbench score`` re-scores a run folder. Without a suite the
code's defaults (:data:`DEFAULTS`, the default suite's own values) apply and the verdict says so.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

from rockbench.reference_solver.errors import ConfigError

#: The word that makes each scenario's equivalence margin its own η_H–η_M reference gap.
RESTITUTION_GAP = "restitution-gap"
#: The rule that makes the fail limit the largest η_H–η_M reference gap of the run's scenarios.
LARGEST_GAP = "largest-restitution-gap"
#: The rule that makes a held-out variant's margin half the mean η_H–η_M reference gap of the scenarios
#: it is tested on (problems averaged as its difference is).
HALF_GAP = "half-restitution-gap"


@dataclass(frozen=True)
class Declared:
    """The verdict's declarations.

    Attributes
    ----------
    fail_distance : str or float
        A variant fails when in any in-sample scenario its boundary lies farther than this from the
        reference's: ``"largest-restitution-gap"`` (the largest η_H–η_M reference gap of the run's
        scenarios, :func:`fail_limit`) or one number [w/a units]. Independent of the grid.
    equivalence_margin : str or float
        "Within the uncertainty of the restitution": ``"restitution-gap"`` (each scenario's distance
        between the η_H and η_M, average k, reference boundaries) or one number [w/a units].
    held_out_margin : str or float
        A held-out calibration "carries over" when its paired difference from its in-sample twin lies
        within ± this, by a two one-sided test: ``"half-restitution-gap"`` (half the mean η_H–η_M
        reference gap of the scenarios it is tested on, :func:`held_out_margin_of`) or one number
        [w/a units].
    general_range_h_over_b : tuple of float
        ``(lo, hi)``: the slenderness range a claim about problems in general may cover; stated only
        when the suite's problems span it with at least :data:`MIN_SLENDERNESSES` slendernesses [-].
    source : str
        Where the values come from, in words (the suite file, a run's suite.json, the code's defaults).
    """

    fail_distance: str | float = LARGEST_GAP
    equivalence_margin: str | float = RESTITUTION_GAP
    held_out_margin: str | float = HALF_GAP
    general_range_h_over_b: tuple = (1.5, 6.0)
    source: str = field(default="the code's defaults (the default suite's): no suite.json", compare=False)

    def to_dict(self) -> dict:
        """score.json's ``verdict.declared``."""
        d = asdict(self)
        d["general_range_h_over_b"] = list(self.general_range_h_over_b)
        return d


#: The code's defaults: equal to the default suite's ``[verdict]`` table (a test checks it).
DEFAULTS = Declared()

#: The fewest slendernesses that may carry a claim about problems in general.
MIN_SLENDERNESSES = 3


# -- one rule per key ------------------------------------------------------------------------------------
# Each rule returns the checked value or raises ConfigError with the tail of a message that follows the
# key's name (" must be ..., got ...").

def _positive(v) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
        raise ConfigError(f" must be a number > 0 in the normalised plane, got {v!r}.")
    return float(v)


def _rule_or_positive(v, rule: str) -> str | float:
    """``rule`` (any case) or a number > 0 [w/a units]."""
    if isinstance(v, str) and v.strip().lower() == rule:
        return rule
    try:
        if isinstance(v, str):
            raise ConfigError("")
        return _positive(v)
    except ConfigError:
        raise ConfigError(f" must be \"{rule}\" or a number > 0 in the normalised plane, got {v!r}.") from None


def check_fail_distance(v) -> str | float:
    """``fail_distance``: ``"largest-restitution-gap"`` or a number > 0 [w/a units]."""
    return _rule_or_positive(v, LARGEST_GAP)


def check_held_out_margin(v) -> str | float:
    """``held_out_margin``: ``"half-restitution-gap"`` or a number > 0 [w/a units]."""
    return _rule_or_positive(v, HALF_GAP)


def check_equivalence_margin(v) -> str | float:
    """``equivalence_margin``: ``"restitution-gap"`` or a number > 0 [w/a units]."""
    if isinstance(v, str) and v.strip().lower() == RESTITUTION_GAP:
        return RESTITUTION_GAP
    if isinstance(v, str):
        raise ConfigError(f" must be \"{RESTITUTION_GAP}\" or a number > 0, got {v!r}.")
    try:
        return _positive(v)
    except ConfigError:
        raise ConfigError(f" must be \"{RESTITUTION_GAP}\" or a number > 0, got {v!r}.") from None


def check_general_range(v) -> tuple:
    """``general_range_h_over_b``: ``[lo, hi]``, two slendernesses h/b with 0 < lo < hi."""
    ok = (isinstance(v, (list, tuple)) and len(v) == 2
          and all(not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(x) for x in v))
    if not ok or not 0 < v[0] < v[1]:
        raise ConfigError(f" must be [lo, hi], two slendernesses h/b with 0 < lo < hi, got {v!r}.")
    return (float(v[0]), float(v[1]))


#: The keys of a ``[verdict]`` table and their rules.
KEY_RULES = {"fail_distance": check_fail_distance, "equivalence_margin": check_equivalence_margin,
             "held_out_margin": check_held_out_margin, "general_range_h_over_b": check_general_range}


# -- the numbers the rules give on a run ------------------------------------------------------------------

def fail_limit(declared: Declared, gaps: dict) -> dict:
    """The fail limit on a run: ``{"value", "rule", "from"}``. With :data:`LARGEST_GAP`, ``value`` is the
    largest of ``gaps`` (``{(block, pulse): η_H–η_M reference gap}``, score.json's ``reference_gaps``)
    and ``from`` its scenario (``{"block", "pulse", "gap"}``); None where the run has no gap (no η_M
    reference map), and then no scenario fails by its distance. A declared number is its own value
    (``rule`` None)."""
    if declared.fail_distance != LARGEST_GAP:
        return {"value": float(declared.fail_distance), "rule": None, "from": None}
    known = {k: g for k, g in gaps.items() if math.isfinite(g) and g > 0}
    if not known:
        return {"value": None, "rule": LARGEST_GAP, "from": None}
    (block, pulse), gap = max(known.items(), key=lambda kv: (kv[1], kv[0]))
    return {"value": gap, "rule": LARGEST_GAP, "from": {"block": block, "pulse": pulse, "gap": gap}}


def held_out_margin_of(declared: Declared, gaps) -> float | None:
    """A held-out test's margin [w/a units]: with :data:`HALF_GAP`, half the mean over problems of
    ``gaps`` (``(gap, cluster)`` of each tested scenario: a problem's sizes averaged first, as the
    paired difference averages them), None where no tested scenario has a gap; else the declared
    number."""
    if declared.held_out_margin != HALF_GAP:
        return float(declared.held_out_margin)
    per: dict = {}
    for gap, cluster in gaps:
        if math.isfinite(gap) and gap > 0:
            per.setdefault(cluster, []).append(gap)
    if not per:
        return None
    return 0.5 * sum(sum(g) / len(g) for g in per.values()) / len(per)


def rule_words(value) -> str:
    """A declared value in words: a rule's meaning, a number as written."""
    return {LARGEST_GAP: "the largest η_H–η_M reference gap of the run's scenarios",
            HALF_GAP: "half the mean η_H–η_M reference gap of the tested scenarios",
            RESTITUTION_GAP: "each scenario's η_H–η_M reference gap"}.get(value, f"{value:g}" if isinstance(value, float)
                                                                          else str(value))


def declared_from_table(table, source: str, where: str = "verdict") -> Declared:
    """A ``[verdict]`` table (keys left out take :data:`DEFAULTS`) as :class:`Declared`.

    Raises
    ------
    ConfigError
        Not a table, an unknown key or a bad value: one line naming ``where`` and the key.
    """
    if not isinstance(table, dict):
        raise ConfigError(f"{where} must be a table of {', '.join(KEY_RULES)}, got {table!r}.")
    unknown = sorted(set(table) - set(KEY_RULES))
    if unknown:
        raise ConfigError(f"unknown key {where}.{unknown[0]}; [verdict] takes {', '.join(sorted(KEY_RULES))}.")
    values = {}
    for key, rule in KEY_RULES.items():
        if key in table:
            try:
                values[key] = rule(table[key])
            except ConfigError as e:
                raise ConfigError(f"{where}.{key}{e}") from None
    return Declared(**values, source=source)


def declared_of_runs(roots) -> Declared:
    """The declarations of the runs at ``roots`` (folders written by ``rockbench run``): the ``[verdict]``
    table of the suite each ran, as its suite.json records it; the code's :data:`DEFAULTS` where no run
    has a suite.json, and :data:`Declared.source` says which.

    Raises
    ------
    ConfigError
        A suite.json whose table is damaged, or runs that declare different verdicts (score them one
        at a time).
    """
    from rockbench.benchmark.store.files import read_json  # the store on first use: declared values need no file

    found: dict = {}
    for root in dict.fromkeys(Path(r) for r in roots):
        f = root / "suite.json"
        if not f.is_file():
            continue
        suite = read_json(f).get("suite") or {}
        name = (suite.get("suite") or {}).get("name") or root.name
        where = f"{str(f)!r}: verdict"
        if "verdict" in suite:
            found[root] = declared_from_table(suite["verdict"], f"the suite {name!r} (its run's suite.json)", where)
        else:
            found[root] = Declared(source=f"the code's defaults (the default suite's): the suite {name!r} declares none")
    if not found:
        return DEFAULTS
    first = next(iter(found.values()))
    other = next((r for r, d in found.items() if d != first), None)
    if other is not None:
        raise ConfigError(f"the runs given declare different verdicts ({next(iter(found))} and {other}: "
                          "suite.json's [verdict]); score them one at a time.")
    return first


def defaults_note(declared: dict) -> str | None:
    """A line saying that the code's defaults were used, with their values (``declared``: score.json's
    ``verdict.declared``); None for a suite's own."""
    if not str(declared.get("source", "")).startswith("the code's defaults"):
        return None
    return (f"the verdict's declarations are {declared['source']}: fail_distance {declared['fail_distance']}, "
            f"equivalence_margin {declared['equivalence_margin']}, held_out_margin {declared['held_out_margin']}, "
            f"general_range_h_over_b {list(declared['general_range_h_over_b'])}")
