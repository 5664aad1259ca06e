"""Measure the MuJoCo Warp adapter: world-steps per second, whole maps per second, agreement.

What it prints (and writes as JSON and Markdown into ``--out DIR``):

1. ``setup``: the device, versions, the first kernel load (compile, or the kernel cache) and the
   calibration to Housner's η (``calibrate``; cached on disk after the first run).
2. ``steps``: the engine alone: one batch of ``nworld`` worlds stepped a fixed number of steps
   through the adapter's own batch (drive kernel, ``mujoco_warp.step``, record; CUDA graph on a GPU),
   world-steps per second.
3. ``maps``: whole maps through ``rockbench.benchmark.sweep.run_map`` (the CLI's ``rockbench map``
   path: cells judged by the one classifier and validity rule, written to ``cells.csv``, no
   picture), N×N cells over ω/p × a₀/(g·tanα) (the default suite's axes), every cell simulated
   (no adaptive refinement), timed from the call to the written map; maps per second, cells per
   second and world-steps per second; scored against the reference map of the same grid
   (``rockbench score``'s metrics).
4. ``parity`` (``--parity``): CPU MuJoCo on the same model, free-rocking η and one small map,
   cell for cell.

It measures and prints; it never passes or fails on time.

Usage::

    python tests/measurements/bench_mujoco_warp.py [--device auto|cpu|cuda] [--sizes 11 51 201]
        [--block B3M] [--pulse sine] [--steps-worlds 64 1024] [--parity] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from rockbench.benchmark.maps.grid import Axis, MapSpec
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.benchmark.scoring.metrics import score
from rockbench.benchmark.store.loading import load_entry
from rockbench.engines.contract import Case
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.model import G
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution, housner_eta
from rockbench.engines.calibration.free_rocking import measure_restitution
from rockbench.engines.calibration.routine import calibrate

W_AXIS = (1.0, 16.0)     # the default suite's axes
A_AXIS = (1.0, 12.0)


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _case(block, kind, w, a):
    return Case(block, make_pulse(kind, a * G * math.tan(block.alpha_rad), w * block.p_rad_s))


def measure_steps(ad, block, kind: str, nworld: int, nsteps: int) -> dict:
    """The engine alone: ``nworld`` worlds (a spread of pulses) stepped ``nsteps`` steps."""
    from rockbench.engines.adapters.mujoco import MujocoAdapter  # noqa: F401 - the builder
    p = ad.resolve(block, Restitution("housner"), None)
    bm = ad._build(block, p, ad.fixed_dt_s)
    rng = np.random.default_rng(0)
    pulses = [make_pulse(kind, a * G * math.tan(block.alpha_rad), w * block.p_rad_s)
              for w, a in zip(rng.uniform(*W_AXIS, nworld), rng.uniform(*A_AXIS, nworld))]
    ad._run_batch(bm, pulses[:2], None, n_steps=ad._seg_steps(bm))     # graph and kernels ready
    t0 = time.perf_counter()
    ad._run_batch(bm, pulses, None, n_steps=nsteps)
    wall = time.perf_counter() - t0
    return {"nworld": nworld, "steps": nsteps, "wall_s": wall, "world_steps_per_s": nworld * nsteps / wall}


def map_spec(block_name: str, kind: str, n: int, engine: str, settings: dict) -> MapSpec:
    blk = PRESETS[block_name].block()
    return MapSpec(blk, kind, Restitution("housner"), Axis("w_ratio", *W_AXIS, n), Axis("a_ratio", *A_AXIS, n),
                   engine=engine, engine_settings=dict(settings))


def run_one_map(block_name, kind, n, engine, settings, out_dir: Path) -> dict:
    """One whole map as ``rockbench map`` computes it, timed from the call to the written map (the
    executor is made here only to read the adapter's world-step count afterwards)."""
    from rockbench.benchmark.maps.executors import make_executor
    spec = map_spec(block_name, kind, n, engine, settings)
    t0 = time.perf_counter()
    ex = make_executor(engine, settings)
    res = run_map(spec, out_dir, progress=False, executor=ex)
    wall = time.perf_counter() - t0
    r = {"n": n, "cells": n * n, "wall_s": wall, "maps_per_s": 1.0 / wall, "cells_per_s": n * n / wall,
         "failed": int(len(res.failures))}
    ad = getattr(ex, "adapter", None)
    if ad is not None and getattr(ad, "world_steps_run", 0):
        r["world_steps"] = int(ad.world_steps_run)
        r["world_steps_per_s"] = ad.world_steps_run / wall
        r["stepping_s"] = ad.stepping_s
        r["trajectories_and_judge_s"] = ad.judging_s
    ex.close()
    return r


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", default="auto")
    ap.add_argument("--settings", default="calibrated", choices=["calibrated", "shipped"],
                    help="the adapter's mode: calibrated to Housner's η, or MuJoCo's shipped contact")
    ap.add_argument("--sizes", type=int, nargs="+", default=[11, 51])
    ap.add_argument("--block", default="B3M")
    ap.add_argument("--pulse", default="sine")
    ap.add_argument("--steps-worlds", type=int, nargs="*", default=[64, 1024])
    ap.add_argument("--nsteps", type=int, default=2000)
    ap.add_argument("--parity", action="store_true", help="also CPU MuJoCo: free-rocking η and the first map size")
    ap.add_argument("--no-reference", action="store_true", help="skip the reference maps and the scores")
    ap.add_argument("--also", nargs="*", default=[], metavar="BLOCK:PULSE:N",
                    help="more maps after the size sweep, e.g. B6M:cosine:51")
    ap.add_argument("--out", default=None, help="folder for results.json and results.md")
    args = ap.parse_args(argv)

    import mujoco
    import mujoco_warp
    import warp

    out = {"script": "tests/measurements/bench_mujoco_warp.py", "argv": sys.argv[1:],
           "utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
           "machine": {"platform": platform.platform(), "python": platform.python_version(),
                       "cpus": os.cpu_count(), "loadavg": os.getloadavg()},
           "versions": {"mujoco": mujoco.__version__, "mujoco_warp": mujoco_warp.__version__,
                        "warp": warp.__version__, "numpy": np.__version__}}
    blk = PRESETS[args.block].block()
    t0 = time.perf_counter()
    settings = {"device": args.device}
    if args.settings != "calibrated":
        settings["settings"] = args.settings
    out["settings"] = settings
    ad = get_adapter("mujoco_warp", **settings)
    dev = ad.device_name()
    out["device"] = dev
    if dev.startswith("cuda"):
        out["machine"]["gpu"] = warp.get_device(dev).name
    _log(f"device {dev}")
    # first kernel load: compile on a cold cache, else read from the kernel cache
    t1 = time.perf_counter()
    ad.run_many([_case(blk, args.pulse, 6.0, 0.8)])
    first = time.perf_counter() - t1
    out["setup"] = {"adapter_and_warp_init_s": t1 - t0, "first_run_incl_kernel_load_and_calibration_s": first}
    if args.settings == "calibrated":
        cal = calibrate(ad, blk, housner_eta(blk.alpha_rad))
        out["setup"]["calibration"] = cal.to_dict()
        _log(f"setup {first:.1f} s; calibration η {cal.eta_measured:.4f} vs {cal.eta_target:.4f} "
             f"({100 * cal.rel_error:+.2f} %)")
    out["free_rocking"] = {}
    for name in ("B3M", "B6M"):
        b = PRESETS[name].block()
        m = measure_restitution(ad, b)
        out["free_rocking"][name] = {"eta_housner": housner_eta(b.alpha_rad), "eta_mean": m.eta_mean,
                                     "eta_std": m.eta_std, "impacts": len(m.etas), "settings": m.settings}
        _log(f"free rocking {name} ({args.settings}): η {m.eta_mean:.4f} ± {m.eta_std:.4f} over {len(m.etas)} "
             f"impacts, η_H {housner_eta(b.alpha_rad):.4f}")
    out["steps"] = []
    for nw in args.steps_worlds:
        r = measure_steps(ad, blk, args.pulse, nw, args.nsteps)
        out["steps"].append(r)
        _log(f"steps: {nw} worlds × {args.nsteps} steps in {r['wall_s']:.2f} s = {r['world_steps_per_s']:.3g} world-steps/s")

    out["maps"] = []
    jobs = [(args.block, args.pulse, n) for n in args.sizes]
    for spec in args.also:
        b, k, n = spec.split(":")
        jobs.append((b, k, int(n)))
    with tempfile.TemporaryDirectory() as tmp:
        for block_name, kind, n in jobs:
            d = Path(tmp) / f"warp-{block_name}-{kind}-{n}"
            r = run_one_map(block_name, kind, n, "mujoco_warp", settings, d)
            r.update(block=block_name, pulse=kind)
            _log(f"map {block_name} {kind} {n}×{n}: {r['wall_s']:.2f} s ({r['cells_per_s']:.0f} cells/s), failed {r['failed']}")
            if not args.no_reference:
                rd = Path(tmp) / f"ref-{block_name}-{kind}-{n}"
                rr = run_one_map(block_name, kind, n, "reference", {}, rd)
                s = score(load_entry(d).map, load_entry(rd).map)
                r["reference_wall_s"] = rr["wall_s"]
                r["score"] = {k: s[k] for k in ("agreement", "overturn_agreement", "iou_overturn", "boundary_mean",
                                                "spurious_invalid", "failed_cells", "consistency")}
                _log(f"  against the reference: agreement {s['agreement']:.4f}, overturn {s['overturn_agreement']:.4f}")
            if args.parity and (block_name, kind, n) == jobs[0]:
                cd = Path(tmp) / f"cpu-{n}"
                rc = run_one_map(block_name, kind, n, "mujoco", {}, cd)
                ew, ec = load_entry(d).map, load_entry(cd).map
                same = float(np.mean(ew.outcome == ec.outcome))
                r["parity_cpu_mujoco"] = {"wall_s": rc["wall_s"], "same_outcome": same,
                                          "score_vs_cpu": {k: v for k, v in score(ew, ec).items()
                                                           if k in ("agreement", "overturn_agreement")}}
                _log(f"  CPU MuJoCo on the same grid: {100 * same:.1f} % of cells the same outcome")
            out["maps"].append(r)

    if args.parity:
        cpu = get_adapter("mujoco")
        par = {}
        for name in ("B3M", "B6M"):
            b = PRESETS[name].block()
            mw = measure_restitution(ad, b)
            mc = measure_restitution(cpu, b)
            # the same contact in both: MuJoCo Warp at the CPU engine's calibrated solref
            same = measure_restitution(get_adapter("mujoco_warp", device=args.device, timeconst_s=mc.settings["timeconst"],
                               dampratio=mc.settings["dampratio"]), b)
            par[name] = {"eta_housner": housner_eta(b.alpha_rad), "warp": [mw.eta_mean, mw.eta_std, len(mw.etas)],
                         "cpu": [mc.eta_mean, mc.eta_std, len(mc.etas)],
                         "warp_at_cpu_settings": [same.eta_mean, same.eta_std, len(same.etas)],
                         "warp_settings": {k: mw.settings[k] for k in ("timeconst", "dampratio")},
                         "cpu_settings": {k: mc.settings[k] for k in ("timeconst", "dampratio")}}
            _log(f"free rocking {name}: warp η {mw.eta_mean:.4f} ± {mw.eta_std:.4f}, cpu η {mc.eta_mean:.4f} ± "
                 f"{mc.eta_std:.4f}, warp at the cpu's solref {same.eta_mean:.4f}, η_H {housner_eta(b.alpha_rad):.4f}")
        out["parity_free_rocking"] = par

    text = json.dumps(out, indent=2, default=float)
    print(text)
    if args.out:
        o = Path(args.out)
        o.mkdir(parents=True, exist_ok=True)
        (o / "results.json").write_text(text)
        lines = [f"# bench_mujoco_warp {out['utc']} on {dev} ({out['machine'].get('gpu', platform.processor())})", "",
                 "| map | cells | wall [s] | stepping [s] | judge [s] | cells/s | agreement | overturn agreement | failed |",
                 "|---|---|---|---|---|---|---|---|---|"]
        for r in out["maps"]:
            s = r.get("score", {})
            lines.append(f"| {r['block']} {r['pulse']} {r['n']}×{r['n']} | {r['cells']} | {r['wall_s']:.2f} | "
                         f"{r.get('stepping_s', float('nan')):.2f} | {r.get('trajectories_and_judge_s', float('nan')):.2f} | "
                         f"{r['cells_per_s']:.0f} | "
                         f"{s.get('agreement', float('nan')):.4f} | {s.get('overturn_agreement', float('nan')):.4f} | "
                         f"{r['failed']} |")
        lines += ["", "| worlds | steps | wall [s] | world-steps/s |", "|---|---|---|---|"]
        for r in out["steps"]:
            lines.append(f"| {r['nworld']} | {r['steps']} | {r['wall_s']:.2f} | {r['world_steps_per_s']:.3g} |")
        (o / "results.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
