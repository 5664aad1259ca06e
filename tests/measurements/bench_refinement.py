"""Fewer simulations per adaptive map? A boundary tracer against the block-wise refinement
(benchmark/maps/adaptive.py), replayed on full grids. Measures and prints; it passes or fails nothing.

    python tests/measurements/bench_refinement.py [--engine-maps DIR ...] [--json FILE]

Both refinements are replayed on maps computed in full (every cell simulated), so each one's
result can be compared with the truth cell by cell at no cost:

- the reference maps of the default suite (51 × 51: four blocks × sine and cosine × Housner, the
  modified η with average and exact k), computed here, and 120 more per grid (three pulses × ten
  constant η) at 31 × 31, 51 × 51, 100 × 100 and 200 × 200;
- engine maps given with ``--engine-maps`` (run directories of ``rockbench map`` *without*
  ``--adaptive``, or folders holding them), e.g. the default suite's grid for one engine::

      rockbench map --engine mujoco --block B3M --pulse cosine --w-ratio 1:16:51 --a-ratio 1:12:51 \\
          --out full/mujoco/B3M-cosine --no-plot

The tracer (:func:`trace`) simulates the same coarse nodes (stride 4), then the cells between
two coarse nodes of different regimes, then follows every boundary: for each pair of 4-adjacent
simulated cells of different regimes, the cells beside them along the boundary and ``width − 1``
more on each side across it; where a simulated cell shares its regime with none of its simulated
4-neighbours (noise, a dotted band) the stride-4 blocks around it (``halo`` blocks on each side;
−1: none) are simulated whole; last, every unsimulated region whose simulated border shows more than
one regime is refined around its minority cells. Regions are then filled with their border's regime.

What was found (docs/speed.md has the tables): on reference maps the plain tracer (width 1, no
blocks) is exact with 45 % fewer simulations at 51 × 51; on engine maps it misses isolated cells
(an overturn among rocking cells two or three cells from a boundary) that the block-wise
refinement finds because it simulates whole blocks; the variants that miss nothing the blocks find
on the engine maps measured save only 13–15 % of the simulations.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from rockbench.benchmark.maps import adaptive
from rockbench.benchmark.maps.grid import MapSpec, parse_range
from rockbench.benchmark.maps.result import MISSING
from rockbench.benchmark.store.loading import load_map
from rockbench.benchmark.blocks.presets import PRESETS, get_preset
from rockbench.benchmark.suites.model import restitution_for
from rockbench.benchmark.errors import IncomparableError
from rockbench.reference_solver.restitution import Restitution
from rockbench.reference_solver.solver import solve_batch

N4 = ((-1, 0), (1, 0), (0, -1), (0, 1))
N8 = N4 + ((-1, -1), (-1, 1), (1, -1), (1, 1))

#: tracer variants replayed: name → (width, halo)
VARIANTS = {"trace": (1, -1), "trace+blocks0": (1, 0), "trace+blocks1": (1, 1), "trace-w2": (2, -1),
            "trace-w2+blocks0": (2, 0), "trace-w2+blocks1": (2, 1), "trace-w3+blocks0": (3, 0),
            "trace-w3+tips0": (3, 0, 1)}


def _shift(a, di, dj, fill):
    ny, nx = a.shape
    out = np.full_like(a, fill)
    out[max(di, 0):ny + min(di, 0), max(dj, 0):nx + min(dj, 0)] = \
        a[max(-di, 0):ny + min(-di, 0), max(-dj, 0):nx + min(-dj, 0)]
    return out


def _dilate(mask, nbrs=N8):
    out = mask.copy()
    for di, dj in nbrs:
        out |= _shift(mask, di, dj, False)
    return out


def _along(key, sim, width):
    """Cells beside each 4-adjacent differing simulated pair along the boundary, and ``width − 1``
    more on each side across it."""
    want = np.zeros(key.shape, bool)
    v = sim[:-1] & sim[1:] & (key[:-1] != key[1:])            # pairs (i, j)–(i+1, j)
    h = sim[:, :-1] & sim[:, 1:] & (key[:, :-1] != key[:, 1:])
    vl, vu, hl, hr = (np.zeros(key.shape, bool) for _ in range(4))
    vl[:-1], vu[1:], hl[:, :-1], hr[:, 1:] = v, v, h, h
    both_v, both_h = vl | vu, hl | hr
    want |= _shift(both_v, 0, 1, False) | _shift(both_v, 0, -1, False)
    want |= _shift(both_h, 1, 0, False) | _shift(both_h, -1, 0, False)
    for d in range(1, width):
        want |= _shift(vl, -d, 0, False) | _shift(vu, d, 0, False) | _shift(hl, 0, -d, False) | _shift(hr, 0, d, False)
    return want


def _irregular(key, sim, most=0):
    """Simulated cells with two or more simulated 4-neighbours, at most ``most`` of them of their own
    regime (0: isolated cells, the dots of a dotted band; 1: also the cells and tips of lines one cell
    wide)."""
    same = np.zeros(key.shape, np.int16)
    nsim = np.zeros(key.shape, np.int16)
    for di, dj in N4:
        s2 = _shift(sim, di, dj, False)
        nsim += s2
        same += s2 & (_shift(key, di, dj, -9) == key)
    return sim & (nsim >= 2) & (same <= most)


def _regions(sim):
    from scipy import ndimage
    return ndimage.label(~sim, structure=np.ones((3, 3)))


def trace(key, sim, evaluate, stride=adaptive.DEFAULT_STRIDE, width=1, halo=-1, most=0) -> int:
    """The tracer (module docstring), with the interface of :func:`adaptive.refine`; returns rounds."""
    ny, nx = key.shape
    ri, rj = adaptive.coarse_index(ny, stride), adaptive.coarse_index(nx, stride)
    nbi, nbj = ri.size - 1, rj.size - 1
    refined = np.zeros((nbi, nbj), bool)
    rounds = 1
    evaluate([(int(i), int(j)) for i in ri for j in rj if not sim[i, j]])
    seeds = []
    for a in range(ri.size):
        for b in range(nbj):
            if key[ri[a], rj[b]] != key[ri[a], rj[b + 1]]:
                seeds += [(int(ri[a]), int(j)) for j in range(rj[b] + 1, rj[b + 1])]
    for b in range(rj.size):
        for a in range(nbi):
            if key[ri[a], rj[b]] != key[ri[a + 1], rj[b]]:
                seeds += [(int(i), int(rj[b])) for i in range(ri[a] + 1, ri[a + 1])]
    seeds = [c for c in dict.fromkeys(seeds) if not sim[c]]
    if seeds:
        evaluate(seeds)
        rounds += 1
    while True:
        todo = _along(key, sim, width) & ~sim
        if not todo.any() and halo >= 0:
            todo = np.zeros_like(sim)
            for i, j in zip(*np.nonzero(_irregular(key, sim, most))):
                for a in [b for b in range(nbi) if ri[b] <= i <= ri[b + 1]]:
                    for b in [c for c in range(nbj) if rj[c] <= j <= rj[c + 1]]:
                        for a2 in range(max(a - halo, 0), min(a + halo + 1, nbi)):
                            for b2 in range(max(b - halo, 0), min(b + halo + 1, nbj)):
                                if not refined[a2, b2]:
                                    refined[a2, b2] = True
                                    todo[ri[a2]:ri[a2 + 1] + 1, rj[b2]:rj[b2 + 1] + 1] = True
            todo &= ~sim
        if not todo.any():
            lab, n = _regions(sim)
            todo = np.zeros_like(sim)
            for r in range(1, n + 1):
                comp = lab == r
                border = _dilate(comp) & sim
                vals, counts = np.unique(key[border], return_counts=True)
                if vals.size > 1:
                    odd = border & (key != vals[np.argmax(counts)])
                    todo |= _dilate(odd) & comp
            if not todo.any():
                return rounds
        ii, jj = np.nonzero(todo)
        evaluate(list(zip(ii.tolist(), jj.tolist())))
        rounds += 1


def fill_regions(outcome, key, sim) -> None:
    """Every unsimulated region whose simulated border has one regime takes that regime's outcome."""
    lab, n = _regions(sim)
    for r in range(1, n + 1):
        comp = lab == r
        border = _dilate(comp) & sim
        if np.unique(key[border]).size == 1:
            outcome[comp] = outcome[border][0]


