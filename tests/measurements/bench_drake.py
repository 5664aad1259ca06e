"""Benchmark of the Drake adapter: engine steps per second, free-rocking η, and maps on the suites' grid.

Measures and prints; it passes or fails on nothing (timings depend on the machine and its load).

Usage (from the repository's top folder, in the venv, with ``pip install -e '.[drake]'``)::

    python tests/measurements/bench_drake.py steps                 # steps per second, one process, several models
    python tests/measurements/bench_drake.py eta                   # free-rocking η: calibrated and as shipped, B3M B6M
    python tests/measurements/bench_drake.py cells [--repeat 2] [--max-worlds K]   # CPU time per cell through
                                                                   # run_many, 16 B3M sine cells, batches of K
    python tests/measurements/bench_drake.py worlds [--settings shipped] [--repeat 2]   # CPU a step and a cell,
                                                                   # batches of K worlds, and Δθ from batches of 1
    python tests/measurements/bench_drake.py flips [--settings shipped]   # outcomes alone and in a batch, at
                                                                   # the overturning boundary
    python tests/measurements/bench_drake.py maps --out DIR [--jobs 2] [--maps B3M:sine,B6L:cosine]
        [--settings calibrated]                            # maps on the default suite's grid, then `summary`
    python tests/measurements/bench_drake.py summary DIR           # cells, worker time, agreement with the reference
    python tests/measurements/bench_drake.py suite [full] --out DIR [--engines drake]   # a suite's run, timed

``maps`` runs ``rockbench map --engine drake`` on the default suite's grid (ω/p 1–16 and
a₀/(g·tanα) 1–12, 51 × 51, adaptive with coarse stride 4) for each listed block and pulse, each into
``DIR/<settings>-<block>-<pulse>`` (rerunning resumes). ``summary`` reads each map's ``cells.csv``:
the cells simulated, their summed wall time (the worker time a suite spends on that map; it
grows with the machine's load), the CPU time of the map command and its workers (``maps`` records
it in ``bench.json``), and
the agreement with the reference solver (Housner's η) on the same cells, counting cells valid in
both (overturn or not, and the three outcomes). The default suite has 8 such maps per engine
variant (4 blocks × 2 pulses); the worker time of a suite is estimated from these maps' mean.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import resource
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.contract import Case
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.model import G
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution, housner_eta
from rockbench.engines.calibration.free_rocking import measure_restitution

#: The default suite's grid (benchmark/suites/default.toml)
GRID = ["--w-ratio", "1:16:51", "--a-ratio", "1:12:51", "--adaptive", "--coarse-stride", "4"]

#: The engine ``maps`` runs, as ``rockbench map`` arguments (``bench_dart.py`` reuses ``maps`` with its own)
ENGINE_ARGS = ["--engine", "drake"]


def _case(block_name: str, pulse: str, w: float, a: float) -> Case:
    b = get_preset(block_name).block()
    return Case(b, make_pulse(pulse, a * G * math.tan(b.alpha_rad), w * b.p_rad_s), Restitution())


def _stamp() -> str:
    return f"# {datetime.now(timezone.utc).isoformat(timespec='seconds')}  load {os.getloadavg()[0]:.1f}"


def cmd_steps(args) -> None:
    """Engine steps per second (wall and CPU) in one process, on the adapter's own loop (diagram reused)."""
    print(_stamp(), file=sys.stderr)
    models = [("point, SAP, planar (default)", {}),
              ("point, SAP, free body", {"planar": False}),
              ("point, lagged (as shipped)", {"settings": "shipped"}),
              ("point, SAP, table drive", {"drive": "table"}),
              ("hydroelastic, SAP, planar", {"contact": "hydroelastic", "hydroelastic_modulus_pa": 1e8,
                                             "relaxation_time_s": 1e-3})]
    cells = [("B3M", "sine", 4.0, 3.0), ("B6M", "cosine", 3.0, 2.0), ("B3M", "sine", 2.0, 1.5), ("B6M", "sine", 6.0, 3.0)]
    print("| model | steps | steps per wall second | steps per CPU second | load |")
    print("|---|---|---|---|---|")
    for label, settings in models:
        ad = get_adapter("drake", **settings)
        for c in cells:
            ad.simulate(_case(*c))  # calibration and diagram built, not timed
        steps = wall = cpu = 0.0
        for _ in range(args.repeat):
            for c in cells:
                d = ad.simulate(_case(*c)).diagnostics
                steps += d["steps"]
                wall += d["wall_s"]
                cpu += d["cpu_s"]
        print(f"| {label} | {int(steps)} | {steps / wall:,.0f} | {steps / cpu:,.0f} | {os.getloadavg()[0]:.1f} |")


