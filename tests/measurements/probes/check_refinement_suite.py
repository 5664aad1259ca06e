"""The boundary tracer against the block-wise refinement on every engine map of a suite run.
Measures and prints; it passes or fails nothing.

    python tests/measurements/probes/check_refinement_suite.py RUN_DIR [--jobs N] [--record NAME] [--only TEXT]

RUN_DIR is the output of ``rockbench run`` (block-wise refinement), e.g. the README's first command
on commit 96434a9. For each adaptive engine map under it, a tracer of ``tests/measurements/bench_refinement.py``
(:data:`VARIANT`: width 3, the blocks around isolated cells and the tips of one-cell lines) is run
from scratch as if it computed the map: a cell it asks for is taken from the run when the run
simulated it, and simulated here by the same engine and settings otherwise (the engines are
deterministic: a cell simulated again gives the run's verdict). Both maps are then filled by their
own rule and compared cell by cell; every cell where they differ and neither simulated is simulated
here too, so that each difference has a known truth. Printed per map: the share of cells each
refinement simulated, the cells simulated here, the cells where the two filled maps differ, and how
many of those each refinement has wrong. Cells both refinements inferred alike are not checked
(full-grid maps do that: ``bench_refinement.py --engine-maps``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

# the tracer is the rerunnable benchmark's, one folder up (tests/measurements/bench_refinement.py)
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench_refinement import VARIANTS, fill_regions, trace  # noqa: E402
from records import write_record  # noqa: E402
from rockbench.benchmark.maps import adaptive  # noqa: E402
from rockbench.benchmark.maps.result import MISSING, empty_result, record_result  # noqa: E402
from rockbench.benchmark.store.loading import load_map  # noqa: E402

#: the tracer variant checked (bench_refinement.VARIANTS)
VARIANT = "trace-w3+tips0"


def check_map(d: str, view: bool = False) -> dict:
    from rockbench.engines.registry import get_adapter

    t0 = time.perf_counter()
    run = load_map(d)
    spec = run.spec
    adapter = get_adapter(spec.engine, **spec.engine_settings)
    # what is known: the run's simulated cells, then whatever is simulated here
    oracle = {(int(i), int(j)): (int(run.outcome[i, j]), int(run.n_impacts[i, j]))
              for i, j in zip(*np.nonzero(run.simulated))}
    extra = [0]
    scratch = empty_result(spec)    # turns CellResults into outcome codes and impacts

    def simulate(cells):
        cells = [c for c in cells if c not in oracle]
        if not cells:
            return
        extra[0] += len(cells)
        for (i, j), r in zip(cells, adapter.run_many(spec.cases(cells))):
            o = record_result(scratch, i, j, r)
            oracle[(i, j)] = (int(o), int(scratch.n_impacts[i, j]))

    shape = spec.shape
    out = np.full(shape, MISSING, np.int8)
    key = np.full(shape, MISSING, np.int16)
    sim = np.zeros(shape, bool)

    def evaluate(cells):
        simulate(cells)
        for c in cells:
            o, n = oracle[c]
            out[c] = o
            key[c] = adaptive.regime_key(o, n)
            sim[c] = True

    v = VARIANTS[VARIANT]
    rounds = trace(key, sim, evaluate, run.coarse_stride, width=v[0], halo=v[1], most=v[2] if len(v) > 2 else 0)
    fill_regions(out, key, sim)
    blocks = run.outcome
    differ = list(zip(*np.nonzero(out != blocks)))
    simulate([(int(i), int(j)) for i, j in differ])
    truth = {c: v[0] for c, v in oracle.items()}
    wrong_trace = [c for c, o in truth.items() if out[c] != o]
    wrong_blocks = [c for c, o in truth.items() if blocks[c] != o]
    if view:
        return run, sim, oracle
    return {"map": str(Path(d).relative_to(Path(d).parents[1])), "cells": int(np.prod(shape)),
            "blocks_fraction": float(run.simulated.mean()), "trace_fraction": float(sim.mean()),
            "trace_rounds": rounds, "simulated_here": extra[0], "differ": len(differ),
            "trace_wrong": len(wrong_trace), "blocks_wrong": len(wrong_blocks),
            "trace_wrong_cells": [list(map(int, c)) for c in wrong_trace],
            "blocks_wrong_cells": [list(map(int, c)) for c in wrong_blocks], "wall_s": time.perf_counter() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--record", default=None, help="write the rows as this benchmark record (tests/measurements/records.py)")
    ap.add_argument("--only", default=None, help="only the maps whose folder path contains this text (e.g. "
                    "settings=shipped: the as-shipped maps, which need no calibration)")
    args = ap.parse_args(argv)
    dirs = []
    for p in sorted(Path(args.run_dir).rglob("run.json")):
        meta = json.loads(p.read_text())
        if meta.get("spec", {}).get("engine") != "reference" and (meta.get("options") or {}).get("adaptive"):
            if args.only is None or args.only in str(p.parent):
                dirs.append(str(p.parent))
    # the costliest engines first
    dirs.sort(key=lambda d: ("exudyn" not in d, "pybullet" not in d, d))
    t0 = time.perf_counter()
    rows = []
    with ProcessPoolExecutor(args.jobs) as pool:
        for r in pool.map(check_map, dirs):
            rows.append(r)
            print(f"{r['map']:55} blocks {100 * r['blocks_fraction']:5.1f} % trace {100 * r['trace_fraction']:5.1f} % "
                  f"(+{r['simulated_here']} here) differ {r['differ']:3d} wrong: trace {r['trace_wrong']} "
                  f"blocks {r['blocks_wrong']}", flush=True)
    tot = {k: sum(r[k] for r in rows) for k in ("differ", "trace_wrong", "blocks_wrong", "simulated_here")}
    bf = float(np.mean([r["blocks_fraction"] for r in rows])) if rows else 0.0
    tf = float(np.mean([r["trace_fraction"] for r in rows])) if rows else 0.0
    print(f"{len(rows)} maps: blocks {100 * bf:.1f} %, trace {100 * tf:.1f} % simulated; {tot['differ']} cells "
          f"differ; wrong: trace {tot['trace_wrong']}, blocks {tot['blocks_wrong']}; {tot['simulated_here']} cells "
          f"simulated here; {time.perf_counter() - t0:.0f} s")
    if args.record:
        write_record(args.record, "the boundary tracer against the block-wise refinement on a run's adaptive maps: "
                     "share of cells simulated, and cells of the filled maps that differ from every cell simulated",
                     "python tests/measurements/probes/check_refinement_suite.py " + " ".join(argv or sys.argv[1:]),
                     {"rows": rows, "totals": tot, "blocks_fraction_mean": bf, "trace_fraction_mean": tf})
    return 0


if __name__ == "__main__":
    sys.exit(main())
