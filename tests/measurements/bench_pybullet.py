"""Benchmark of the PyBullet adapter: engine steps per second, and stability maps against the reference.

Measures and prints; it passes or fails on nothing (timings depend on the machine and its load).

Usage (from the repository's top folder, in the venv)::

    python tests/measurements/bench_pybullet.py steps                      # engine steps/s, one process
    python tests/measurements/bench_pybullet.py maps --out DIR [--n 50] [--jobs 2]
        [--dts 0.001,0.0005,0.00025] [--defaults]                  # maps, agreement, cells/s
    python tests/measurements/bench_pybullet.py reference --out DIR [--n 50]  # save the reference maps in DIR
    python tests/measurements/bench_pybullet.py compare DIR                # (re)score saved maps vs the reference
    python tests/measurements/bench_pybullet.py plot DIR [--figures docs/figures]  # one PNG per saved map
    python tests/measurements/bench_pybullet.py liftoff DIR                # does the reference motion need N < 0?

``maps`` runs 50×50 maps of B3M under a sine and B6M under a cosine (ω/p and a₀/(g·tanα) over the
ranges below), with settings calibrated to Housner's η at each time step, and with
``--defaults`` also PyBullet as shipped at the default step. Each map is saved as JSON in DIR
(outcome, impacts and flags per cell, wall time, cells/s), so ``compare`` can score it again. The
score needs the reference adapter (``rockbench.engines.adapters.reference``): cell agreement on
the three outcomes and on overturn-or-not, counting only valid cells, and how many disagreements
are not next to the reference's overturning boundary.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from datetime import datetime, timezone
from multiprocessing import get_context
from pathlib import Path

import numpy as np

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.contract import Case
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.model import G
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution

#: The maps: (block, pulse) pairs of the issue, and the axes' ranges [-]
MAPS = [("B3M", "sine"), ("B6M", "cosine")]
W_RANGE = (0.5, 10.0)
A_RANGE = (0.5, 10.0)
SCHEMA = 1

_ADAPTERS: dict = {}


def _case(block_name: str, pulse: str, w: float, a: float, dt: float | None) -> Case:
    b = get_preset(block_name).block()
    return Case(b, make_pulse(pulse, a * G * math.tan(b.alpha_rad), w * b.p_rad_s), Restitution(), dt)


def _work(job):
    """One chunk of cells in a worker: the worker's one adapter (and PyBullet client) is reused."""
    settings, block_name, pulse, dt, cells = job
    key = json.dumps(settings, sort_keys=True)
    if key not in _ADAPTERS:
        _ADAPTERS[key] = get_adapter("pybullet", **settings)
    ad = _ADAPTERS[key]
    out = []
    for i, j, w, a in cells:
        r = ad.run(_case(block_name, pulse, w, a, dt))
        d = r.diagnostics or {}
        out.append({"i": i, "j": j, "w_ratio": w, "a_ratio": a, "outcome": r.outcome, "n_impacts": r.n_impacts,
                    "flags": r.flags, "valid": r.valid, "steps": d.get("steps", 0), "loop_s": d.get("wall_s", 0.0),
                    "loop_cpu_s": d.get("cpu_s", 0.0),
                    "ended_by": d.get("ended_by")})
    return out


def grid(n: int):
    return np.linspace(*W_RANGE, n), np.linspace(*A_RANGE, n)


