"""Record the suite's power against an engine's own restitution error from a finished run of
``suite_engine_planted.toml`` (docs/scores.md, "The suite's power against an engine's own restitution
error"): per δ, the engine-planted variant against the engine's δ = 0 variant across problems (the
verdict's ``engine_power``: mean signed offset and distance change, their 95 % intervals, resolved or
not), the η each variant's calibration reached and its own free-rocking η, and what each variant
costs in CPU time: its maps (the cells' and bisection samples' ``cpu_s``) and its calibrations, timed
again here one block at a time in a scratch copy of the calibration cache without that variant's
records (the time-step rule's records kept: a planted variant uses its δ = 0 step).

Run from the repository root after the suite::

    nice rockbench run tests/measurements/probes/suite_engine_planted.toml --jobs 1 --out OUT --no-report
    nice python tests/measurements/probes/record_engine_planted.py OUT [--no-record]

The calibrations may be timed first, while the suite's maps run (they need only its calibration cache):
``record_engine_planted.py --time-calibrations CAL.json``, then ``record_engine_planted.py OUT
--calibrations CAL.json``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # tests/measurements/: the records module
from records import write_record  # noqa: E402

from rockbench.benchmark.blocks.presets import get_preset  # noqa: E402
from rockbench.benchmark.engine_info.adapters import build_adapter  # noqa: E402
from rockbench.benchmark.suites.model import load_suite, restitution_for  # noqa: E402
from rockbench.benchmark.suites.plan import blocks_of, variant_settings  # noqa: E402
from rockbench.engines.calibration.free_rocking import measure_restitution  # noqa: E402
from rockbench.engines.calibration import planted  # noqa: E402
from rockbench.engines.contract import PLANTED  # noqa: E402

SUITE = Path(__file__).resolve().parent / "suite_engine_planted.toml"
NAME = "engine-planted-mujoco"


def map_cpu_s(folder: Path) -> float:
    """The CPU time a map's cells and bisection samples recorded [s]."""
    total = 0.0
    for name in ("cells.csv", "bisection.csv"):
        p = folder / name
        if p.exists():
            with p.open() as f:
                total += sum(float(r["cpu_s"]) for r in csv.DictReader(f) if r.get("cpu_s"))
    return total


def etas(out: Path, folder: str, variant: str) -> dict:
    """Per block, the η a variant's calibration aimed at and reached (its sine map's run.json) and its own
    free-rocking η (the run's calibration.json) over the law's η: ``{block: {"target", "reached",
    "reached_ok", "own"}}`` (each η as a ratio to the law's)."""
    own = {m["block"]: m["eta_measured"] for m in json.loads((out / "calibration.json").read_text())["measurements"]
           if m["variant"] == variant}
    res = {}
    for m in sorted((out / "maps" / folder).glob("*-sine-*")):
        run = json.loads((m / "run.json").read_text())
        law = float(run["spec"]["restitution"]["eta"]) if "eta" in run["spec"].get("restitution", {}) else None
        cal = run["engine"]["resolved_settings"]["calibration"]
        block = m.name.split("-")[0]
        law = law or run["summary"]["eta"]
        res[block] = {"target": cal["eta_target"] / law, "reached": cal["eta_measured"] / law,
                      "reached_ok": cal["reached"], "own": own[block] / law if block in own else None}
    return res


