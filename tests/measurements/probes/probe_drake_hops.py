"""Why does calibrated Drake flag cells where the rigid model is valid (409 "spurious
invalid" cells in the full suite, almost all under the cosine pulse)? Measures and prints; it passes
or fails nothing.

    python tests/measurements/probes/probe_drake_hops.py [--cells N] [--json FILE]

For N cells per block and pulse (B3M and B6L, sine and cosine; ω/p and a₀/(g·tanα) drawn at random
over the default suite's grid) the reference and calibrated Drake are run. Kept are the cells whose
reference trajectory is valid and has an impact; for those, the reference's angular velocity just
before its first impact (over p) is compared between the cells Drake flags and those it does not,
and for each flagged cell the first flagged sample is placed against Drake's own impacts: a hop
right after an impact shows as both corners above the rest level with θ̇ constant (free flight).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import rockbench.benchmark as rb
from rockbench.reference_solver.validity import jump_tol_m, slip_tol_m


def first_flag_s(sim) -> float | None:
    """Time of the first sample the validity rule would flag (slip or jump), from Drake's corners."""
    tr = sim._trajectory
    b = sim.case.block
    z = tr.corner_z_m - np.min(tr.corner_z_m[0])
    x = tr.corner_x_m
    slip = np.where(z <= jump_tol_m(b), np.abs(x - x[0]), 0.0).max(axis=1) > slip_tol_m(b)
    jump = np.min(z, axis=1) > jump_tol_m(b)
    k = np.nonzero(slip | jump)[0]
    return float(tr.t_s[k[0]]) if k.size else None


def probe(block: str, pulse: str, n: int, rng) -> dict:
    flagged, valid, after_impact = [], [], []
    for _ in range(n):
        w, a = float(rng.uniform(1, 16)), float(rng.uniform(1, 12))
        ref = rb.simulate(block, pulse=pulse, w_ratio=w, a_ratio=a)
        if not ref.valid or ref.n_impacts < 1:
            continue
        v = float(np.interp(ref.impacts_s[0] - 1e-9, ref.t_s, np.abs(ref.theta_dot_rad_s))) / ref.p_rad_s
        sim = rb.simulate(block, engine="drake", settings="calibrated", pulse=pulse, w_ratio=w, a_ratio=a)
        if sim.valid:
            valid.append(v)
            continue
        flagged.append(v)
        t1 = first_flag_s(sim)
        imp = sim.impacts_s[sim.impacts_s <= t1] if t1 is not None else np.zeros(0)
        after_impact.append(None if t1 is None or imp.size == 0 else t1 - float(imp[-1]))

    def stats(x):
        x = np.asarray(x, float)
        return {"n": int(x.size), **({"median": float(np.median(x)), "p10": float(np.percentile(x, 10)),
                                     "p90": float(np.percentile(x, 90))} if x.size else {})}

    dt = [d for d in after_impact if d is not None]
    return {"block": block, "pulse": pulse, "flagged": stats(flagged), "valid": stats(valid),
            "flag_after_an_impact": len(dt), "flag_before_any_impact": len(after_impact) - len(dt),
            "s_after_impact": stats(dt)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=150)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(17)
    rows = []
    for block in ("B3M", "B6L"):
        for pulse in ("sine", "cosine"):
            r = probe(block, pulse, args.cells, rng)
            rows.append(r)

            def fmt(s):
                return f"{s['n']} (|θ̇⁻|/p median {s['median']:.2f}, 10-90 % {s['p10']:.2f}-{s['p90']:.2f})" if s["n"] \
                    else "0"
            print(f"{block} {pulse}: reference valid with an impact: Drake flags {fmt(r['flagged'])}, valid "
                  f"{fmt(r['valid'])}; first flag after an impact in {r['flag_after_an_impact']}"
                  + (f" ({1e3 * r['s_after_impact']['median']:.1f} ms after it, median)" if r['flag_after_an_impact'] else "")
                  + f", before any in {r['flag_before_any_impact']}", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
