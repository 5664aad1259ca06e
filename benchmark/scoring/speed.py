"""The speed stage's answer, score.json's ``speed``: each engine's accuracy against its cost at each time
step, what the time-step rule chose, and what the engine costs at matched accuracy (docs/speed.md, "The
accuracy–cost stage").

Pure functions of the speed maps' scored pairs and costs (the store reads them:
:func:`~rockbench.benchmark.store.loading.map_cost`); no file, no plotting.

- **A point** is one engine, calibrated at one step, on the stage's problems (one block per slenderness
  under one pulse by default): its accuracy the verdict's measure on them, the boundary distance's mean
  over the problems with its error from the grid alone (:func:`~.statistics.fixed`); its cost the CPU
  seconds per simulated second of block motion, the CPU time of every simulation of its maps (cells and
  the boundary's samples) over the time they simulated. An engine that ran on a GPU is costed by wall
  seconds instead (the device's time: its batch's wall time over its worlds), and its row says so.
- **The detectable difference** of a step from the engine's finest: the verdict's rule (the one-sided
  95 % critical value of the many-to-one comparison of every step with the finest, plus the normal's
  80 % quantile, times the paired difference's error) on the stage's own problems (:func:`detectable_from`).
- **Cost at matched accuracy**: per engine, the cheapest step whose distance lies (a) within that
  detectable difference of its finest step's, (b) within the declared :data:`MATCHED_DISTANCE` of the
  reference; "not reached" where no step does.
- **The time-step rule's choice** per block (the speed maps record it), and the point it makes: the
  blocks mapped at their chosen steps.
"""

from __future__ import annotations

import math
import statistics as _py

from rockbench.benchmark.scoring.labels import engine_name, short_version
from rockbench.benchmark.scoring.metrics import PRIMARY_METRIC
from rockbench.benchmark.scoring.scenarios import cluster_of, scenario_of
from rockbench.benchmark.scoring.statistics import CONFIDENCE, POWER, dunnett_critical, detectable, fixed, paired

#: The steps of the stage where a suite lists none [s]: the one time-step rule's ladder
#: (engines/calibration/step_rule.py), so the rule's choice lies on every curve. Coarser steps do not follow the
#: default grid's highest frequency (20 steps per wave at ω/p = 16 on B2M is 1.46 ms); a suite with a
#: lower frequency range may add them.
SPEED_STEPS_S = (1e-3, 5e-4, 2e-4, 1e-4)

#: The accuracy a step must reach for criterion (b), a boundary distance in the normalised plane (ω/p,
#: a0/(g·tanα)) where a suite declares none: a tenth of the cell diagonal of the 51 × 51 grid of the
#: full suite and of the earlier default suite (0.3 × 0.22, diagonal 0.372), a sixth of the mean η_H–η_M
#: reference gap (0.21), and twelve times the located boundaries' resolution on that grid (0.0031 root
#: mean square): a distance the suites resolve, and finer than what the physics itself knows.
MATCHED_DISTANCE = 0.037

#: ``rockbench compare`` flags an engine whose cost at matched accuracy rose by more than this factor
#: between two runs on like machines (its ``--cost-factor``; docs/scores.md argues it).
COST_RISE_FACTOR = 1.5

#: The cost's two units: CPU seconds per simulated second (a CPU engine), or the device's wall seconds
#: per simulated second (an engine that ran on a GPU).
CPU_COST, GPU_COST = "CPU s per simulated s", "GPU wall s per simulated s"


# -- points --------------------------------------------------------------------------------------------

def point(dt_s: float, pairs: list[dict], costs: list[dict], on_gpu: bool) -> dict:
    """One engine at one step: its distance on the stage's problems (``pairs``: the like-for-like pairs of
    its maps) and its cost (``costs``: :func:`~rockbench.benchmark.store.loading.map_cost` of each map)."""
    items = {(p["block"], p["pulse"]): _item(p) for p in pairs}
    e = fixed([it for it in items.values() if math.isfinite(it[0])])
    sims = sum(c["simulations"] for c in costs)
    costed = sum(c["costed"] for c in costs)
    simulated = sum(c["simulated_s"] for c in costs)
    cpu, wall = sum(c["cpu_s"] for c in costs), sum(c["wall_s"] for c in costs)
    per = (wall if on_gpu else cpu) / simulated if simulated > 0 else None
    return {"dt_s": dt_s, "value": None if not e["items"] else e["mean"], "se": None if not e["items"] else e["se"],
            "ci95": e["ci95"], "scenarios": e["items"], "clusters": e["clusters"],
            "per_scenario": [{"block": b, "pulse": q, "value": _num(items[(b, q)][0])} for b, q in sorted(items)],
            "cost": per, "cpu_per_simulated_s": cpu / simulated if simulated > 0 else None,
            "wall_per_simulated_s": wall / simulated if simulated > 0 else None, "cpu_s": cpu, "wall_s": wall,
            "simulated_s": simulated, "simulations": sims, "costed": costed,
            "complete": all(p.get("complete", True) for p in pairs) and costed == sims,
            "_items": items}


