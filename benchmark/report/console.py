"""The scores on a terminal: what ``rockbench run`` prints at its end (:func:`console_summary`)."""

from __future__ import annotations

from rockbench.benchmark.scoring.scores import Scores
from rockbench.benchmark.report.speed_words import speed_block
from rockbench.benchmark.report.tables import SUMMARY_TITLE, summary_table, verdict_block


def console_summary(scores: Scores) -> str:
    """The verdict, the summary table (where a pair was scored) and the speed stage, as text."""
    parts = [verdict_block(scores), SUMMARY_TITLE, summary_table(scores)] if scores.pairs else []
    return "\n".join(parts + [speed_block(None if scores.speed is None else scores.speed.record)]).strip()
