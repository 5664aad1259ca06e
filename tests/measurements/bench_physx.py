"""Benchmark of the PhysX adapter: which knobs move free-rocking η, the calibration, cost per cell, slip.

Measures and prints; it passes or fails on nothing (timings depend on the machine and its load).

Usage (from the repository's top folder, in the venv, with ``pip install -e '.[physx]'``)::

    python tests/measurements/bench_physx.py eta [B3M B6L]    # η against step, substeps, solver, iterations, offset, restitution
    python tests/measurements/bench_physx.py calibrate        # the calibration to η_H of the four Table 1 blocks
    python tests/measurements/bench_physx.py cost             # CPU ms per cell, as shipped and calibrated, both drives
    python tests/measurements/bench_physx.py creep            # the pivot corner's slip at friction 10, TGS and PGS
    python tests/measurements/bench_physx.py batch            # CPU ms per cell of 16 B3M sine cells through run_many
    python tests/measurements/bench_physx.py worlds           # calibrated CPU per cell and per block-step by worlds per scene
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from rockbench.engines.adapters.physx import SHIPPED_DT_S
from rockbench.engines.registry import get_adapter
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.reference_solver.model import a_ratio_to_amplitude, w_ratio_to_omega
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution, housner_eta
from rockbench.engines.contract import Case

#: (label, settings, Δt [s] or None for the adapter's 0.5 ms): one knob changed from PhysX as shipped
KNOBS = ([("as shipped", {}, None)]
         + [(f"Δt {dt * 1e3:g} ms", {}, dt) for dt in (SHIPPED_DT_S, 2e-3, 1e-3, 2e-4, 1e-4)]
         + [(f"substeps {n}", {"substeps": n}, None) for n in (2, 3, 4, 6, 8, 12, 16)]
         + [("PGS", {"solver": "pgs"}, None), ("PGS, Δt 0.1 ms", {"solver": "pgs"}, 1e-4)]
         + [(f"position iterations {n}", {"position_iterations": n}, None) for n in (1, 4, 50)]
         + [(f"velocity iterations {n}", {"velocity_iterations": n}, None) for n in (0, 4, 20)]
         + [(f"contact offset {c * 1e3:g} mm", {"contact_offset_m": c}, None) for c in (1e-4, 1e-3, 0.05)]
         + [(f"restitution {e}", {"contact_restitution": e}, None) for e in (0.5, 1.0)]
         + [(f"restitution {e}, bounce threshold 0.01 m/s", {"contact_restitution": e, "bounce_threshold_m_s": 0.01},
             None) for e in (0.2, 0.5)])

#: cells the cost is measured on (block, pulse, ω/p, a₀/(g·tanα)): rocking, rest and overturn
CELLS = [("B3M", "sine", 8.0, 2.0), ("B3M", "sine", 5.0, 0.7), ("B3M", "sine", 2.0, 2.0), ("B6L", "sine", 4.0, 3.0),
         ("B6L", "cosine", 8.0, 3.0), ("B6L", "cosine", 3.0, 3.0)]


def _case(name: str, pulse: str, w: float, a: float) -> Case:
    b = get_preset(name).block()
    return Case(b, make_pulse(pulse, a_ratio_to_amplitude(b, a), w_ratio_to_omega(b, w)), Restitution(), None)


def _stamp() -> str:
    return f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load {os.getloadavg()[0]:.1f}"


def cmd_eta(args) -> None:
    """Free-rocking η (release from α/2, four impacts) with one knob changed from PhysX as shipped."""
    print(_stamp(), file=sys.stderr)
    print("| block | knob | η (per-impact spread) | impacts | vs η_H |")
    print("|---|---|---|---|---|")
    for name in args.blocks:
        block = get_preset(name).block()
        eta_h = housner_eta(block.alpha_rad)
        for label, settings, dt in KNOBS:
            m = get_adapter("physx", settings="shipped", **settings).measure_restitution(block, dt_s=dt)
            print(f"| {name} | {label} | {m.eta_mean:.4f} ± {m.eta_std:.4f} | {len(m.etas)} | "
                  f"{100 * (m.eta_mean / eta_h - 1):+.1f} % |")


def cmd_calibrate(args) -> None:
    """The calibration to η_H at the adapter's step (no cache), its pick and its CPU time."""
    print(_stamp(), file=sys.stderr)
    print("| block | η_H | substeps | η measured | error | evaluations | CPU [s] |")
    print("|---|---|---|---|---|---|---|")
    for name in ("B3M", "B6M", "B3L", "B6L"):
        block = get_preset(name).block()
        c0 = time.process_time()
        res = get_adapter("physx").calibrate(block, housner_eta(block.alpha_rad), use_cache=False)
        print(f"| {name} | {res.eta_target:.4f} | {res.settings['substeps']} | {res.eta_measured:.4f} ± "
              f"{res.eta_std:.4f} | {100 * res.rel_error:+.2f} % | {res.evaluations} | {time.process_time() - c0:.2f} |")


