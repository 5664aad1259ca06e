"""The report stage of ``rockbench run`` timed on a finished run folder: wall and CPU seconds.

    python tests/measurements/bench_report.py RUN_DIR [--repeat 2] [--json OUT] [--before OUT] [--record NAME]

RUN_DIR is a finished run's output (``rockbench-results/default`` after ``rockbench run``). It is copied
to a temporary folder (the original is only read); each repeat removes the copy's report (score.json,
report.md, index.html, img/, trajectories/) and runs the suite runner's report stage on it as
``rockbench run`` does once its maps are done (the θ(t) runs of the suite's ``[report] cases``
simulated, the maps scored, every picture drawn, the pages written), with the suite of the run's
suite.json when that file exists, else the default suite. CPU is this process's and its helper
processes' (user + system). ``--json OUT`` writes the figures to OUT; ``--before OUT`` puts the
figures of such a file (e.g. measured on an earlier commit) beside them; ``--record NAME`` writes the
record NAME among tests/measurements/results/ (:mod:`records`).
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))   # records

from records import write_record  # noqa: E402
from rockbench.benchmark.blocks.experiments import load_outcomes  # noqa: E402
from rockbench.benchmark.suites import runner  # noqa: E402
from rockbench.benchmark.suites.model import load_suite  # noqa: E402

DEFAULT_SUITE = Path(__file__).resolve().parents[2] / "benchmark" / "suites" / "default.toml"
REPORT_FILES = ("score.json", "report.md", "index.html", "img", "trajectories")


def cpu_s() -> float:
    """User + system CPU of this process and of its finished helper processes [s]."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def clear_report(run: Path) -> None:
    for name in REPORT_FILES:
        p = run / name
        shutil.rmtree(p) if p.is_dir() else p.unlink(missing_ok=True)


def time_report(run: Path, suite) -> dict:
    """One report stage on ``run`` (its report removed first): wall and CPU [s]."""
    clear_report(run)
    experiments = load_outcomes(suite.report.experiments) if suite.report.experiments else None
    result = {"notes": [], "score": None}
    t0, c0 = time.perf_counter(), cpu_s()
    runner._score_and_report(suite, run, result, experiments, True, ("png",), lambda msg: None, set())
    return {"wall_s": round(time.perf_counter() - t0, 1), "cpu_s": round(cpu_s() - c0, 1)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--before", type=Path)
    ap.add_argument("--record")
    args = ap.parse_args(argv)
    suite_file = Path(json.loads((args.run_dir / "suite.json").read_text()).get("path") or DEFAULT_SUITE)
    suite = load_suite(suite_file if suite_file.is_file() else DEFAULT_SUITE)
    runner._warm_report()   # as the run does while its last maps are computed
    with tempfile.TemporaryDirectory(prefix="bench-report-") as tmp:
        run = Path(tmp) / "run"
        shutil.copytree(args.run_dir, run, symlinks=True)
        runs = []
        for i in range(args.repeat):
            runs.append(time_report(run, suite))
            print(f"report stage {i + 1}: wall {runs[-1]['wall_s']} s, CPU {runs[-1]['cpu_s']} s", flush=True)
    figures = {"runs": runs, "wall_s_median": statistics.median(r["wall_s"] for r in runs),
               "cpu_s_median": statistics.median(r["cpu_s"] for r in runs),
               "maps": len(list((args.run_dir / "maps").rglob("run.json")))}
    if args.before:
        figures["before"] = json.loads(args.before.read_text())
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1) + "\n")
    if args.record:
        path = write_record(args.record, "The report stage of `rockbench run` (θ(t) runs, scores, pictures, "
                            "pages: the runner's report after the last map) on a copy of a finished run "
                            "folder: wall and CPU seconds (this process and its helpers) per repeat.",
                            "python tests/measurements/bench_report.py " + " ".join(argv or sys.argv[1:]),
                            figures, packages=("matplotlib", "numpy"))
        print(f"record written: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
