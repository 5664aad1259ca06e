"""From run directories to scores: pair engines with references, score, check and compare score.json.

This is the glue between the run folders (found and read by :mod:`rockbench.benchmark.store.loading`) and
the pure metrics of :mod:`rockbench.benchmark.scoring.metrics`; the ``score``, ``compare``, ``report`` and
``run`` commands call it.

Pairing rule. Every map whose engine is not ``reference`` is scored against every reference map of
the same block and pulse over the same grid (Housner, modified with the average k, modified with
the exact k, a constant η, whatever was computed) **of its own run**: each RUN_DIR given is one run
(or, below it, each folder written by ``rockbench run``, the one holding ``suite.json``), so
several runs scored together are not cross-paired. An engine map whose run has no reference map of
its block and pulse is paired with those of the other runs given, and a note says so
(:func:`pair_within_runs`). With ``against=`` the maps found there are the references and *every*
map of the run directories is scored against them (so a reference map can be compared with another
reference map, e.g. at half the time step). A pair is *like for like* when both maps use the same
restitution law; gates (``--fail-under``) apply to like-for-like pairs, or to all pairs of an engine
map that has none.

Tolerances of ``compare`` are stated in cells (:data:`DEFAULT_TOLERANCE_CELLS`): what that many
flipped cells can change in each metric on the pair's own grid (:func:`cell_units`), never less
than the metric's absolute default, so a one-cell change on a coarse grid is not a regression.

A reference map must be complete for its grid: every cell simulated, or (adaptive maps) inferred by
its own fill rule. An unfinished one is refused (:class:`IncomparableError`, exit 5, naming what is
missing) rather than scored on the cells it happens to have. An engine map must be complete too
(:func:`check_complete`: cells neither simulated nor inferred, or fewer rows in cells.csv than its
run.json says it finished with): it is refused with exit 2 naming the map, the cells missing and the
command that completes it, unless ``allow_incomplete``; then its pair is scored on the cells it has
and marked ``"complete": false`` with ``cells_missing``.

The document's ``verdict`` (:mod:`rockbench.benchmark.scoring.verdict`) ranks the variants by the primary
metric with 95 % intervals and ties, and says in words which are closest and which fail.
"""

from __future__ import annotations

import hashlib
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import numpy as np

from rockbench.reference_solver.errors import ConfigError

from rockbench.benchmark.errors import IncomparableError
from rockbench.reference_solver.rules import RULES_VERSION, rules_mismatch
from rockbench.reference_solver.pulses import is_number
from rockbench.benchmark.blocks.presets import PRESETS, TABLE_1
from rockbench.benchmark.engine_info.versions import version_of
from rockbench.benchmark.maps.result import MapResult
from rockbench.benchmark.store.files import read_json, stored_variant, utc_stamp, variant_name
from rockbench.benchmark.store.loading import MapEntry, find_map_dirs, grid_of, load_entries, load_entry, load_own_eta
from rockbench.benchmark.scoring.experiments import score_outcomes
from rockbench.benchmark.scoring.labels import CALIBRATED, PLANTED_SETTING, settings_class, variant_labels
from rockbench.benchmark.scoring.metrics import (FAILED, METRICS, METRICS_VERSION, OVERTURN, boundary_edges, cell_counts, check_gate,
                      judged_cells, located_counts, score)
from rockbench.benchmark.scoring.declared import Declared, declared_of_runs
from rockbench.benchmark.scoring.speed import COST_RISE_FACTOR, compare_speed
from rockbench.benchmark.scoring.speed_runs import speed_section, split, stage_record
from rockbench.benchmark.scoring.scores import SCORE_KIND, SCORE_SCHEMA_VERSION, Scores, pair_key
from rockbench.benchmark.scoring.verdict import verdict

# -- scoring ---------------------------------------------------------------------------------------