def cmd_cost(args) -> None:
    """CPU milliseconds per cell on :data:`CELLS` (calibration done before the clock starts)."""
    print(_stamp(), file=sys.stderr)
    print("| variant | drive | cells | CPU ms per cell | PhysX steps per CPU second |")
    print("|---|---|---|---|---|")
    for settings in ("shipped", "calibrated"):
        for drive in ("inertial", "table"):
            ad = get_adapter("physx", settings=settings, drive=drive)
            for c in CELLS:
                ad.simulate(_case(*c))
            cpu = steps = 0.0
            for _ in range(args.repeat):
                for c in CELLS:
                    tr = ad.simulate(_case(*c))
                    cpu += tr.diagnostics["cpu_s"]
                    steps += tr.diagnostics["steps"] * tr.diagnostics["substeps"]
            n = args.repeat * len(CELLS)
            print(f"| {settings} | {drive} | {n} | {1e3 * cpu / n:.1f} | {steps / cpu:,.0f} |")


def cmd_creep(args) -> None:
    """The validity rule's largest corner slip [mm] and flags, TGS as shipped against PGS, on B3M sine cells
    inside the rigid model's domain (the reference needs no lift or slip) and two outside it."""
    print(_stamp(), file=sys.stderr)
    cells = [("B3M", "sine", w, a) for w, a in ((4.75, 7.1875), (8.5, 7.875), (9.4375, 7.875), (10.375, 7.875),
                                                  (8.5, 8.5625), (12.0, 10.0), (16.0, 10.0))]
    variants = [("TGS (shipped)", {"settings": "shipped"}), ("PGS", {"settings": "shipped", "solver": "pgs"}),
                ("calibrated (PGS, substeps)", {})]
    ref = get_adapter("reference")
    print("| cell (ω/p, a₀/(g·tanα)) | reference needs | " + " | ".join(v for v, _ in variants) + " |")
    print("|---|---|" + "---|" * len(variants))
    for c in cells:
        out = []
        for _, settings in variants:
            r = get_adapter("physx", **settings).run(_case(*c))
            out.append(f"{r.outcome}{' (' + ', '.join(r.flags) + ')' if r.flags else ''}, "
                       f"{1e3 * r.diagnostics['max_slip_m']:.2f}")
        need = ", ".join(ref.run(_case(*c)).flags) or "nothing"
        print(f"| B3M sine {c[2]:g}, {c[3]:g} | {need} | " + " | ".join(out) + " |")


#: the 16 cells of ``batch``: B3M sine, ω/p 2, 6, 10, 14 × a₀/(g·tanα) 1.5, 3, 6, 10 (rest, rocking, overturn)
BATCH_CELLS = [("B3M", "sine", w, a) for w in (2.0, 6.0, 10.0, 14.0) for a in (1.5, 3.0, 6.0, 10.0)]


def cmd_batch(args) -> None:
    """CPU ms per cell of :data:`BATCH_CELLS` through ``run_many`` (the map sweep's entry), calibrated and as
    shipped, the calibration made before the clock starts; the fastest of ``--repeat`` calls."""
    print(_stamp(), file=sys.stderr)
    cases = [_case(*c) for c in BATCH_CELLS]
    print("| variant | CPU ms per cell | outcomes (overturn / rocking / rest) |")
    print("|---|---|---|")
    for label, settings in (("calibrated", {}), ("as shipped", {"settings": "shipped"})):
        ad = get_adapter("physx", **settings)
        ad.run(cases[0])   # the calibration, cached
        best, out = float("inf"), []
        for _ in range(args.repeat):
            c0 = time.process_time()
            out = ad.run_many(cases)
            best = min(best, time.process_time() - c0)
        n = {k: sum(r.outcome == k for r in out) for k in ("overturn", "rocking", "rest")}
        print(f"| {label} | {1e3 * best / len(cases):.2f} | {n['overturn']} / {n['rocking']} / {n['rest']} |")


def cmd_worlds(args) -> None:
    """Calibrated CPU per cell and per block-step of :data:`BATCH_CELLS` twice over (32 cells) through
    ``run_many``, with the adapter's ``max_worlds`` set to each of 1, 4, 8, 16, 32."""
    print(_stamp(), file=sys.stderr)
    cases = [_case(*c) for c in BATCH_CELLS] * 2
    ad = get_adapter("physx")
    ad.run(cases[0])   # the calibration, cached
    print("| worlds per scene | CPU ms per cell | CPU µs per block-step |")
    print("|---|---|---|")
    for k in (1, 4, 8, 16, 32):
        ad.max_worlds = k
        best, out = float("inf"), []
        for _ in range(args.repeat):
            c0 = time.process_time()
            out = ad.run_many(cases)
            best = min(best, time.process_time() - c0)
        steps = sum(r.diagnostics["steps"] for r in out)
        print(f"| {k} | {1e3 * best / len(cases):.2f} | {1e6 * best / steps:.1f} |")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("eta")
    e.add_argument("blocks", nargs="*", default=["B3M", "B6L"])
    e.set_defaults(func=cmd_eta)
    sub.add_parser("calibrate").set_defaults(func=cmd_calibrate)
    c = sub.add_parser("cost")
    c.add_argument("--repeat", type=int, default=3)
    c.set_defaults(func=cmd_cost)
    sub.add_parser("creep").set_defaults(func=cmd_creep)
    b = sub.add_parser("batch")
    b.add_argument("--repeat", type=int, default=3)
    b.set_defaults(func=cmd_batch)
    w = sub.add_parser("worlds")
    w.add_argument("--repeat", type=int, default=2)
    w.set_defaults(func=cmd_worlds)
    args = p.parse_args(argv)
    args.func(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