def replay(truth_outcome, truth_impacts, how: str):
    """Replay one refinement on a full grid: ``(inferred outcome grid, simulated mask, rounds)``."""
    key_t = adaptive.regime_key(truth_outcome, truth_impacts)
    out = np.full(truth_outcome.shape, MISSING, np.int8)
    key = np.full(truth_outcome.shape, MISSING, np.int16)
    sim = np.zeros(truth_outcome.shape, bool)

    def evaluate(cells):
        for i, j in cells:
            out[i, j], key[i, j], sim[i, j] = truth_outcome[i, j], key_t[i, j], True

    if how == "blocks":
        rounds = adaptive.refine(key, sim, evaluate, adaptive.DEFAULT_STRIDE)
        adaptive.fill(out, sim, adaptive.DEFAULT_STRIDE)
    else:
        v = VARIANTS[how]
        rounds = trace(key, sim, evaluate, width=v[0], halo=v[1], most=v[2] if len(v) > 2 else 0)
        fill_regions(out, key, sim)
    return out, sim, rounds


def reference_maps(grid_w: str, grid_a: str, restitutions):
    for block in PRESETS:
        for pulse, rest in restitutions(block):
            s = MapSpec(get_preset(block).block(), pulse, rest, parse_range("w", grid_w, "w_ratio"),
                        parse_range("a", grid_a, "a_ratio"))
            om, am = np.meshgrid(s.omegas(), s.amplitudes())
            b = solve_batch(s.block.alpha_rad, s.block.p_rad_s, s.eta, pulse, om, am, dt_s=1e-3)
            yield f"reference {block} {pulse} {rest.label}", b.outcome.astype(np.int8), b.n_impacts


