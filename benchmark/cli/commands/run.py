"""``rockbench run``: the whole benchmark (a suite): maps (resumed), scores, report, summary table.

Exit code 3 when an engine cannot simulate (:mod:`rockbench.benchmark.engine_info.health`): its other maps
are skipped, the other engines' maps and the report still come out, and one line per such engine
ends the output.
"""

from __future__ import annotations

import sys
from pathlib import Path

from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.blocks.experiments import load_outcomes
from rockbench.benchmark.store.atomic import check_output_dir
from rockbench.benchmark.suites.model import grid_cells, load_suite, skipped_reference_note, suite_path
from rockbench.benchmark.suites.plan import check_suite, engine_names, parse_engines, plan, speed_engines, speed_plan_lines
from rockbench.benchmark.suites.runner import run_suite
from rockbench.benchmark.cli.options import add_figure_format_option, figure_formats_from_args, jobs_from_args


def register(sub) -> None:
    p = sub.add_parser("run", help="the whole benchmark: every engine, block and pulse, reference maps, scores, "
                       "report (a suite file; default: the shipped suite 'default', see --show-suite)")
    p.add_argument("suite", nargs="?", default=None, metavar="SUITE.toml",
                   help="a suite file, or the name of a shipped suite (default, quick, full, newton, speed)")
    p.add_argument("--show-suite", nargs="?", const="default", default=None, metavar="NAME",
                   help="print a shipped suite (default, quick, full, newton, speed) as TOML, to read or to copy and edit, and exit")
    p.add_argument("--quick", action="store_true", help="the reduced suite (one block per slenderness, coarse grids)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output directory (default rockbench-results/<suite name>); rerunning resumes")
    p.add_argument("--engines", default=None, metavar="NAME,...",
                   help="only these engines (e.g. the one under test); the reference maps are always computed")
    p.add_argument("--jobs", default=None, metavar="N",
                   help="worker processes (default: all cores): N engine maps at a time, one worker each")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="compute the calibrations and maps on a Dask cluster (tcp://host:8786), or 'local' for a "
                   "LocalCluster of --jobs workers on 127.0.0.1; the same maps and scores, resumed the same way")
    p.add_argument("--experiments", metavar="FILE.csv", help="shaking-table outcomes to score against: "
                   "block,pulse,f_hz,amplitude_mps2,outcome,repetitions,source (or omega_rad_s/period_s, amplitude_g); "
                   "outcome T, R or O")
    p.add_argument("--no-report", action="store_true", help="maps and score.json only")
    p.add_argument("--plan", action="store_true", help="list the maps the suite would compute (and on stderr what its "
                   "speed stage costs per engine) and exit")
    add_figure_format_option(p, what="report's pictures in DIR/img/ (index.html embeds the PNG, always written)")
    p.set_defaults(func=run)


def run(args) -> int:

    if args.show_suite is not None:
        if args.suite is not None or args.quick:
            raise ConfigError("--show-suite NAME prints one shipped suite; give no other suite or --quick.")
        if args.show_suite.endswith(".toml") or "/" in args.show_suite:
            raise ConfigError(f"--show-suite takes the name of a shipped suite (default, quick, full, newton, speed), got "
                              f"{args.show_suite!r}.")
        print(suite_path(args.show_suite, False).read_text(), end="")
        return 0
    if args.quick and args.suite is not None:
        raise ConfigError(f"give either a suite ({args.suite}) or --quick, not both.")
    only = parse_engines(args.engines)
    suite = load_suite(suite_path(args.suite, args.quick))
    jobs = jobs_from_args(args)
    formats = figure_formats_from_args(args)
    out = Path(args.out) if args.out else Path("rockbench-results") / suite.name
    if args.plan:
        engines, notes = engine_names(suite, only)
        engines, more = check_suite(suite, engines, only is not None or suite.engines.names != "available")
        fast, speed_notes = speed_engines(suite, engines)
        notes += more + speed_notes + [n for n in (skipped_reference_note(suite),) if n]
        notes += speed_plan_lines(suite, fast, grid_cells(suite))
        for n in notes:
            print(f"rockbench: {n}", file=sys.stderr)
        for j in plan(suite, engines):
            print(out / j.subdir)
        return 0
    check_output_dir(out, "--out")
    points = None
    if args.experiments:
        points = load_outcomes(args.experiments)
    res = run_suite(suite, out, jobs=jobs, experiments=points, report=not args.no_report, engines=only,
                    figure_formats=formats, scheduler=args.scheduler)
    for n in res["notes"]:
        print(f"rockbench: note: {n}", file=sys.stderr)
    print(f"rockbench: {len(res['maps'])} maps in {res['maps_wall_s']:.0f} s, total {res['wall_s']:.0f} s; "
          f"results in {out}", file=sys.stderr)
    print(res["summary"] or "no scores (no engine map could be paired with a reference map)")
    for line in res["failed_cells"]:
        print(f"failed cells: {line}")
    if res.get("report"):
        print(f"report: {res['report']['html']}")
    for line in res["cannot_simulate"]:
        print(f"rockbench: error: {line}", file=sys.stderr)
    return 3 if res["cannot_simulate"] else 0
