"""Could an engine run stop once the block has settled after the pulse, before the minimum tail ends
? Measures and prints; it passes or fails nothing.

    python tests/measurements/probes/probe_settle_stop.py [--cells N] [--json FILE]

For N cells per engine variant (the four blocks, sine and cosine, ω/p and a₀/(g·tanα) drawn at
random over the default suite's grid), each run as the adapter runs it today, the candidate rule
"settled" is tested on its samples: after the pulse, |θ| at most the uplift tolerance (2 % of α) and
the rigid energy too low to tilt the block past it. Printed: in how many runs it fires before the
run ends today, in how many of those the block later rises past the tolerance again (the rule would
have changed the run's verdict inputs there), and the share of the simulated time it would save
(Exudyn checks its stop rule every 0.05 s, so its stop is rounded up to that).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from rockbench.benchmark.api import request_of
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.validity import uplift_tol_rad

VARIANTS = (("exudyn", "calibrated", 0.05), ("exudyn", "shipped", 0.05), ("pybullet", "calibrated", 0.0),
            ("pybullet", "shipped", 0.0), ("mujoco", "calibrated", 0.0))


def probe(engine: str, settings: str, granularity_s: float, n: int) -> dict:
    rng = np.random.default_rng(5)
    total = saved = 0.0
    fired = rose_again = 0
    for k in range(n):
        block, pulse = ("B3M", "B6M", "B3L", "B6L")[k % 4], ("sine", "cosine")[(k // 4) % 2]
        ns = request_of(block, engine=engine, settings=settings, pulse=pulse, w_ratio=rng.uniform(1, 16),
                        a_ratio=rng.uniform(1, 12))
        case = ns.case()[0]
        tr = get_adapter(engine, **ns.engine_settings()).simulate(case)
        t, th, thd = tr.t_s, tr.theta_rad, tr.theta_dot_rad_s
        b = case.block
        a, p, tol = b.alpha_rad, b.p_rad_s, uplift_tol_rad(b)
        total += t[-1]
        energy = 0.5 * thd ** 2 + p ** 2 * np.cos(a - np.abs(th))
        ok = (t >= tr.t_pulse_end_s) & (np.abs(th) <= tol) & (energy <= p ** 2 * math.cos(a - tol))
        if ok.any():
            i = int(np.argmax(ok))
            ts = math.ceil(t[i] / granularity_s - 1e-9) * granularity_s if granularity_s else t[i]
            if ts < t[-1]:
                fired += 1
                saved += t[-1] - ts
                rose_again += bool(np.any(np.abs(th[i:]) > tol))
    return {"engine": engine, "settings": settings, "cells": n, "fired": fired, "rose_again": rose_again,
            "time_saved": saved / total}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=40)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    rows = []
    for engine, settings, gran in VARIANTS:
        r = probe(engine, settings, gran, args.cells)
        rows.append(r)
        print(f"{engine:8} {settings:10} {r['cells']} runs: settled before the end in {r['fired']}, rose past the "
              f"tolerance again in {r['rose_again']}; {100 * r['time_saved']:.1f} % of the simulated time saved", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