#: the cells ``cells`` times: B3M under a sine wave, ω/p × a₀/(g·tanα) on a 4 × 4 grid holding rest,
#: rocking and overturn (the yardstick's range), each at the time-step rule's step
CELLS = [("B3M", "sine", float(w), float(a)) for a in np.linspace(1.5, 6.0, 4) for w in np.linspace(2.0, 5.0, 4)]


def cmd_cells(args) -> None:
    """CPU time per cell of :data:`CELLS` through ``run_many`` (the sweep's batch entry), calibrated
    Drake in batches of ``--max-worlds`` (default: the adapter's); the calibration, the step rule and
    the diagram made first, untimed."""
    print(_stamp(), file=sys.stderr)
    ad = get_adapter("drake")
    if args.max_worlds:
        ad.max_worlds = args.max_worlds
    cases = [_case(*c) for c in CELLS]
    for c in cases:
        ad.resolve(c.block, c.restitution, None)   # calibration and step rule, not timed
    ad.run_many(cases)   # the diagrams built, not timed
    for _ in range(args.repeat):
        c0 = time.process_time()
        res = ad.run_many(cases)
        cpu = time.process_time() - c0
        outcomes = {o: sum(r.outcome == o for r in res) for o in ("rest", "rocking", "overturn")}
        steps = sum((r.diagnostics or {}).get("steps", 0) for r in res)
        print(f"{len(cases)} cells, max_worlds {getattr(ad, 'max_worlds', 1)}: {cpu:.2f} CPU s, "
              f"{cpu / len(cases) * 1e3:.0f} ms a cell, {cpu / steps * 1e6:.1f} µs a block-step "
              f"({steps} steps; {outcomes}); load {os.getloadavg()[0]:.1f}")


def cmd_worlds(args) -> None:
    """What K worlds a batch cost (``--settings``; CPU time, the least of ``--repeat``): a step of the
    batch's diagram with K worlds all rocking (B3M, sine, ω/p 3, a₀/(g·tanα) 1.5, 0.2 s) and with K − 1
    of them retired, then 32 B3M sine cells (ω/p 2–5 × a₀/(g·tanα) 1.5–6) through the adapter's batch in
    batches of K, with the largest |Δθ| of any cell from its run in batches of 1 (0: bit for bit)."""
    print(_stamp(), file=sys.stderr)
    ad = get_adapter("drake", settings=args.settings)
    c = ad.posed(_case("B3M", "sine", 3.0, 1.5))
    s = ad.resolve(c.block, c.restitution, c.dt_s)
    for k in WORLDS_K:
        for retired in sorted({0, k - 1}):
            cpu = _step_cpu(c, s, k, retired, args.repeat)
            print(f"{args.settings}, {k} worlds, {retired} retired: {cpu * 1e6:.0f} µs a step, "
                  f"{cpu / (k - retired) * 1e6:.1f} µs a running world's step")
    cases = [ad.posed(_case("B3M", "sine", float(w), float(a))) for a in np.linspace(1.5, 6.0, 4)
             for w in np.linspace(2.0, 5.0, 8)]
    alone = None
    for k in WORLDS_K:
        ad.max_worlds = k
        ad._simulate_many(cases)   # the diagrams built, not timed
        cpus = []
        for _ in range(args.repeat):
            c0 = time.process_time()
            trs = ad._simulate_many(cases)
            cpus.append(time.process_time() - c0)
        alone = alone or trs
        steps = sum(tr.diagnostics["steps"] for tr in trs)
        print(f"{args.settings}, batches of {k}: {min(cpus) / len(cases) * 1e3:.0f} ms a cell, "
              f"{min(cpus) / steps * 1e6:.1f} µs a block-step, max |Δθ| from batches of 1 "
              f"{max(_max_dtheta(a, b) for a, b in zip(alone, trs)):.2g} rad")


