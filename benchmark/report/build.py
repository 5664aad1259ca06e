"""The benchmark report: ``index.html`` (self-contained) and ``report.md`` with its pictures (this module
gathers the maps, scores and pictures; :mod:`.sections` builds the tables, :mod:`.page` writes the pages).

The first screen answers "which engine is how faithful, and how sure is that": the verdict as a
picture (a forest plot of every variant's value and interval, :mod:`.plots.verdict`) beside the
verdict in at most 120 words, the full sentences collapsed below it. Then the summary table (one row
per engine variant, in words such as "MuJoCo 4.0, calibrated to η_H"), each metric explained in words
(the definitions of :data:`~rockbench.benchmark.scoring.metrics.METRICS`), then one stability figure per
engine variant (small multiples, one panel per block and pulse). Then θ(t) of the reference and
every engine for chosen cases (the paper's Fig. 17 case by default), the calibration (η per engine
against Housner, the modified η and the experiment), speed against accuracy and the experiments.
Collapsed below (``<details>``): the stability graphs by case (every variant side by side), every
scored pair, and the versions and settings of every map as tables.

Pictures are written to ``OUT/img/`` (report.md links them) and embedded as base64 in
index.html, so that one file can be mailed or attached to a CI run. Every file is written through
a temporary file and a rename.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from rockbench.engines.adapters.reference import PLANTED
from rockbench.reference_solver.errors import ConfigError, RockbenchError
from rockbench.benchmark.errors import IncomparableError
from rockbench.reference_solver.model import a_ratio_to_amplitude
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution
from rockbench.benchmark.blocks.cases import FIG17, TrajectoryCase
from rockbench.benchmark.blocks.experiments import restitution_targets, st_limit_a_ratio
from rockbench.benchmark.blocks.presets import PRESETS, TABLE_1, get_preset, no_exact_k_note
from rockbench.benchmark.scoring.labels import case_title, restitution_symbol, variant_labels
from rockbench.benchmark.scoring.score_runs import RunMaps, at_own_eta, load_run_maps, score_run
from rockbench.benchmark.scoring.scores import Scores
from rockbench.benchmark.report.tables import summary
from rockbench.benchmark.store.atomic import write_bytes_atomic
from rockbench.benchmark.store.files import DISPLAY_UTC, is_own_eta_map, map_cell_rows, utc_stamp, write_json
from rockbench.benchmark.store.loading import MapEntry
from rockbench.benchmark.store.trajectories import FOLDER, case_stem, read_case
from rockbench.benchmark.report.histories import picture_span_s
from rockbench.benchmark.report.page import html_page, markdown_page
from rockbench.benchmark.report.plots.drawing import Drawings
from rockbench.benchmark.report.plots.speed import plot_accuracy_cost
from rockbench.benchmark.report.plots.stability import REFERENCE_STYLES, plot_panels
from rockbench.benchmark.report.plots.trajectories import plot_theta
from rockbench.benchmark.report.plots.verdict import plot_verdict
from rockbench.benchmark.report.sections import SPEED_METRICS


def build_report(run_dirs, out_dir, *, against=None, experiments=None, cases=(FIG17,),
                 trajectories: bool = True, log=None, allow_incomplete=False,
                 figure_formats=("png",), declared=None, maps: RunMaps | None = None) -> dict:
    """Write the report of the maps under ``run_dirs`` into ``out_dir``.

    Parameters
    ----------
    run_dirs : list of path
        Map directories or folders holding them.
    out_dir : path
        Where index.html, report.md, img/ and score.json go (created).
    against : list of path, optional
        Reference maps to score against (default: the reference maps among ``run_dirs``).
    experiments : list of OutcomePoint, optional
        Shaking-table outcomes (markers and accuracy).
    cases : sequence of TrajectoryCase
        θ(t) comparisons to draw.
    trajectories : bool
        Draw the θ(t) comparisons of ``cases`` stored in ``out_dir/trajectories``
        (:func:`~rockbench.benchmark.trajectories.record_trajectories` simulates and stores them).
    log : callable, optional
        Progress messages (default: stderr).
    allow_incomplete : bool or collection of Path
        Score engine maps that lack cells on what they have (flagged) instead of refusing them: all
        (True) or those of these map directories (:func:`~rockbench.benchmark.scoring.score_runs.score_run`).
    figure_formats : sequence of str
        The formats of the pictures in ``img/`` (``png``, ``svg``, ``pdf``); the PNG is always
        written too, since index.html embeds it and report.md links it.
    declared : Declared, optional
        The verdict's declarations (default: those of the runs' suite.json, else the code's).
    maps : RunMaps, optional
        The maps of ``run_dirs``, ``against`` and ``declared`` when already read
        (:func:`~rockbench.benchmark.scoring.score_runs.load_run_maps`).

    Returns
    -------
    dict
        Paths written (``html``, ``markdown``, ``score``, ``images``), the ``scores`` (:class:`~rockbench.benchmark.scoring.scores.Scores`,
        None when nothing could be scored) and notes.

    Raises
    ------
    ConfigError
        ``out_dir`` is a file, no map was found, or an engine map is incomplete (without
        ``allow_incomplete``).
    """
    log = log or (lambda msg: print(f"rockbench: {msg}", file=sys.stderr))
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {str(out)!r} is a file; give a directory for the report.")
    if maps is None:
        maps = load_run_maps(run_dirs, against, declared)
    scores, notes = None, list(maps.notes)
    try:
        scores = score_run(maps, experiments, allow_incomplete)
    except IncomparableError as e:
        notes.append(f"No scores: {e}")
    return write_report(maps, scores, out, experiments=experiments, cases=cases, trajectories=trajectories, log=log,
                        figure_formats=figure_formats, notes=notes + _no_exact_k(maps.references), run_dirs=run_dirs)


def write_report(maps: RunMaps, scores: Scores | None, out: Path, *, experiments=None, cases=(FIG17,),
                 trajectories: bool = True, log=None, figure_formats=("png",), notes=(), run_dirs=(),
                 created: str | None = None) -> dict:
    """Draw and write the report of ``maps`` and their ``scores`` (:func:`~rockbench.benchmark.scoring.score_runs.score_run`;
    None: nothing could be scored) into ``out``; the arguments as :func:`build_report`'s, ``notes`` the
    page's notes and ``created`` its time stamp (default now). Returns the paths written
    (:func:`_write_report`), the ``scores`` and the notes."""
    log = log or (lambda msg: print(f"rockbench: {msg}", file=sys.stderr))
    notes = list(notes)
    drawings = Drawings(figure_formats)   # every picture, drawn at once over the cores below

    # the speed stage's maps are in the scores' speed section and its picture, not among the variants' figures
    cands, refs, own_eta = [e for e in maps.candidates if not e.in_speed_stage], maps.references, maps.own_eta
    labels = variant_labels(cands)
    pair_of = _like_pairs(scores)
    variant_graphs = _variant_figures(cands, refs, own_eta, experiments, labels, pair_of, drawings)
    case_graphs = _case_figures(cands, refs, own_eta, experiments, labels, pair_of, drawings)
    verdict_img = _verdict_figure(scores, drawings)
    traj_imgs = _trajectory_figures(cases, out / FOLDER, drawings, notes) if trajectories else []
    speed = _speed_rows([e for e in maps.entries if not e.in_speed_stage], scores)
    speed_img = _speed_figure(None if scores is None or scores.speed is None else scores.speed.record, drawings)
    images, widths = drawings.draw_all()
    ctx = {"entries": maps.entries, "refs": refs, "scores": scores, "verdict_img": verdict_img,
           "variant_graphs": variant_graphs, "case_graphs": case_graphs, "traj": traj_imgs,
           "calib": _calibration_rows(cands, own_eta), "speed": speed,
           "speed_img": speed_img,
           "notes": notes, "labels": labels, "run_dirs": [str(d) for d in run_dirs],
           "created": created or utc_stamp(DISPLAY_UTC), "fig_widths": widths}
    paths = _write_report(out, images, scores, markdown_page(ctx), html_page(ctx, images))
    log(f"report written to {out / 'index.html'} and {out / 'report.md'}")
    return {**paths, "scores": scores, "notes": notes}


def _no_exact_k(refs: list[MapEntry]) -> list[str]:
    """Where the reference maps hold the exact k's η_M for some blocks, the note for the blocks that have
    none (presets without a measured k)."""
    def which(r):
        law, pre = _restitution_from_label(r.restitution), PRESETS.get(r.block.upper())
        return pre.which_k(law.k) if law is not None and law.kind == "modified" and pre is not None else None

    if not any(which(r) == "exact" for r in refs):
        return []
    note = no_exact_k_note(sorted({r.block for r in refs}, key=lambda b: list(PRESETS).index(b.upper())
                                  if b.upper() in PRESETS else len(PRESETS)))
    return [note] if note else []


def _trajectory_figures(cases, folder: Path, drawings, notes: list) -> list:
    """``[(case, image name)]`` of the θ(t) comparisons drawn; a case that cannot be drawn is a note."""
    out = []
    for case in cases:
        try:
            name, case_notes = _trajectory_figure(case, folder, drawings)
            notes += case_notes
            if name:
                out.append((case, name))
        except RockbenchError as e:
            notes.append(f"θ(t) for {case.title or case.block}: not drawn ({e})")
    return out


def _verdict_figure(scores: Scores | None, drawings) -> str | None:
    """The verdict as a forest plot (:func:`~rockbench.benchmark.report.plots.verdict.plot_verdict`);
    None without scores or without a variant to draw."""
    if not scores or not any(r["value"] is not None or r["held_out"] for r in scores.verdict.variants):
        return None
    return drawings.add("verdict.png", plot_verdict, scores.verdict.to_json())


def _speed_figure(speed: dict | None, drawings) -> str | None:
    """The accuracy–cost picture of the run's speed stage (:func:`~.plots.speed.plot_accuracy_cost`); None
    without a speed stage, or without a point to draw (the report says so)."""
    if not speed or not any(p.get("value") is not None and p.get("cost") for r in speed.get("engines", [])
                            for p in r["points"]):
        return None
    return drawings.add("speed_accuracy.png", plot_accuracy_cost, speed)


def _write_report(out: Path, images: dict, scores: Scores | None, md: str, page: str) -> dict:
    """Write the pictures, score.json, report.md and index.html (each atomically); their paths."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "img").mkdir(exist_ok=True)
    written = [write_bytes_atomic(out / "img" / name, data) for name, data in images.items()]
    paths = {"images": [str(p) for p in written]}
    if scores is not None:
        paths["score"] = str(write_json(out / "score.json", scores.to_json()))
    paths["markdown"] = str(write_bytes_atomic(out / "report.md", md.encode()))
    paths["html"] = str(write_bytes_atomic(out / "index.html", page.encode()))
    return paths