def score_entries(candidates: list[MapEntry], references: list[MapEntry], experiments=None,
                  own_eta: dict | None = None, pair_with=None, allow_incomplete=False,
                  declared: Declared | None = None, speed_record: dict | None = None,
                  runs: "RunMaps | None" = None) -> Scores:
    """Score every candidate against every reference of its block and pulse (see the module docstring).

    Parameters
    ----------
    candidates, references : list of MapEntry
        Maps to score, and maps to score them against.
    experiments : list of OutcomePoint, optional
        Shaking-table points; every map (candidates and references) of a preset block is scored
        against them.
    own_eta : dict, optional
        ``{(variant, block): η}``: each engine variant's restitution measured in free rocking [-]. A
        reference map with that constant η (to 4 decimals) is the engine's *own-η* reference: it
        isolates the engine's integration and contact error from its energy-loss model.
    pair_with : callable, optional
        ``pair_with(candidate)`` → the references that candidate may be paired with (default: all
        of ``references``); :func:`pair_within_runs` makes one that keeps runs apart.
    allow_incomplete : bool or collection of Path
        Score engine maps that lack cells on the cells they have (marked in their pairs) instead of
        refusing them: every such map (True), or those of these map directories (``rockbench run``
        passes the maps of an engine that could not simulate, so its report still comes out).
    declared : Declared, optional
        The suite's declarations for the verdict (default: the code's, the default suite's).
    speed_record : dict, optional
        What the run's speed stage declared (its speed.json, :func:`~.speed_runs.stage_record`).
    runs : RunMaps, optional
        The runs the maps were loaded from (:func:`load_run_maps`): each pair is marked with its run and the
        scores say how maps were paired (``pairing``, :func:`mark_runs`).

    Returns
    -------
    Scores
        Whose score.json document (:meth:`~.scores.Scores.to_json`) holds ``kind``, ``schema_version``, ``metrics_version``, ``metrics``
        (definitions), ``created_utc``, ``pairs`` (one per scored pair, with ``key``, the maps,
        ``like_for_like``, ``scores``), ``skipped`` (pairs on different grids, with the reason),
        ``experiments`` (per map, when given), ``verdict``, and ``speed`` where the candidates hold
        maps of a speed stage (:mod:`.speed`; they are scored there and kept out of ``pairs`` and the
        verdict), and ``pairing`` with ``runs``.

    Raises
    ------
    ConfigError
        An engine map lacks cells and ``allow_incomplete`` is False.
    IncomparableError
        No candidate has a reference of its block and pulse on its grid.
    """
    candidates, speed_maps = split(candidates)
    pairs, skipped = _pairs_of(candidates, references, pair_with, own_eta, allow_incomplete)
    speed_pairs, speed_skipped = _pairs_of(speed_maps, references, pair_with, own_eta, allow_incomplete)
    skipped += speed_skipped
    if not pairs and not speed_pairs:
        _nothing_paired(bool(candidates or speed_maps), skipped)
    pairs.sort(key=lambda p: p["key"])
    pairing = None if runs is None else mark_runs(pairs, runs.run_of, against=runs.against, notes=runs.notes)
    doc = {"kind": SCORE_KIND, "schema_version": SCORE_SCHEMA_VERSION, "metrics_version": METRICS_VERSION,
           "rules_version": RULES_VERSION, "created_utc": utc_stamp(),
           "metrics": [m.to_dict() for m in METRICS.values()], "pairs": pairs, "skipped": skipped,
           "reference_gaps": reference_gaps(references)}
    if experiments is not None:
        doc["experiments"] = score_experiments(list(candidates) + [r for r in references if r not in candidates],
                                               experiments)
    doc["verdict"] = verdict(doc, declared)
    if speed_maps:
        mdd = ((doc["verdict"].get("mcb") or {}).get(CALIBRATED) or {}).get("mdd")
        doc["speed"] = speed_section(speed_maps, speed_pairs, speed_record or {}, mdd)
    if pairing is not None:
        doc["pairing"] = pairing
    return Scores.from_json(doc)


def _nothing_paired(any_engine_map: bool, skipped: list) -> None:
    """The IncomparableError of a scoring in which no engine map found a reference: why, and what to do."""
    if not any_engine_map:
        raise IncomparableError("nothing to score: the run directories hold only reference maps; give engine "
                                "maps, or --against REF_DIR to score these maps against others.")
    why = (f"{len(skipped)} candidate pair(s) lie on different grids" if skipped else
           "no reference map of the same block and pulse")
    raise IncomparableError(f"no engine map could be paired with a reference map ({why}); compute the "
                            "reference with the same block, pulse, --w-ratio and --a-ratio "
                            "(or pass it with --against).")


def _pairs_of(candidates: list[MapEntry], references: list[MapEntry], pair_with, own_eta, allow_incomplete):
    """``(scored pairs, pairs skipped for their grids)`` of ``candidates`` against their references."""
    labels = variant_labels(candidates)
    pairs, skipped = [], []
    for c in candidates:
        check_complete(c, allow_incomplete)
        check_rules(c)
        for r in (references if pair_with is None else pair_with(c)):
            if r.path == c.path or (r.block, r.pulse) != (c.block, c.pulse):
                continue
            check_complete(r, reference=True)
            check_rules(r)
            if not c.map.same_axes(r.map):
                skipped.append({"engine_dir": str(c.path), "reference_dir": str(r.path),
                                "reason": "different grids", "engine_grid": grid_of(c.map),
                                "reference_grid": grid_of(r.map)})
                continue
            pairs.append(scored_pair(c, r, labels[c.variant], own_eta))
    return pairs, skipped


