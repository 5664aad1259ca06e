"""Benchmark of the DART adapter: engine steps per second, free-rocking η, and maps against the reference.

Measures and prints; it passes or fails on nothing (timings depend on the machine and its load).

Usage (from the repository's top folder, in the venv, with ``pip install -e '.[dart]'``)::

    python tests/measurements/bench_dart.py steps                  # steps per second, one process, four models
    python tests/measurements/bench_dart.py eta                    # free-rocking η of B3M and B6M at three time steps
    python tests/measurements/bench_dart.py restitution            # what DART's restitution coefficient does to η
    python tests/measurements/bench_dart.py maps --out DIR [--jobs 2] [--maps B3M:sine,B6M:cosine] [--drive table]
                                                           # maps on the default suite's grid, then a summary
    python tests/measurements/bench_dart.py summary DIR            # cells, worker time, agreement with the reference

``maps`` and ``summary`` are Drake's (``tests/measurements/bench_drake.py``) with the engine set to ``dart``.
"""

from __future__ import annotations

import argparse
import math
import os
import sys

import bench_drake
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.model import Block
from rockbench.reference_solver.restitution import Restitution, housner_eta
from rockbench.engines.calibration.free_rocking import measure_restitution

#: the cells the speed is measured on (block, pulse, ω/p, a₀/(g·tanα)): rocking, overturn and rest
CELLS = [("B3M", "sine", 4.0, 3.0), ("B6M", "cosine", 3.0, 2.0), ("B3M", "sine", 2.0, 1.5), ("B6M", "sine", 6.0, 3.0)]


def cmd_steps(args) -> None:
    """Engine steps per second (wall and CPU) in one process, on the adapter's own loop (world reused)."""
    print(bench_drake._stamp(), file=sys.stderr)
    models = [("planar, inertial (default)", {}), ("planar, table drive", {"drive": "table"}),
              ("free body, inertial", {"planar": False}), ("free body, table drive", {"planar": False, "drive": "table"})]
    print("| model | steps | steps per wall second | steps per CPU second | load |")
    print("|---|---|---|---|---|")
    for label, settings in models:
        ad = get_adapter("dart", **settings)
        for c in CELLS:
            ad.simulate(bench_drake._case(*c))  # calibration and world built, not timed
        steps = wall = cpu = 0.0
        for _ in range(args.repeat):
            for c in CELLS:
                d = ad.simulate(bench_drake._case(*c)).diagnostics
                steps, wall, cpu = steps + d["steps"], wall + d["wall_s"], cpu + d["cpu_s"]
        print(f"| {label} | {int(steps)} | {steps / wall:,.0f} | {steps / cpu:,.0f} | {os.getloadavg()[0]:.1f} |")


def cmd_eta(args) -> None:
    """Free-rocking η of B3M and B6M, planar and free, at Δt = 1, 0.5 and 0.25 ms, DART as shipped."""
    print(bench_drake._stamp(), file=sys.stderr)
    print("| block | model | Δt [s] | η measured (per-impact spread) | η_H | relative error |")
    print("|---|---|---|---|---|---|")
    for name in ("B3M", "B6M"):
        block = get_preset(name).block()
        eta_h = housner_eta(block.alpha_rad)
        for planar in (True, False):
            for dt in (1e-3, 5e-4, 2.5e-4):
                m = measure_restitution(get_adapter("dart", planar=planar, settings="shipped"), block, dt_s=dt)
                print(f"| {name} | {'planar' if planar else 'free'} | {dt:g} | {m.eta_mean:.4f} ± {m.eta_std:.4f} | "
                      f"{eta_h:.4f} | {100 * (m.eta_mean - eta_h) / eta_h:+.2f} % |")


def landing_speed_m_s(block: Block, theta0_frac: float) -> float:
    """The speed [m/s] at which the landing corner of a rigid block released from rest at
    ``theta0_frac·α`` reaches the table: ``b·θ̇₀``, with ``θ̇₀ = p·√(2(cos(α − θ0) − cos α))`` the
    free-rocking energy's angular speed at θ = 0."""
    a = block.alpha_rad
    return block.width_m * block.p_rad_s * math.sqrt(2.0 * (math.cos(a - theta0_frac * a) - math.cos(a)))


def cmd_restitution(args) -> None:
    """η and the highest hop (both bottom corners off the table) of free rocking with DART's restitution
    coefficient e (the table's is 1): B3M, B6M and a large block (0.4 m × 0.8 m) whose corners land
    faster than 0.1 m/s/e."""
    print(bench_drake._stamp(), file=sys.stderr)
    print("| block | first landing speed [m/s] | e | η measured (per-impact spread) | highest hop (lower corner) [mm] |")
    print("|---|---|---|---|---|")
    blocks = [get_preset("B3M").block(), get_preset("B6M").block(), Block(0.4, 0.8, mass_kg=100.0, name="0.4 × 0.8 m")]
    for block in blocks:
        theta0, v_land = 0.5 * block.alpha_rad, landing_speed_m_s(block, 0.5)
        for e in (0.0, 0.25, 0.5, 0.75, 1.0):
            ad = get_adapter("dart", contact_restitution=e)
            s = ad.resolve(block, Restitution())
            m = measure_restitution(ad, block, settings=s)
            tr, _ = ad.run_worlds(block, s, ad.fixed_dt_s, [None], theta0, 1.0)[0]
            hop = max(float(tr.corner_z_m.min(axis=1).max()), 0.0)
            print(f"| {block.name} | {v_land:.3f} | {e:g} | {m.eta_mean:.4f} ± {m.eta_std:.4f} | {1e3 * hop:.3f} |")


def cmd_maps(args) -> None:
    """``bench_drake.py maps`` with the engine ``dart`` (and ``--set drive=...``)."""
    bench_drake.ENGINE_ARGS = ["--engine", "dart"] + (["--set", f"drive={args.drive}"] if args.drive else [])
    bench_drake.cmd_maps(args)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("steps")
    s.add_argument("--repeat", type=int, default=3)
    s.set_defaults(func=cmd_steps)
    sub.add_parser("eta").set_defaults(func=cmd_eta)
    sub.add_parser("restitution").set_defaults(func=cmd_restitution)
    m = sub.add_parser("maps")
    m.add_argument("--out", required=True)
    m.add_argument("--jobs", type=int, default=2)
    m.add_argument("--maps", default="B3M:sine,B6M:cosine")
    m.add_argument("--settings", default="calibrated", choices=["calibrated", "shipped"])
    m.add_argument("--drive", choices=["inertial", "table"])
    m.set_defaults(func=cmd_maps)
    r = sub.add_parser("summary")
    r.add_argument("dir")
    r.set_defaults(func=bench_drake.cmd_summary)
    args = p.parse_args(argv)
    args.func(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
