"""Precision bought with problems: the calibrated class's across-problem minimal detectable difference
(MDD) against the number of problems, and what the maps of more problems cost.

    python tests/measurements/mdd_problems.py DEFAULT_RUN MORE_RUN [--record mdd-problems]

DEFAULT_RUN is a `rockbench run` of the default suite (its score.json and maps), MORE_RUN one of
``tests/measurements/suites/more-problems.toml`` (the same engines calibrated to Housner on B4M, B5M,
B7M, both pulses, on the default grid). The calibrated variants' in-sample scenarios of both runs are
pooled by variant; for a set of problems (slenderness × pulse) the MDD is the product's own
(``comparisons.across_problems``: the engine × problem interaction of the class's two-way table,
Dunnett's t on (k − 1)(C − 1) degrees of freedom, (q + t₀.₈)·se, the grid error as a floor):

- every subset of k of the default run's 8 problems (k = 4..8);
- the 8 with whole slendernesses of MORE_RUN added (both pulses of a block together): 10, 12, 14;
- every subset of k of all 14 problems (k = 4..14), as a distribution (min, quartiles, max).

The cost of a map is its CPU (cells.csv and bisection.csv ``cpu_s`` summed), per engine variant and
block; the projection of a suite with more blocks (:func:`projection`) adds to the recorded main job
(record run-default-suite, 2 lanes) the maps every variant of the default suite would map on them, at
the record's time per map of that variant, scaled for a calibrated variant by the CPU of its new maps
over its default maps, and the record's calibration time per block. Measures and prints; passes nothing.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import statistics
import sys
from pathlib import Path

from rockbench.benchmark.scoring.comparisons import across_problems
from rockbench.benchmark.scoring.scenarios import Variant, items, variants_of

sys.path.insert(0, str(Path(__file__).resolve().parent))
from records import load, write_record  # noqa: E402  (tests/measurements/, beside this script)

#: The main job's budget [s] on 2 cores (docs/speed.md)
BUDGET_S = 1200.0


def calibrated(doc: dict) -> dict[str, Variant]:
    """The calibrated class's in-sample variants of a score document, by engine."""
    return {v.engine: v for v in variants_of(doc) if v.settings == "calibrated" and not v.held_out_only
            and v.planted_factor is None}


def pooled(*docs: dict) -> dict[str, dict]:
    """Each engine's in-sample scenario items (``{(block, pulse): (value, sd, cluster)}``) over the runs;
    engines every run has."""
    runs = [calibrated(d) for d in docs]
    common = set.intersection(*(set(r) for r in runs))
    return {e: {k: x for r in runs for k, x in items(r[e]).items()} for e in sorted(common)}


#: ``{(block, pulse): η_H–η_M reference gap}`` of the pooled runs (set by :func:`main`)
GAPS: dict = {}


def mdd(heads: dict[str, dict], problems: set) -> dict:
    """The class's across-problem figures on ``problems`` (clusters) alone, its entries those that pass
    the default fail rule there (the largest η_H–η_M gap of those problems' scenarios; a failing variant
    is out of its class), ``failing`` the others."""
    sub = {e: {k: x for k, x in it.items() if x[2] in problems} for e, it in heads.items()}
    limit = max(g for k, g in GAPS.items() if any(k in it for it in sub.values()))
    failing = sorted(e for e, it in sub.items() if any(x[0] > limit for x in it.values()))
    a = across_problems(None, {e: it for e, it in sub.items() if e not in failing})
    return {"problems": a["problems"], "df": a["df"], "mdd": a["mdd"], "interaction_sd": a["interaction_sd"],
            "critical": a["critical"], "pair_se": a["pair_se"], "grid_sd": a["grid_sd"], "fail_limit": limit,
            "failing": failing}