def scored_pair(c: MapEntry, r: MapEntry, label: str, own_eta: dict | None) -> dict:
    """One pair of score.json: the engine map ``c`` (shown as ``label``) scored against the reference
    map ``r``, with what the scores rest on."""
    if c.restitution == r.restitution:
        kind = "same-law"
    elif at_own_eta(r, c, own_eta):
        kind = "own-eta"
    else:
        kind = "other"
    planted = PLANTED_SETTING in (c.settings or {})
    p = {"variant": c.variant, "engine": c.engine, "label": label,
         "settings": c.variant if c.is_reference and not planted else settings_class(c.settings, c.variant, c.engine),
         "block": c.block, "pulse": c.pulse, "restitution": c.restitution, "eta": c.eta, "engine_dir": str(c.path),
         "reference": {"restitution": r.restitution, "eta": r.eta, "dir": str(r.path), "kind": kind},
         "like_for_like": c.restitution == r.restitution, "grid": grid_of(c.map),
         "filled_cells": c.map.filled, **cell_counts(c.map, r.map),
         "cells": grid_cells(c.map, r.map), "scores": score(c.map, r.map)}
    # the map's own count (run.json against cells.csv) can see rows the grid's fill hides
    p["cells_missing"] = max(p["cells_missing"], int(c.map.meta.get("missing_cells", 0)))
    p["complete"] = p["cells_missing"] == 0
    p["engine_version"] = version_of(c)    # from the map's run.json (engine_versions.py)
    p.update(map_facts(c))
    p["key"] = pair_key(p)
    return p


def map_facts(c: MapEntry) -> dict:
    """What the verdict reads of an engine map beside its scores: its block's ``slenderness`` (h/b,
    the cluster it replicates in), a fingerprint of its outcomes (``engine_cells``: equal in two maps
    of one grid when they hold the same cells), and from its run.json, when the adapter wrote them,
    ``shipped_note`` (``engine.resolved_settings.shipped_note``: a line about its shipped settings),
    ``equals_shipped`` (``...calibration.equals_shipped``: the calibration picked the shipped
    settings) and ``held_out`` (``...calibration.calibrated_on`` names another block), with
    ``in_sample_variant``: the variant of the same settings calibrated on each block itself, which the
    held-out check sets it beside; and ``planted_eta_factor`` of a planted variant (the reference solver
    with its restitution × that factor: the suite's power)."""
    block = _obj(_obj(c.run).get("spec")).get("block")
    try:
        slender = round(float(block["height_m"]) / float(block["width_m"]), 4)
    except (KeyError, TypeError, ValueError, ZeroDivisionError):
        slender = None
    if slender is not None and not (math.isfinite(slender) and slender > 0):
        slender = None
    out = np.ascontiguousarray(c.map.outcome, dtype=np.int8)
    resolved = _obj(_obj(_obj(c.run).get("engine")).get("resolved_settings"))
    cal = _obj(resolved.get("calibration"))
    on = cal.get("calibrated_on") if isinstance(cal.get("calibrated_on"), str) else None
    facts = {"slenderness": slender,
             "engine_cells": hashlib.sha1(out.tobytes() + str(out.shape).encode()).hexdigest()[:16],
             "held_out": bool(on) and str(on).upper() != str(c.block).upper()}
    if isinstance(resolved.get("shipped_note"), str) and resolved["shipped_note"].strip():
        facts["shipped_note"] = resolved["shipped_note"].strip()
    if cal.get("equals_shipped") is True:
        facts["equals_shipped"] = True
    if on:
        facts["calibrated_on"] = str(on)
    factor = (c.settings or {}).get(PLANTED_SETTING)
    if isinstance(factor, (int, float)) and not isinstance(factor, bool):
        facts[PLANTED_SETTING] = float(factor)
    if facts["held_out"]:
        facts["in_sample_variant"] = variant_name(c.engine, {k: v for k, v in (c.settings or {}).items()
                                                             if k != "calibrate_on"}, c.dt_s)
    return facts


def _obj(x) -> dict:
    """``x`` when it is a JSON object, else an empty one (run.json is read defensively: absent or
    damaged keys are normal)."""
    return x if isinstance(x, dict) else {}


def reference_gaps(references: list[MapEntry]) -> list[dict]:
    """Per block and pulse of a Table 1 block, the distance between the overturning boundaries of its
    η_H reference map and its η_M reference map with the size's average k (the physics' own uncertainty
    about the restitution: the verdict's scale), judged on the η_H map's domain."""
    out, seen = [], set()
    for h in references:
        pre = PRESETS.get(str(h.block).upper())
        if h.restitution != "housner" or pre is None or (h.block, h.pulse) in seen:
            continue
        for m in references:
            k = re.fullmatch(r"modified\(k=([0-9.]+)\)", str(m.restitution))
            if ((m.block, m.pulse) == (h.block, h.pulse) and k and pre.which_k(float(k.group(1))) == "average"
                    and m.map.same_axes(h.map)):
                out.append({"block": h.block, "pulse": h.pulse, "between": [h.restitution, m.restitution],
                            "boundary_mean": score(m.map, h.map)["boundary_mean"]})
                seen.add((h.block, h.pulse))
                break
    return out


#: What ``score``, ``report`` and ``compare`` take to score incomplete engine maps anyway, and its help.
ALLOW_INCOMPLETE = "--allow-incomplete"
ALLOW_INCOMPLETE_HELP = ("score engine maps that lack cells (cut, emptied or deleted cells.csv, an unfinished run) on "
                         "the cells they have, marked incomplete, instead of exiting 2")


