"""Each engine's answer against its time step: the accuracy–speed curve (issue 36). Measures and
prints; it passes or fails on nothing.

For one block and pulse (default B3M under one sine wave, Housner's η) and each engine, at each
step of ``--steps`` (default 2, 1, 0.5, 0.2, 0.1 ms):

1. the calibration to η at that step (:func:`~rockbench.engines.calibration.routine.calibrate`, cached like every calibration): the η it
   measured and whether it reached the target;
2. the engine's calibrated map at that step (``rockbench map --dt``: the contact calibrated at that
   step), on one grid, adaptive, in this process;
3. that map scored against the reference map of the same grid by the scores of ``rockbench score``
   (:func:`~rockbench.benchmark.scoring.score_runs.score_entries`): the boundary distance
   (``boundary_mean``) and the engine's invalid cells;
4. the cost of a simulated cell: the mean ``wall_s`` of its cells.csv.

Then the engine as shipped at its own default step (capped by the pulse, as the benchmark runs it),
and the step the one time-step rule (:mod:`rockbench.engines.calibration.step_rule`) chooses for the block and η.

The record goes to the benchmark record ``step-accuracy-<block>-<pulse>-<grid>`` (tests/measurements/records.py: machine,
commit, versions, command); rows of engines not run this time are kept from an earlier record of
the same name, so engines can be run one by one. The Markdown table is printed.

Usage (from the repository's top folder, in the venv)::

    python tests/measurements/bench_step_accuracy.py --engines mujoco,pybullet [--steps 2,1,0.5,0.2,0.1]
    python tests/measurements/bench_step_accuracy.py --table step-accuracy-b3m-sine-38x51   # a record's table, no runs
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import shutil
import statistics
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))   # tests/measurements/: the records module beside this script
import records  # noqa: E402

MEASURES = ("each engine's answer against its time step on one map: calibrated to the target η at each step, "
            "its map scored against the reference map of the same grid (boundary distance, invalid cells) "
            "and its cost per simulated cell; as shipped at its own step; the step the time-step rule chooses")
#: Engines measured by default: those the CPU runs in minutes on a small map
ENGINES = ("mujoco", "pybullet", "exudyn", "dart", "physx", "drake")
#: Steps tried by default [ms], coarsest first
STEPS_MS = (2.0, 1.0, 0.5, 0.2, 0.1)
#: The grid: the default maps' spacing (0.30 along ω/p, 0.22 along a₀/(g·tanα)), ω/p up to 12 only, so
#: that 2 ms keeps 20 steps per wave on B3M (at ω/p = 16 it does not)
W_RATIO, A_RATIO = "1:12:38", "1:12:51"


def _map_spec(block, pulse: str, w_text: str, a_text: str, engine: str, settings: dict, dt_s: float | None):
    """The map of ``engine`` with ``settings`` at step ``dt_s`` [s] (None: the engine's own) on the grid
    ``w_text`` × ``a_text`` (``LO:HI:N``), Housner's η."""
    from rockbench.benchmark.maps.grid import MapSpec, parse_range
    from rockbench.reference_solver.restitution import Restitution

    return MapSpec(block, pulse, Restitution(), parse_range("--w-ratio", w_text, "w_ratio"),
                   parse_range("--a-ratio", a_text, "a_ratio"), engine=engine, engine_settings=settings, dt_s=dt_s)


def map_scores(spec, out_dir: Path, reference) -> dict:
    """Compute ``spec``'s map (adaptive, in this process) into ``out_dir`` and score it against the
    ``reference`` map entry as ``rockbench score`` does: boundary distance, invalid cells, the cells
    it simulated and their mean cost (cells.csv ``wall_s``) [s], and the map's wall and CPU time [s]
    (the CPU time, of this process, says more than the wall time on a shared machine)."""
    from rockbench.benchmark.sweep import run_map
    from rockbench.benchmark.scoring.score_runs import score_entries
    from rockbench.benchmark.store.files import read_cell_table
    from rockbench.benchmark.store.loading import load_entry

    t0, c0 = time.perf_counter(), time.process_time()
    run_map(spec, out_dir, serial=True, adaptive=True, progress=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    pair = score_entries([load_entry(out_dir)], [reference]).pairs[0]
    rows = [r for r in read_cell_table(out_dir / "cells.csv") if r.get("status", "ok") == "ok"]
    walls = [float(r["wall_s"]) for r in rows if r.get("wall_s")]
    return {"boundary_mean": pair["scores"]["boundary_mean"], "boundary_max": pair["scores"]["boundary_max"],
            "invalid_cells": pair["invalid_cells"], "invalid_in_domain": pair["invalid_in_domain"],
            "failed_cells": pair["failed_in_domain"],
            "simulated_cells": len(rows), "cell_wall_s_mean": statistics.fmean(walls) if walls else None,
            "map_wall_s": wall, "map_cpu_s": cpu}


def calibrated_row(engine: str, block, eta: float, dt_s: float, make_spec, tmp: Path, reference) -> dict:
    """One step: the calibration to ``eta`` at ``dt_s`` [s] and the calibrated map's scores."""
    from rockbench.engines.calibration.routine import calibrate
    from rockbench.engines.registry import get_adapter

    row = {"engine": engine, "variant": "calibrated", "dt_s": dt_s}
    try:
        spec = make_spec(engine, {}, dt_s)     # a step too coarse for the grid's pulses is refused here
        cal = calibrate(get_adapter(engine), block, eta, dt_s=dt_s)
        row.update(eta=cal.eta_measured, eta_target=eta, reached=bool(cal.reached))
        row.update(map_scores(spec, tmp / f"{engine}-{dt_s:g}", reference))
    except Exception as e:  # noqa: BLE001 - recorded and the run goes on (asv's rule)
        row["error"] = f"{type(e).__name__}: {e}"
    return row


def shipped_row(engine: str, block, make_spec, tmp: Path, reference) -> dict:
    """The engine as shipped at its own default step: its free-rocking η and its map's scores."""
    from rockbench.engines.calibration.free_rocking import measure_restitution
    from rockbench.engines.calibration.time_step import step_for
    from rockbench.engines.registry import get_adapter

    ad = get_adapter(engine, settings="shipped")
    row = {"engine": engine, "variant": "as shipped", "dt_s": step_for(ad, block, math.nan),
           "shipped_dt_s": ad.own_dt_s}
    try:
        m = measure_restitution(ad, block)
        row.update(eta=m.eta_mean)   # NaN where the block sinks or never rocks freely
        row.update(map_scores(make_spec(engine, {"settings": "shipped"}, None), tmp / f"{engine}-shipped", reference))
    except Exception as e:  # noqa: BLE001 - recorded and the run goes on
        row["error"] = f"{type(e).__name__}: {e}"
    return row


def rule_step(engine: str, block, eta: float) -> dict:
    """The step the one time-step rule chooses for ``block`` at η, and whether it converged."""
    from rockbench.engines.calibration import time_step
    from rockbench.engines.registry import get_adapter

    try:
        dt, rec = time_step.rule_step(get_adapter(engine), block, eta)
        return {"engine": engine, "dt_s": dt, "converged": rec["converged"]}
    except Exception as e:  # noqa: BLE001 - recorded and the run goes on
        return {"engine": engine, "error": f"{type(e).__name__}: {e}"}


def engine_rows(engine: str, steps_s: list, block, eta: float, make_spec, tmp: Path, reference,
                with_rule: bool) -> tuple[list, dict | None]:
    """Every calibrated step of one engine, then as shipped; and the rule's step (None: not asked)."""
    rows = []
    for dt in steps_s:
        print(f"  {engine} calibrated at {dt * 1e3:g} ms ...", file=sys.stderr, flush=True)
        rows.append(calibrated_row(engine, block, eta, dt, make_spec, tmp, reference))
        print(f"    {json.dumps(rows[-1])}", file=sys.stderr, flush=True)
    print(f"  {engine} as shipped ...", file=sys.stderr, flush=True)
    rows.append(shipped_row(engine, block, make_spec, tmp, reference))
    print(f"    {json.dumps(rows[-1])}", file=sys.stderr, flush=True)
    return rows, (rule_step(engine, block, eta) if with_rule else None)


# -- the table --------------------------------------------------------------------------------------

def _ms(dt_s) -> str:
    return "–" if dt_s is None else f"{dt_s * 1e3:.3g} ms"


def _row_cells(r: dict, rule: dict) -> list[str]:
    step = _ms(r["dt_s"])
    if r["variant"] == "calibrated" and rule.get("dt_s") == r["dt_s"]:
        step += " (rule)" if rule.get("converged") else " (rule: no coarser step agrees)"
    if r["variant"] != "calibrated":
        step = f"as shipped, {_ms(r['dt_s'])}"
    if "error" in r:
        return [step, "not run: " + r["error"].split("\n")[0][:120], "", "", "", "", ""]
    eta = "–" if r.get("eta") is None else f"{r['eta']:.4f}"
    if r["variant"] == "calibrated" and not r.get("reached"):
        eta += " (not reached)"
    cost = "–" if r.get("cell_wall_s_mean") is None else f"{1e3 * r['cell_wall_s_mean']:.1f}"
    bd = "n/a" if r.get("boundary_mean") is None else f"{r['boundary_mean']:.3f}"
    inside = r.get("invalid_in_domain")
    invalid = f"{r['invalid_cells']}" + ("" if inside is None else f" ({inside})")
    cpu = "–" if r.get("map_cpu_s") is None else f"{1e3 * r['map_cpu_s'] / max(1, r['simulated_cells']):.1f}"
    return [step, eta, bd, invalid, cost, cpu, str(r["simulated_cells"])]


def markdown_table(record: dict) -> str:
    """The record's rows as a Markdown table, engine by engine, coarsest step first; the step the
    time-step rule chose is marked ``(rule)``, or where no coarser step agreed with the finest
    (the rule then keeps the finest) ``(rule: no coarser step agrees)``."""
    rules = {r["engine"]: r for r in record.get("rule_steps", [])}
    lines = ["| engine | step | η | boundary distance | invalid cells (inside the domain) | ms per cell "
             "| CPU ms per cell | simulated cells |", "|---|---|---|---|---|---|---|---|"]
    order = {e: i for i, e in enumerate(dict.fromkeys(r["engine"] for r in record["rows"]))}
    rows = sorted(record["rows"], key=lambda r: (order[r["engine"]], r["variant"] != "calibrated", -r["dt_s"]))
    for r in rows:
        lines.append("| " + " | ".join([r["engine"], *_row_cells(r, rules.get(r["engine"], {}))]) + " |")
    return "\n".join(lines) + "\n"


# -- the record -------------------------------------------------------------------------------------

def _json_safe(x):
    """``x`` with NaN and infinities as None (strict JSON has no NaN; an engine whose block sinks has no η)."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_json_safe(v) for v in x]
    return x


def _versions(engines: list) -> dict:
    from rockbench.engines.registry import availability

    return {e: availability(e)["version"] for e in ["reference", *engines]}


def _merged(old: dict | None, record: dict, engines: list) -> dict:
    """``record`` with the rows of other engines kept from ``old``, an earlier record's figures (if any)."""
    if old is None:
        return record
    keep = lambda rows: [r for r in rows if r["engine"] not in engines]   # noqa: E731
    record["rows"] = keep(old.get("rows", [])) + record["rows"]
    record["rule_steps"] = keep(old.get("rule_steps", [])) + record["rule_steps"]
    record["versions"] = {**old.get("versions", {}), **record["versions"]}
    record["runs"] = old.get("runs", []) + record["runs"]
    return record


def measure(args) -> dict:
    """The record of one command: the reference map, then every engine of ``args.engines``
    (:func:`engine_rows`), with the machine, the versions, the commit and the command."""
    from rockbench.benchmark.blocks.presets import get_preset
    from rockbench.benchmark.sweep import run_map
    from rockbench.benchmark.store.loading import load_entry
    from rockbench.benchmark.store.run_folder import git_info
    from rockbench.reference_solver.restitution import Restitution

    block = get_preset(args.block).block()
    eta = Restitution().eta(block.alpha_rad)
    engines = [e for e in args.engines.split(",") if e]
    steps_s = [float(x) * 1e-3 for x in args.steps.split(",") if x]
    make_spec = lambda engine, settings, dt: _map_spec(block, args.pulse, args.w_ratio, args.a_ratio,   # noqa: E731
                                                   engine, settings, dt)
    run = {"started_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"), "engines": engines,
           "command": "python " + " ".join([f"tests/measurements/{Path(sys.argv[0]).name}", *sys.argv[1:]]),
           "git": git_info(), "loadavg_before": list(os.getloadavg())}
    record = {"kind": "rockbench-step-accuracy", "block": args.block, "pulse": args.pulse, "eta": eta,
              "restitution": "housner", "w_ratio": args.w_ratio, "a_ratio": args.a_ratio, "adaptive": True,
              "machine": {"platform": platform.platform(), "python": sys.version.split()[0], "cpus": os.cpu_count()},
              "versions": _versions(engines), "rows": [], "rule_steps": [], "runs": [run]}
    tmp = Path(tempfile.mkdtemp(prefix="rb-step-accuracy-"))
    try:
        run_map(make_spec("reference", {}, None), tmp / "reference", serial=True, adaptive=True, progress=False)
        reference = load_entry(tmp / "reference")
        for engine in engines:
            rows, rule = engine_rows(engine, steps_s, block, eta, make_spec, tmp, reference, not args.no_rule)
            record["rows"] += rows
            record["rule_steps"] += [rule] if rule else []
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    run["finished_utc"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
    run["loadavg_after"] = list(os.getloadavg())
    return record


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engines", default=",".join(ENGINES), help=f"comma list (default {','.join(ENGINES)})")
    ap.add_argument("--steps", default=",".join(f"{s:g}" for s in STEPS_MS), help="comma list of steps [ms]")
    ap.add_argument("--block", default="B3M")
    ap.add_argument("--pulse", default="sine")
    ap.add_argument("--w-ratio", default=W_RATIO, help=f"LO:HI:N (default {W_RATIO})")
    ap.add_argument("--a-ratio", default=A_RATIO, help=f"LO:HI:N (default {A_RATIO})")
    ap.add_argument("--no-rule", action="store_true", help="skip the time-step rule's own search")
    ap.add_argument("--record", default=None, help="the benchmark record's name (default step-accuracy-BLOCK-PULSE-"
                    "COLSxROWS, in tests/measurements/results/); a run merges its engines' rows into it")
    ap.add_argument("--table", metavar="NAME", help="print the table of a record and run nothing")
    args = ap.parse_args(argv)
    if args.table:
        print(markdown_table(records.load(args.table)["figures"]), end="")
        return 0
    grid = f"{args.w_ratio.split(':')[-1]}x{args.a_ratio.split(':')[-1]}"
    name = args.record or f"step-accuracy-{args.block}-{args.pulse}-{grid}".lower()
    old = records.load(name)["figures"] if (records.RESULTS_DIR / f"{name}.json").exists() else None
    figures = _json_safe(_merged(old, measure(args), [e for e in args.engines.split(",") if e]))
    path = records.write_record(name, MEASURES, "python " + " ".join([f"tests/measurements/{Path(sys.argv[0]).name}", *sys.argv[1:]]),
                                figures, packages=[e for e in args.engines.split(",") if e])
    print(f"record: {path}", file=sys.stderr)
    print(markdown_table(figures), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