def _item(p: dict) -> tuple:
    s = scenario_of(p)
    return (s.value, s.sd, cluster_of(p))


def _num(x):
    return x if x is not None and math.isfinite(x) else None


def detectable_from(points: list[dict]) -> dict | None:
    """The smallest difference from the finest step the stage could detect for one engine (module
    docstring): ``value``, the ``critical`` value and the paired error ``pair_se`` it rests on, the
    ``comparisons`` made; None with fewer than two steps that have a value."""
    have = [p for p in points if p["value"] is not None]
    if len(have) < 2:
        return None
    finest = min(have, key=lambda p: p["dt_s"])
    var_f = finest["se"] ** 2
    ses = [paired(p["_items"], finest["_items"])["se"] for p in have if p is not finest]
    ses = [s for s in ses if s is not None and s > 0]
    if not ses:
        return None
    q = dunnett_critical([math.sqrt(var_f) / s for s in ses])
    se = _py.median(ses)
    return {"value": detectable(q, se), "critical": q, "pair_se": se, "comparisons": len(ses), "power": POWER,
            "confidence": CONFIDENCE}


def matched(points: list[dict], mdd: dict | None, distance: float) -> dict:
    """Cost at matched accuracy: the finest step, and the cheapest step (a) ``within_mdd`` of the finest
    step's distance, (b) ``within_distance`` of the reference; None for "not reached". Only points with a
    value and a cost take part."""
    have = [p for p in points if p["value"] is not None and p["cost"] is not None]
    if not have:
        return {"finest": None, "within_mdd": None, "within_distance": None}
    finest = min(have, key=lambda p: p["dt_s"])

    def cheapest(ok) -> dict | None:
        hits = [p for p in have if ok(p)]
        if not hits:
            return None
        best = min(hits, key=lambda p: (p["cost"], -p["dt_s"]))
        return {"dt_s": best["dt_s"], "value": best["value"], "cost": best["cost"],
                "speedup_vs_finest": finest["cost"] / best["cost"] if best["cost"] > 0 else None}

    limit = finest["value"] + mdd["value"] if mdd else finest["value"]
    return {"finest": {"dt_s": finest["dt_s"], "value": finest["value"], "cost": finest["cost"]},
            "within_mdd": cheapest(lambda p: p["value"] <= limit), "mdd_limit": limit,
            "within_distance": cheapest(lambda p: p["value"] <= distance)}


def rule_point(points: list[dict], chosen: dict, pairs_at: dict, costs_at: dict, on_gpu: bool) -> dict | None:
    """The point of the time-step rule's choice: each block (``chosen``: ``{block: step [s]}``) at its own
    step, from the stage's maps at that step (``pairs_at`` / ``costs_at``: ``{(block, step): [...]}``);
    ``on_curve`` the step when every block chose the same one. None when the rule's choice is not known
    for every block; without a value or a cost (``outside``) where a chosen step is not one of the stage's."""
    if not chosen or any(v is None for v in chosen.values()):
        return None
    pairs, costs = [], []
    for block, dt in chosen.items():
        if (block, dt) not in pairs_at:
            return {"per_block": dict(chosen), "steps_s": sorted(set(chosen.values()), reverse=True),
                    "on_curve": None, "value": None, "se": None, "cost": None, "scenarios": 0, "outside": True}
        pairs += pairs_at[(block, dt)]
        costs += costs_at.get((block, dt), [])
    p = point(math.nan, pairs, costs, on_gpu)
    steps = sorted(set(chosen.values()), reverse=True)
    on = steps[0] if len(steps) == 1 and any(q["dt_s"] == steps[0] for q in points) else None
    return {"per_block": dict(chosen), "steps_s": steps, "on_curve": on, "value": p["value"], "se": p["se"],
            "cost": p["cost"], "scenarios": p["scenarios"]}


def public(p: dict) -> dict:
    """A point as score.json holds it (its working items left out)."""
    return {k: v for k, v in p.items() if not k.startswith("_")}


# -- the section -----------------------------------------------------------------------------------------

def engine_row(engine: str, version: str | None, device: dict, by_step: dict, chosen: dict, distance: float,
               costs_of, verdict_mdd: float | None = None) -> dict:
    """One engine of the section: its points by step (``by_step``: ``{step: [(pair, map dir)]}``), the stage's
    own detectable difference, the ``band`` criterion (a) and the picture use (:func:`band`), its cost at
    matched accuracy and the rule's point (``chosen``: ``{block: step}``; ``costs_of``: map dir → its cost)."""
    on_gpu = device.get("runs_on") == "gpu"
    pts, pairs_at, costs_at = [], {}, {}
    for dt in sorted(by_step, reverse=True):
        pairs = [p for p, _ in by_step[dt]]
        costs = [costs_of(d) for _, d in by_step[dt]]
        pts.append(point(dt, pairs, costs, on_gpu))
        for (p, d), c in zip(by_step[dt], costs):
            pairs_at.setdefault((p["block"], dt), []).append(p)
            costs_at.setdefault((p["block"], dt), []).append(c)
    mdd = detectable_from(pts)
    b = band(verdict_mdd, mdd)
    head = engine_name(engine) + (f" {short_version(version)}" if version else "")
    return {"engine": engine, "label": head, "version": version, "device": device,
            "cost_unit": GPU_COST if on_gpu else CPU_COST, "points": [public(p) for p in pts], "mdd": mdd,
            "band": b, "matched": matched(pts, b, distance),
            "rule": rule_point(pts, chosen, pairs_at, costs_at, on_gpu)}


