"""How much could a better order of a suite's engine maps on its lanes buy? The lanes
(benchmark/suites/lanes.py) are replayed on the measured cost of each map. Measures and prints; it
passes or fails nothing.

    python tests/measurements/bench_lanes_replay.py RUN_DIR [--lanes 2] [--add COST.json ...]
    python tests/measurements/bench_lanes_replay.py --record RECORD.json --lanes 8 32 128


Each engine map of RUN_DIR (the output of ``rockbench run``) costs what its cells cost (cells.csv
``wall_s`` summed). ``--add`` adds the maps of engines measured by ``bench_engine_cost.py`` (its
JSON): 8 maps per variant (4 blocks × 2 pulses), each costing the sampled CPU per cell × the mean
cells of a map. The maps
are then dealt to ``--lanes`` lanes, each map to the lane that frees first, in three orders: the
runner's (``preparation.cost_rank``: finest default step first, engines without a batch before
those with one), longest map first (which needs each map's cost before it runs), and the lower
bound, the total over the lanes. The lanes' lending of a core to the last map (lanes.py) is not
modelled: it narrows the gap further.

The second form projects a suite on a cluster of N one-core workers (``rockbench run --scheduler``: one
task per map, each map on one core) from a record of ``bench_run.py`` (e.g. ``run-default-suite.json``),
which keeps each engine variant's maps and their summed wall time on a 2-lane run: every map of a
variant is given the variant's mean. A projection, not a measurement: the maps' spread within a
variant, the calibrations (run before the engine maps, one task per variant and block) and the
cluster's own overhead are left out (a bench_run.py record keeps no calibration's cost); the report (on
the client, one core) is added as recorded.

    python tests/measurements/bench_lanes_replay.py --cluster-record RECORD.json --lanes 2 8 32 128

The third form replays a record of ``bench_suite_cluster.py`` (e.g. ``suite-cluster-quick-task-cpu.json``),
which keeps every task of its 1-worker cluster run with its cost (its CPU where the record has it, else
its compute wall time): the calibration tasks first, each to the core that frees first, then every map
once the last calibration has ended (the runner submits the engine maps then; the reference maps,
submitted at once, are held back with them, which costs at most their few seconds), in the order they
ran; the cost outside the tasks (the client's CPU, else its wall before the first task and after the
last) is added. Left out: each worker's own start-up where it runs on a machine of its own (the
reference's compiled kernels, which the 1-worker run paid once) and the cluster's dispatch.
"""

from __future__ import annotations

import argparse
import csv
import heapq
import json
from pathlib import Path

from rockbench.benchmark.suites.preparation import cost_rank


def run_maps(run_dir: Path) -> list[tuple[str, float]]:
    """(engine, cost [s]) of every engine map of a run folder."""
    out = []
    for f in sorted(run_dir.glob("maps/*/*/cells.csv")):
        variant = f.parts[-3]
        if variant == "reference":
            continue
        with open(f) as fh:
            out.append((variant.split("-")[0], sum(float(r["wall_s"] or 0) for r in csv.DictReader(fh))))
    return out


def added_maps(cost_json: Path, scenarios: int = 8) -> list[tuple[str, float]]:
    """The maps of engines sampled by bench_engine_cost.py: per variant, ``scenarios`` maps each
    costing the sample's CPU per cell × the mean cells per map."""
    out = []
    for row in json.loads(cost_json.read_text()):
        for v in row["variants"]:
            if "cpu_per_cell_s" in v:
                out += [(row["engine"], v["cpu_per_cell_s"] * row["mean_cells_per_map"])] * scenarios
    return out


def record_maps(record: Path) -> tuple[list[tuple[str, float]], dict]:
    """(engine, cost [s]) of every map of a bench_run.py record (each map its variant's mean), and its summary."""
    summary = json.loads(record.read_text())["figures"]["summary"]
    out = []
    for variant, v in summary["per_variant"].items():
        out += [(variant.split("-")[0], v["wall_s"] / v["maps"])] * v["maps"]
    return out, summary


def project(record: Path, cores: list[int]) -> None:
    """The suite of ``record`` on clusters of ``cores`` one-core workers (see the module docstring)."""
    maps, summary = record_maps(record)
    runner = [c for e, c in sorted(maps, key=lambda m: cost_rank(m[0]))]
    total, longest = sum(runner), max(runner)
    report_s = summary.get("report_wall_s") or 0.0
    print(f"{len(maps)} maps (reference maps included), {total:.0f} s of map wall on one core each; "
          f"longest map {longest:.0f} s; report {report_s:.0f} s (recorded wall of the whole suite "
          f"{summary['wall_s']:.0f} s on {summary.get('lanes', 2)} lanes)")
    for n in cores:
        maps_s = makespan(runner, n)
        print(f"  {n:4d} cores: maps {maps_s:7.0f} s (lower bound {max(total / n, longest):7.0f} s), "
              f"with the report {maps_s + report_s:7.0f} s  [projection]")


