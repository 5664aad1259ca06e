"""Print the README's numbers from the default suite's verdict record: the main job's time, and the
results table with the line under it.

    python tests/measurements/readme_results.py [RECORD]     (default: verdict-default)

The README holds the two blocks between its ``<!-- quick-start-time -->`` and ``<!-- results -->``
markers (each closed by ``<!-- /... -->``), and tests/test_readme.py holds them equal to this output: a
number in the README is the record's, never typed by hand. The record is written by
tests/measurements/record_verdict.py from a finished run of the README's first command.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from records import load  # noqa: E402

from rockbench.benchmark.report.verdict_words import held_out_word  # noqa: E402
from rockbench.benchmark.scoring.failing import scenario_words  # noqa: E402

#: How the README names each settings class of the verdict, in the order it lists them.
CLASSES = {"calibrated": "calibrated to η_H", "as-shipped": "as shipped", "held-out": "held out"}


def _num(x: float) -> str:
    return f"{x:.3f}" if abs(x) < 1 else f"{x:.3g}"


def _engine(label: str) -> str:
    """``MuJoCo 4.0, calibrated to η_H`` → ``MuJoCo 4.0``."""
    return label.split(",")[0]


def _worst(r: dict) -> str:
    missing = [s for s in r["per_scenario"] if s.get("missing_boundary")]
    if missing:
        return f"{len(missing)} of {len(r['per_scenario'])} without a boundary"
    s = max(r["per_scenario"], key=lambda s: s["value"])
    return f"{s['block']} {s['pulse']} {_num(s['value'])}"


def _standing(r: dict) -> str:
    if r["fails"]:
        f = r["fails_in"][0]
        if f.get("missing_boundary"):
            return f"fails: {scenario_words(f)}"
        return f"fails: {f['block']} {f['pulse']} {_num(f['value'])} > {f['limit']:.3g}"
    if r["group"] == "held-out":
        h = r["held_out"]
        if h.get("tost") is None:
            return f"not tested: {len(h.get('left_out') or [])} of {h['scenarios']} scenarios identical or unresponsive"
        words = held_out_word(h)
        tested = f", {h['tested_scenarios']} of {h['scenarios']} scenarios tested" if h.get("left_out") else ""
        return f"{words} (in-sample {_num(h['in_sample'])}{tested})"
    scope = f" {r['scope']}" if r.get("scope") else ""
    if r.get("best_in_class"):
        return f"best{scope}"
    if not r.get("in_best_subset"):
        return f"behind the best{scope}"
    only = r.get("on_suite") and r["scope"] != r["on_suite"]["scope"] and not r["on_suite"]["in_best_subset"]
    return f"may be the best (tied){scope}" + ("; behind on this suite only" if only else "")


def _offset(r: dict) -> str:
    """The mean signed offset of the boundary (positive: overturns at a lower amplitude than the rigid
    model, conservative) and its share of the reference's critical amplitude; – where there is none."""
    if r.get("offset") is None:
        return "–"
    pct = f" ({r['offset_percent']:+.1f} %)" if r.get("offset_percent") is not None else ""
    return f"{r['offset']:+.3f}{pct}"


def rows(verdict: dict) -> list[str]:
    """One table row per variant, planted ones aside: the classes in :data:`CLASSES`' order, failing
    variants last, each class in the verdict's order."""
    variants = [r for r in verdict["variants"] if r["group"] in CLASSES]
    variants.sort(key=lambda r: (r["fails"], list(CLASSES).index(r["group"])))
    out = []
    for r in variants:
        own = r["held_out"] if r["group"] == "held-out" else r   # a held-out value is its test's
        value = ("no mean: a map without a boundary" if own["value"] is None else
                 f"{_num(own['value'])} [{_num(own['ci95'][0])}, {_num(own['ci95'][1])}]")
        if r.get("in_best_subset") and not r["fails"]:
            value = f"**{value}**"
        out.append(f"| {CLASSES[r['group']]} | {_engine(r['label'])} | {value} | {_offset(r)} | {_standing(r)} | "
                   f"{_worst(r)} |")
    return out


