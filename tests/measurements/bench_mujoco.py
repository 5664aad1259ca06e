"""Measure the MuJoCo adapter: engine speed, and 50×50 maps against the reference Housner maps.

What it prints (and writes as JSON with ``--out FILE``):

1. ``steps``: engine steps per second of this model, one thread and all threads, measured on
   ``mujoco.rollout`` alone (no adapter bookkeeping), for the calibrated settings.
2. ``maps``: for B3M (sine) and B6M (cosine), N×N cells over ω/p and a₀/(g·tanα) in
   [0.5, 10] × [0.5, 10] (the recomputed figures' ranges), restitution Housner:
   agreement of outcomes with the reference map (all cells, and valid cells only), the
   disagreements that are *not* next to the reference boundary (a cell whose 8 neighbours all have
   its reference outcome), the same against the reference judged with the engines' uplift
   tolerance (:func:`~rockbench.engines.contract.uplift_tol_rad`: a reference "rocking" below it is
   "rest" to any soft-contact engine), the invalid cells and their flags, and how many of them lie
   where the rigid model itself needs a pulling table (``N < 0``) or more friction than given
   (the reference's own ``min_normal_mg``/``max_friction_ratio``), wall time, cells/s and engine steps/s, at each time step asked
   for (calibrated) and with ``settings=shipped``.

The machine may be shared: timings are what was measured then; the load average is recorded, and
so is the process CPU time (all threads), whose "steps per CPU-second" is the per-core speed
less disturbed by other programs than wall-clock rates are.
It measures and prints; it never passes or fails on time.

Usage::

    python tests/measurements/bench_mujoco.py [--n 50] [--dt 1e-3 5e-4 2.5e-4] [--blocks B3M:sine B6M:cosine]
                                      [--no-defaults] [--threads 0] [--out results.json]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from collections import Counter
from datetime import datetime, timezone

import numpy as np

from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.engines.contract import Case, uplift_tol_rad
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.model import G
from rockbench.reference_solver.pulses import make_pulse

W_RANGE = (0.5, 10.0)
A_RANGE = (0.5, 10.0)
CODES = {"rest": 0, "rocking": 1, "overturn": 2, None: -1}


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def grid_cases(block, kind: str, n: int, dt_s: float | None):
    w = np.linspace(*W_RANGE, n)
    a = np.linspace(*A_RANGE, n)
    cases = [Case(block, make_pulse(kind, ai * G * math.tan(block.alpha_rad), wj * block.p_rad_s), dt_s=dt_s)
             for ai in a for wj in w]
    return w, a, cases


def outcome_grid(results, n):
    return np.array([CODES[r.outcome] for r in results]).reshape(n, n)


def far_from_boundary(ref: np.ndarray) -> np.ndarray:
    """Cells whose 8 neighbours (inside the grid) share their reference outcome."""
    n0, n1 = ref.shape
    pad = np.pad(ref, 1, constant_values=-9)   # -9: outside the grid, never a disagreement
    far = np.ones_like(ref, dtype=bool)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            nb = pad[1 + di: 1 + di + n0, 1 + dj: 1 + dj + n1]
            far &= (nb == ref) | (nb == -9)
    return far


def measure_steps(adapter, block, dt_s: float, nthreads: int, nbatch: int = 64, nstep: int = 2000) -> float:
    """Engine steps per second of ``mujoco.rollout`` on this model: a sine drive, no adapter work."""
    import mujoco
    from mujoco import rollout

    from rockbench.reference_solver.restitution import Restitution
    p = adapter.resolve(block, Restitution("housner"), dt_s)
    bm = adapter._model(block, p, dt_s)
    t = np.arange(nstep + 1) * dt_s
    ctrl = np.empty((nbatch, nstep, 1))
    for k in range(nbatch):
        pulse = make_pulse("sine", (0.5 + 4.0 * k / nbatch) * G * math.tan(block.alpha_rad), 6.0 * block.p_rad_s)
        ctrl[k, :, 0] = -bm.mass_kg * np.diff(pulse.vel(t)) / dt_s
    datas = [mujoco.MjData(bm.model) for _ in range(nthreads)]
    init = np.tile(bm.s0, (nbatch, 1))
    with rollout.Rollout(nthread=nthreads) as ro:
        ro.rollout([bm.model] * nbatch, datas, init, ctrl[:, :10], initial_warmstart=np.zeros((nbatch, bm.model.nv)))
        t0, c0 = time.perf_counter(), time.process_time()
        ro.rollout([bm.model] * nbatch, datas, init, ctrl, initial_warmstart=np.zeros((nbatch, bm.model.nv)))
        el, cpu = time.perf_counter() - t0, time.process_time() - c0
    return nbatch * nstep / el, nbatch * nstep / cpu


def run_map(adapter, block, kind, n, dt_s, ref_grid, demand=None, ref_grid_tol=None):
    w, a, cases = grid_cases(block, kind, n, dt_s)
    t0 = time.perf_counter()
    # calibration (cached after the first time) is part of resolve(): done before the clock matters
    adapter.resolve(block, cases[0].restitution, adapter.dt_for(cases[0]))
    t_cal = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    res = adapter.run_many(cases)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    grid = outcome_grid(res, n)
    valid = np.array([r.valid for r in res]).reshape(n, n)
    far = far_from_boundary(ref_grid)
    agree = grid == ref_grid
    steps = sum(int(r.diagnostics.get("steps", 0)) for r in res)
    flags = Counter(f for r in res for f in r.flags)
    dis_far = int(np.sum(~agree & far))
    dis_far_valid = int(np.sum(~agree & far & valid))
    extra = {}
    if ref_grid_tol is not None:
        # the reference judged with the engines' uplift tolerance (rocking below it counts as rest)
        far_t = far_from_boundary(ref_grid_tol)
        agree_t = grid == ref_grid_tol
        extra.update({"agreement_all_tol_aware": float(agree_t.mean()),
                      "agreement_valid_tol_aware": float(agree_t[valid].mean()) if valid.any() else math.nan,
                      "disagree_far_tol_aware": int(np.sum(~agree_t & far_t)),
                      "disagree_far_tol_aware_valid": int(np.sum(~agree_t & far_t & valid))})
    if demand is not None:
        lift = demand[0] < 0.0
        over_mu = demand[1] > adapter.settings["friction"]
        need = lift | over_mu
        extra.update({"rigid_needs_pull_or_mu": int(need.sum()),
                 "invalid_where_rigid_needs_pull_or_mu": int(np.sum(~valid & need)),
                 "invalid_where_rigid_is_fine": int(np.sum(~valid & ~need)),
                 "valid_where_rigid_needs_pull_or_mu": int(np.sum(valid & need))})
    return {
        **extra,
        "valid_grid": valid.astype(int).tolist(),
        "cells": n * n,
        "agreement_all": float(agree.mean()),
        "agreement_valid": float(agree[valid].mean()) if valid.any() else math.nan,
        "disagree": int(np.sum(~agree)),
        "disagree_far_from_boundary": dis_far,
        "disagree_far_from_boundary_valid": dis_far_valid,
        "invalid": int(np.sum(~valid)),
        "flags": dict(flags),
        "invalid_far_from_boundary_by_outcome": {k: int(np.sum(~valid & far & (ref_grid == c)))
                                                 for k, c in (("rest", 0), ("rocking", 1), ("overturn", 2))},
        "wall_s": wall,
        "calibration_s": t_cal,
        "cells_per_s": n * n / wall,
        "engine_steps": steps,
        "steps_per_s": steps / wall,
        "cpu_s": cpu,
        "steps_per_cpu_s": steps / cpu,
        "cells_per_cpu_s": n * n / cpu,
        "settings": adapter.resolve(block, cases[0].restitution, adapter.dt_for(cases[0])),
        "outcome_grid": grid.tolist(),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=50)
    ap.add_argument("--dt", type=float, nargs="+", default=[1e-3, 5e-4, 2.5e-4])
    ap.add_argument("--blocks", nargs="+", default=["B3M:sine", "B6M:cosine"])
    ap.add_argument("--no-defaults", action="store_true", help="skip the settings=shipped maps")
    ap.add_argument("--defaults-dt", type=float, default=5e-4)
    ap.add_argument("--defaults-friction", type=float, nargs="+", default=[10.0, 1.0],
                    help="friction coefficients of the settings=shipped maps (10: the adapter's anti-slip "
                         "value; 1: what MuJoCo's pyramidal cones tolerate)")
    ap.add_argument("--threads", type=int, default=0, help="rollout threads (0: all cores)")
    ap.add_argument("--out", default=None, help="write the results as JSON here")
    args = ap.parse_args(argv)

    import mujoco
    from rockbench.engines.adapters.mujoco import MujocoAdapter

    nthreads = args.threads or os.cpu_count() or 1
    out = {"when_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"), "mujoco": mujoco.__version__,
           "python": platform.python_version(), "machine": platform.platform(), "cpus": os.cpu_count(),
           "threads": nthreads, "load_avg_start": os.getloadavg(), "n": args.n,
           "w_range": W_RANGE, "a_range": A_RANGE, "steps": [], "maps": []}
    ref = get_adapter("reference")
    for item in args.blocks:
        name, kind = item.split(":")
        block = PRESETS[name].block()
        _, _, rcases = grid_cases(block, kind, args.n, None)
        t0 = time.perf_counter()
        ref_res = ref.run_many(rcases)
        ref_grid = outcome_grid(ref_res, args.n)
        ref_max = np.array([r.max_abs_theta_rad for r in ref_res]).reshape(args.n, args.n)
        ref_grid_tol = np.where((ref_grid == 1) & (ref_max < uplift_tol_rad(block)), 0, ref_grid)
        _log(f"{name} {kind}: reference map {args.n}x{args.n} in {time.perf_counter() - t0:.1f} s")
        # the rigid model's contact demand, as the reference itself reports it (reference_solver.demand)
        dem = np.array([[r.min_normal_mg, r.max_friction_ratio] for r in ref_res]).T.reshape(2, args.n, args.n)
        _log(f"  rigid model needs a pulling table (N < 0) in {int(np.sum(dem[0] < 0))} cells")
        out.setdefault("rigid_demand", {})[name] = {"n_min_over_mg": dem[0].tolist(), "f_over_n_max": dem[1].tolist()}
        runs = [("calibrated", dt, 10.0) for dt in args.dt]
        if not args.no_defaults:
            runs += [("shipped", args.defaults_dt, mu) for mu in args.defaults_friction]
        for mode, dt, mu in runs:
            ad = MujocoAdapter(settings=mode, threads=nthreads, friction=mu)
            if mode == "calibrated":
                for nt in sorted({1, nthreads}):
                    sps, spc = measure_steps(ad, block, dt, nt)
                    out["steps"].append({"block": name, "dt_s": dt, "threads": nt, "steps_per_s": sps,
                                         "steps_per_cpu_s": spc, "load_avg": os.getloadavg()})
                    _log(f"  rollout speed dt={dt:g} threads={nt}: {sps:,.0f} steps/s wall, "
                         f"{spc:,.0f} steps per CPU-second")
            r = run_map(ad, block, kind, args.n, dt, ref_grid, dem, ref_grid_tol)
            r.update({"block": name, "pulse": kind, "mode": mode, "dt_s": dt, "friction": mu,
                      "load_avg": os.getloadavg()})
            out["maps"].append(r)
            _log(f"  {mode:10s} dt={dt:g} friction={mu:g}: agree {100 * r['agreement_all']:.1f} % (valid {100 * r['agreement_valid']:.1f} %), "
                 f"disagree {r['disagree']} ({r['disagree_far_from_boundary']} far from boundary; with the uplift "
                 f"tolerance applied to the reference: agree {100 * r['agreement_all_tol_aware']:.1f} %, "
                 f"{r['disagree_far_tol_aware']} far, {r['disagree_far_tol_aware_valid']} of them valid), "
                 f"invalid {r['invalid']} {r['flags']} ({r['invalid_where_rigid_needs_pull_or_mu']} where the rigid model "
                 f"needs N < 0 or |F/N| > mu), {r['cells_per_s']:.1f} cells/s, "
                 f"{r['steps_per_s']:,.0f} steps/s, {r['steps_per_cpu_s']:,.0f} steps/CPU-s, wall {r['wall_s']:.0f} s")
    out["load_avg_end"] = os.getloadavg()
    # a compact table on stdout
    print(f"MuJoCo {out['mujoco']}, {out['when_utc']}, {nthreads} threads, load {out['load_avg_start'][0]:.1f}"
          f"->{out['load_avg_end'][0]:.1f}")
    print("block pulse  mode        dt[s]    mu   agree%  agree%valid  disagree(far)  invalid  cells/s  steps/s  steps/CPU-s")
    for r in out["maps"]:
        print(f"{r['block']:5s} {r['pulse']:6s} {r['mode']:10s} {r['dt_s']:<8g} {r['friction']:<4g} {100 * r['agreement_all']:6.1f} "
              f"{100 * r['agreement_valid']:11.1f} {r['disagree']:6d}({r['disagree_far_from_boundary']:3d})    "
              f"{r['invalid']:6d} {r['cells_per_s']:8.1f} {r['steps_per_s']:9,.0f} {r['steps_per_cpu_s']:11,.0f}")
    for s in out["steps"]:
        print(f"rollout {s['block']} dt={s['dt_s']:g} threads={s['threads']}: {s['steps_per_s']:,.0f} steps/s wall, "
              f"{s['steps_per_cpu_s']:,.0f} steps per CPU-second")
    if args.out:
        with open(args.out, "w") as f:
            json.dump(out, f, indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