# -- pieces ----------------------------------------------------------------------------------------

def _slug(s: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in str(s)).strip("-").lower()


def _like_pairs(scores: Scores | None) -> dict:
    """``engine_dir`` → its like-for-like scored pair."""
    out = {}
    for p in (scores.pairs if scores else []):
        if p["like_for_like"]:
            out[p["engine_dir"]] = p
    return out


def _ref_order(r: MapEntry):
    law = _restitution_from_label(r.restitution)
    pre = PRESETS.get(r.block.upper())
    if law is not None and law.kind == "housner":
        return (0, 0.0)
    if law is not None and law.kind == "modified":
        which = pre.which_k(law.k) if pre is not None else None
        return ({"average": 1, "exact": 2}.get(which, 3), law.k)
    return (4, r.eta)


def _ref_line(r: MapEntry) -> tuple[str, dict]:
    """A reference map's legend label and line style by its role (the same in every panel)."""
    role = _ref_order(r)[0]
    label = {0: "reference, η_H", 1: "reference, η_M with the average k", 2: "reference, η_M with the exact k",
             3: f"reference, {restitution_symbol(r.restitution, r.block)}"}.get(role, f"reference, η = {r.eta:.4g}")
    return label, REFERENCE_STYLES[min(role, 2) if role < 3 else 4]