#: the batch sizes ``worlds`` measures
WORLDS_K = (1, 4, 8, 16)


def _step_cpu(c: Case, s: dict, k: int, retired: int, repeat: int) -> float:
    """CPU seconds a step of the adapter's diagram of ``k`` worlds of cell ``c``, ``retired`` of them
    out of contact from the start, over 0.2 s (the least of ``repeat``)."""
    from rockbench.engines.adapters import drake as da

    sc, n, cpus = da._Scene(c.block, s, c.dt_s, k), round(0.2 / c.dt_s), []
    for _ in range(repeat):
        sc.start(c.block, [c.pulse] * k, 0.0)
        for w in range(k - retired, k):
            sc.retire(w)
        c0 = time.process_time()
        sc.advance(0, n)
        cpus.append((time.process_time() - c0) / n)
    return min(cpus)


def _max_dtheta(a, b) -> float:
    """The largest |Δθ| [rad] of two trajectories of one cell over their common samples (inf: other lengths)."""
    if a.theta_rad.size != b.theta_rad.size:
        return math.inf
    return float(np.max(np.abs(a.theta_rad - b.theta_rad)))


def cmd_flips(args) -> None:
    """Whether a cell's outcome depends on its batch-mates at the overturning boundary: B3M, sine,
    ω/p 3.5, the boundary amplitude bisected (one world at a time) between a₀/(g·tanα) 1.5 (rocking)
    and 3 (overturn); then 15 amplitudes within ±rel of it, alone and as one batch of 16 with a cosine
    pulse (the adapter's batch hooks at 16 worlds; the product runs one world a batch)."""
    ad = get_adapter("drake", settings=args.settings)
    ad.max_worlds = 16

    def overturns(a: float) -> bool:
        c = ad.posed(_case("B3M", "sine", 3.5, a))
        return ad.judge(c, ad._simulate_many([c])[0]).outcome == "overturn"

    lo, hi = 1.5, 3.0
    for _ in range(34):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if overturns(mid) else (mid, hi)
    print(f"boundary a₀/(g·tanα) in [{lo!r}, {hi!r}]")
    for rel in (1e-4, 1e-6, 1e-8):
        amps = 0.5 * (lo + hi) * (1 + rel * np.linspace(-1.0, 1.0, 15))
        cases = [ad.posed(_case("B3M", "sine", 3.5, float(a))) for a in amps] + [ad.posed(_case("B3M", "cosine", 2.5, 2.5))]
        alone = [ad.judge(c, ad._simulate_many([c])[0]).outcome[0] for c in cases[:15]]
        batch = [ad.judge(c, tr).outcome[0] for c, tr in zip(cases, ad._simulate_many(cases))][:15]
        print(f"±{rel:g}: {sum(x != y for x, y in zip(alone, batch))} of 15 flip (alone {''.join(alone)}, "
              f"in a batch {''.join(batch)})")


