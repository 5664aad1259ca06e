"""How well a map located below the cell knows its boundary distance (docs/scores.md, "The grid's
resolution: a boundary located below the cell").

``truth`` maps B3M and B6M, sine and cosine, with the reference solver for η_H and for a restitution
0.5 %, 1 % and 2 % below it (η_H·(1 − δ): an "engine" a little off), once on a fine grid (401 × 401
over ω/p 1–16, a₀/(g·tanα) 1–12, adaptive, every boundary edge bisected 8 times: the truth) and
then on coarser grids at 16 phases (the grid's nodes offset by 0, ¼, ½, ¾ of a step along each axis),
each located by the production path: ``run_map`` (the reference map of η_H in full, as ``rockbench run``
computes reference maps, the others adaptive with the given coarse stride; every map bisected to the
given depth), ``load_entry``, and the metric: the crossings it counts in the reference's domain
(:func:`rockbench.benchmark.scoring.metrics.judged_crossings`), each to the other map's polyline. Both
the truth and the coarse maps count only the crossings inside one common window (``WINDOW``), so the
edges of the ranges do not.

It prints, per configuration (grid, coarse stride, depth) and scenario (block × pulse × δ): the truth,
the coarse grids' bias and root mean square error over the phases (also in cell diagonals), and the
runs per engine map (cells simulated plus bisection samples, mean and range over the coarse maps of
δ > 0, adaptive as a suite's engine maps are); then the
error of a *paired difference* (δ = 2 % minus δ = 0.5 %, both against the same reference map) against
its truth beside √(sd₂² + sd₀.₅²), the error the verdict assumes when it takes the two as
independent; and, as a diagnosis, the root mean square errors with every crossing counted, also
outside the reference's domain (the difference is the domain's share of the error). The maps are
kept in OUT and reused by a rerun (the fine ones take most of the time: about 40 minutes of one
core for the sixteen fine maps, measured under load).

Run from the repository root:
``python tests/measurements/probes/probe_resolution.py truth OUT [--configs 26:3:6,36:3:5,...] [--record]``
(``--record`` writes the figures as the record ``probe-resolution``).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.benchmark.maps.grid import MapSpec, make_axis
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.scoring.metrics import boundary_of, judged_crossings, point_segment_distances
from rockbench.benchmark.store.loading import load_entry, load_map
from rockbench.reference_solver.restitution import Restitution, housner_eta

W_RANGE, A_RANGE = (1.0, 16.0), (1.0, 12.0)
FINE_N, FINE_DEPTH, FINE_STRIDE = 401, 8, 4
SHIFTS = (0.0, 0.005, 0.01, 0.02)       # restitution below η_H, as a share of it
PHASES = (0.0, 0.25, 0.5, 0.75)          # offsets of a coarse grid's nodes, in steps
#: the common window of truth and coarse crossings: inside the range every phase of a 26 × 26 grid covers
WINDOW = (1.5, 15.9, 1.4, 11.9)
CONFIGS = ((26, 3, 5), (26, 3, 6), (26, 2, 6), (31, 3, 5), (31, 3, 6), (36, 3, 4), (36, 4, 4), (36, 3, 5),
           (51, 4, 4))


def eta_of(block: str, shift: float) -> float:
    return housner_eta(PRESETS[block].block().alpha_rad) * (1.0 - shift)


def one_map(d: Path, block: str, pulse: str, shift: float, n: int, phase: tuple, stride: int, depth: int):
    """The map (as the scores read it) and its runs (cells simulated plus bisection samples): the
    reference (δ = 0) in full, as ``rockbench run`` computes reference maps, the others adaptive."""
    d = d.with_name(d.name + ("-full" if shift == 0.0 else ""))
    if not (d / "run.json").exists() or load_map(d).located.depth != depth or not _finished(d):
        dw, da = (W_RANGE[1] - W_RANGE[0]) / (n - 1), (A_RANGE[1] - A_RANGE[0]) / (n - 1)
        w0, a0 = W_RANGE[0] + phase[0] * dw, A_RANGE[0] + phase[1] * da
        spec = MapSpec(PRESETS[block].block(), pulse, Restitution("constant", value=eta_of(block, shift)),
                       make_axis("w", "w_ratio", w0, w0 + (n - 1) * dw, n),
                       make_axis("a", "a_ratio", a0, a0 + (n - 1) * da, n))
        run_map(spec, d, serial=True, adaptive=shift != 0.0, coarse_stride=stride, locate_depth=depth, progress=False)
    m = load_entry(d).map
    return m, int(m.simulated.sum()) + m.located.n_samples


def _finished(d: Path) -> bool:
    import json
    return bool(json.loads((d / "run.json").read_text()).get("summary"))


def distance(eng, ref, domain: bool = True) -> float:
    """``boundary_mean`` of the pair (the crossings the metric counts, :func:`judged_crossings`, each to
    the other map's polyline) with only the crossings inside :data:`WINDOW` counted; with ``domain``
    False every crossing counts, also where the reference is not valid (a diagnosis: it separates the
    located boundary's own error from the domain's)."""
    be, br = boundary_of(eng), boundary_of(ref)
    ce, cr = judged_crossings(eng, ref) if domain else (np.ones(be.n_crossings, bool), np.ones(br.n_crossings, bool))
    pe, pr = be.points[ce & _in_window(be.points)], br.points[cr & _in_window(br.points)]
    return float(np.concatenate([point_segment_distances(pe, br.segments()),
                                 point_segment_distances(pr, be.segments())]).mean())


def _in_window(p: np.ndarray) -> np.ndarray:
    w0, w1, a0, a1 = WINDOW
    return (p[:, 0] >= w0) & (p[:, 0] <= w1) & (p[:, 1] >= a0) & (p[:, 1] <= a1)


def truth(out: Path, configs) -> dict:
    """Print the truth and each configuration's errors; return them as the figures of the record
    ``probe-resolution`` (``{scenario: {"truth": {δ: d}, "configs": {"N:S:D": {...}}}}``)."""
    figures: dict = {}
    for block in ("B3M", "B6M"):
        for pulse in ("sine", "cosine"):
            fine = {s: one_map(out / "fine" / f"{block}-{pulse}-{s}", block, pulse, s, FINE_N, (0, 0), FINE_STRIDE,
                               FINE_DEPTH) for s in SHIFTS}
            true = {s: distance(fine[s][0], fine[0.0][0]) for s in SHIFTS[1:]}
            true_all = {s: distance(fine[s][0], fine[0.0][0], False) for s in SHIFTS[1:]}
            scenario = figures.setdefault(f"{block} {pulse}", {"truth": {f"{s:g}": round(v, 5) for s, v in true.items()},
                                                               "configs": {}})
            print(f"{block} {pulse}: truth {', '.join(f'δ {100 * s:.1f} % {v:.4f}' for s, v in true.items())}; "
                  f"fine runs per map {min(r for _, r in fine.values())}–{max(r for _, r in fine.values())}",
                  flush=True)
            for n, stride, depth in configs:
                err, runs, paired = {s: [] for s in SHIFTS[1:]}, [], []
                err_all = {s: [] for s in SHIFTS[1:]}
                for pw in PHASES:
                    for pa in PHASES:
                        maps = {s: one_map(out / f"g{n}-s{stride}-d{depth}" / f"{block}-{pulse}-{s}-{pw}-{pa}", block,
                                           pulse, s, n, (pw, pa), stride, depth) for s in SHIFTS}
                        runs += [maps[s][1] for s in SHIFTS[1:]]   # engine maps (the reference's cost ms)
                        d = {s: distance(maps[s][0], maps[0.0][0]) for s in SHIFTS[1:]}
                        for s in SHIFTS[1:]:
                            err[s].append(d[s] - true[s])
                            err_all[s].append(distance(maps[s][0], maps[0.0][0], False) - true_all[s])
                        paired.append((d[0.02] - d[0.005]) - (true[0.02] - true[0.005]))
                cell = math.hypot((W_RANGE[1] - W_RANGE[0]) / (n - 1), (A_RANGE[1] - A_RANGE[0]) / (n - 1))
                parts = []
                rms = {}
                for s, e in err.items():
                    e = np.array(e)
                    rms[s] = float(np.sqrt(np.mean(e ** 2)))
                    parts.append(f"δ {100 * s:.1f} %: bias {e.mean():+.4f} rms {rms[s]:.4f} ({rms[s] / cell:.4f} diag)")
                pr = float(np.sqrt(np.mean(np.square(paired))))
                scenario["configs"][f"{n}:{stride}:{depth}"] = {
                    "runs_per_map_mean": round(float(np.mean(runs))), "runs_per_map_range": [min(runs), max(runs)],
                    "rms": {f"{s:g}": round(v, 5) for s, v in rms.items()},
                    "bias": {f"{s:g}": round(float(np.mean(e)), 5) for s, e in err.items()},
                    "rms_over_diagonal": {f"{s:g}": round(v / cell, 5) for s, v in rms.items()},
                    "paired_rms": round(pr, 5), "paired_independent_sd": round(math.hypot(rms[0.02], rms[0.005]), 5),
                    "rms_domain_ignored": {f"{s:g}": round(float(np.sqrt(np.mean(np.square(e)))), 5)
                                           for s, e in err_all.items()}}
                print(f"  {n}×{n} stride {stride} depth {depth}: runs per map {np.mean(runs):.0f} "
                      f"({min(runs)}–{max(runs)}); " + "; ".join(parts) +
                      f"; paired 2 %−0.5 % rms {pr:.4f} vs √(sd²+sd²) {math.hypot(rms[0.02], rms[0.005]):.4f}; "
                      "domain ignored: rms " + "/".join(f"{np.sqrt(np.mean(np.square(e))):.4f}" for e in err_all.values()),
                      flush=True)
    return figures


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("truth",), help="truth: the fine-grid truth and the coarse grids' error")
    ap.add_argument("path", type=Path, help="the output folder (maps kept and reused)")
    ap.add_argument("--configs", default=",".join(f"{n}:{s}:{d}" for n, s, d in CONFIGS),
                    help="N:STRIDE:DEPTH,... coarse grids (N × N), adaptive coarse strides and bisection depths")
    ap.add_argument("--record", action="store_true",
                    help="write the figures as the record tests/measurements/results/probe-resolution.json")
    a = ap.parse_args(argv)
    configs = [tuple(int(x) for x in c.split(":")) for c in a.configs.split(",")]
    figures = truth(a.path, configs)
    if a.record:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
        from records import write_record
        write_record("probe-resolution",
                     "The located boundary's error: per scenario (B3M, B6M × sine, cosine), the reference solver's "
                     "boundary distance for η_H·(1 − δ) against η_H on a 401 × 401 grid bisected 8 times (the truth), "
                     "and for coarser grids (N:STRIDE:DEPTH: N × N, adaptive coarse stride, bisection depth) at 16 "
                     "phases the bias and root mean square error of boundary_mean against that truth, the runs per "
                     "engine map (cells simulated plus bisection samples), and the error of a paired difference "
                     "(δ = 2 % minus 0.5 %, one reference map) beside the error of two independent ones.",
                     "python tests/measurements/probes/probe_resolution.py truth OUT --configs " + a.configs + " --record",
                     figures)
    return 0


if __name__ == "__main__":
    sys.exit(main())