def _panel(e: MapEntry | None, std: list[MapEntry], own: list[MapEntry], experiments, pair, title: str,
           block: str, pulse: str) -> dict:
    """Keyword arguments of :func:`~rockbench.benchmark.report.plots.stability.plot_panel` for one map."""
    references = [(*_ref_line(r)[:1], r.map, _ref_line(r)[1]) for r in std]
    references += [("reference at the engine's own measured η", r.map, REFERENCE_STYLES[3]) for r in own]
    like = None
    if e is not None:
        like = next((r.map for r in std + own if r.restitution == e.restitution), None)
    domain = like if like is not None else (std[0].map if std else None)
    pts, st = _points_and_limit(experiments, block, pulse)
    note = None
    if pair is not None:
        sc = pair["scores"]
        note = _panel_note(sc)
    return {"engine": e.map if e is not None else None, "references": references, "like": like,
            "domain": domain, "points": pts, "st_limit": st if block.upper() in TABLE_1 else None, "title": title,
            "note": note}


def _panel_note(sc: dict) -> str:
    """The scores under a panel's title in words (:data:`READ_GRAPHS` explains them): the share of
    cells with the reference's outcome, the boundary distance in the chart's own normalised units,
    and the share of the cells outside the rigid model's domain that the engine flags."""
    def num(m, f):
        x = sc.get(m)
        return f(x) if x is not None and math.isfinite(x) else "n/a"

    return (f"agrees {num('agreement', lambda x: f'{100 * x:.1f} %')}, "
            f"boundary off {num('boundary_mean', lambda x: f'{x:.2f}')}, "
            f"flags {num('consistency', lambda x: f'{100 * x:.0f} %')} off-model")


