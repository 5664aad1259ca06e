"""``rockbench run``: the whole benchmark (a suite): maps (resumed), scores, report, summary table."""

from __future__ import annotations

import sys


def register(sub) -> None:
    p = sub.add_parser("run", help="the whole benchmark: every engine, block and pulse, reference maps, scores, "
                       "report (a suite file; default benchmark/suites/default.toml)")
    p.add_argument("suite", nargs="?", default=None, metavar="SUITE.toml",
                   help="a suite file, or the name of a shipped suite (default, quick)")
    p.add_argument("--quick", action="store_true", help="the reduced suite (one block per slenderness, coarse grids)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output directory (default rockbench-results/<suite name>); rerunning resumes")
    p.add_argument("--jobs", default=None, metavar="N",
                   help="worker processes (default: all cores): N engine maps at a time, one worker each")
    p.add_argument("--experiments", metavar="FILE.csv", help="shaking-table outcomes to score against (docs/data.md)")
    p.add_argument("--no-report", action="store_true", help="maps and score.json only")
    p.add_argument("--plan", action="store_true", help="list the maps the suite would compute and exit")
    p.set_defaults(func=run)


def run(args) -> int:
    from pathlib import Path

    from ...reference_solver.errors import ConfigError
    from ..run import engine_names, load_suite, plan, run_suite, suite_path

    if args.quick and args.suite is not None:
        raise ConfigError(f"give either a suite ({args.suite}) or --quick, not both.")
    suite = load_suite(suite_path(args.suite, args.quick))
    jobs = None
    if args.jobs is not None:
        try:
            jobs = int(args.jobs)
        except ValueError:
            jobs = 0
        if jobs < 1:
            raise ConfigError(f"--jobs must be a whole number >= 1, got {args.jobs!r}.")
    out = Path(args.out) if args.out else Path("rockbench-results") / suite.name
    if args.plan:
        engines, notes = engine_names(suite)
        for n in notes:
            print(f"rockbench: {n}", file=sys.stderr)
        for j in plan(suite, engines):
            print(out / j.subdir)
        return 0
    points = None
    if args.experiments:
        from ..experiments import load_outcomes
        points = load_outcomes(args.experiments)
    res = run_suite(suite, out, jobs=jobs, experiments=points, report=not args.no_report)
    for n in res["notes"]:
        print(f"rockbench: note: {n}", file=sys.stderr)
    print(f"rockbench: {len(res['maps'])} maps in {res['maps_wall_s']:.0f} s, total {res['wall_s']:.0f} s; "
          f"results in {out}", file=sys.stderr)
    print(res["summary"] or "no scores (no engine map could be paired with a reference map)")
    if res.get("report"):
        print(f"report: {res['report']['html']}")
    return 0