def _read_full_grid(d: Path):
    """``(name, outcome codes, impacts, skip)`` of a map from its run.json and cells.csv columns alone."""
    import csv
    meta = json.loads((d / "run.json").read_text())
    spec = meta["spec"]
    ny, nx = spec["y"]["n"], spec["x"]["n"]
    outcome = np.full((ny, nx), MISSING, np.int8)
    impacts = np.full((ny, nx), -1, np.int32)
    codes = {"rest": 0, "rocking": 1, "overturn": 2}
    with open(d / "cells.csv", newline="") as f:
        for row in csv.DictReader(f):
            i, j = int(row["i"]), int(row["j"])
            outcome[i, j] = codes.get(row["outcome"], -1) if row["status"] == "ok" else -1
            impacts[i, j] = int(row["n_impacts"]) if row["n_impacts"] else -1
    skip = bool((meta.get("options") or {}).get("adaptive")) or bool((outcome == MISSING).any())
    return f"{spec['engine']} {spec.get('engine_settings')} {d.name}", outcome, impacts, skip


def judge(name, outcome, impacts, methods) -> dict:
    row = {"map": name}
    for how in methods:
        out, sim, rounds = replay(outcome, impacts, how)
        row[how] = {"fraction": float(sim.mean()), "wrong": int((out != outcome).sum()), "rounds": rounds}
    return row


