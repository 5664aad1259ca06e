"""How much could a better order of a suite's engine maps on its lanes buy? The lanes
(benchmark/suites/lanes.py) are replayed on the measured cost of each map. Measures and prints; it
passes or fails nothing.

    python tests/measurements/bench_lanes_replay.py RUN_DIR [--lanes 2] [--add COST.json ...]

Each engine map of RUN_DIR (the output of ``rockbench run``) costs what its cells cost (cells.csv
``wall_s`` summed). ``--add`` adds the maps of engines measured by ``bench_engine_cost.py`` (its
JSON): 8 maps per variant (4 blocks × 2 pulses), each costing the sampled CPU per cell × the mean
cells of a map. The maps
are then dealt to ``--lanes`` lanes, each map to the lane that frees first, in three orders: the
runner's (``preparation.cost_rank``: finest default step first, engines without a batch before
those with one), longest map first (which needs each map's cost before it runs), and the lower
bound, the total over the lanes. The lanes' lending of a core to the last map (lanes.py) is not
modelled: it narrows the gap further.
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


def makespan(costs: list[float], lanes: int) -> float:
    """When the last lane ends, each map going to the lane that frees first [s]."""
    free = [0.0] * lanes
    for c in costs:
        heapq.heappush(free, heapq.heappop(free) + c)
    return max(free)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("--lanes", type=int, default=2)
    ap.add_argument("--add", type=Path, nargs="*", default=[])
    a = ap.parse_args(argv)
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
