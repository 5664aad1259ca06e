"""Where an Exudyn cell's time goes (Exudyn's maps were about 70 % of the main job's engine
time). Measures and prints; it passes or fails nothing.

    python tests/measurements/probes/probe_exudyn_cost.py [--cells N] [--json FILE]

1. The cost of one step, and Exudyn's own timers (``show.computationTime``) over one run of a
   rocking B3M cell, calibrated contact.
2. The Newton variants Exudyn offers that keep the time step and the contact model: full Newton, and
   the modified Newton's Jacobian refreshed after 2, 3 (rockbench's setting) or 5 iterations; wall
   time per simulated 0.5 s and the largest |θ| reached (the answer should not move).
3. For ``N`` random cells of the default suite's grid (B3M sine), per settings: how the simulated
   time divides between the pulse, the minimum tail after it (``min_tail_s``, in which an energy
   gain is watched for) and what runs beyond it.
4. Whether checking the stop rule more often would keep the trajectories: the same cells integrated
   for 0.3 s in segments of 0.05 s (rockbench's ``segment_s``) and of 0.01 s, compared sample by
   sample.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import time
from pathlib import Path

import numpy as np

from rockbench.benchmark.api import request_of
from rockbench.engines.adapters import exudyn as X
from rockbench.engines.registry import get_adapter


def _case(settings: str, w: float, a: float, block: str = "B3M"):
    ns = request_of(block, engine="exudyn", settings=settings, pulse="sine", w_ratio=w, a_ratio=a)
    case, _ = ns.case()
    return get_adapter("exudyn", **ns.engine_settings()), case


def _model(adapter, case):
    dt = adapter.dt_for(case)
    res = adapter.resolve(case.block, case.restitution, dt)
    m = X._Model(case.block, {k: res[k] for k in X._CONTACT_KEYS}, "inertial", True, dt, None)
    m.set_pulse(case.pulse)
    return m


def step_cost() -> dict:
    adapter, case = _case("calibrated", 4.0, 3.0)
    m = _model(adapter, case)
    ok, _, steps, wall = m.run(case.pulse.duration_s, lambda s: False, 0.05, 0.5)
    m2 = _model(adapter, case)
    m2.ss.timeIntegration.verboseMode = 1
    m2.ss.show.computationTime = True
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        m2.run(case.pulse.duration_s, lambda s: False, 0.5, 0.5)
    timers = {}
    for line in buf.getvalue().splitlines():
        if "=" in line and "%" in line:
            k, v = line.split("=", 1)
            with contextlib.suppress(ValueError):
                timers[k.strip().lstrip("_ ")] = float(v.split("%")[0])
    return {"steps": steps, "wall_s": wall, "us_per_step": 1e6 * wall / steps, "timers_percent": timers}


def newton_variants() -> list[dict]:
    out = []
    for settings in ("calibrated", "shipped"):
        for w, a in ((4, 3), (8, 6), (2, 1.5)):
            adapter, case = _case(settings, w, a)
            row = {"settings": settings, "w_ratio": w, "a_ratio": a}
            for label, full, mod in (("rockbench (modified, 3)", False, 3), ("full Newton", True, 3),
                                     ("modified, 2", False, 2), ("modified, 5", False, 5)):
                m = _model(adapter, case)
                m.ss.timeIntegration.newton.maxModifiedNewtonIterations = mod
                _, _, _, wall = m.run(case.pulse.duration_s, lambda s: False, 0.05, 0.5, full)
                _, th, *_ = m.samples()
                row[label] = {"ms_per_0.5s": 1e3 * wall, "max_abs_theta_rad": float(np.max(np.abs(th)))}
            out.append(row)
    return out


def time_shares(n: int) -> dict:
    rng = np.random.default_rng(2)
    out = {}
    for settings in ("calibrated", "shipped"):
        tot = np.zeros(3)
        for _ in range(n):
            adapter, case = _case(settings, rng.uniform(1, 16), rng.uniform(1, 12))
            tr = adapter.simulate(case)
            T, tpe, mt = float(tr.t_s[-1]), tr.t_pulse_end_s, float(adapter.settings["min_tail_s"])
            tot += [min(T, tpe), min(max(T - tpe, 0.0), mt), max(T - tpe - mt, 0.0)]
        out[settings] = dict(zip(("pulse", "min_tail", "beyond"), (tot / tot.sum()).round(3).tolist()))
    return out


def segments(n: int) -> dict:
    rng = np.random.default_rng(3)
    out = {}
    for settings in ("calibrated", "shipped"):
        same = 0
        worst = 0.0
        for _ in range(n):
            adapter, case = _case(settings, rng.uniform(1, 16), rng.uniform(1, 12))
            runs = []
            for seg in (0.05, 0.01):
                m = _model(adapter, case)
                m.run(case.pulse.duration_s, lambda s: False, seg, 0.3)
                t, th, *_ = m.samples()
                runs.append((t, th))
            (t1, a), (t2, b) = runs
            if t1.shape == t2.shape and np.array_equal(t1, t2) and np.array_equal(a, b):
                same += 1
            else:   # at the sample times both runs share
                _, i1, i2 = np.intersect1d(np.round(t1, 9), np.round(t2, 9), return_indices=True)
                worst = max(worst, float(np.max(np.abs(a[i1] - b[i2]))))
        out[settings] = {"cells": n, "identical": same, "largest_theta_difference_at_shared_times_rad": worst}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=40)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    res = {"step": step_cost()}
    print(f"1. {res['step']['us_per_step']:.1f} µs a step; Exudyn's timers [%]: {res['step']['timers_percent']}")
    res["newton"] = newton_variants()
    print("2. wall per simulated 0.5 s [ms] (largest |θ| [rad]):")
    for r in res["newton"]:
        print(f"   {r['settings']:10} ω/p {r['w_ratio']:<3} a {r['a_ratio']:<4} " + " | ".join(
            f"{k} {v['ms_per_0.5s']:.0f} ({v['max_abs_theta_rad']:.5f})" for k, v in r.items() if isinstance(v, dict)))
    res["time_shares"] = time_shares(args.cells)
    print(f"3. simulated time of {args.cells} random cells: {res['time_shares']}")
    res["segments"] = segments(min(args.cells, 30))
    print(f"4. segments of 0.05 s against 0.01 s: {res['segments']}")
    res["wall_s"] = time.perf_counter() - t0
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