def _groups(cands, refs, own_eta):
    """``{(block, pulse): (standard references, {variant: own-η references}, {variant: engine map})}``.

    A reference that ``rockbench run`` made at a variant's own η which no variant measures any more
    (the η was measured again after a recalibration or an engine upgrade, the run folder resumed) is
    left out: drawn as a standard reference it would stand in every panel for nothing."""
    out: dict = {}
    for r in refs:
        out.setdefault((r.block, r.pulse), ([], {}, {}))
    for e in cands:
        out.setdefault((e.block, e.pulse), ([], {}, {}))[2].setdefault(e.variant, e)
    for r in refs:
        std, own, engines = out[(r.block, r.pulse)]
        owners = [v for v, e in engines.items() if at_own_eta(r, e, own_eta)]
        if owners:
            for v in owners:
                own.setdefault(v, []).append(r)
        elif not (own_eta and is_own_eta_map(r.path)):
            std.append(r)
    for std, _, _ in out.values():
        std.sort(key=_ref_order)
    return out


def _variant_order(label: str):
    """Variants by engine, calibrated before "as shipped"."""
    return (label.split(",")[0], "as shipped" in label, label)


def _case_order(key):
    """Blocks in Table 1's order (custom blocks after them), then sine, cosine, half-sine."""
    block, pulse = key
    order = list(PRESETS)
    return (order.index(block) if block in order else len(order), block,
            {"sine": 0, "cosine": 1, "half-sine": 2}.get(pulse, 3), pulse)


def _variant_figures(cands, refs, own_eta, experiments, labels, pair_of, drawings) -> list[tuple[str, str, str]]:
    """One figure per engine variant: a panel per block and pulse. Returns ``(variant, label, image)``."""
    groups = _groups(cands, refs, own_eta)
    out = []
    for v in sorted(labels, key=lambda v: _variant_order(labels[v])):
        keys = sorted((k for k, g in groups.items() if v in g[2]), key=_case_order)
        if not keys:
            continue
        pulses = {p for _, p in keys}
        panels = []
        for block, pulse in keys:
            std, own, engines = groups[(block, pulse)]
            e = engines[v]
            panels.append(_panel(e, std, own.get(v, []), experiments, pair_of.get(str(e.path)),
                                 case_title(block, pulse), block, pulse))
        out.append((v, labels[v], drawings.add(f"variant_{_slug(v)}.png", plot_panels, panels, cost=len(panels),
                                           ncols=min(len(pulses), 3) if len(keys) > 1 else 1,
                                           suptitle=f"{labels[v]}: overturn region against the reference boundaries")))
    return out