def summary(figures: dict) -> str:
    """The line under the table: what the values rest on and how small a difference the suite sees."""
    v = figures["verdict"]
    first = next(r for r in v["variants"] if r["group"] == "calibrated")
    mdd = ", ".join(f"{_num(f['across']['mdd'])} across problems and {_num(f['mdd'])} on this suite ({CLASSES[c]})"
                    if f.get("across") else f"{_num(f['mdd'])} on this suite ({CLASSES[c]})"
                    for c, f in v["mcb"].items() if f.get("mdd") is not None)
    resolved = [p for p in v["power"]["planted"] if p["resolved"]]
    smallest = min(resolved, key=lambda p: p["delta"]) if resolved else None
    power = (f"a restitution planted {smallest['delta'] * 100:g} % low in the reference solver itself is told from "
             f"the exact one on this suite (distance {_num(smallest['distance'])}; an engine that already errs moves "
             "by less, or the other way)" if smallest else "no planted restitution error is resolved")
    power += "; " + engine_power_words(v) if v.get("engine_power") else ""
    return (f"Each value is the mean boundary distance over the suite's {first['clusters']} problems (4 "
            f"slendernesses × 2 pulses; held-out values over their {figures['held_out_scenarios']}), "
            f"lower is better; intervals on this suite (these problems fixed, each map's measured location error alone); the signed offset is positive where the engine overturns at a lower amplitude than the rigid model (conservative), negative where later; bold: may be "
            f"the best of its class across problems (Hsu's MCB, 95 %, the engine × problem spread as error). The "
            f"smallest difference the suite detects at 80 % power: {mdd}; {power}.")


def _min_s(seconds: float) -> str:
    m, s = divmod(int(round(seconds)), 60)
    return f"{m} min {s:02d} s" if m else f"{s} s"


def time_block(rec: dict) -> str:
    """The sentence beside the quick start: the first command's measured time and what it rests on."""
    t = rec["figures"]["timing_s"]
    m = rec["machine"]
    return (f"The first command took **{_min_s(t['total'])}** on a fresh clone of commit {rec['commit'][:7]} "
            f"({rec['date_utc'][:10]}): install {_min_s(t['install'])}, `rockbench run` {_min_s(t['run'])} "
            f"({t['run_cpu_user_sys']:,} s of CPU, {rec['figures']['maps']} maps, empty calibration cache), on "
            f"{m['cores']} cores ({m['cpu']}, {m['memory_gib']} GiB) with nothing else running.")


def results_block(rec: dict) -> str:
    """The results table and the line under it."""
    figures = dict(rec["figures"])
    held = [r["held_out"]["scenarios"] for r in figures["verdict"]["variants"] if r["group"] == "held-out"]
    figures["held_out_scenarios"] = f"{max(held)} scenarios" if held else "scenarios"
    lines = ["| class | engine | boundary distance [95 %, on this suite] | signed offset (of a_crit) | standing | "
             "worst scenario |", "|---|---|---|---|---|---|"]
    return "\n".join(lines + rows(figures["verdict"]) + ["", summary(figures)])


#: The record of the suite's power against an engine's own restitution error (an engine calibrated to
#: η_H·(1 + δ) against its calibration to η_H), written by tests/measurements/probes/record_engine_planted.py
ENGINE_POWER_RECORD = "engine-planted-mujoco"


def realised_shift(f: dict, delta_key: str) -> float:
    """The mean over blocks of the η a δ variant's calibration reached less its δ = 0's, over η_H [-]."""
    v, base = f["variants"][delta_key]["eta_over_law"], f["base_eta_over_law"]
    return sum(v[b]["reached"] - base[b]["reached"] for b in v) / len(v)


def engine_power_words(verdict: dict) -> str:
    """What the suite resolves of an engine's own restitution error: the |δ| resolved across problems by the
    signed offset and by the distance, from the verdict's own ``engine_power`` (the default suite runs
    MuJoCo's engine-planted variants), and the η shifts their calibrations realised (measured by
    tests/measurements/probes/record_engine_planted.py, record :data:`ENGINE_POWER_RECORD`)."""
    e = verdict["engine_power"]["engines"]["mujoco"]
    res = e["resolved_abs_delta"]
    first = next(r["distance"] for r in e["rows"] if r["distance"])
    deltas = ", ".join(f"{r['delta'] * 100:+g} %" for r in sorted(e["rows"], key=lambda r: r["delta"]))
    said = {m: " and ".join(f"{d * 100:g} %" for d in res[m]) for m in res if res[m]}
    told = ("is told from its own calibration across the {n} problems at no |δ| up to 2 %, by the signed offset or by "
            "the distance" if not said else "is told from its own calibration across the {n} problems at |δ| "
            + "; ".join(f"{d} by the {m}" for m, d in said.items()))
    f = load(ENGINE_POWER_RECORD)["figures"]
    shifts = sorted(realised_shift(f, k) for k in f["variants"])
    return (f"MuJoCo calibrated to η_H·(1 + δ), δ = {deltas}, "
            + told.format(n=first["problems"])
            + f" (t on {first['df']} degrees of freedom), its calibrations having moved η by only "
            f"{100 * shifts[0]:+.1f} to {100 * shifts[-1]:+.1f} % (record {ENGINE_POWER_RECORD}; docs/scores.md)")


#: The README's markers of each generated block: name → the function that writes it
BLOCKS = {"quick-start-time": time_block, "results": results_block}


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    rec = load(argv[0] if argv else "verdict-default")
    for name, block in BLOCKS.items():
        print(f"<!-- {name} -->\n{block(rec)}\n<!-- /{name} -->\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