def cheaper_grid(m: dict, scale: float) -> dict:
    """The across-problem MDD of ``m`` (:func:`mdd`) on a grid whose steps are ``scale`` times the
    default's at the same bisection depth: each map's location error (its bisection brackets) grows by
    ``scale``; the interaction mean square grows by (scale² − 1)·grid_sd² at most (all of the grid's
    error in it), the MDD in proportion to its square root (the critical values kept)."""
    ms = m["interaction_sd"] ** 2
    worst = (ms + (scale ** 2 - 1) * m["grid_sd"] ** 2) ** 0.5
    return {"scale": scale, "grid_sd": scale * m["grid_sd"], "interaction_sd_at_most": worst,
            "mdd_at_most": m["mdd"] * worst / m["interaction_sd"]}


def with_all(heads: dict, problems: set) -> dict:
    """:func:`mdd` with every engine kept, failing or not (what the spread alone does)."""
    sub = {e: {k: x for k, x in it.items() if x[2] in problems} for e, it in heads.items()}
    a = across_problems(None, sub)
    return {"problems": a["problems"], "mdd": a["mdd"], "interaction_sd": a["interaction_sd"]}


def spread(values: list[float]) -> dict:
    q = statistics.quantiles(values, n=4) if len(values) > 1 else values * 3
    return {"n": len(values), "min": min(values), "q1": q[0], "median": statistics.median(values), "q3": q[2],
            "max": max(values), "share_at_most_0.015": sum(v <= 0.015 for v in values) / len(values)}


def subsets(heads: dict, problems: list, sizes) -> dict:
    return {k: spread([mdd(heads, set(s))["mdd"] for s in itertools.combinations(problems, k)]) for k in sizes}


def map_cpu(run: Path) -> dict:
    """``{variant: {block: [CPU s of each map]}}`` of a run folder's engine maps."""
    out: dict = {}
    for d in sorted(run.glob("maps/*/*/")):
        if not (d / "cells.csv").is_file() or d.parts[-2] == "reference":
            continue
        cpu = 0.0
        for f in ("cells.csv", "bisection.csv"):
            if (d / f).is_file():
                with open(d / f) as fh:
                    cpu += sum(float(r["cpu_s"] or 0) for r in csv.DictReader(fh))
        out.setdefault(d.parts[-2], {}).setdefault(d.name.split("-")[0], []).append(cpu)
    return out


def per_map(cpu: dict) -> dict:
    """Mean CPU per map of each variant [s]."""
    return {v: sum(sum(b) for b in blocks.values()) / sum(len(b) for b in blocks.values()) for v, blocks in cpu.items()}