def summarize(rows, methods) -> dict:
    return {how: {"maps": len(rows), "fraction_mean": float(np.mean([r[how]["fraction"] for r in rows])),
                  "wrong": int(sum(r[how]["wrong"] for r in rows)),
                  "maps_with_errors": int(sum(r[how]["wrong"] > 0 for r in rows))} for how in methods}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine-maps", nargs="*", default=[], help="full-grid engine run directories, or folders of them")
    ap.add_argument("--no-extra", action="store_true", help="only the default suite's 24 reference maps")
    ap.add_argument("--engines-only", action="store_true", help="only the engine maps given")
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    methods = ["blocks", *VARIANTS]
    res = {"started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
           "variants": {k: {"width": v[0], "halo": v[1], "most": v[2] if len(v) > 2 else 0} for k, v in VARIANTS.items()}}

    def suite_rest(block):
        return [(p, restitution_for(t, block)) for p in ("sine", "cosine")
                for t in ("housner", "modified-average", "modified-exact")]

    if not args.engines_only:
        rows = [judge(*m, methods) for m in reference_maps("1:16:51", "1:12:51", suite_rest)]
        res["reference_default_suite"] = {"rows": rows, "summary": summarize(rows, methods)}
        print("1. reference, the default suite's 24 maps (51×51):")
        for how, v in res["reference_default_suite"]["summary"].items():
            print(f"   {how:18} {100 * v['fraction_mean']:5.1f} % simulated, {v['wrong']} cells wrong")
    if not args.no_extra and not args.engines_only:
        etas = (0.55, 0.7, 0.75, 0.8, 0.85, 0.9, 0.93, 0.95, 0.97, 1.0)
        res["reference_more"] = {}
        print("2. reference, three pulses × ten constant η per block: blocks, trace-w3+tips0, the plain tracer:")
        for gw, ga in (("1:16:31", "1:12:31"), ("1:16:51", "1:12:51"), ("0.5:10:100", "0.5:10:100"),
                       ("0.5:10:200", "0.5:10:200")):
            rows = [judge(*m, ["blocks", "trace-w3+tips0", "trace"]) for m in reference_maps(
                gw, ga, lambda b: [(p, Restitution("constant", value=e)) for p in ("sine", "cosine", "half-sine")
                                   for e in etas])]
            s = summarize(rows, ["blocks", "trace-w3+tips0", "trace"])
            res["reference_more"][f"{gw} x {ga}"] = s
            print(f"   {gw} × {ga}: {len(rows)} maps; " + ", ".join(
                f"{how} {100 * s[how]['fraction_mean']:.1f} % ({s[how]['wrong']} wrong)"
                for how in ("blocks", "trace-w3+tips0", "trace")), flush=True)
    dirs = []
    for d in map(Path, args.engine_maps):
        dirs += [d] if (d / "run.json").is_file() else sorted(p.parent for p in d.rglob("run.json"))
    if dirs:
        rows = []
        print("3. engine maps computed in full:")
        for d in dirs:
            try:
                r = load_map(d)
                name, outcome, impacts = f"{r.spec.engine} {r.spec.engine_settings} {d.name}", r.outcome, r.n_impacts
                skip = not r.complete or r.adaptive
            except IncomparableError:   # a map of an older schema: its cells.csv columns are enough here
                name, outcome, impacts, skip = _read_full_grid(d)
            if skip:
                print(f"   {d}: skipped (incomplete or adaptive)")
                continue
            row = judge(name, outcome, impacts, methods)
            rows.append(row)
            print(f"   {row['map']:48} " + " | ".join(f"{how} {100 * row[how]['fraction']:.1f} %/{row[how]['wrong']}"
                                                     for how in methods), flush=True)
        res["engines"] = {"rows": rows, "summary": summarize(rows, methods)}
        print("   all engine maps (mean % simulated / cells wrong):")
        for how, v in res["engines"]["summary"].items():
            print(f"   {how:18} {100 * v['fraction_mean']:5.1f} % / {v['wrong']} wrong in {v['maps_with_errors']} maps")
    res["wall_s"] = time.perf_counter() - t0
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
