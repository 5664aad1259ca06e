"""What a suite declares before its verdict is computed: the failing limit, the equivalence margins and
the slenderness range a claim about problems in general may cover (the suite file's ``[verdict]``
table; docs/scores.md, "What a suite declares").

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


@dataclass(frozen=True)
class Declared:
    """The verdict's declarations.

    Attributes
    ----------
    fail_distance : float
        A variant fails when in any in-sample scenario its boundary lies farther than this from the
        reference's [w/a units]. Independent of the grid.
    equivalence_margin : str or float
        "Within the uncertainty of the restitution": ``"restitution-gap"`` (each scenario's distance
        between the η_H and η_M, average k, reference boundaries) or one number [w/a units].
    held_out_margin : float
        A held-out calibration "carries over" when its paired difference from its in-sample twin lies
        within ± this, by a two one-sided test [w/a units].
    general_range_h_over_b : tuple of float
        ``(lo, hi)``: the slenderness range a claim about problems in general may cover; stated only
        when the suite's problems span it with at least :data:`MIN_SLENDERNESSES` slendernesses [-].
    source : str
        Where the values come from, in words (the suite file, a run's suite.json, the code's defaults).
    """

    fail_distance: float = 0.3
    equivalence_margin: str | float = RESTITUTION_GAP
    held_out_margin: float = 0.05
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


def check_fail_distance(v) -> float:
    """``fail_distance``: a number > 0 [w/a units]."""
    return _positive(v)


def check_held_out_margin(v) -> float:
    """``held_out_margin``: a number > 0 [w/a units]."""
    return _positive(v)


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
    return (f"the verdict's declarations are {declared['source']}: fail_distance {declared['fail_distance']:g}, "
            f"equivalence_margin {declared['equivalence_margin']}, held_out_margin {declared['held_out_margin']:g}, "
            f"general_range_h_over_b {list(declared['general_range_h_over_b'])}")
