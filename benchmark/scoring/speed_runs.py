"""The speed stage of run folders: its maps (those whose run.json names the stage) scored like any map
against the references of their run, their costs read from their tables, and score.json's ``speed``
section made of them (:mod:`.speed`). The verdict never sees these maps: one rule,
:attr:`~rockbench.benchmark.store.loading.MapEntry.in_speed_stage`, keeps them apart wherever maps are
scored (``rockbench run``, ``score``, ``report``)."""

from __future__ import annotations

from pathlib import Path

from rockbench.benchmark.engine_info.versions import version_of
from rockbench.benchmark.store.files import read_json, variant_name
from rockbench.benchmark.store.loading import MapEntry, map_cost
from rockbench.benchmark.scoring.speed import MATCHED_DISTANCE, SPEED_STEPS_S, engine_row, section

#: The file at the top of a run folder that says what the speed stage declared and which engines meant for
#: a GPU it left out (written by ``rockbench run`` before the stage's maps).
SPEED_FILE = "speed.json"


def split(candidates: list[MapEntry]) -> tuple[list[MapEntry], list[MapEntry]]:
    """``(the verdict's maps, the speed stage's maps)``."""
    return [c for c in candidates if not c.in_speed_stage], [c for c in candidates if c.in_speed_stage]


def stage_record(folders) -> dict:
    """What the run wrote in its speed.json: the first found in ``folders`` (a run's folders,
    :func:`~.score_runs.run_folders`), {} where none is."""
    for folder in folders:
        f = Path(folder) / SPEED_FILE
        if f.is_file():
            return read_json(f)
    return {}


def speed_section(entries: list[MapEntry], pairs: list[dict], record: dict, verdict_mdd: float | None) -> dict:
    """score.json's ``speed`` for the speed maps ``entries`` and their scored ``pairs`` (like for like:
    each map against the reference of its own restitution), with the run's ``record`` (speed.json) and the
    verdict's calibrated class's detectable difference."""
    like = {p["engine_dir"]: p for p in pairs if p["like_for_like"]}
    groups: dict = {}
    for e in entries:
        p = like.get(str(e.path))
        if p is None or e.dt_s is None:
            continue
        base = variant_name(e.engine, e.settings)
        g = groups.setdefault(base, {"engine": e.engine, "version": version_of(e), "by_step": {}, "chosen": {},
                                     "device": e.stage.get("device") or {"runs_on": "cpu", "note": ""}})
        g["by_step"].setdefault(float(e.dt_s), []).append((p, e.path))
        rule = e.stage.get("step_rule") or {}
        g["chosen"].setdefault(e.block, rule.get("dt_s") if isinstance(rule.get("dt_s"), (int, float)) else None)
    declared = record.get("declared") or {"steps_s": list(SPEED_STEPS_S), "matched_distance": MATCHED_DISTANCE,
                                          "source": "the code's defaults: the run has no speed.json"}
    distance = float(declared.get("matched_distance", MATCHED_DISTANCE))
    costs: dict = {}

    def cost_of(d):
        if d not in costs:
            costs[d] = map_cost(d)
        return costs[d]

    rows = []
    for g in groups.values():
        by_step, unmapped = whole_steps(g["by_step"], declared)
        rows.append({**engine_row(g["engine"], g["version"], g["device"], by_step, g["chosen"], distance, cost_of,
                                  verdict_mdd), "unmapped": unmapped})
    rows.sort(key=lambda r: r["label"])
    return section(rows, declared, _machines(entries), list(record.get("absent") or []), verdict_mdd)


def whole_steps(by_step: dict, declared: dict) -> tuple[dict, list[dict]]:
    """The steps an engine mapped on every problem the stage declared (``by_step``: ``{step: [(pair, map
    dir)]}``), and the declared steps it did not: ``{"dt_s", "blocks"}``, the blocks mapped at that step
    (none, or some: a run stopped midway). A point is a mean over the stage's problems, so a step mapped
    on some of them only would be a mean over other problems than its neighbours': it is not a point."""
    blocks = set(declared.get("blocks") or [])
    whole, unmapped = {}, []
    for dt in sorted(set(by_step) | {float(x) for x in declared.get("steps_s", [])}, reverse=True):
        have = {p["block"] for p, _ in by_step.get(dt, [])}
        if dt in by_step and blocks <= have:
            whole[dt] = by_step[dt]
        else:
            unmapped.append({"dt_s": dt, "blocks": sorted(have)})
    return whole, unmapped


def _machines(entries: list[MapEntry]) -> list[dict]:
    """The distinct machines the speed maps ran on: CPU model, cores, and each worker's threads."""
    out = []
    for e in entries:
        m = dict((e.run.get("machine") or {}))
        ex = ((e.run.get("options") or {}).get("executor") or {})
        m = {"cpu_model": m.get("cpu_model") or m.get("processor"), "cpu_count": m.get("cpu_count"),
             "cores_usable": m.get("cores_usable", m.get("cpu_count")),
             "threads_per_worker": ex.get("threads_per_worker", ex.get("threads"))}
        if m not in out:
            out.append(m)
    return out