def check_complete(entry: MapEntry, allow_incomplete=False, *, reference: bool = False) -> None:
    """Refuse a map that does not cover its grid (module docstring): a map scored against as the
    ``reference`` always, a map being scored (an engine map) unless ``allow_incomplete``.

    Raises
    ------
    IncomparableError
        A reference's cells are neither simulated nor inferred by its own fill rule.
    ConfigError
        The same of a map being scored, or fewer rows than its run.json says it finished with.
    """
    missing = int(entry.map.meta.get("missing_cells", 0))
    allowed = allow_incomplete is True or (not isinstance(allow_incomplete, bool)
                                           and Path(entry.path) in {Path(d) for d in allow_incomplete})
    if not missing or (allowed and not reference):
        return
    n = entry.map.outcome.size
    what = f"{missing} of its {n} cells are missing (cut, emptied or deleted cells.csv, or an unfinished run)"
    if reference:
        raise IncomparableError(f"the reference map {str(entry.path)!r} is incomplete: {what}; finish it ("
                                f"{completing_command(entry.path)}) before scoring against it.")
    raise ConfigError(f"the {'reference' if entry.is_reference else 'engine'} map {str(entry.path)!r} is "
                      f"incomplete: {what}; complete it with "
                      f"{completing_command(entry.path)}, or score what is there with {ALLOW_INCOMPLETE}.")


def check_rules(entry: MapEntry) -> None:
    """Refuse a map this rockbench's store wrote under another rule set
    (:mod:`~rockbench.reference_solver.rules`); a map from elsewhere (a bare cells.csv) has none.

    Raises
    ------
    IncomparableError
        Its run.json records another ``rules_version`` (or none: made before version 2).
    """
    if entry.run.get("kind") != "rockbench-map":
        return
    stale = rules_mismatch(entry.run.get("rules_version"), f"the map {str(entry.path)!r}")
    if stale:
        raise IncomparableError(f"{stale}; compute it again ({completing_command(entry.path)} in a new or "
                                "emptied folder) before scoring it.")


def completing_command(map_dir: Path) -> str:
    """The command that completes a map: the same ``rockbench run`` for a map of a run folder (it resumes
    and recomputes what is missing), else the same ``rockbench map ... --out DIR``."""
    d = Path(map_dir)
    runs = [q for q in d.parents if (q / "suite.json").is_file()]
    if runs or d.parent.parent.name == "maps":   # <run>/maps/<variant>/<case>: a `rockbench run` output
        run = runs[0] if runs else d.parent.parent.parent
        return f"`rockbench run --out {run}` with the suite it was run with"
    return f"the `rockbench map` that wrote it, with --out {map_dir}"


def at_own_eta(reference: MapEntry, candidate: MapEntry, own_eta: dict | None) -> bool:
    """Whether ``reference`` is a constant-η map at ``candidate``'s own measured η (``own_eta`` as
    from :func:`load_own_eta`; the maps of ``rockbench run`` name that η to 4 decimals)."""
    own = (own_eta or {}).get((candidate.variant, candidate.block))
    return own is not None and is_number(reference.restitution) and abs(reference.eta - own) < 5e-5


def score_experiments(entries: list[MapEntry], points) -> list[dict]:
    """Each map of a Table 1 block (the experiments' blocks) scored against the experimental points of its
    block and pulse."""
    out = []
    for e in entries:
        if e.block.upper() not in TABLE_1:
            continue
        s = score_outcomes(points, e.map, e.block, e.pulse)
        if s["points"]:
            out.append({"variant": e.variant, "restitution": e.restitution, "dir": str(e.path), **s})
    return out


@dataclass(frozen=True)
class RunMaps:
    """The maps of one or more runs as scoring reads them (:func:`load_run_maps`): every map found
    (``entries``) with its run (``run_of``: map directory → run), the engine maps to score
    (``candidates``) and the references (``references``: those of the runs, or those given with
    ``against``), which references each candidate may be paired with (``pair_with``, None: any) and the
    notes of that pairing, the engine variants' own η and the speed stage's record read from the runs'
    folders (:func:`run_folders`), and the verdict's declarations."""

    entries: list
    run_of: dict
    candidates: list
    references: list
    against: bool
    pair_with: object
    notes: tuple
    own_eta: dict
    speed_record: dict
    declared: Declared


def run_folders(roots: Iterable) -> list[Path]:
    """Where a run's own files are read from (calibration.json: its engines' own η; speed.json: its
    speed stage): each run's folder (:func:`load_runs`) and the folder just above it, since
    ``rockbench run`` scores its ``maps`` folder. One rule for every command that scores."""
    return list(dict.fromkeys(q for r in roots for q in (Path(r), Path(r).parent)))


def load_run_maps(run_dirs: Iterable, against: Iterable | None = None, declared: Declared | None = None) -> RunMaps:
    """The maps under ``run_dirs`` (and the references under ``against``) ready to score (:func:`score_run`):
    each engine map is paired with the reference maps of its own run (see the module docstring). The
    verdict's declarations are ``declared``, else those of the suite each run recorded in its suite.json
    (:func:`~rockbench.benchmark.scoring.declared.declared_of_runs`)."""
    entries, run_of = load_runs(list(run_dirs))
    if against:
        refs, cands = load_entries(against), entries
        pair_with, notes = None, []
    else:
        refs = [e for e in entries if e.is_reference]
        cands = [e for e in entries if not e.is_reference]
        pair_with, notes = pair_within_runs(cands, refs, run_of)
    folders = run_folders(run_of.values())
    return RunMaps(entries, run_of, cands, refs, bool(against), pair_with, tuple(notes), load_own_eta(folders),
                   stage_record(folders), declared or declared_of_runs(run_of.values()))