def _case_figures(cands, refs, own_eta, experiments, labels, pair_of, drawings) -> list[tuple[str, str, str, int]]:
    """One figure per block and pulse: a panel per engine variant (or the references alone).
    Returns ``(block, pulse, image, number of experimental points)``."""
    out = []
    for (block, pulse), (std, own, engines) in sorted(_groups(cands, refs, own_eta).items(),
                                                      key=lambda kv: _case_order(kv[0])):
        if not std and not engines:
            continue
        panels = [_panel(e, std, own.get(v, []), experiments, pair_of.get(str(e.path)), labels.get(v, v), block, pulse)
                  for v, e in sorted(engines.items(), key=lambda kv: _variant_order(labels.get(kv[0], kv[0])))]
        if not panels:
            if not std:
                continue
            panels = [_panel(None, std, [], experiments, None, "reference boundaries", block, pulse)]
        name = drawings.add(f"stability_{_slug(block)}_{_slug(pulse)}.png", plot_panels, panels, cost=len(panels),
                        ncols=min(len(panels), 3), suptitle=case_title(block, pulse))
        pts, _ = _points_and_limit(experiments, block, pulse)
        out.append((block, pulse, name, len(pts)))
    return out


def _points_and_limit(points, block, pulse):
    """The shaking-table points and its faithful limit: Table 1's blocks only (the experiments' blocks)."""
    if block.upper() not in TABLE_1:
        return [], None
    sel = [(p.w_ratio, p.a_ratio, p.outcome, p.repetitions) for p in (points or [])
           if p.block == block.upper() and p.pulse == pulse]
    return sel, st_limit_a_ratio(block)


def _trajectory_figure(case: TrajectoryCase, folder: Path, drawings):
    """Draw the θ(t) curves of ``case`` that the run stored in ``folder``
    (:func:`~rockbench.benchmark.trajectories.record_trajectories`); ``(image name or None, notes)``."""
    have = read_case(folder, case)
    if have is None:
        return None, [f"θ(t) for {case.title or case.block}: not drawn (no θ(t) stored for it in {folder}; "
                      f"rockbench run stores the suite's [report] cases)"]
    hist = have["curves"]
    if not hist:
        return None, have["notes"]
    block = get_preset(case.block).block()
    pulse = make_pulse(case.pulse, a_ratio_to_amplitude(block, case.a_ratio), case.w_ratio * block.p_rad_s)
    ends = [float(np.asarray(h["t_s"])[-1]) for h in hist if not h["reference"]]
    overturns = [h["t_overturn_s"] for h in hist if h["t_overturn_s"] is not None]
    # every engine curve runs to its own decision; the references are drawn over the same span
    span = picture_span_s(pulse, max(overturns) if overturns else None)
    t_end = max([span] + ends)
    return drawings.add(f"{case_stem(case)}.png", plot_theta, hist, alpha_rad=block.alpha_rad, pulse=pulse, t_end_s=t_end,
                    title=case.title), have["notes"]


def _restitution_from_label(label: str):
    """The law a run folder's restitution label names (:meth:`Restitution.parse`), None if not understood."""
    try:
        return Restitution.parse(label)
    except ConfigError:
        return None


def _find_key(d, key):
    """The first value of ``key`` anywhere in nested dicts/lists, or None."""
    if isinstance(d, dict):
        if key in d and d[key] is not None:
            return d[key]
        for v in d.values():
            r = _find_key(v, key)
            if r is not None:
                return r
    elif isinstance(d, list):
        for v in d:
            r = _find_key(v, key)
            if r is not None:
                return r
    return None