def calibration_cpu_s(engine: str, variant: dict, blocks: list[str], restitution: str, done=None) -> dict:
    """A planted variant's calibrations and own-η measurements, timed in a scratch cache that lacks its
    calibration records: ``{block: {"calibration_cpu_s", "own_eta_cpu_s", "eta_target", "eta_reached",
    "eta_own"}}`` (``done(out)`` called after each block)."""
    src = Path(os.environ["ROCKBENCH_CACHE"])
    out = {}
    with tempfile.TemporaryDirectory() as scratch:
        shutil.copytree(src, scratch, dirs_exist_ok=True)
        os.environ["ROCKBENCH_CACHE"] = scratch
        try:
            for block in blocks:
                b, law = get_preset(block).block(), restitution_for(restitution, block)
                ad = build_adapter(engine, **variant_settings(variant))
                target = planted.calibration_target(ad, b, law)[1]
                for p in Path(scratch, "calibration").glob("*.json"):     # this variant's records out
                    res = (json.loads(p.read_text()).get("result") or {})
                    if res.get("eta_target") is not None and abs(res["eta_target"] - target) < 1e-12:
                        p.unlink()
                t0 = time.process_time()
                cal = ad.resolve(b, law)["calibration"]
                t1 = time.process_time()
                own = measure_restitution(build_adapter(engine, **variant_settings(variant)), b)
                t2 = time.process_time()
                out[block] = {"calibration_cpu_s": round(t1 - t0, 2), "own_eta_cpu_s": round(t2 - t1, 2),
                              "eta_target": target, "eta_reached": cal.get("eta_measured"),
                              "eta_own": float(own.eta_mean), "eta_law": law.eta(b.alpha_rad)}
                if done is not None:
                    done(out)
        finally:
            os.environ["ROCKBENCH_CACHE"] = str(src)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, nargs="?")
    ap.add_argument("--no-record", action="store_true")
    ap.add_argument("--time-calibrations", type=Path, help="time the calibrations alone into this JSON file")
    ap.add_argument("--calibrations", type=Path, help="the calibrations' times from --time-calibrations")
    args = ap.parse_args(argv)
    suite = load_suite(SUITE)
    planted = [v for v in suite.engines.variants if PLANTED in v]
    if args.time_calibrations:
        cals: dict = {}
        for v in sorted(planted, key=lambda v: abs(v[PLANTED] - 1.0)):     # the 1 % variants first

            def done(out, key=str(v[PLANTED])):
                cals[key] = out
                args.time_calibrations.write_text(json.dumps(cals, indent=1))
            calibration_cpu_s("mujoco", v, blocks_of(suite, v), suite.engines.restitution, done)
        return 0
    timed = json.loads(args.calibrations.read_text()) if args.calibrations else None
    verdict = json.loads((args.out / "score.json").read_text())["verdict"]
    power = verdict["engine_power"]
    maps = {d.name: round(sum(map_cpu_s(m) for m in d.iterdir() if m.is_dir()), 1)
            for d in (args.out / "maps").iterdir() if d.is_dir() and d.name.startswith("mujoco")}
    variants = {}
    for v in planted:
        factor = v[PLANTED]
        cal = (timed.get(str(factor), {}) if timed is not None else
               calibration_cpu_s("mujoco", v, blocks_of(suite, v), suite.engines.restitution))
        folder = next(n for n in maps if f"factor={factor:g}-" in n)
        name = f"mujoco[{PLANTED}={factor:g},settings=calibrated]"
        variants[f"{factor - 1:+.2f}"] = {"eta_factor": factor, "map_cpu_s": maps[folder], "blocks": cal,
                                          "eta_over_law": etas(args.out, folder, name),
                                          "blocks_timed": len(cal),
                                          "calibration_cpu_s": round(sum(c["calibration_cpu_s"] for c in cal.values()), 1),
                                          "own_eta_cpu_s": round(sum(c["own_eta_cpu_s"] for c in cal.values()), 1)}
        print(f"δ = {factor - 1:+.2f}: maps {maps[folder]:.0f} s, calibrations {variants[f'{factor - 1:+.2f}']['calibration_cpu_s']:.0f} s, "
              f"own η {variants[f'{factor - 1:+.2f}']['own_eta_cpu_s']:.0f} s of CPU")
    rows = power["engines"]["mujoco"]["rows"]
    for r in rows:
        print(f"δ = {r['delta']:+.2f}: distance {r['distance']['difference']:+.4f} {r['distance']['ci95']} "
              f"{'resolved' if r['distance']['resolved'] else 'not'}; offset {r['offset']['difference']:+.4f} "
              f"{r['offset']['ci95']} {'resolved' if r['offset']['resolved'] else 'not'}")
    base = next(r for r in verdict["variants"] if r["group"] == "calibrated")
    figures = {"suite": SUITE.name, "problems": rows[0]["distance"]["problems"] if rows and rows[0]["distance"] else None,
               "engine_power": power, "base": {"variant": base["variant"], "value": base["value"], "offset": base["offset"],
                                               "map_cpu_s": next(c for n, c in maps.items() if "planted" not in n)},
               "map_cpu_s_by_folder": maps,
               "base_eta_over_law": etas(args.out, "mujoco-settings=calibrated", "mujoco[settings=calibrated]"), "variants": variants,
               "planted_variants_cpu_s": round(sum(v["map_cpu_s"] + v["calibration_cpu_s"] + v["own_eta_cpu_s"]
                                                   for v in variants.values()), 1)}
    print(f"the four planted variants: {figures['planted_variants_cpu_s']:.0f} s of CPU in all")
    if not args.no_record:
        print(write_record(NAME, "MuJoCo calibrated to η_H·(1 + δ), δ = −2, −1, +1, +2 %, on the default suite's eight "
                           "problems and grid, each against its calibration to η_H (δ = 0) across problems by the "
                           "boundary distance and the signed offset (the verdict's engine_power), the η each reached, "
                           "and what each variant costs in CPU time (maps; calibrations and own-η measurement timed "
                           "again in a scratch cache)",
                           f"nice rockbench run {SUITE.relative_to(Path.cwd()) if SUITE.is_relative_to(Path.cwd()) else SUITE} "
                           "--jobs 1 --out OUT --no-report; nice python tests/measurements/probes/record_engine_planted.py OUT",
                           figures, packages=("mujoco",)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