def score_run(maps: RunMaps, experiments=None, allow_incomplete=False) -> Scores:
    """The one producer of a run's :class:`~.scores.Scores`: ``maps`` (:func:`load_run_maps`) scored, each
    engine map against the references it is paired with (:func:`score_entries`), with the runs marked."""
    return score_entries(maps.candidates, maps.references, experiments, own_eta=maps.own_eta,
                         pair_with=maps.pair_with, allow_incomplete=allow_incomplete, declared=maps.declared,
                         speed_record=maps.speed_record, runs=maps)


def score_dirs(run_dirs: Iterable, against: Iterable | None = None, experiments=None,
               allow_incomplete=False, declared: Declared | None = None) -> Scores:
    """:func:`score_run` of :func:`load_run_maps`: the maps under ``run_dirs`` (and ``against``) scored."""
    return score_run(load_run_maps(run_dirs, against, declared), experiments, allow_incomplete)


def _run_root(d: Path, arg: Path) -> Path:
    """The run a map directory ``d`` found under the argument ``arg`` belongs to: the nearest folder at or
    below ``arg`` holding ``suite.json`` (a ``rockbench run`` output), else ``arg`` itself."""
    for q in [d, *d.parents]:
        if (q / "suite.json").is_file():
            return q
        if q == arg:
            break
    return arg


def load_runs(run_dirs: Iterable) -> tuple[list[MapEntry], dict]:
    """Every map under ``run_dirs`` (as :func:`load_entries`) and ``{map dir: its run}``."""
    entries, run_of = [], {}
    for arg in run_dirs:
        arg = Path(arg)
        for d in find_map_dirs([arg]):
            if d in run_of:
                continue   # found under an earlier argument too: it belongs to that run
            run_of[d] = _run_root(d, arg)
            entries.append(load_entry(d))
    return entries, run_of


def pair_within_runs(cands: list[MapEntry], refs: list[MapEntry], run_of: dict):
    """``(pair_with, notes)`` for :func:`score_entries`: each candidate is paired with the references of
    its own run; a candidate whose run has none of its block and pulse takes those of the other runs,
    and a note says so."""
    notes: list[str] = []
    own: dict = {}
    for c in cands:
        same = [r for r in refs if run_of.get(r.path) == run_of.get(c.path)]
        if not any((r.block, r.pulse) == (c.block, c.pulse) for r in same):
            others = [r for r in refs if (r.block, r.pulse) == (c.block, c.pulse)]
            if others:
                runs = sorted({str(run_of.get(r.path)) for r in others})
                notes.append(f"{c.path} ({c.variant}, {c.block} {c.pulse}): its run {str(run_of.get(c.path))!r} has "
                             f"no reference map of this block and pulse; paired across runs with those of "
                             f"{', '.join(repr(x) for x in runs)}")
            same = same + others
        own[c.path] = same
    return (lambda c: own.get(c.path, [])), notes


def mark_runs(pairs: list[dict], run_of: dict, *, against: bool = False, notes=()) -> dict:
    """Record in each scored pair which run it comes from; returns score.json's ``pairing``: how maps
    were paired."""
    for p in pairs:
        run = run_of.get(Path(p["engine_dir"]))
        p["run"] = None if run is None else str(run)
        ref_run = run_of.get(Path(p["reference"]["dir"]))
        p["reference"]["run"] = None if ref_run is None else str(ref_run)
        p["across_runs"] = bool(not against and run is not None and ref_run is not None and run != ref_run)
    return {"rule": "against" if against else "within each run",
            "runs": sorted({str(r) for r in run_of.values()}), "notes": list(notes or [])}


def grid_cells(eng: MapResult, ref: MapResult) -> dict:
    """How many cells a pair's metrics are taken over: ``judged`` (the reference's domain: it has an
    outcome and is valid, less the cells the engine map lacks), ``overturn_union`` (judged cells where
    either map overturns or the engine failed), the boundary edges the boundary distance averages
    over, the bisection depth the boundaries are located to with their crossings and flagged edges
    (:func:`~rockbench.benchmark.scoring.metrics.located_counts`), and the grid's steps, from which
    :func:`cell_units` turns a number of cells into each metric's units."""
    judged, _ = judged_cells(eng, ref)
    union = judged & ((eng.outcome == OVERTURN) | (ref.outcome == OVERTURN) | (eng.outcome == FAILED))
    w, a = eng.w_ratio, eng.a_ratio
    return {"judged": int(judged.sum()), "overturn_union": int(union.sum()),
            "boundary_edges": boundary_edges(eng, ref), **located_counts(eng, ref),
            "w_step": float((w[-1] - w[0]) / (w.size - 1)) if w.size > 1 else 0.0,
            "a_step": float((a[-1] - a[0]) / (a.size - 1)) if a.size > 1 else 0.0}