def cmd_eta(args) -> None:
    """Free-rocking η of B3M and B6M: calibrated to Housner, as shipped, and the hydroelastic variant."""
    print(_stamp(), file=sys.stderr)
    print("| block | variant | η measured (per-impact spread) | η_H | relative error | settings |")
    print("|---|---|---|---|---|---|")
    for name in ("B3M", "B6M"):
        block = get_preset(name).block()
        eta_h = housner_eta(block.alpha_rad)
        for label, settings in (("calibrated to η_H", {}), ("as shipped", {"settings": "shipped"}),
                                ("hydroelastic, calibrated to η_H", {"contact": "hydroelastic"})):
            ad = get_adapter("drake", **settings)
            s = ad.resolve(block, Restitution())
            m = measure_restitution(ad, block, settings=s)
            shown = {k: s[k] for k in (*ad.SHIPPED, "approximation") if s.get(k) is not None}
            print(f"| {name} | {label} | {m.eta_mean:.4f} ± {m.eta_std:.4f} | {eta_h:.4f} | "
                  f"{100 * (m.eta_mean - eta_h) / eta_h:+.2f} % | {json.dumps(shown)} |")


def cmd_maps(args) -> None:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for item in args.maps.split(","):
        block, pulse = item.split(":")
        d = out / f"{args.settings}-{block}-{pulse}"
        t0 = time.perf_counter()
        cmd = [sys.executable, "-m", "rockbench.benchmark", "map", *ENGINE_ARGS, "--block", block, "--pulse", pulse,
               *GRID, "--jobs", str(args.jobs), "--out", str(d), "--no-plot", "--json"]
        if args.settings != "calibrated":
            cmd[cmd.index("--engine") + 2:cmd.index("--engine") + 2] = ["--settings", args.settings]
        print(_stamp(), " ".join(cmd[1:]), file=sys.stderr)
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        load0 = os.getloadavg()[0]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        # CPU time of the map command and its workers: what the map costs, whatever the neighbours do
        cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
        wall = time.perf_counter() - t0
        (d / "bench.json").write_text(json.dumps({"wall_s": wall, "cpu_s": cpu, "jobs": args.jobs,
                                                  "load_before": load0, "load_after": os.getloadavg()[0],
                                                  "utc": datetime.now(timezone.utc).isoformat(timespec="seconds")}))
        print(f"{d.name}: {wall:.0f} s wall, {cpu:.0f} s CPU with {args.jobs} workers", file=sys.stderr)
    args.dir = args.out
    cmd_summary(args)