#: the kind of a calibration task in a bench_suite_cluster.py record's task stream
#: (preparation._prepare_remote, as dask.utils.key_split names it)
CALIBRATION = "prepare_remote"


def cluster_tasks(record: Path, workers: int = 1) -> tuple[dict, list[tuple[str, float]], float]:
    """The cluster run of ``workers`` in a bench_suite_cluster.py record, its tasks (kind, cost [s]) in the
    order they started, and the cost outside them [s]. A task costs its CPU where the record has it
    (its worker's tree meanwhile), and the outside the client's CPU; else a task costs its compute wall
    time, and the outside the run's wall before the first task and after the last."""
    runs = json.loads(record.read_text())["figures"]["runs"]
    run = next(r for r in runs if r["run"].startswith(f"cluster, {workers} worker"))
    stream = run["tasks"]["stream"]
    if all(len(t) > 4 and t[4] is not None for t in stream):
        return run, [(t[0], t[4]) for t in stream], run["client_cpu_s"]
    outside_s = stream[0][1] + (run["wall_s"] - max(t[2] for t in stream))
    return run, [(t[0], t[2] - t[1]) for t in stream], outside_s


def replay_cluster(tasks: list[tuple[str, float]], cores: int) -> float:
    """When the last of ``tasks`` ends on ``cores`` one-core workers: the calibrations first, the maps
    after the last calibration has ended, each task to the core that frees first [s]."""
    free = [0.0] * cores
    for kind, c in tasks:
        if kind == CALIBRATION:
            heapq.heappush(free, heapq.heappop(free) + c)
    barrier = max(free) if any(kind == CALIBRATION for kind, _ in tasks) else 0.0
    free = [max(f, barrier) for f in free]
    heapq.heapify(free)
    for kind, c in tasks:
        if kind != CALIBRATION:
            heapq.heappush(free, heapq.heappop(free) + c)
    return max(free)


def project_cluster(record: Path, cores: list[int]) -> None:
    """The suite of a bench_suite_cluster.py record on clusters of ``cores`` one-core workers."""
    run, tasks, outside_s = cluster_tasks(record)
    calib = [c for k, c in tasks if k == CALIBRATION]
    maps = [c for k, c in tasks if k != CALIBRATION]
    measured = {r["run"]: r["wall_s"] for r in json.loads(record.read_text())["figures"]["runs"]}
    print(f"{len(calib)} calibration tasks ({sum(calib):.0f} s, longest {max(calib, default=0):.0f} s) and "
          f"{len(maps)} map tasks ({sum(maps):.0f} s, longest {max(maps, default=0):.0f} s) of the 1-worker run; "
          f"{outside_s:.0f} s outside them; measured wall: "
          + ", ".join(f"{k} {v:.0f} s" for k, v in measured.items()))
    for n in cores:
        tasks_s, calib_s = replay_cluster(tasks, n), replay_cluster([t for t in tasks if t[0] == CALIBRATION], n)
        print(f"  {n:4d} cores: tasks {tasks_s:7.0f} s (the calibrations' part {calib_s:6.0f} s), "
              f"with the time outside them {tasks_s + outside_s:7.0f} s  [projection]")


def makespan(costs: list[float], lanes: int) -> float:
    """When the last lane ends, each map going to the lane that frees first [s]."""
    free = [0.0] * lanes
    for c in costs:
        heapq.heappush(free, heapq.heappop(free) + c)
    return max(free)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path, nargs="?")
    ap.add_argument("--lanes", type=int, nargs="+", default=[2])
    ap.add_argument("--add", type=Path, nargs="*", default=[])
    ap.add_argument("--record", type=Path, help="project a bench_run.py record on clusters of --lanes cores")
    ap.add_argument("--cluster-record", type=Path,
                    help="replay a bench_suite_cluster.py record's 1-worker tasks on clusters of --lanes cores")
    a = ap.parse_args(argv)
    if a.cluster_record is not None:
        project_cluster(a.cluster_record, a.lanes)
        return 0
    if a.record is not None:
        project(a.record, a.lanes)
        return 0
    if a.run_dir is None:
        ap.error("give RUN_DIR or --record")
    a.lanes = a.lanes[0]
    maps = run_maps(a.run_dir)
    for p in a.add:
        maps += added_maps(p)
    runner = [c for e, c in sorted(maps, key=lambda m: cost_rank(m[0]))]
    longest = sorted((c for _, c in maps), reverse=True)
    total = sum(c for _, c in maps)
    print(f"{len(maps)} engine maps, {total:.0f} s of cells, {a.lanes} lanes")
    print(f"  lower bound (total / lanes)   {total / a.lanes:8.0f} s")
    print(f"  the runner's order            {makespan(runner, a.lanes):8.0f} s")
    print(f"  longest map first             {makespan(longest, a.lanes):8.0f} s")
    print(f"  the longest map               {longest[0]:8.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