#: Default tolerance of ``compare``, in flipped cells (converted per pair by :func:`cell_units`).
DEFAULT_TOLERANCE_CELLS = 2.0


def cell_units(pair: dict) -> dict:
    """What one flipped cell can change in each metric of ``pair`` (in the metric's own units).

    Each metric says which (its ``cell_unit``): fractions of cells change by one over the cells they
    are taken over; distances in the normalised plane by a cell's diagonal (in % of a critical amplitude,
    by a diagonal over the grid's lowest amplitude, the most it can be); critical amplitudes by an
    amplitude step (the mean by one step over the columns); counts by one. A pair without ``cells``
    (an older score.json) uses its whole grid.
    """
    g = pair.get("grid") or {}
    n_w, n_a = int(g.get("n_w", 1) or 1), int(g.get("n_a", 1) or 1)
    c = pair.get("cells") or {}
    dw = c.get("w_step", (g.get("w_hi", 0) - g.get("w_lo", 0)) / max(n_w - 1, 1))
    da = c.get("a_step", (g.get("a_hi", 0) - g.get("a_lo", 0)) / max(n_a - 1, 1))
    base = {"1/judged": 1.0 / max(int(c.get("judged", n_w * n_a)), 1),
            "1/overturn_union": 1.0 / max(int(c.get("overturn_union", n_w * n_a)), 1),
            "1/outside_simulated": 1.0 / max(pair.get("cells_outside_domain_simulated", n_w * n_a), 1),
            "diagonal": math.hypot(dw, da), "a_step": da, "a_step/columns": da / n_w, "one": 1.0}
    a_lo = float(g.get("a_lo", 0) or 0)
    base["diagonal/a_lo %"] = 100.0 * base["diagonal"] / (a_lo if a_lo > 0 else max(da, 1e-12))
    return {name: base[m.cell_unit] for name, m in METRICS.items()}


def gate(scores: Scores, thresholds: dict) -> list[str]:
    """Failed gate lines for every gated pair of the scores (see the module docstring)."""
    by_engine: dict[str, list[dict]] = {}
    for p in scores.pairs:
        by_engine.setdefault(p["engine_dir"], []).append(p)
    out = []
    for ps in by_engine.values():
        gated = [p for p in ps if p["like_for_like"]] or ps
        for p in gated:
            out += [f"{p['key']}: {line}" for line in check_gate(p["scores"], thresholds)]
    return out


def load_score(path, allow_incomplete: bool = False) -> Scores:
    """The scores of a score.json file (:meth:`~.scores.Scores.from_json`), or computed from a run directory.

    A directory with a ``score.json`` gives that file; otherwise its maps are scored (engine maps
    against the reference maps found with them).

    Raises
    ------
    ConfigError
        The path does not exist, is not readable JSON or not a score file at all, or holds pairs of
        incomplete maps and ``allow_incomplete`` is False.
    IncomparableError
        A score file of another schema.
    """
    p = Path(path)
    if p.is_dir():
        if (p / "score.json").is_file():
            p = p / "score.json"
        else:
            return score_dirs([p], allow_incomplete=allow_incomplete)
    if not p.is_file():
        raise ConfigError(f"{str(p)!r} does not exist; give a score.json or a run directory.")
    doc = read_json(p)
    if doc.get("kind") != SCORE_KIND:
        raise ConfigError(f"{str(p)!r} is not a rockbench score file (it has no \"kind\": \"{SCORE_KIND}\"); give "
                          "the score.json written by `rockbench score` or `rockbench run`, or a run directory.")
    if doc.get("schema_version") != SCORE_SCHEMA_VERSION:
        raise IncomparableError(f"{str(p)!r} has score schema {doc.get('schema_version')} (metrics version "
                                f"{doc.get('metrics_version')}), this rockbench reads schema {SCORE_SCHEMA_VERSION} "
                                f"(metrics version {METRICS_VERSION}); rescore its run with this rockbench "
                                "(`rockbench score RUN_DIR`) and compare again.")
    if _older(doc.get("metrics_version"), FIRST_VERDICT_VERSION):
        raise IncomparableError(f"{str(p)!r} holds metrics version {doc.get('metrics_version')}, whose verdict this "
                                f"rockbench (metrics version {METRICS_VERSION}) no longer reads; re-score its run: "
                                "`rockbench score RUN_DIR` (or `rockbench run --out RUN_DIR` in the same folder, which "
                                "recomputes no map).")
    check_score_doc(doc, p)
    gaps = [q for q in doc["pairs"] if q.get("complete") is False]
    if gaps and not allow_incomplete:
        raise ConfigError(f"{str(p)!r} scores {len(gaps)} pair(s) of incomplete maps (the first, {gaps[0]['key']!r}, "
                          f"lacks {gaps[0].get('cells_missing')} cells); complete the maps and rescore, or compare "
                          f"anyway with {ALLOW_INCOMPLETE}.")
    for q in doc["pairs"]:   # a score.json written under older names is refused, never read as today's
        if isinstance(q.get("variant"), str):
            stored_variant(q["variant"], str(p))
    return Scores.from_json(doc)