def _calibration_rows(cands: list[MapEntry], own_eta: dict | None = None) -> list[dict]:
    """η measured per engine map against Housner, the modified η and the experiment.

    The η comes from the calibration recorded in the map's run.json (calibrated settings), else
    from the free-rocking measurement of ``rockbench run`` (``own_eta``).
    """
    rows, seen = [], set()
    for e in cands:
        key = (e.variant, e.block, e.restitution)
        if key in seen:
            continue
        seen.add(key)
        resolved = e.resolved_settings
        on = _find_key(resolved, "calibrated_on")
        # a calibration made on another block measured that block's η, not this one's
        measured = _find_key(resolved, "eta_measured") if not on or str(on).upper() == e.block.upper() else None
        if measured is None:
            measured = (own_eta or {}).get((e.variant, e.block))
        if e.is_planted:   # the reference solver rocks freely with exactly the η it applies
            measured = e.eta * float(e.settings[PLANTED])
        points = _find_key(resolved, "contact_points")
        r = {"variant": e.variant, "block": e.block, "restitution": e.restitution, "eta_target": e.eta,
             "eta_measured": float(measured) if measured is not None else math.nan,
             "reached": _find_key(resolved, "reached"), "price": _find_key(resolved, "price"),
             "contact": f"{int(points)} points along the base" if points and int(points) > 2 else "corners"}
        for k, v in _restitution_targets(e.block).items():
            r[f"{k}_eta"] = v
            r[f"{k}_rel_error"] = (r["eta_measured"] - v) / v
        rows.append(r)
    return rows


def _restitution_targets(block: str) -> dict:
    """The η a preset's measured η is set beside (:func:`restitution_targets`): Table 1's blocks have
    the free-rocking test's (``experiment``), the others Housner's and the size's average k's only; a
    custom block none."""
    pre = PRESETS.get(block.upper())
    if pre is None:
        return {}
    if pre.in_table_1:
        return restitution_targets(block)
    row = pre.row()
    return {"housner": row["eta_housner"], "modified_average_k": row["eta_modified_average_k"]}


def _speed_rows(entries: list[MapEntry], scores: Scores | None) -> list[dict]:
    """Per variant: wall time per simulated cell and CPU seconds per simulated second (from cells.csv: the
    second where its cells carry their cost, schema 5), and the mean like-for-like agreement."""
    acc = summary(scores) if scores else {}
    per: dict[str, list[float]] = {}
    cost: dict[str, list[float]] = {}
    for e in entries:
        try:
            rows = map_cell_rows(e.path)
        except (OSError, ConfigError):
            continue
        for row in rows:
            w, cpu, sim = (_float(row.get(k)) for k in ("wall_s", "cpu_s", "simulated_s"))
            if math.isfinite(w) and row.get("status", "ok") == "ok":
                per.setdefault(e.variant, []).append(w)
                if math.isfinite(cpu) and math.isfinite(sim):
                    c = cost.setdefault(e.variant, [0.0, 0.0])
                    c[0], c[1] = c[0] + cpu, c[1] + sim
    rows = []
    for v in sorted({e.variant for e in entries}):
        ws = per.get(v, [])
        ms = 1e3 * sum(ws) / len(ws) if ws else math.nan
        cpu, sim = cost.get(v, (0.0, 0.0))
        rows.append({"variant": v, "cells": len(ws), "ms_per_cell": ms,
                     "cpu_per_simulated_s": cpu / sim if sim > 0 else math.nan,
                     **{m: acc.get(v, {}).get(m, math.nan) for m in SPEED_METRICS}})
    return rows


def _float(x) -> float:
    try:
        return float(x) if x not in (None, "") else math.nan
    except ValueError:
        return math.nan


# -- tables ------------------------------------------------------------------------------------------


# -- Markdown ----------------------------------------------------------------------------------------


# -- HTML --------------------------------------------------------------------------------------------


# The page's style (report.css). After load, its script (report.js) marks the page when a picture fails to
# load (a visible warning, and attributes a headless browser can read), and gives every table wider
# than its column a visible note.