def cmd_summary(args) -> None:
    ref = get_adapter("reference")
    rows = []
    for d in sorted(Path(args.dir).iterdir()):
        f = d / "cells.csv"
        if not f.is_file():
            continue
        cells = list(csv.DictReader(f.open()))
        run = json.loads((d / "run.json").read_text())
        block, pulse = cells[0]["block"], cells[0]["pulse"]
        cases = [_case(block, pulse, float(c["w_ratio"]), float(c["a_ratio"])) for c in cells]
        rr = ref.run_many(cases)
        both = [(c, r) for c, r in zip(cells, rr) if c["valid"] in ("True", "true", "1") and r.valid]
        over = sum((c["outcome"] == "overturn") == (r.outcome == "overturn") for c, r in both)
        same = sum(c["outcome"] == r.outcome for c, r in both)
        wall = sum(float(c["wall_s"]) for c in cells)
        flags: dict = {}
        for c in cells:
            for fl in filter(None, c["flags"].replace(";", " ").replace("|", " ").split()):
                flags[fl] = flags.get(fl, 0) + 1
        bench = json.loads((d / "bench.json").read_text()) if (d / "bench.json").is_file() else {}
        rows.append({"map": d.name, "cells": len(cells), "worker_s": wall, "s_per_cell": wall / len(cells),
                     "cpu_s": bench.get("cpu_s"), "map_wall_s": bench.get("wall_s"),
                     "valid_both": len(both), "agree_overturn": over / max(len(both), 1),
                     "agree_outcome": same / max(len(both), 1), "flags": flags,
                     "version": run.get("engine", {}).get("version")})
    print("| map | cells simulated | worker time [s] | s per cell | CPU [s] | agree (overturn) | agree (3 outcomes) | "
          "valid in both | flags |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        fl = ", ".join(f"{k} {v}" for k, v in sorted(r["flags"].items())) or "-"
        cpu = "-" if r["cpu_s"] is None else f"{r['cpu_s']:.0f}"
        print(f"| {r['map']} | {r['cells']} | {r['worker_s']:.0f} | {r['s_per_cell']:.3f} | {cpu} | "
              f"{100 * r['agree_overturn']:.1f} % | {100 * r['agree_outcome']:.1f} % | {r['valid_both']} | {fl} |")
    cpus = [r["cpu_s"] for r in rows if r["cpu_s"] is not None]
    if cpus:
        c = float(np.mean(cpus))
        print(f"\nmean CPU time per map: {c:.0f} s; the default suite's 16 maps (8 per variant): about "
              f"{16 * c / 60:.0f} min of CPU, {8 * c / 60:.0f} min of wall time on 2 free cores")
    if rows:
        mean = float(np.mean([r["worker_s"] for r in rows]))
        print(f"\nmean worker time per map: {mean:.0f} s; the default suite's 8 maps per variant: about "
              f"{8 * mean / 60:.0f} min of worker time per variant, {16 * mean / 60:.0f} min for two variants "
              f"(about half that in wall time on 2 cores)")
    (Path(args.dir) / "summary.json").write_text(json.dumps(rows, indent=2))


def cmd_suite(args) -> None:
    """A suite's run restricted to engines (default: drake), timed: wall and CPU of the whole job."""
    cmd = [sys.executable, "-m", "rockbench.benchmark", "run", args.suite, "--engines", args.engines, "--out", args.out,
           "--no-report"]
    print(_stamp(), " ".join(cmd[1:]), file=sys.stderr)
    t0, load0 = time.perf_counter(), os.getloadavg()[0]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    wall = time.perf_counter() - t0
    maps = [json.loads(p.read_text()) for p in Path(args.out).glob("maps/*/*/run.json")]
    out = {"suite": args.suite, "engines": args.engines, "wall_s": wall, "cpu_s": cpu, "maps": len(maps),
           "load_before": load0, "load_after": os.getloadavg()[0],
           "utc": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    print(json.dumps(out))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("steps")
    s.add_argument("--repeat", type=int, default=3)
    s.set_defaults(func=cmd_steps)
    sub.add_parser("eta").set_defaults(func=cmd_eta)
    c = sub.add_parser("cells")
    c.add_argument("--repeat", type=int, default=2)
    c.add_argument("--max-worlds", type=int, default=0)
    c.set_defaults(func=cmd_cells)
    k = sub.add_parser("worlds")
    k.add_argument("--settings", default="calibrated", choices=["calibrated", "shipped"])
    k.add_argument("--repeat", type=int, default=2)
    k.set_defaults(func=cmd_worlds)
    f = sub.add_parser("flips")
    f.add_argument("--settings", default="calibrated", choices=["calibrated", "shipped"])
    f.set_defaults(func=cmd_flips)
    m = sub.add_parser("maps")
    m.add_argument("--out", required=True)
    m.add_argument("--jobs", type=int, default=2)
    m.add_argument("--maps", default="B3M:sine,B6L:cosine")
    m.add_argument("--settings", default="calibrated", choices=["calibrated", "shipped"])
    m.set_defaults(func=cmd_maps)
    u = sub.add_parser("suite")
    u.add_argument("suite", nargs="?", default="full")
    u.add_argument("--engines", default="drake")
    u.add_argument("--out", required=True)
    u.set_defaults(func=cmd_suite)
    r = sub.add_parser("summary")
    r.add_argument("dir")
    r.set_defaults(func=cmd_summary)
    args = p.parse_args(argv)
    args.func(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