def band(verdict_mdd: float | None, stage_mdd: dict | None) -> dict | None:
    """The detectable difference criterion (a) and the picture's band use: the verdict's (score.json's
    ``verdict.mcb.calibrated.mdd``, between the run's calibrated variants) where the run has one, else the
    stage's own for the engine (:func:`detectable_from`; a run of the speed stage alone has no verdict
    variants); ``source`` says which. None where neither is known."""
    if verdict_mdd is not None and math.isfinite(verdict_mdd):
        return {"value": float(verdict_mdd), "source": "verdict"}
    if stage_mdd:
        return {"value": stage_mdd["value"], "source": "stage"}
    return None


def section(rows: list[dict], declared: dict, machines: list[dict], absent: list[dict],
            verdict_mdd: float | None) -> dict:
    """score.json's ``speed``: the engines' rows (:func:`engine_row`), what the stage declared (``steps_s``,
    ``blocks``, ``pulses``, ``matched_distance``), the machine(s) it ran on, the engines meant for a GPU
    that are absent and why, and the verdict's own detectable difference beside the stage's."""
    return {"metric": PRIMARY_METRIC, "declared": declared, "machine": machines[0] if len(machines) == 1 else None,
            "machines": machines, "engines": rows, "absent": absent,
            "mdd": _py.median([r["mdd"]["value"] for r in rows if r["mdd"]]) if any(r["mdd"] for r in rows) else None,
            "verdict_mdd": verdict_mdd,
            "method": ("each point: the engine calibrated at one step on the stage's problems, its boundary distance "
                       "averaged over them and its CPU time over the time it simulated; matched accuracy: the cheapest "
                       "step within the detectable difference (80 % power, 95 % many-to-one comparisons with the "
                       "finest step) of its finest step's distance, and the cheapest within the declared distance")}


# -- compare ---------------------------------------------------------------------------------------------

#: What must be equal of two runs' machines for their costs to be compared.
MACHINE_KEYS = ("cpu_model", "cores_usable", "threads_per_worker")


def compare_speed(base: dict | None, cur: dict | None, factor: float = COST_RISE_FACTOR) -> dict | None:
    """The speed sections of two runs side by side: each engine's cost at matched accuracy (both
    criteria), flagged where it rose by more than ``factor`` or is no longer reached, on like machines
    only (:data:`MACHINE_KEYS`); a note where the machines differ. None when either run has no stage."""
    if not base or not cur:
        return None
    out = {"factor": factor, "flags": [], "rows": [], "notes": []}
    mb, mc = base.get("machine"), cur.get("machine")
    alike = bool(mb and mc) and all(mb.get(k) == mc.get(k) for k in MACHINE_KEYS)
    if not alike:
        out["notes"].append(f"costs not compared: the runs were timed on other machines ({_machine_words(mb)} and "
                            f"{_machine_words(mc)}); cost is machine-dependent, compare runs of one machine")
    b = {r["engine"]: r for r in base.get("engines", [])}
    for r in cur.get("engines", []):
        old = b.get(r["engine"])
        if old is None or old.get("cost_unit") != r.get("cost_unit"):
            continue
        for crit in ("within_mdd", "within_distance"):
            row = _compare_one(r, old, crit, factor)
            out["rows"].append(row)
            if alike and row["flag"]:
                out["flags"].append(row)
    return out


def _compare_one(cur: dict, base: dict, crit: str, factor: float) -> dict:
    was, now = (base.get("matched") or {}).get(crit), (cur.get("matched") or {}).get(crit)
    ratio = now["cost"] / was["cost"] if was and now and was["cost"] else None
    if was and not now:
        why = "no longer reached"
    elif ratio is not None and ratio > factor:
        why = f"cost rose {ratio:.2f}-fold (more than {factor:g})"
    else:
        why = ""
    return {"engine": cur["engine"], "criterion": crit, "baseline": was, "current": now, "ratio": ratio,
            "flag": bool(why), "why": why}


def _machine_words(m: dict | None) -> str:
    if not m:
        return "an unrecorded machine"
    return f"{m.get('cpu_model')}, {m.get('cores_usable')} cores, {m.get('threads_per_worker')} thread(s) a worker"