#: The first metrics version whose verdict this rockbench reads (classes, MCB, declarations, power).
FIRST_VERDICT_VERSION = 7


def _older(version, than: int) -> bool:
    """Whether a stored metrics ``version`` (a text or a number) is older than ``than``; one that does not
    read as a whole number is older."""
    try:
        return int(str(version)) < than
    except ValueError:
        return True


def check_score_doc(doc: dict, where) -> None:
    """ConfigError naming the file and the first damaged part of a score document of this schema."""
    def bad(what: str):
        return ConfigError(f"{str(where)!r} is damaged: {what}; score the run again (`rockbench score RUN_DIR`).")

    _check_parts(doc, bad)
    pairs = doc.get("pairs")
    if not isinstance(pairs, list):
        raise bad(f"'pairs' must be a list, got {type(pairs).__name__ if pairs is not None else 'nothing'}")
    for n, p in enumerate(pairs):
        if not isinstance(p, dict):
            raise bad(f"pairs[{n}] is {type(p).__name__}, not an object")
        for key, kind in (("key", str), ("grid", dict), ("scores", dict)):
            if not isinstance(p.get(key), kind):
                raise bad(f"pairs[{n}] has no {key!r} {'text' if kind is str else 'object'}")
        for key in ("engine", "variant", "engine_version", "block", "pulse"):
            if p.get(key) is not None and not isinstance(p[key], str):
                raise bad(f"pairs[{n}].{key} is {p[key]!r}, not a text")
        if "cells" in p and not isinstance(p["cells"], dict):
            raise bad(f"pairs[{n}].cells is {p['cells']!r}, not an object")
        for part in ("scores", "grid", "cells"):
            for name, v in (p.get(part) or {}).items():
                # a score may be missing, and so may the maps' location error (no crossing to bracket)
                may_lack = part == "scores" or (part, name) == ("cells", "location_sd")
                if (v is None and not may_lack) or isinstance(v, bool) or not isinstance(v, (int, float, type(None))):
                    raise bad(f"pairs[{n}].{part}.{name} is {v!r}, not a number")
        for name in ("n_w", "n_a"):
            if not isinstance(p["grid"].get(name), int) or p["grid"][name] < 1:
                raise bad(f"pairs[{n}].grid.{name} is {p['grid'].get(name)!r}, not a whole number >= 1")
        # the domain's cell counts (metrics version 2), when present
        for name in ("cells_in_domain", "cells_outside_domain", "cells_outside_domain_simulated", "invalid_cells"):
            if name in p and (isinstance(p[name], bool) or not isinstance(p[name], int) or p[name] < 0):
                raise bad(f"pairs[{n}].{name} is {p[name]!r}, not a whole number >= 0")


def _check_parts(doc: dict, bad) -> None:
    """The parts :class:`~.scores.Scores` reads beside the pairs: ``bad(what)`` for the first of another kind."""
    verdict_ = doc.get("verdict")
    if not isinstance(verdict_, dict):
        raise bad(f"'verdict' must be an object, got {type(verdict_).__name__ if verdict_ is not None else 'nothing'}")
    if not isinstance(verdict_.get("variants", []), (list, type(None))):
        raise bad(f"'verdict.variants' must be a list, got {type(verdict_['variants']).__name__}")
    for name in ("metrics", "skipped", "reference_gaps", "experiments"):
        if not isinstance(doc.get(name, []), (list, type(None))):
            raise bad(f"{name!r} must be a list, got {type(doc[name]).__name__}")
    for name in ("speed", "pairing", "gate"):
        if not isinstance(doc.get(name), (dict, type(None))):
            raise bad(f"{name!r} must be an object, got {type(doc[name]).__name__}")


# -- comparing two score documents -----------------------------------------------------------------

def parse_tolerances(items: Iterable[str]) -> dict:
    """``--tolerance`` items: ``VALUE`` or ``Ncells`` (every metric), ``METRIC=VALUE`` or
    ``METRIC=Ncells`` (one metric); returns per-metric tolerances.

    A tolerance is ``{"cells": N, "at_least": X}``: N flipped cells on the pair's grid
    (:func:`cell_units`), never less than the absolute X. The default is
    :data:`DEFAULT_TOLERANCE_CELLS` cells at least the metric's own absolute tolerance; ``VALUE``
    states an absolute tolerance alone, ``Ncells`` a number of cells alone.
    """
    tol = {name: {"cells": DEFAULT_TOLERANCE_CELLS, "at_least": m.tolerance} for name, m in METRICS.items()}
    for item in items:
        name, eq, val = str(item).partition("=")
        if not eq:
            name, val = "", name
        text = val.strip().lower()
        in_cells = text.endswith(("cells", "cell"))
        try:
            v = float(text[: -5 if text.endswith("cells") else -4] if in_cells else text)
        except ValueError:
            raise ConfigError(f"--tolerance takes VALUE, Ncells, METRIC=VALUE or METRIC=Ncells with a number, got "
                              f"{item!r}.") from None
        if not math.isfinite(v) or v < 0:
            raise ConfigError(f"--tolerance must be a finite number >= 0, got {item!r}.")
        t = {"cells": v, "at_least": 0.0} if in_cells else {"cells": 0.0, "at_least": v}
        if not name:
            tol = {k: dict(t) for k in tol}
        elif name in METRICS:
            tol[name] = t
        else:
            raise ConfigError(f"--tolerance: unknown metric {name!r}; metrics: {', '.join(METRICS)}.")
    return tol


