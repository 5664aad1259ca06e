"""``rockbench versions ENGINE==A ENGINE==B [--quick | SUITE]``: one engine release against another.

Builds (or reuses) an isolated environment per version (:mod:`rockbench.benchmark.engine_info.envs`),
runs the same suite in each with that environment's rockbench (``run --engines ENGINE``), then prints
``compare``'s verdict between them, A the baseline and B the candidate, with the versions named.

Exit codes: those of ``compare`` (0 no regression, 1 a regression, 5 not comparable); 2 bad usage
(not ENGINE==VERSION, an unknown engine, two engines, one version twice); 3 an environment cannot be
built (e.g. no such version) or the engine cannot simulate at one of the versions (the verdict is
still printed when both runs wrote scores); another code of a run is passed on.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.engine_info.envs import build_env, parse_pair, plan_env, source_dir, source_fingerprint
from rockbench.benchmark.store.atomic import check_output_dir
from rockbench.benchmark.cli.options import jobs_from_args
from rockbench.benchmark.cli.commands import compare


def register(sub) -> None:
    p = sub.add_parser("versions", help="one engine release against another: a cached environment per version, "
                       "the same suite in each, compare's verdict",
                       description="Runs the suite (--quick, a suite file or a shipped suite's name; default: "
                       "'default') restricted to ENGINE in a cached virtual environment per version and compares "
                       "the two (the first is the baseline). Environments live under $ROCKBENCH_CACHE/versions.")
    p.add_argument("specs", nargs="*", metavar="ENGINE==VERSION [SUITE]",
                   help="two versions of one engine, e.g. mujoco==3.3.7 mujoco==4.0.0, then optionally a suite file "
                   "or a shipped suite's name (default, quick, full, newton, speed)")
    p.add_argument("--quick", action="store_true", help="the reduced suite (what an engine project's CI runs)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="where the two runs go (default rockbench-results/versions/ENGINE-A-vs-B); rerunning resumes")
    p.add_argument("--jobs", default=None, metavar="N", help="worker processes of each run (default: all cores)")
    p.add_argument("--source", default=None, metavar="DIR",
                   help="the rockbench source tree to install in the environments (default: the one running)")
    p.set_defaults(func=run)


def _suite_args(args, suite: str | None) -> list[str]:
    if args.quick and suite:
        raise ConfigError(f"give either a suite ({suite}) or --quick, not both.")
    if args.quick:
        return ["--quick"]
    if suite:
        p = Path(suite)
        return [str(p.resolve())] if p.exists() else [suite]
    return []


def plan_runs(args):
    """``(a, b, plans, suite_args, out)``: everything checked, nothing built."""
    specs, suite = list(args.specs), None
    if len(specs) == 3 and "==" not in specs[2]:
        suite = specs.pop()
    a, b = parse_pair(specs)
    suite_args = _suite_args(args, suite)
    jobs = jobs_from_args(args)
    if jobs is not None:
        suite_args += ["--jobs", str(jobs)]
    src = source_dir(args.source)
    fp = source_fingerprint(src)
    plans = [plan_env(s, src, fingerprint=fp) for s in (a, b)]
    out = Path(args.out) if args.out else Path("rockbench-results") / "versions" / f"{a.slug}-vs-{b.version}"
    return a, b, plans, suite_args, out


def _runner():
    """How commands are run (a test replaces this to run nothing)."""
    return subprocess.run


def run(args) -> int:
    runner = _runner()

    a, b, plans, suite_args, out = plan_runs(args)
    check_output_dir(out, "--out")
    log = (lambda m: print(f"rockbench: {m}", file=sys.stderr))
    codes, times = {}, {}
    for plan in plans:
        t0 = time.perf_counter()
        log(f"{plan.spec.label}: environment {plan.path} ({plan.state})")
        build_env(plan, runner=runner, log=log)
        t1 = time.perf_counter()
        cmd = [str(plan.rockbench), "run", *suite_args, "--engines", plan.spec.engine, "--out",
               str(out / plan.spec.slug), "--no-report"]
        log(f"{plan.spec.label}: {' '.join(cmd[1:])}")
        codes[plan.spec] = runner(cmd).returncode      # its output goes straight to this terminal
        times[plan.spec] = (t1 - t0, time.perf_counter() - t1)
    for plan in plans:
        env_s, run_s = times[plan.spec]
        print(f"{plan.spec.label}: environment {env_s:.0f} s ({plan.state}), suite {run_s:.0f} s, "
              f"exit {codes[plan.spec]}")
    bad = {s: c for s, c in codes.items() if c not in (0, 3)}
    if bad:
        s, c = next(iter(bad.items()))
        print(f"rockbench: error: the run with {s.label} exited {c} (its output is above); nothing compared.",
              file=sys.stderr)
        return c
    verdict = _compare(out / a.slug, out / b.slug)
    print(f"versions: {a.label} (baseline) → {b.version} (candidate): "
          + {0: "no regression", 1: "REGRESSION", 5: "not comparable"}.get(verdict, f"exit {verdict}"))
    return 3 if 3 in codes.values() else verdict


def _compare(base: Path, cur: Path) -> int:
    """``rockbench compare BASE CUR`` in this process: its table, versions line and exit code."""
    return compare.run(argparse.Namespace(baseline=str(base), current=str(cur), tolerance=[], json=False,
                                          markdown=False, allow_incomplete=False,
                                          cost_factor=compare.COST_RISE_FACTOR))
