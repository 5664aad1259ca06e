"""``rockbench compare``: did a change make an engine's scores worse? Exit 1 on a regression."""

from __future__ import annotations

import json
import math

from rockbench.benchmark.engine_info.versions import differences, differences_line
from rockbench.benchmark.scoring.metrics import METRICS
from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.scoring.score_runs import DEFAULT_TOLERANCE_CELLS, compare_scores, load_score, parse_tolerances
from rockbench.benchmark.scoring.speed import COST_RISE_FACTOR
from rockbench.benchmark.report.tables import compare_table
from rockbench.benchmark.store.files import json_safe


def register(sub) -> None:
    p = sub.add_parser("compare", help="compare two scored runs; exit 1 on a regression beyond the tolerance",
                       description="BASELINE and CURRENT are score.json files or run directories (scored on the "
                       "fly when they hold no score.json). A pair (engine, block, pulse, restitution, reference) "
                       "regresses when a metric got worse by more than its tolerance, or when the pair is missing "
                       "from CURRENT. Default tolerance of every metric: what "
                       f"{DEFAULT_TOLERANCE_CELLS:g} flipped cells change on the pair's grid, at least "
                       + ", ".join(f"{k} {m.tolerance:g}" for k, m in METRICS.items())
                       + ". Where both runs have a speed stage, an engine whose cost at matched accuracy rose by more "
                       "than --cost-factor (or is no longer reached) regresses too, when both were timed on like "
                       "machines. Exit 0 no regression, 1 regression, 2 bad usage, 5 not comparable.")
    p.add_argument("baseline", metavar="BASELINE")
    p.add_argument("current", metavar="CURRENT")
    p.add_argument("--tolerance", action="append", default=[], metavar="VALUE|Ncells|METRIC=VALUE|METRIC=Ncells",
                   help="accepted worsening: a number in the metric's units, or Ncells (what N flipped cells change "
                   "on the pair's grid); alone for every metric, METRIC=... for one (repeatable)")
    p.add_argument("--json", action="store_true", help="print the comparison as JSON on stdout")
    p.add_argument("--markdown", action="store_true", help="print a Markdown table (for a pull-request comment)")
    p.add_argument("--cost-factor", type=float, default=COST_RISE_FACTOR, metavar="F",
                   help="flag (exit 1) an engine whose cost at matched accuracy in the speed stage rose by more than F "
                   f"times, on like machines only (CPU model, cores, threads; default {COST_RISE_FACTOR:g})")
    p.add_argument("--allow-incomplete", action="store_true",
                   help="compare score files (or run directories) whose pairs come from incomplete maps instead of "
                   "exiting 2")
    p.set_defaults(func=run)


def run(args) -> int:
    tol = parse_tolerances(args.tolerance)
    if not (math.isfinite(args.cost_factor) and args.cost_factor >= 1.0):
        raise ConfigError(f"--cost-factor must be a number >= 1 (how many times costlier is a regression), got "
                          f"{args.cost_factor:g}; e.g. --cost-factor 1.5.")
    allow = args.allow_incomplete
    base, cur = load_score(args.baseline, allow), load_score(args.current, allow)
    res = compare_scores(base, cur, tol, args.cost_factor)
    docs = base.to_json(), cur.to_json()
    res["engine_versions"] = differences(*docs)      # engines compared at other versions (engine_versions.py)
    if args.json:
        print(json.dumps(json_safe(res), indent=2))
    else:
        if res["engine_versions"]:
            print(differences_line(*docs))
        print(compare_table(res, markdown=args.markdown))
    return 1 if res["status"] != "ok" else 0