def tolerance_for(tol, name: str, units: dict) -> float:
    """The tolerance of metric ``name`` in its own units for a pair with ``units`` (see :func:`parse_tolerances`;
    a plain number is an absolute tolerance)."""
    if not isinstance(tol, dict):
        return float(tol)
    cells = float(tol.get("cells", 0.0))
    return max(float(tol.get("at_least", 0.0)), cells * units[name] if cells and name in units else 0.0)


def compare_scores(base: Scores, cur: Scores, tolerances: dict | None = None,
                   cost_factor: float = COST_RISE_FACTOR) -> dict:
    """Regressions of ``cur`` against ``base``, pair by pair and metric by metric, and of the speed stage's
    cost at matched accuracy (:func:`~.speed.compare_speed`: a rise by more than ``cost_factor`` on a like
    machine).

    Each tolerance is turned into the metric's units on the baseline pair's grid
    (:func:`tolerance_for`); the rows give the value used.

    Returns
    -------
    dict
        ``status`` (``ok`` or ``regression``), ``compared`` (pairs in both), ``regressions`` and
        ``improvements`` (lists of ``{key, metric, baseline, current, delta, tolerance}``),
        ``missing`` (pair keys in the baseline only: a regression), ``new`` (in the current only),
        ``tolerances``, and ``speed`` (None unless both runs have a speed stage).

    Raises
    ------
    IncomparableError
        Other metric definitions, no pair in common (two runs of a speed stage alone excepted), a common
        pair on another grid, or a document holding one pair twice (several runs scored together).
    """
    tol = dict(parse_tolerances([]) if tolerances is None else tolerances)
    rules = [str(d.rules_version or "1") for d in (base, cur)]
    if rules[0] != rules[1]:
        raise IncomparableError(f"the results follow other rules (baseline rules version {rules[0]}, current "
                                f"{rules[1]}; docs/engines.md says what each changed): rerun the older one with "
                                "one rockbench (`rockbench run`) before comparing.")
    if base.metrics_version != cur.metrics_version:
        raise IncomparableError(f"the scores use other metric definitions (baseline metrics version "
                                f"{base.metrics_version}, current {cur.metrics_version}; docs/scores.md "
                                "says what each version changed); rescore both with one rockbench "
                                "(`rockbench score RUN_DIR`).")
    b = _pairs_by_key(base, "baseline")
    c = _pairs_by_key(cur, "current")
    common = sorted(set(b) & set(c))
    speed = compare_speed(*(None if d.speed is None else d.speed.to_json() for d in (base, cur)), cost_factor)
    if not common and not (speed is not None and not b and not c):
        raise IncomparableError("the two results share no scored pair (engine, block, pulse, restitution, "
                                "reference): they describe other scenarios.")
    for k in common:
        if b[k]["grid"] != c[k]["grid"]:
            raise IncomparableError(f"{k}: the maps lie on other grids (baseline {b[k]['grid']}, current "
                                    f"{c[k]['grid']}); compare runs of one suite.")
    regressions, improvements = [], []
    for k in common:
        units = cell_units(b[k])
        for name, m in METRICS.items():
            old, new = b[k]["scores"].get(name), c[k]["scores"].get(name)
            old = math.nan if old is None else float(old)
            new = math.nan if new is None else float(new)
            t = tolerance_for(tol.get(name, m.tolerance), name, units)
            row = {"key": k, "metric": name, "baseline": old, "current": new,
                   "delta": new - old if math.isfinite(old) and math.isfinite(new) else math.nan,
                   "tolerance": t}
            if m.worse(new, old, t):
                regressions.append(row)
            elif m.worse(old, new, 0.0):
                improvements.append(row)
    missing = sorted(set(b) - set(c))
    slower = bool(speed and speed["flags"])
    return {"status": "regression" if regressions or missing or slower else "ok", "compared": len(common),
            "regressions": regressions, "improvements": improvements, "missing": missing,
            "new": sorted(set(c) - set(b)), "tolerances": tol, "speed": speed}


def _pairs_by_key(scores: Scores, which: str) -> dict:
    out: dict = {}
    for p in scores.pairs:
        if p["key"] in out:
            runs = [str(q.get("run")) for q in (out[p["key"]], p)]
            raise IncomparableError(f"the {which} holds the pair {p['key']!r} twice (runs {runs[0]} and {runs[1]}); "
                                    "score one run at a time to compare it.")
        out[p["key"]] = p
    return out
