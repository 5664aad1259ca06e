"""``rockbench report``: index.html and report.md with scores, stability graphs, θ(t), calibration, speed."""

from __future__ import annotations

import sys

from rockbench.benchmark.blocks.cases import FIG17, parse_case
from rockbench.benchmark.blocks.experiments import load_outcomes
from rockbench.benchmark.report.build import build_report
from rockbench.benchmark.scoring.score_runs import ALLOW_INCOMPLETE, ALLOW_INCOMPLETE_HELP
from rockbench.benchmark.store.atomic import check_output_dir
from rockbench.benchmark.trajectories import record_for_report
from rockbench.benchmark.cli.options import add_figure_format_option, figure_formats_from_args

#: the outcomes CSV format (kept here so that --help needs no import of the harness)
_FORMAT = ("block,pulse,f_hz,amplitude_mps2,outcome,repetitions,source (or omega_rad_s/period_s, amplitude_g); "
           "outcome T, R or O")


def register(sub) -> None:
    p = sub.add_parser("report", help="write the benchmark report (index.html, report.md) for run directories")
    p.add_argument("run_dirs", nargs="+", metavar="RUN_DIR", help="map directories, or folders holding them")
    p.add_argument("--out", required=True, metavar="DIR", help="report directory (created)")
    p.add_argument("--against", action="append", default=[], metavar="REF_DIR",
                   help="reference maps to score against (default: the reference maps among RUN_DIR)")
    p.add_argument("--experiments", metavar="FILE.csv", help="shaking-table outcomes to draw and score: " + _FORMAT)
    p.add_argument("--case", action="append", default=[], metavar="BLOCK:PULSE:W_RATIO:A_RATIO",
                   help="θ(t) comparison case (repeatable; default the paper's Fig. 17 case B3M:sine:6:6.1)")
    p.add_argument("--no-trajectories", action="store_true", help="skip the θ(t) comparison (no simulation)")
    p.add_argument(ALLOW_INCOMPLETE, action="store_true", help=ALLOW_INCOMPLETE_HELP)
    add_figure_format_option(p, what="pictures in DIR/img/ (index.html embeds the PNG, which is always written)")
    p.set_defaults(func=run)


def run(args) -> int:
    cases = tuple(parse_case(c) for c in args.case) or (FIG17,)
    formats = figure_formats_from_args(args)
    check_output_dir(args.out, "--out")
    points = None
    if args.experiments:
        points = load_outcomes(args.experiments)
    if not args.no_trajectories:
        record_for_report(cases, args.run_dirs, args.out, against=args.against or None)
    res = build_report(args.run_dirs, args.out, against=args.against or None, experiments=points, cases=cases,
                       trajectories=not args.no_trajectories, allow_incomplete=args.allow_incomplete,
                       figure_formats=formats)
    for n in res["notes"]:
        print(f"rockbench: note: {n}", file=sys.stderr)
    print(res["html"])
    return 0