def projection(record: dict, default_cpu: dict, more_cpu: dict, calibration_s_per_block: float,
               blocks: list[str]) -> dict:
    """The main job (``record``: run-default-suite's summary) with ``blocks`` added, each with both pulses:
    every variant but the held-out one maps 2 more maps a block at the record's own time per map of that
    variant, scaled for a calibrated variant by the CPU of its measured new map over its default maps'
    mean; the reference maps (5 of its 110 a block and pulse, ×0.05 per map) likewise unscaled; dealt to
    the record's 2 lanes (the added lane time halved), plus each block's calibrations."""
    mean_old = per_map(default_cpu)
    lane_s = 0.0
    for variant, v in record["per_variant"].items():
        if "calibrate-on" in variant:
            continue                                      # the held-out variant maps B2M and B8M only
        per_map_s = v["wall_s"] / v["maps"]
        if variant == "reference":
            lane_s += len(blocks) * 2 * 3 * per_map_s      # η_H and η_M maps, and the own-η one
            continue
        for b in blocks:
            new = more_cpu.get(variant, {}).get(b)
            ratio = (sum(new) / len(new)) / mean_old[variant] if new and mean_old.get(variant) else 1.0
            lane_s += 2 * per_map_s * ratio
    wall = record["wall_s"] + lane_s / 2 + calibration_s_per_block * len(blocks)
    return {"blocks": blocks, "added_lane_s": lane_s, "projected_wall_s": wall, "budget_s": BUDGET_S,
            "within_budget": wall <= BUDGET_S}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("default_run", type=Path)
    ap.add_argument("more_run", type=Path)
    ap.add_argument("--calibration-s-per-block", type=float, default=None,
                    help="calibration time per added block [s]; default: the run-default-suite record's lane "
                         "time outside its maps over its 4 blocks")
    ap.add_argument("--record", default=None)
    a = ap.parse_args(argv)
    docs = [json.loads((r / "score.json").read_text()) for r in (a.default_run, a.more_run)]
    heads = pooled(*docs)
    GAPS.update({(g["block"], g["pulse"]): g["boundary_mean"] for d in docs for g in d["reference_gaps"]})
    old = sorted({x[2] for v in calibrated(docs[0]).values() for x in items(v).values()}, key=str)
    new = sorted({x[2] for it in heads.values() for x in it.values()} - set(old), key=str)
    slender = sorted({c[0] for c in new})
    figures = {"engines": sorted(heads), "default_problems": [list(c) for c in old],
               "added_problems": [list(c) for c in new],
               "default_all": mdd(heads, set(old)), "subsets_of_default": subsets(heads, old, range(4, len(old) + 1))}
    nested = {}
    for n in range(1, len(slender) + 1):
        for chosen in itertools.combinations(slender, n):
            ps = set(old) | {c for c in new if c[0] in chosen}
            nested[" + ".join(f"h/b {s:g}" for s in chosen)] = {**mdd(heads, ps), "every_engine": with_all(heads, ps)}
    figures["default_plus_slendernesses"] = nested
    figures["added_scenarios"] = [
        {k: p.get(k) for k in ("variant", "block", "pulse", "overturn_extra", "overturn_missed", "reference_overturn")}
        | {m: p["scores"].get(m) for m in ("boundary_mean", "boundary_offset", "boundary_max", "critical_one_sided")}
        for p in docs[1]["pairs"] if p.get("like_for_like") and p["settings"] == "calibrated"]
    figures["added_reference_gaps"] = [g for g in docs[1]["reference_gaps"]]
    everything = old + new
    figures["subsets_of_all"] = subsets(heads, everything, range(4, len(everything) + 1))
    scale = 35 / 25                                         # 26 × 26 on the same axes: steps 35/25 of 36 × 36's
    figures["cheaper_grid_26x26"] = {"default_8": cheaper_grid(figures["default_all"], scale),
                                     "all_14": cheaper_grid(mdd(heads, set(everything)), scale)}
    record = load("run-default-suite")["figures"]["summary"]
    blocks = sorted({b for bl in map_cpu(a.more_run).values() for b in bl})
    cal = a.calibration_s_per_block
    if cal is None:       # the record's lane time outside its maps (calibrations), per block, on 2 lanes
        maps_lane_s = sum(v["wall_s"] for v in record["per_variant"].values())
        cal = (2 * record["maps_wall_s"] - maps_lane_s) / 2 / 4
    default_cpu, more_cpu = map_cpu(a.default_run), map_cpu(a.more_run)
    figures["map_cpu_s"] = {"per_map_default": per_map(default_cpu),
                            "per_map_added": {v: {b: sum(x) / len(x) for b, x in bl.items()} for v, bl in more_cpu.items()},
                            "calibration_s_per_block": cal}
    figures["projection"] = {" + ".join(c): projection(record, default_cpu, more_cpu, cal, list(c))
                             for n in range(1, len(blocks) + 1) for c in itertools.combinations(blocks, n)}
    print(json.dumps({k: figures[k] for k in ("default_all", "default_plus_slendernesses", "projection",
                                             "cheaper_grid_26x26", "map_cpu_s")}, indent=1))
    for k, s in figures["subsets_of_all"].items():
        print(f"{k:2d} problems: median {s['median']:.4f} [{s['min']:.4f}, {s['max']:.4f}], "
              f"≤ 0.015 in {100 * s['share_at_most_0.015']:.0f} %")
    if a.record:
        write_record(a.record, "The calibrated class's across-problem minimal detectable difference against the "
                     "number of problems (every subset of the default run's 8 and of 14 with B4M, B5M, B7M added), "
                     "and the CPU of a map of each added block per engine variant with the main job projected.",
                     "python tests/measurements/mdd_problems.py " + " ".join(str(x) for x in (argv or sys.argv[1:])),
                     figures)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
