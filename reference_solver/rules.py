"""The version of rockbench's rule set: the rules that decide an engine's answer apart from the engine.

A rule applied to every engine alike may change when a better-founded one is found; every answer
it moves must then say why. :data:`RULES_VERSION` names the rule set in force. It is part of every
calibration's cache key, written into every map's run.json and every score.json, and `rockbench
compare` refuses to compare results computed under two versions (exit 5): rerun the older one.

The rules it covers:

* the calibration of a contact engine: the one free-rocking η reader and the one pick among the
  settings a search measured (engines/, docs/engines.md);
* the one end-of-run rule, floor 1's per-sample ``run_end`` (reference_solver/classify.py);
* the time step of a calibrated variant: the coarsest step of a ladder agreeing with the finest
  step at which the calibration reaches its target (engines/calibration/step_rule.py);
* what "as shipped" means: the engine's own defaults, its own time step included, with only the
  block, the table, μ and the pulse posed by the benchmark (docs/engines.md);
* the one classifier and the one validity rule of floor 1, with their tolerances.

Version 3 takes the time-step rule's yardstick as the finest step at which the calibration is
reached, where version 2 took the ladder's finest step whether or not it was reached.

The metric definitions have their own version (``METRICS_VERSION``, docs/scores.md): a new metric
rescores old maps; a new rule needs new maps.
"""

from __future__ import annotations

__all__ = ["RULES_VERSION", "rules_mismatch"]

#: The rule set in force (the module docstring lists what it covers)
RULES_VERSION = "3"


def rules_mismatch(recorded, what: str) -> str | None:
    """The start of a line saying that ``what`` was made under another rule set (the caller adds
    what to do); None when ``recorded`` is :data:`RULES_VERSION`. A record without a version
    predates version 2."""
    have = "1" if recorded is None else str(recorded)
    if have == RULES_VERSION:
        return None
    return f"{what} was computed under rules version {have}, this rockbench applies rules version {RULES_VERSION}"
