"""The yardstick of the engine contract's refactor (issue 45): small maps and the calibrations behind
them, per engine, recorded once and recomputed after any change to the engines' code.

For every installed engine it computes, from an empty calibration cache:

* the calibrated variant and the as-shipped variant on a small map of B3M under a sine wave
  (:data:`W_RATIOS` × :data:`A_RATIOS`, 5 × 4 cells holding the overturning boundary, every cell
  simulated: no adaptive refinement), each cell's outcome, impacts, max |θ|, uplift and overturn
  times, validity and flags, the step it ran at and the engine steps and end of its run;
* as shipped under the other drive and the other ``planar`` value (a 3 × 2 part of the grid), where
  the engine runs them, and, for the engines with a row of contact points along the base, an
  explicit contact along the base (:data:`EXPLICIT`);
* the resolved settings of every variant (``resolve()``, run.json's record: the calibration and the
  time-step rule's record among them) and every calibration the cache holds afterwards (the candidates
  each search measured and the pick).

``record`` writes them as ``results/yardstick-<engine>.json``; ``compare`` recomputes and lists every
difference (exit 1 if any). ``tests/engines/test_yardstick.py`` runs ``compare`` for each engine
recorded (slow: every calibration is made afresh).

    ROCKBENCH_CACHE=$(mktemp -d) python tests/measurements/yardstick.py record mujoco pybullet
    ROCKBENCH_CACHE=$(mktemp -d) python tests/measurements/yardstick.py compare mujoco
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from records import load, write_record  # noqa: E402

#: the map: B3M, one sine wave, ω/p × a₀/(g·tanα)
BLOCK = "B3M"
PULSE = "sine"
W_RATIOS = tuple(float(x) for x in np.linspace(2.0, 5.0, 5))
A_RATIOS = tuple(float(x) for x in np.linspace(1.5, 6.0, 4))
#: the part of the grid the other modes run on
MODE_W = (2.0, 3.5, 5.0)
MODE_A = (3.0, 6.0)

#: an explicit contact along the base (a row of points), for the engines that build one
EXPLICIT = {
    "mujoco": {"contact": "distributed", "contact_points": 9, "timeconst_s": 0.002, "dampratio": 1.0,
               "solimp_d": 0.5},
    "pybullet": {"contact": "distributed", "contact_points": 9, "contact_stiffness_n_m": 2e5,
                 "contact_damping_n_s_m": 300.0},
    "exudyn": {"contact": "distributed", "contact_points": 9, "contact_restitution": 0.2},
}

#: the fields of a cell compared (floats to the last digit)
CELL_FIELDS = ("outcome", "n_impacts", "max_abs_theta_rad", "t_overturn_s", "t_uplift_s", "valid", "flags", "status",
               "message")


def _block():
    from rockbench.reference_solver.model import Block

    # B3M of Table 1 (benchmark/blocks/presets.py), written out: the engines' floor knows no presets
    return Block(0.045, 0.10125, mass_kg=0.5444, name="B3M")


def _jsonable(x):
    """``x`` as JSON keeps it: floats exact (repr), NaN and infinities as strings."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        x = float(x)
        return x if math.isfinite(x) else repr(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    if x is None or isinstance(x, (str, int, bool)):
        return x
    return str(x)


def step_of(adapter, case) -> float:
    """The step a case runs at, by the adapter's one resolver (``posed``; before issue 45, ``dt_for``)."""
    if hasattr(adapter, "posed"):
        return float(adapter.posed(case).dt_s)
    return float(adapter.dt_for(case))


def _cells(adapter, block, ws, as_) -> list[dict]:
    try:
        from rockbench.engines.contract import Case
    except ImportError:   # the engines' layout before issue 45 (the base commit the record was made at)
        from rockbench.engines.base import Case
    from rockbench.reference_solver.model import a_ratio_to_amplitude, w_ratio_to_omega
    from rockbench.reference_solver.pulses import make_pulse
    from rockbench.reference_solver.restitution import Restitution

    grid = [(w, a) for a in as_ for w in ws]
    cases = [Case(block, make_pulse(PULSE, a_ratio_to_amplitude(block, a), w_ratio_to_omega(block, w)),
                  Restitution("housner")) for w, a in grid]
    steps = [step_of(adapter, c) for c in cases]
    out = []
    for (w, a), dt, r in zip(grid, steps, adapter.run_many(cases)):
        cell = {"w_ratio": w, "a_ratio": a, "dt_s": dt, **{k: getattr(r, k) for k in CELL_FIELDS}}
        diag = r.diagnostics or {}
        cell.update(steps=diag.get("steps"), ended_by=diag.get("ended_by"))
        out.append(_jsonable(cell))
    return out


def variants(engine: str, cls) -> dict:
    """The variants of ``engine``: name → (settings, ω/p values, a₀/(g·tanα) values)."""
    if "settings" not in cls.SETTINGS:   # not a contact engine (the reference): its defaults
        return {"default": ({}, W_RATIOS, A_RATIOS)}
    out = {"calibrated": ({"settings": "calibrated"}, W_RATIOS, A_RATIOS),
           "shipped": ({"settings": "shipped"}, W_RATIOS, A_RATIOS)}
    modes = getattr(cls, "supported_modes", None)
    if modes is not None:
        own = cls.SETTINGS
        for key in ("drive", "planar"):
            others = [v for v in modes(key) if v != own.get(key)]
            for v in others:
                out[f"shipped-{key}={str(v).lower()}"] = ({"settings": "shipped", key: v}, MODE_W, MODE_A)
    if engine in EXPLICIT:
        out["explicit-distributed"] = (dict(EXPLICIT[engine]), MODE_W, MODE_A)
    return out


def _cache_records() -> list:
    """Every calibration and step-rule record of the calibration cache, sorted."""
    root = Path(os.environ["ROCKBENCH_CACHE"]) / "calibration"
    recs = [json.loads(p.read_text()) for p in sorted(root.glob("*.json"))] if root.is_dir() else []
    return sorted((_jsonable(r) for r in recs), key=lambda r: json.dumps(r, sort_keys=True))


def compute(engine: str, cache_root: str) -> dict:
    """The yardstick figures of one engine (module docstring), its calibrations made in
    ``cache_root/<engine>`` (empty before: they are made afresh)."""
    from rockbench.engines.registry import adapter_class, get_adapter
    from rockbench.reference_solver.restitution import Restitution

    # each engine its own calibration cache, made afresh: the records below are this engine's alone
    os.environ["ROCKBENCH_CACHE"] = str(Path(cache_root) / engine)
    block = _block()
    cls = adapter_class(engine)
    out = {"engine": engine, "version": cls.version(), "block": BLOCK, "pulse": PULSE, "variants": {}}
    for name, (settings, ws, as_) in variants(engine, cls).items():
        t0 = time.perf_counter()
        ad = get_adapter(engine, **settings)
        rec = {"settings": _jsonable(settings)}
        try:
            rec["resolved"] = _jsonable(ad.resolve(block, Restitution("housner"), None))
        except Exception as e:  # noqa: BLE001 - recorded: run.json records it so too
            rec["resolved"] = {"error": f"{type(e).__name__}: {e}"}
        try:
            rec["cells"] = _cells(ad, block, ws, as_)
        except Exception as e:  # noqa: BLE001 - recorded: a map stops with it
            rec["cells"] = {"error": f"{type(e).__name__}: {e}"}
        out["variants"][name] = {**rec, "wall_s": time.perf_counter() - t0}
        print(f"{engine} {name}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    out["cache"] = _cache_records()
    return out


#: keys of a record that are words, compared apart (a note may be reworded)
WORDS = ("note", "shipped_note")

#: Record keys issue 45 renamed (old → new), per engine: MuJoCo's knob and cache said ``timeconst`` where
#: the setting is ``timeconst_s``
RENAMED = {"mujoco": {"timeconst": "timeconst_s"}, "mujoco_warp": {"timeconst": "timeconst_s"}}

#: Engines whose free-rocking figures may differ in the last digits, and why: MuJoCo's release moved to
#: the one start pose (``pivot_pose``: R·sin(α − θ) where MuJoCo computed b/2·(1 − cos θ) + h/2·sin θ,
#: the same position rounded differently, 1.7e-18 m on B3M) and its test to the one length (ceil,
#: where MuJoCo's own rounded: one sample more on B3M). Most of its candidates' η move in the 13th
#: digit; a bouncing one (time constant 2·Δt, damping ratio 0.5) in the 6th, and its per-impact spread
#: in the 4th. Every pick, step and cell stays exact.
ROUNDING = {"mujoco", "mujoco_warp"}
#: how far such figures may move: ``(relative, absolute)`` per field (η, its spread [-], the sink and
#: hop [m])
ROUNDED_FIELDS = {"eta": (1e-4, 0.0), "eta_measured": (1e-4, 0.0), "finer_eta": (1e-4, 0.0), "etas": (1e-4, 0.0),
                  "eta_std": (0.0, 1e-4), "sink_m": (0.0, 1e-8), "hop_m": (0.0, 1e-8)}


def _normal(engine: str, x):
    """A record in one shape, old or new: keys renamed (:data:`RENAMED`); Exudyn's model parameters
    (its settings and calibrations recorded impact model, restitution coefficient and the spheres'
    stiffness beside the settings before issue 45) as the settings they came from; MuJoCo's resolved
    contact ``corners`` (its record said so for ``auto``) as ``auto``."""
    if isinstance(x, list):
        return [_normal(engine, v) for v in x]
    if not isinstance(x, dict):
        return x
    out = {RENAMED.get(engine, {}).get(k, k): _normal(engine, v) for k, v in x.items()}
    if engine == "exudyn" and "impact_model" in out:
        out["contact_restitution"] = out["restitution_coefficient"] if out["impact_model"] == 2 else None
        out["contact_points"] = None if out.get("contact_points") == 2 else out.get("contact_points")
    if engine in ("mujoco", "mujoco_warp") and out.get("contact") in ("corners", "auto"):
        out.update(contact="auto", contact_radius_m=None)
    return out


def _cache_order(r) -> tuple:
    """A calibration or step-rule record's place among its engine's, the same old and new (its η to
    six digits, not the last)."""
    res = r.get("result") or {}
    return ("result" in r, res.get("eta_target", r.get("yardstick_dt_s") or 0.0), res.get("evaluations", 0),
            round(res.get("eta_measured", r.get("dt_s", 0.0)) or 0.0, 6))


def _same(a, b, key: str, engine: str) -> bool:
    if (engine in ROUNDING and key in ROUNDED_FIELDS and isinstance(a, float) and isinstance(b, float)
            and math.isfinite(a) and math.isfinite(b)):
        rtol, atol = ROUNDED_FIELDS[key]
        return math.isclose(a, b, rel_tol=rtol, abs_tol=atol)
    return a == b


def _diff(a, b, engine: str, path="", key="") -> list[str]:
    """The places where ``a`` (recorded) and ``b`` (now) differ, one line each; a key one side lacks
    is ``only recorded`` or ``only now``."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k in ("wall_s", "version"):
                continue
            if k not in a or k not in b:
                out.append(f"{path}/{k}: only {'recorded' if k in a else 'now'}")
                continue
            out += _diff(a[k], b[k], engine, f"{path}/{k}", k)
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: {len(a)} entries recorded, {len(b)} now"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _diff(x, y, engine, f"{path}[{i}]", key)]
    return [] if _same(a, b, key, engine) else [f"{path}: recorded {a!r}, now {b!r}"]


def compare(recorded: dict, now: dict) -> tuple[list[str], list[str], list[str]]:
    """``(differences, reworded notes, record shape)`` between a recorded yardstick and one computed now,
    both in one shape (:func:`_normal`, records paired by :func:`_cache_order`): a cell must be equal
    field by field, floats to the last digit; a record's values too (but the rounding of
    :data:`ROUNDING`); a key one record has and the other lacks is its shape (issue 45 dropped
    Exudyn's model parameters and MuJoCo's solver settings from calibration records, added the
    pick's sink and hop), listed apart, as are notes (words)."""
    engine = recorded["engine"]
    a, b = _normal(engine, recorded), _normal(engine, now)
    a["cache"], b["cache"] = sorted(a["cache"], key=_cache_order), sorted(b["cache"], key=_cache_order)
    diffs = _diff(a, b, engine)
    words = [d for d in diffs if d.split(":")[0].rsplit("/", 1)[-1] in WORDS]
    shape = [d for d in diffs if d.endswith((": only now", ": only recorded")) and "/cells" not in d and d not in words]
    return [d for d in diffs if d not in words and d not in shape], words, shape


def record_name(engine: str) -> str:
    return f"yardstick-{engine.replace('_', '-')}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("action", choices=("record", "compare"))
    ap.add_argument("engines", nargs="+")
    ap.add_argument("--keep", metavar="DIR", help="compare: keep what was computed in DIR/<engine>.json, and compare "
                    "what a file there holds instead of computing it again")
    args = ap.parse_args(argv)
    if "ROCKBENCH_CACHE" not in os.environ:
        ap.error("set ROCKBENCH_CACHE to an empty folder: the calibrations must be made afresh")
    bad, root = 0, os.environ["ROCKBENCH_CACHE"]
    for engine in args.engines:
        kept = Path(args.keep) / f"{engine}.json" if args.keep else None
        if kept is not None and kept.is_file():
            now = json.loads(kept.read_text())
        else:
            now = compute(engine, root)
            if kept is not None:
                kept.parent.mkdir(parents=True, exist_ok=True)
                kept.write_text(json.dumps(now))
        if args.action == "record":
            path = write_record(record_name(engine), f"The contract refactor's yardstick for {engine}: a 5 × 4 map "
                                "of B3M sine calibrated and as shipped (and as shipped in the other modes) and the "
                                "calibrations behind it, from an empty cache (tests/measurements/yardstick.py).",
                                f"ROCKBENCH_CACHE=$(mktemp -d) python tests/measurements/yardstick.py record {engine}",
                                now)
            print(path)
            continue
        diffs, words, added = compare(load(record_name(engine))["figures"], now)
        for tag, lines in (("DIFF ", diffs), ("WORDS", words), ("SHAPE", added)):
            for d in lines:
                print(f"{tag} {engine}{d}")
        print(f"{engine}: {len(diffs)} differences, {len(words)} notes reworded, {len(added)} record keys added or "
              "dropped")
        bad += bool(diffs)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