def run_map(block_name: str, pulse: str, settings: dict, dt: float, n: int, jobs: int) -> dict:
    """One PyBullet map with a pool of ``jobs`` worker processes."""
    ws, as_ = grid(n)
    # calibrate once in the parent so the workers read the stored result instead of racing for it
    ad = get_adapter("pybullet", **settings)
    resolved = ad.resolve(get_preset(block_name).block(), Restitution(), dt_s=dt)
    cells = [(i, j, float(ws[j]), float(as_[i])) for i in range(n) for j in range(n)]
    chunks = [cells[k::max(1, len(cells) // 20)] for k in range(max(1, len(cells) // 20))]
    t0 = time.perf_counter()
    rows = []
    with get_context("fork").Pool(jobs) as pool:
        for part in pool.imap_unordered(_work, [(settings, block_name, pulse, dt, c) for c in chunks]):
            rows.extend(part)
    wall = time.perf_counter() - t0
    steps = sum(r["steps"] for r in rows)
    loop = sum(r["loop_s"] for r in rows)
    cpu = sum(r.get("loop_cpu_s", 0.0) for r in rows)
    return {"schema": SCHEMA, "block": block_name, "pulse": pulse, "restitution": "housner", "dt_s": dt,
            "settings": settings, "resolved": resolved, "n": n, "w_range": W_RANGE, "a_range": A_RANGE,
            "jobs": jobs, "wall_s": wall, "cells_per_s": len(rows) / wall, "steps": steps,
            "steps_per_s_per_process": steps / loop if loop > 0 else None,
            "steps_per_cpu_s": steps / cpu if cpu > 0 else None,
            "utc": datetime.now(timezone.utc).isoformat(timespec="seconds"), "load_avg": os.getloadavg(),
            "machine": platform.platform(), "cpus": os.cpu_count(),
            "engine_version": ad.version(), "cells": sorted(rows, key=lambda r: (r["i"], r["j"]))}


def reference_map(block_name: str, pulse: str, n: int, out: Path | None = None) -> np.ndarray:
    """Outcomes of the reference solver on the same grid (strings, shape (n, n): rows are a_ratio).

    Read from ``out/reference-BLOCK-PULSE-nN.json`` when ``reference`` saved it there, else computed.
    """
    if out is not None:
        path = out / f"reference-{block_name}-{pulse}-n{n}.json"
        if path.exists():
            return np.array(json.loads(path.read_text())["outcomes"], dtype=object)
    ref = get_adapter("reference")
    ws, as_ = grid(n)
    cases = [_case(block_name, pulse, float(w), float(a), None) for a in as_ for w in ws]
    res = ref.run_many(cases)
    return np.array([r.outcome for r in res], dtype=object).reshape(n, n)


def score(m: dict, ref: np.ndarray) -> dict:
    """Agreement of a PyBullet map with the reference map."""
    n = m["n"]
    eng = np.full((n, n), None, dtype=object)
    valid = np.zeros((n, n), dtype=bool)
    flags: dict[str, int] = {}
    for c in m["cells"]:
        eng[c["i"], c["j"]] = c["outcome"]
        valid[c["i"], c["j"]] = c["valid"]
        for f in c["flags"]:
            flags[f] = flags.get(f, 0) + 1
    ref_over = ref == "overturn"
    eng_over = eng == "overturn"
    # a cell touches the boundary when one of its 8 neighbours differs from it in the reference
    pad = np.pad(ref_over, 1, mode="edge")
    near = np.zeros_like(ref_over)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            near |= pad[1 + di:1 + di + n, 1 + dj:1 + dj + n] != ref_over
    v = valid
    agree3 = (eng == ref) & v
    agree2 = (eng_over == ref_over) & v
    dis2 = (~agree2) & v
    return {"cells": n * n, "valid": int(v.sum()), "invalid": int((~v).sum()), "flags": flags,
            "agree_outcome": float(agree3.sum() / max(v.sum(), 1)),
            "agree_overturn": float(agree2.sum() / max(v.sum(), 1)),
            "disagree_overturn": int(dis2.sum()), "disagree_not_near_boundary": int((dis2 & ~near).sum()),
            "invalid_reference_overturn": int(((~v) & ref_over).sum())}


def cmd_steps(args) -> None:
    """Engine steps per second in one process, on long rocking runs (the loop only)."""
    print(f"# {datetime.now(timezone.utc).isoformat(timespec='seconds')}  load {os.getloadavg()}", file=sys.stderr)
    for planar in (True, False):
        for iters in (30, 50):
            ad = get_adapter("pybullet", planar=planar, solver_iterations=iters)
            ad.simulate(_case("B3M", "sine", 4.0, 3.0, None))  # calibration and scene set-up, not timed
            ad.simulate(_case("B6M", "cosine", 3.0, 2.0, None))
            steps = loop = cpu = 0.0
            t0 = time.perf_counter()
            for name, pulse, w, a in (("B3M", "sine", 4.0, 3.0), ("B6M", "cosine", 3.0, 2.0),
                                      ("B3M", "sine", 2.0, 1.5), ("B6M", "sine", 6.0, 3.0)):
                for _ in range(3):
                    tr = ad.simulate(_case(name, pulse, w, a, None))
                    steps += tr.diagnostics["steps"]
                    loop += tr.diagnostics["wall_s"]
                    cpu += tr.diagnostics["cpu_s"]
            total = time.perf_counter() - t0
            print(json.dumps({"planar": planar, "solver_iterations": iters, "steps": int(steps),
                              "steps_per_s_loop": steps / loop, "steps_per_cpu_s_loop": steps / cpu,
                              "steps_per_s_with_setup": steps / total, "load_avg": os.getloadavg()}))


def cmd_maps(args) -> None:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    dts = [float(x) for x in args.dts.split(",")]
    base = {"drive": args.drive} if args.drive != "inertial" else {}
    runs = [(b, p, dict(base), dt) for b, p in MAPS for dt in dts]
    if args.defaults:
        runs += [(b, p, {**base, "settings": "shipped"}, 5e-4) for b, p in MAPS]
    for b, p, s, dt in runs:
        drive = "" if args.drive == "inertial" else f"-{args.drive}"
        tag = f"{b}-{p}-{s.get('settings', 'calibrated')}{drive}-dt{dt:g}-n{args.n}"
        path = out / f"{tag}.json"
        if path.exists():
            print(f"{tag}: exists, skipped", file=sys.stderr)
            continue
        m = run_map(b, p, s, dt, args.n, args.jobs)
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(m, default=float))
        os.replace(tmp, path)
        print(f"{tag}: {m['cells_per_s']:.1f} cells/s with {args.jobs} processes, "
              f"{m['steps_per_s_per_process']:.0f} steps/s per process, wall {m['wall_s']:.0f} s", file=sys.stderr)
    cmd_compare(args)


def cmd_compare(args) -> None:
    out = Path(args.out)
    refs: dict = {}
    table = []
    for path in sorted(out.glob("*.json")):
        if path.name == "summary.json" or path.name.startswith("reference-"):
            continue
        m = json.loads(path.read_text())
        key = (m["block"], m["pulse"], m["n"])
        if key not in refs:
            refs[key] = reference_map(m["block"], m["pulse"], m["n"], out)
        sc = score(m, refs[key])
        row = {"map": path.stem, "block": m["block"], "pulse": m["pulse"],
               "settings": m["settings"].get("settings", "calibrated") + (
                   f", {m['settings']['drive']} drive" if m["settings"].get("drive", "inertial") != "inertial" else ""),
               "dt_s": m["dt_s"],
               "eta_engine": (m["resolved"].get("calibration") or {}).get("eta_measured"),
               "cells_per_s": m["cells_per_s"], "jobs": m["jobs"],
               "steps_per_s_per_process": m["steps_per_s_per_process"],
               "steps_per_cpu_s": m.get("steps_per_cpu_s"), "load_avg": m.get("load_avg"), "utc": m["utc"], **sc}
        table.append(row)
    (out / "summary.json").write_text(json.dumps(table, indent=2))
    print("| map | settings | dt [s] | agree (overturn) | agree (3 outcomes) | disagree / not near boundary "
          "| invalid (flags) | cells/s (jobs) | steps/s per process (wall / CPU) | load |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in table:
        fl = ", ".join(f"{k} {v}" for k, v in sorted(r["flags"].items())) or "-"
        print(f"| {r['block']} {r['pulse']} | {r['settings']} | {r['dt_s']:g} | {100 * r['agree_overturn']:.1f} % "
              f"| {100 * r['agree_outcome']:.1f} % | {r['disagree_overturn']} / {r['disagree_not_near_boundary']} "
              f"| {r['invalid']} ({fl}) | {r['cells_per_s']:.1f} ({r['jobs']}) | {r['steps_per_s_per_process']:.0f} / "
              f"{(r['steps_per_cpu_s'] or float('nan')):.0f} | {(r['load_avg'] or [float('nan')])[0]:.1f} |")


def cmd_reference(args) -> None:
    """Save the reference maps of the grid in DIR (so ``compare`` need not recompute them)."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for b, p in MAPS:
        t0 = time.perf_counter()
        ref = reference_map(b, p, args.n)
        path = out / f"reference-{b}-{p}-n{args.n}.json"
        path.write_text(json.dumps({"block": b, "pulse": p, "n": args.n, "w_range": W_RANGE, "a_range": A_RANGE,
                                    "outcomes": ref.tolist(), "wall_s": time.perf_counter() - t0}))
        print(f"{path.name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)


def cmd_plot(args) -> None:
    """One PNG per saved map: the PyBullet outcomes over the reference's overturning boundary."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    out = Path(args.out)
    figdir = Path(args.figures)
    figdir.mkdir(parents=True, exist_ok=True)
    codes = {"rest": 0, "rocking": 1, "overturn": 2}
    for path in sorted(out.glob("*.json")):
        if path.name == "summary.json" or path.name.startswith("reference-"):
            continue
        m = json.loads(path.read_text())
        n = m["n"]
        ref = reference_map(m["block"], m["pulse"], n, out)
        grid_ = np.full((n, n), np.nan)
        bad = np.zeros((n, n), dtype=bool)
        for c in m["cells"]:
            grid_[c["i"], c["j"]] = codes.get(c["outcome"], np.nan)
            bad[c["i"], c["j"]] = not c["valid"]
        ws, as_ = grid(n)
        fig, ax = plt.subplots(figsize=(5.2, 4.2))
        ax.pcolormesh(ws, as_, grid_, cmap=ListedColormap(["#dddddd", "#9ecae1", "#fb6a4a"]), vmin=-0.5, vmax=2.5,
                      shading="nearest")
        ii, jj = np.nonzero(bad)
        ax.scatter(ws[jj], as_[ii], marker="x", s=6, c="k", linewidths=0.6, label="invalid (slip/jump/energy)")
        ax.contour(ws, as_, (ref == "overturn").astype(float), levels=[0.5], colors="k", linewidths=1.2)
        ax.plot([], [], "k-", label="reference boundary (Housner)")
        ax.set_xlabel("ω/p")
        ax.set_ylabel("a₀/(g·tanα)")
        st = m["settings"].get("settings", "calibrated")
        ax.set_title(f"PyBullet {m['block']} {m['pulse']}, {st}, Δt = {m['dt_s']:g} s\n"
                     "grey rest, blue rocking, red overturn", fontsize=9)
        ax.legend(loc="lower right", fontsize=7)
        fig.tight_layout()
        fig.savefig(figdir / f"pybullet-{path.stem}.png", dpi=110)
        plt.close(fig)
        print(figdir / f"pybullet-{path.stem}.png", file=sys.stderr)


def cmd_liftoff(args) -> None:
    """Does the reference motion itself need the table to pull the block down (tapes)?

    For each overturning cell of a saved map, the normal force the ideal rocking motion needs is
    ``N/(m g) = 1 + R[sin(α − φ)·φ̈ − cos(α − φ)·φ̇²]/g`` with ``φ = |θ|`` (the vertical motion of the
    centre of mass, ``z = R cos(α − φ)``), from the reference trajectory (φ̇, φ̈ by finite differences)
    while ``φ < α``. Counts cells by PyBullet validity and by the sign of the smallest N.
    """
    out = Path(args.out)
    ref = get_adapter("reference")
    for path in sorted(out.glob("*.json")):
        if path.name == "summary.json" or path.name.startswith("reference-"):
            continue
        m = json.loads(path.read_text())
        b = get_preset(m["block"]).block()
        R, al = b.half_diagonal_m, b.alpha_rad
        counts: dict = {}
        for c in m["cells"]:
            if c["outcome"] != "overturn":
                continue
            tr = ref.simulate(_case(m["block"], m["pulse"], c["w_ratio"], c["a_ratio"], 2.5e-4))
            phi = np.abs(tr.theta_rad)
            phid = np.gradient(phi, tr.t_s)
            phidd = np.gradient(phid, tr.t_s)
            keep = (phi < al) & (phi > 1e-3)
            if keep.sum() < 3:
                continue
            n_min = float(np.min(1.0 + (R * np.sin(al - phi) * phidd - R * np.cos(al - phi) * phid**2)[keep] / G))
            k = ("valid" if c["valid"] else "invalid", "N<0" if n_min < 0 else "N>=0")
            counts[k] = counts.get(k, 0) + 1
        print(path.stem, {f"{a} {b_}": v for (a, b_), v in sorted(counts.items())})


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    sub.add_parser("steps").set_defaults(func=cmd_steps)
    q = sub.add_parser("maps")
    q.add_argument("--out", required=True)
    q.add_argument("--n", type=int, default=50)
    q.add_argument("--jobs", type=int, default=2)
    q.add_argument("--dts", default="0.001,0.0005,0.00025")
    q.add_argument("--defaults", action="store_true", help="also PyBullet as shipped (settings=shipped)")
    q.add_argument("--drive", default="inertial", choices=["inertial", "table"], help="table drive (default inertial)")
    q.set_defaults(func=cmd_maps)
    r = sub.add_parser("reference")
    r.add_argument("--out", required=True)
    r.add_argument("--n", type=int, default=50)
    r.set_defaults(func=cmd_reference)
    lo = sub.add_parser("liftoff")
    lo.add_argument("out")
    lo.set_defaults(func=cmd_liftoff)
    g = sub.add_parser("plot")
    g.add_argument("out")
    g.add_argument("--figures", default="docs/figures")
    g.set_defaults(func=cmd_plot)
    c = sub.add_parser("compare")
    c.add_argument("out")
    c.set_defaults(func=cmd_compare)
    args = p.parse_args(argv)
    args.func(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
