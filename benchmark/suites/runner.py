"""The whole benchmark as one job: a suite file → maps (resumed) → scores → report.

A suite is a TOML file (``benchmark/suites/default.toml`` and ``quick.toml`` are shipped)::

    [suite]
    name = "default"
    description = "..."

    [grid]                       # LO:HI:N, N values from LO to HI inclusive
    w_ratio = "1:16:51"          # ω/p
    a_ratio = "1:12:51"          # a0/(g·tanα)
    adaptive = true              # engine maps: coarse grid, refined where neighbours disagree
                                 # (reference maps are always computed in full)
    coarse_stride = 4
    locate_depth = 5             # every map: bisect each boundary edge 5 times (a 32nd of a step)

    [cases]
    blocks = ["B3M", "B6M", "B3L", "B6L"]   # presets (`rockbench blocks`; default: Table 1's four)
    pulses = ["sine", "cosine"]

    [reference]                  # one reference map per block, pulse and restitution
    restitutions = ["housner", "modified-average", "modified-exact"]   # or "modified:K", or a number
                                 # (modified-exact is skipped, with a note, on a block without a measured k)
    # dt_s = 0.001

    [engines]
    names = "available"          # every installed engine but the reference, or a list of names
    exclude = ["drake"]          # with "available": engines left out even when installed (a note says so)
    # include = ["mujoco_warp"]  # with "available": engines taken wherever installed, even those that leave
                                 # suites of every available engine on this machine (MuJoCo Warp without CUDA)
    variants = [{settings = "calibrated"}, {settings = "shipped"}]     # engine settings, one map each
                                 # a variant may carry its own restitution = "modified-average" (...):
                                 # its η target and its maps' label (scored like for like against
                                 # the reference maps with that restitution), engines = [...] (the
                                 # engines it applies to, default all) and blocks = [...] (the blocks it
                                 # maps, default all); none is an engine setting. calibrate_on = "neighbour"
                                 # (or "sibling", or a block's name) is the held-out check
    restitution = "housner"      # the η calibrated variants are tuned to (and their maps' label)
    own_eta = true               # (d): measure each variant's η in free rocking, add reference maps with it
    # dt_s = 0.0005

    [power]                      # the suite's yardstick: the reference solver as an engine with η·(1 − δ),
    eta_reductions = [0.0, 0.005, 0.01, 0.02]   # one variant per δ on the in-sample blocks, mapped and
                                 # scored as engine maps (engine reference, planted_eta_factor = 1 − δ)

    [speed]                      # the accuracy–cost stage (docs/speed.md): every engine calibrated at each step,
    steps_s = [0.001, 0.0005, 0.0002, 0.0001]   # mapped at it on one block per slenderness and one pulse
    blocks = ["B2M", "B3M", "B6M", "B8M"]        # (default: the first of each slenderness of cases.blocks)
    pulses = ["sine"]            # (default: the first of cases.pulses); timed per simulated second, scored
    matched_distance = 0.037     # into score.json's "speed", never the verdict; (b) of matched accuracy
                                 # (with a [speed] table, engines.variants may be [] : the stage alone)

    [run]
    cell_timeout_s = 120

    [report]
    cases = ["B3M:sine:6:6.1"]   # θ(t) comparisons, BLOCK:PULSE:W_RATIO:A_RATIO
    # experiments = "path/to/outcomes.csv"   (relative to the suite file)

    [verdict]                    # declared before the verdict is computed (docs/scores.md)
    fail_distance = "largest-restitution-gap"   # or a number: a scenario farther than this fails the variant
    equivalence_margin = "restitution-gap"   # or a number: "within the uncertainty of the restitution"
    held_out_margin = "half-restitution-gap"    # or a number: a held-out calibration carries over within ± this
    general_range_h_over_b = [1.5, 6.0]      # claims about problems in general, when the suite spans it

Layout of the output directory: ``OUT/maps/<engine variant>/<block>-<pulse>-<restitution>/`` (one
``rockbench map`` run directory each, resumable; the speed stage's under ``OUT/maps/speed/``, with
``OUT/speed.json``), ``OUT/score.json``, ``OUT/index.html``,
``OUT/report.md``, ``OUT/img/``, ``OUT/trajectories/`` (the θ(t) curves of the report's cases, which the
report draws), ``OUT/suite.json`` (the suite as run, and the timings).
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

from rockbench.engines.adapters.reference import is_planted
from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.errors import IncomparableError
from rockbench.reference_solver.pulses import make_pulse
from rockbench.benchmark.blocks.cases import parse_case
from rockbench.benchmark.blocks.experiments import load_outcomes
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.engine_info.devices import device_of
from rockbench.benchmark.engine_info.health import EngineHealth
from rockbench.benchmark.maps.executors import DASK_SCRATCH, DaskConnection, cap_jobs, cpu_count
from rockbench.benchmark.maps.grid import MapSpec, parse_range
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.report.build import build_report
from rockbench.benchmark.scoring.score_runs import load_run_maps, score_dirs
from rockbench.benchmark.scoring.speed_runs import SPEED_FILE
from rockbench.benchmark.store.loading import SPEED_STAGE
from rockbench.benchmark.report.console import console_summary
from rockbench.benchmark.store.atomic import check_output_dir
from rockbench.benchmark.store.files import write_json
from rockbench.benchmark.trajectories import record_for_report
from rockbench.benchmark.suites.cluster import ClusterMaps
from rockbench.benchmark.suites.lanes import ReferenceThread, run_lanes
from rockbench.benchmark.suites.model import Suite, skipped_reference_note
from rockbench.benchmark.suites.plan import check_suite, engine_names, own_eta_jobs, plan, speed_depth, speed_engines, speed_record
from rockbench.benchmark.suites.preparation import Preparation, cost_rank
from rockbench.benchmark.suites.progress import SuiteConsole, say_device_notes


def _score_and_report(suite: Suite, out: Path, result: dict, experiments, report: bool, figure_formats, log,
                      unfinished: set) -> None:
    """The run's scores (``result["score"]``), its report (or score.json alone) and the console's verdict
    and summary table (``result["summary"]``); the ``unfinished`` maps (of an engine that cannot
    simulate) are scored as incomplete instead of refused."""
    if report:
        cases = tuple(parse_case(c) for c in suite.report.cases)
        maps = load_run_maps([out / "maps"], None, suite.verdict)   # read once for the θ(t) runs and the report
        record_for_report(cases, [out / "maps"], out, log=log, entries=maps.entries)
        rep = build_report([out / "maps"], out, experiments=experiments, cases=cases, log=log, maps=maps,
                           figure_formats=figure_formats, allow_incomplete=unfinished, declared=suite.verdict)
        result["score"] = rep["scores"]
        result["notes"] = list(dict.fromkeys(result["notes"] + rep["notes"]))   # each note once
        result["report"] = {k: rep[k] for k in ("html", "markdown") if k in rep}
    else:
        try:
            result["score"] = score_dirs([out / "maps"], experiments=experiments, allow_incomplete=unfinished,
                                         declared=suite.verdict)
            write_json(out / "score.json", result["score"].to_json())
        except IncomparableError as e:  # e.g. no engine installed: the maps are still worth having
            result["notes"].append(f"No scores: {e}")
    if result["score"] is not None:
        result["summary"] = console_summary(result["score"])


def _warm_report() -> None:
    """Import what the report draws with and load the reference solver's history kernel (numba's
    cache), so that the report, which needs every map, starts at once when the last one is done."""
    try:
        # a head start: importing these (and compiling the kernel) early is the point
        from matplotlib import figure  # noqa: F401
        from matplotlib.backends import backend_agg  # noqa: F401
        from rockbench.reference_solver.solver import solve
        from rockbench.benchmark.report import build as report  # noqa: F401
        solve(get_preset("B3M").block(), make_pulse("sine", 30.0, 60.0), 0.8, history=True)
    except Exception:  # noqa: BLE001 - only a head start; the report imports what it needs itself
        pass


def _warm_report_meanwhile() -> None:
    """The report's start-up (matplotlib, the reference's history kernel) costs a few seconds of one core
    at the end; a thread pays it while the workers compute the engine maps."""
    threading.Thread(target=_warm_report, name="rockbench-warm-report", daemon=True).start()


def _started(k: int) -> None:
    """A map starts: nothing is printed (a map is reported when it finishes, by
    :meth:`SuiteConsole.finished`, so that the lines come in order)."""


def run_suite(suite: Suite, out_dir, *, jobs: int | None = None, experiments=None, report: bool = True,
              log=None, engines: list[str] | None = None, figure_formats=("png",),
              scheduler: str | None = None) -> dict:
    """Compute what is missing, score, and write the report (see the module docstring).

    ``engines`` (``run --engines``) restricts the engine maps to those engines; ``figure_formats``
    are the formats of the report's pictures (png, svg, pdf); ``scheduler`` (``run --scheduler``) a
    Dask scheduler's address, or ``"local"`` for a LocalCluster of ``jobs`` workers on 127.0.0.1, to
    compute the calibrations and maps on (:mod:`rockbench.benchmark.suites.cluster`; the same maps).

    Returns
    -------
    dict
        ``maps`` (per map: dir and wall time), ``wall_s``, ``score`` (the run's :class:`~rockbench.benchmark.scoring.scores.Scores` or None),
        ``notes``, ``report`` (paths) and ``summary`` (the summary table as text).
    """
    log = log or (lambda m: print(f"rockbench: {m}", file=sys.stderr))
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {str(out)!r} is a file; give a directory for the benchmark.")
    check_output_dir(out, "--out")
    jobs, note = cap_jobs(jobs)
    if note:
        log(note)
    dask = None
    if scheduler is not None:
        # checked (and a local cluster started) before anything is written
        dask = DaskConnection(scheduler, jobs=jobs, scratch_dir=out / DASK_SCRATCH if scheduler == "local" else None)
    try:
        run = _SuiteRun(suite, out, jobs, log, engines, dask)
        run.compute_maps(report)
    finally:
        if dask is not None:
            dask.close()
    return run.finish(experiments, report, figure_formats)


class _SuiteRun:
    """One :func:`run_suite`: its plan of maps and their specs, the console, what finished and what could not."""

    def __init__(self, suite: Suite, out: Path, jobs: int | None, log, engines: list[str] | None, dask=None):
        self.suite, self.out, self.jobs, self.log, self.dask = suite, out, jobs, log, dask
        self.x = parse_range("grid.w_ratio", suite.grid.w_ratio, "w_ratio")
        self.y = parse_range("grid.a_ratio", suite.grid.a_ratio, "a_ratio")
        explicit = engines is not None or suite.engines.names != "available"
        engines, self.notes = engine_names(suite, engines)
        self.engines, more = check_suite(suite, engines, explicit)
        self.speed_engines, speed_notes = speed_engines(suite, self.engines)
        self.notes += more + speed_notes + [n for n in (skipped_reference_note(suite),) if n]
        self.todo = plan(suite, self.engines)
        self.workers = max(1, jobs or cpu_count())
        # every spec is built (and so checked) before the first map runs (the own-η reference maps, which
        # wait for the measured η, differ from the others only in a constant restitution)
        self.specs = self.specs_of(self.todo)
        self.t0 = time.perf_counter()
        self.records: dict = {}
        # calibrations (and the engines' own η) once, on every core, before the engine maps need them;
        # the helpers start now and work while this process computes the reference maps
        self.prep = Preparation(suite, self.engines, out, log, workers=self.workers, speed_engines=self.speed_engines,
                                pool=dask.client.get_executor(pure=False) if dask else None) if self.engines else None
        if suite.speed is not None:
            write_json(out / SPEED_FILE, speed_record(suite, self.speed_engines, self.notes))
        self.stages: dict = {}   # map index → the stage its run.json records (the speed stage's maps)
        # [k/N]: N planned now, own-η reference maps included; k counts maps as they finish
        self.own_planned = self.prep.own_eta_slots() * len(suite.cases.pulses) if self.prep is not None else 0
        self.console = SuiteConsole(len(self.todo) + self.own_planned, log)
        say_device_notes(self.engines, self.console)
        self.health = EngineHealth()
        self.unfinished: set = set()   # map folders of engines that cannot simulate: scored as incomplete

    def specs_of(self, jobs_) -> list[MapSpec]:
        return [MapSpec(get_preset(j.block).block(), j.pulse, j.restitution, self.x, self.y, engine=j.engine,
                        engine_settings=dict(j.settings), dt_s=j.dt_s) for j in jobs_]

    def map_options(self, job) -> dict:
        """How the suite computes map ``job`` (:func:`run_map`'s options, here or on a cluster's worker).

        Reference maps are computed in full: they cost milliseconds, and scoring needs the rigid
        model's domain (lift-/slip-required) in every cell, not just where refinement looked; a planted
        variant is the reference solver, mapped as an engine map is."""
        engine_map = job.engine != "reference" or is_planted(job.engine, job.settings)
        return {"adaptive": self.suite.grid.adaptive and engine_map, "coarse_stride": self.suite.grid.coarse_stride,
                "locate_depth": self.depth_of(job), "cell_timeout_s": self.suite.run.cell_timeout_s,
                "stage": self.stage_of(job)}

    def one_map(self, k: int, ex, compute=None) -> None:
        """Map ``k``, computed here with executor ``ex`` (None: the reference's, in this process), or by
        ``compute()`` (a cluster's task, written to the run folder), and recorded."""
        job, spec = self.todo[k], self.specs[k]
        d = self.out / job.subdir
        t1 = time.perf_counter()
        # an engine that cannot simulate is stopped after its first map (EngineHealth.guard)
        res = self.health.guard(job.engine, compute or (lambda: run_map(
            spec, d, jobs=self.jobs, serial=job.engine == "reference", log=self.log, executor=ex,
            **self.map_options(job))))
        if res is None:   # the engine cannot simulate: its map is skipped, and counted off
            self.console.not_needed(1, f"{spec.label()} skipped: {job.engine} cannot simulate (see the end of the run)")
            self.unfinished.add(d)
            return
        wall_s = res.wall_s if compute is not None else time.perf_counter() - t1   # a task's: on its worker
        self.records[k] = {"dir": str(d), "label": spec.label(), "wall_s": wall_s,
                           "n_simulated": res.n_simulated, "n_cells": spec.n_cells, "n_failed": len(res.failures)}
        self.console.finished(spec.label(), d, self.records[k]["wall_s"])

    def depth_of(self, job) -> int:
        """The rounds of bisection of a map's boundary: the speed stage's ``locate_depth`` for its maps where
        the stage declares one, else the grid's."""
        return speed_depth(self.suite) if job.stage == SPEED_STAGE else self.suite.grid.locate_depth

    def stage_of(self, job) -> dict | None:
        """What a speed-stage map records of its stage (run.json's ``options.stage``): the stage's name, the
        time-step rule's choice for its engine and block (prepared before the maps), and where its engine
        runs (:func:`~rockbench.benchmark.engine_info.devices.device_of`); None for any other map."""
        if job.stage != SPEED_STAGE:
            return None
        rules = self.prep.rules if self.prep is not None else {}
        return {"name": SPEED_STAGE, "step_rule": rules.get((job.engine, job.block)), "device": device_of(job.engine)}

    def compute_maps(self, report: bool) -> None:
        """Every map: the reference maps on one thread, the engine maps on lanes (with a Dask cluster,
        every map a task on it instead: :meth:`_on_cluster`).

        The reference runs in this process: its compiled batch kernel is parallel already, and worker
        processes would each load it again; engines keep the workers' time limit and crash isolation.
        Its maps are computed by one thread (one caller of the parallel kernel at a time) beside the
        calibrations and then the engine maps, which need none of them: on a fresh install the
        kernel's first compile (about 12 s of one core) no longer holds the engine maps back.
        """
        todo = self.todo
        engine_maps = [k for k, job in enumerate(todo) if job.engine != "reference"]
        # the costliest engines first, so that the last maps, when one core may wait for the other, are short
        engine_maps.sort(key=lambda k: cost_rank(todo[k].engine))
        if self.dask is not None:
            self._on_cluster(engine_maps, report)
            return
        refs = ReferenceThread(_started, self.one_map)
        refs.add(k for k, job in enumerate(todo) if job.engine == "reference")
        try:
            if self.prep is not None:
                self.own_eta_maps(refs)
            refs.close()
            if report:
                _warm_report_meanwhile()
            run_lanes(engine_maps, todo, self.out, min(self.workers, max(1, len(engine_maps))), _started,
                      self.one_map, stop=refs.failed)
        except BaseException:
            refs.abort()   # e.g. Ctrl-C: no reference map is started after the one running now
            if self.prep is not None:
                self.prep.abort()   # nor does a calibration go on in a helper
            raise
        refs.join()

    def _on_cluster(self, engine_maps: list[int], report: bool) -> None:
        """Every map as a task on the Dask cluster (:mod:`rockbench.benchmark.suites.cluster`), which this
        process collects (warming the report meanwhile)."""
        if report:
            _warm_report_meanwhile()
        try:
            ClusterMaps(self, self.dask).run_all(engine_maps)
        except BaseException:
            if self.prep is not None:
                self.prep.abort()   # no calibration task goes on
            raise

    def own_eta_maps(self, refs) -> None:
        """Wait for the calibrations and η measurements; with own_eta, hand ``refs`` (the reference
        thread, or the cluster's tasks) a map at each variant's measured η."""
        etas, more, _ = self.prep.finish()
        self.notes += more
        if self.suite.engines.own_eta:
            extra = own_eta_jobs(self.suite, etas)
            self.console.not_needed(self.own_planned - len(extra), "variants with the same measured η on a block "
                                    "share one reference map, and a failed η measurement has none")
            first = len(self.todo)
            self.specs += self.specs_of(extra)
            self.todo += extra
            refs.add(range(first, len(self.todo)))

    def finish(self, experiments, report: bool, figure_formats) -> dict:
        """Scores, report and suite.json once every map is done; the run's result."""
        suite, health = self.suite, self.health
        done = [self.records[k] for k in sorted(self.records)]
        result = {"suite": suite.name, "maps": done, "maps_wall_s": time.perf_counter() - self.t0,
                  "notes": list(dict.fromkeys(self.notes)), "score": None, "report": None, "summary": "",
                  "cannot_simulate": health.broken_lines(), "failed_cells": health.failure_lines()}
        if experiments is None and suite.report.experiments:
            experiments = load_outcomes(suite.report.experiments)
        t2 = time.perf_counter()
        _score_and_report(suite, self.out, result, experiments, report, figure_formats, self.log, self.unfinished)
        result["report_wall_s"] = time.perf_counter() - t2
        result["wall_s"] = time.perf_counter() - self.t0
        kept = {k: v for k, v in result.items() if k not in ("suite", "score", "summary")}
        write_json(self.out / "suite.json", {"suite": suite.raw, "path": suite.path, "jobs": self.jobs, **kept,
                                             "suite_name": suite.name, "verdict_declared": suite.verdict.to_dict()})
        return result
