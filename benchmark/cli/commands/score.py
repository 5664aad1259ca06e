"""``rockbench score``: score engine maps against reference maps (and experiments); a CI gate."""

from __future__ import annotations

import argparse
import json
import sys
import textwrap
from dataclasses import replace
from pathlib import Path

from rockbench.benchmark.blocks.experiments import load_outcomes
from rockbench.benchmark.scoring.declared import defaults_note
from rockbench.benchmark.report.speed_words import speed_block
from rockbench.benchmark.scoring.metrics import METRICS, METRICS_VERSION, parse_thresholds
from rockbench.benchmark.scoring.score_runs import ALLOW_INCOMPLETE, ALLOW_INCOMPLETE_HELP, gate, score_dirs
from rockbench.benchmark.report.tables import (SCENARIO_TITLE, SUMMARY_TITLE, method_line, pairs_table, scenario_table, summary_table,
                               verdict_block)
from rockbench.benchmark.store.atomic import check_output_file
from rockbench.benchmark.store.files import json_safe, write_json


def register(sub) -> None:

    defs = "\n".join(textwrap.fill(f"{m.name} ({m.role}; {m.direction} is better, perfect {m.perfect:g}): "
                                   f"{m.question} {m.definition}",
                                   width=96, initial_indent="  ", subsequent_indent="    ", break_on_hyphens=False)
                      for m in METRICS.values())
    p = sub.add_parser("score", help="score engine maps against reference maps; gate with --fail-under",
                       formatter_class=argparse.RawDescriptionHelpFormatter,
                       description="Scores every engine map found in or below RUN_DIR against the reference "
                       "maps of the same block and pulse (or those of --against), and prints the verdict: each "
                       "variant's primary metric (boundary_mean) with its 95 % interval on the suite's problems, "
                       "each against the best of its settings class (Hsu's multiple comparisons with the best) with "
                       "the smallest difference the suite could detect, and which fail and why, by the [verdict] "
                       "declarations of the run's suite (suite.json; the default suite's when there is none).\nExit 0 ok, "
                       "1 a gate failed, 2 bad usage or an incomplete engine map, 5 nothing comparable.",
                       epilog=f"metrics (version {METRICS_VERSION}), as score.json also records them:\n{defs}")
    p.add_argument("run_dirs", nargs="+", metavar="RUN_DIR", help="map directories, or folders holding them")
    p.add_argument("--against", action="append", default=[], metavar="REF_DIR",
                   help="score every map of RUN_DIR against the maps found here (repeatable)")
    p.add_argument("--fail-under", action="append", default=[], metavar="METRIC=VALUE",
                   help="exit 1 when a higher-is-better metric is below VALUE (repeatable)")
    p.add_argument("--fail-over", action="append", default=[], metavar="METRIC=VALUE",
                   help="exit 1 when a lower-is-better metric is above VALUE (repeatable)")
    p.add_argument("--experiments", metavar="FILE.csv", help="shaking-table outcomes to score every map against: "
                   "block,pulse,f_hz,amplitude_mps2,outcome,repetitions,source (or omega_rad_s/period_s, amplitude_g); "
                   "outcome T, R or O")
    p.add_argument("--out", metavar="FILE", help="where to write score.json (default: RUN_DIR/score.json of the first)")
    p.add_argument("--no-write", action="store_true", help="do not write score.json")
    p.add_argument("--json", action="store_true", help="print the score document on stdout")
    p.add_argument("--markdown", action="store_true", help="print Markdown tables (for a pull-request comment)")
    p.add_argument(ALLOW_INCOMPLETE, action="store_true", help=ALLOW_INCOMPLETE_HELP)
    p.set_defaults(func=run)


def run(args) -> int:
    thresholds = {**parse_thresholds(args.fail_under, "higher", "--fail-under"),
                  **parse_thresholds(args.fail_over, "lower", "--fail-over")}
    points = None
    if args.experiments:
        points = load_outcomes(args.experiments)
    out = None
    if not args.no_write:   # refused before the scoring, not after it
        out = check_output_file(Path(args.out) if args.out else Path(args.run_dirs[0]) / "score.json", "--out")
    scores = score_dirs(args.run_dirs, args.against or None, points, allow_incomplete=args.allow_incomplete)
    for n in (scores.pairing or {}).get("notes", []):
        print(f"rockbench: note: {n}", file=sys.stderr)
    failures = gate(scores, thresholds)
    scores = replace(scores, gate={"thresholds": thresholds, "failed": failures, "passed": not failures})
    if out is not None:
        write_json(out, scores.to_json())
        print(f"rockbench: scores written to {out}", file=sys.stderr)
    note = defaults_note(scores.verdict.declared)     # after the write: an error stays one line
    if note:
        print(f"rockbench: note: {note}", file=sys.stderr)
    if args.json:
        print(json.dumps(json_safe(scores.to_json()), indent=2))
    else:
        md = args.markdown
        print(verdict_block(scores, markdown=md))
        print((f"\n### {SUMMARY_TITLE}\n\n" if md else f"\n{SUMMARY_TITLE}\n") + summary_table(scores, markdown=md))
        print(("\n" if md else "") + method_line())
        print((f"\n### {SCENARIO_TITLE}\n\n" if md else f"\n{SCENARIO_TITLE}\n") + scenario_table(scores, markdown=md))
        print(("\n### Pairs\n\n" if md else "\nPairs\n") + pairs_table(scores, markdown=md))
        if scores.speed is not None:
            print("\n" + speed_block(scores.speed.record, markdown=md))
        for e in scores.experiments or ():
            print(f"\nexperiments vs {e['variant']} {e.get('restitution', '')} ({Path(e['dir']).name}): "
                  f"accuracy {e['accuracy']:.3f}, overturn accuracy {e['overturn_accuracy']:.3f} over {e['runs']} "
                  f"run(s), {e['outside']} outside the map")
        if thresholds:
            print(("\n**gate: " if md else "\ngate: ") + ("passed" if not failures else f"FAILED ({len(failures)})")
                  + ("**" if md else ""))
    for line in failures:
        print(f"rockbench: gate failed: {line}", file=sys.stderr)
    return 1 if failures else 0
