"""The benchmark report: ``index.html`` (self-contained) and ``report.md`` with its pictures.

The first screen answers "which engine is how faithful, and why": the summary table (one row per
engine variant, in words such as "MuJoCo 4.0, calibrated to η_H"), each metric explained in words
(the definitions of :data:`~rockbench.harness.scoring.metrics.METRICS`), then one stability figure per
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

import base64
import html
import math
import sys
from dataclasses import dataclass
from pathlib import Path

from ...engines.base import Case
from ...reference_solver.errors import ConfigError, IncomparableError, RockbenchError
from ...reference_solver.model import a_ratio_to_amplitude
from ...reference_solver.pulses import make_pulse
from ...reference_solver.restitution import Restitution
from ..scoring.labels import case_title, for_html, restitution_symbol, variant_labels
from ..scoring.metrics import METRICS, PRIMARY_METRIC
from ..scoring.score_runs import at_own_eta, load_own_eta, load_runs, mark_runs, pair_within_runs, score_entries
from ..scoring.tables import (best_group_marks, fmt, incomplete_note, primary_cell, ranked_summary,
                              reference_label, render, row_label, summary, verdict_text)
from ..store.atomic import write_bytes_atomic
from ..store.files import DISPLAY_UTC, map_cell_rows, utc_stamp, write_json
from ..store.loading import MapEntry, load_entries


@dataclass(frozen=True)
class TrajectoryCase:
    """One case whose θ(t) the report draws for the reference and every engine.

    Attributes
    ----------
    block : str
        A preset name.
    pulse : str
        ``sine``, ``cosine`` or ``half-sine``.
    w_ratio, a_ratio : float
        ω/p and a₀/(g·tanα) [-].
    reference_k : tuple of float
        Impulse positions k of the modified restitution for the reference curves [-] (besides the
        restitution laws of the engines' maps).
    title : str
        Caption.
    """

    block: str
    pulse: str
    w_ratio: float
    a_ratio: float
    reference_k: tuple = ()
    title: str = ""


#: The paper's Fig. 17: B3M, sine, ω/p = 6, a₀/(g·tanα) = 6.1 rocks with k = 0.8608 and
#: overturns with k = 0.7595 (paper §5.2, docs/physics.md §6).
FIG17 = TrajectoryCase("B3M", "sine", 6.0, 6.1, (0.8608, 0.7595),
                       "Fig. 17 case: B3M, sine, ω/p = 6, a₀/(g·tanα) = 6.1")

def parse_case(text: str, where: str = "--case"):
    """``BLOCK:PULSE:W_RATIO:A_RATIO`` into a TrajectoryCase (ConfigError when malformed).

    ``where`` names the option or suite key the text came from, for messages. The reference
    curves use the modified η with the block's average and exact k.
    """
    from ..blocks.presets import get_preset

    parts = str(text).split(":")
    if len(parts) != 4:
        raise ConfigError(f"{where} takes BLOCK:PULSE:W_RATIO:A_RATIO, got {text!r}; e.g. B3M:sine:6:6.1.")
    try:
        pre = get_preset(parts[0])
    except ConfigError as e:
        raise ConfigError(f"{where} {text!r}: {e}") from None
    block = pre.name
    pulse = parts[1].strip().lower()
    if pulse not in ("sine", "cosine", "half-sine"):
        raise ConfigError(f"{where} pulse must be sine, cosine or half-sine, got {parts[1]!r} in {text!r}.")
    try:
        w, a = float(parts[2]), float(parts[3])
    except ValueError:
        raise ConfigError(f"{where} W_RATIO and A_RATIO must be numbers, got {text!r}.") from None
    if not (0 < w < math.inf and 0 < a < math.inf):
        raise ConfigError(f"{where} W_RATIO and A_RATIO must be finite numbers > 0, got {text!r}.")
    # the reference is drawn with the block's average and exact k, as in the paper's Fig. 17
    return TrajectoryCase(block, pulse, w, a, (pre.k_average, pre.k_exact),
                          f"{block}, {pulse}, ω/p = {w:g}, a₀/(g·tanα) = {a:g}")


def build_report(run_dirs, out_dir, *, against=None, experiments=None, cases=(FIG17,),
                 trajectories: bool = True, log=None, allow_incomplete=False,
                 figure_formats=("png",)) -> dict:
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
        Simulate and draw the θ(t) comparisons (needs the engines).
    log : callable, optional
        Progress messages (default: stderr).
    allow_incomplete : bool or collection of Path
        Score engine maps that lack cells on what they have (flagged) instead of refusing them: all
        (True) or those of these map directories (:func:`~rockbench.harness.scoring.score_runs.score_entries`).
    figure_formats : sequence of str
        The formats of the pictures in ``img/`` (``png``, ``svg``, ``pdf``); the PNG is always
        written too, since index.html embeds it and report.md links it.

    Returns
    -------
    dict
        Paths written (``html``, ``markdown``, ``score``, ``images``), the score document and notes.

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
    sc = _Scored.of(run_dirs, against, experiments, allow_incomplete)
    notes = sc.notes
    images: dict[str, bytes] = {}
    widths: dict[str, float] = {}

    def save(fig, name):
        from .plots.output import figure_bytes
        widths[name] = fig.get_figwidth()
        stem = name[: -len(".png")]
        for fmt in dict.fromkeys(("png", *figure_formats)):
            images[f"{stem}.{fmt}"] = figure_bytes(fig, fmt)
        return name

    cands, refs, own_eta = sc.cands, sc.refs, sc.own_eta
    labels = variant_labels(cands)
    pair_of = _like_pairs(sc.doc)
    variant_graphs = _variant_figures(cands, refs, own_eta, experiments, labels, pair_of, save)
    case_graphs = _case_figures(cands, refs, own_eta, experiments, labels, pair_of, save)
    traj_imgs = _trajectory_figures(cases, cands, labels, save, log, notes) if trajectories else []
    speed = _speed_rows(sc.entries, sc.doc)
    ctx = {"entries": sc.entries, "refs": refs, "doc": sc.doc, "variant_graphs": variant_graphs,
           "case_graphs": case_graphs, "traj": traj_imgs, "calib": _calibration_rows(cands, own_eta), "speed": speed,
           "speed_img": _speed_figure(speed, labels, save), "notes": notes, "labels": labels,
           "run_dirs": [str(d) for d in run_dirs], "created": utc_stamp(DISPLAY_UTC), "fig_widths": widths}
    paths = _write_report(out, images, sc.doc, _markdown(ctx), _html(ctx, images))
    log(f"report written to {out / 'index.html'} and {out / 'report.md'}")
    return {**paths, "doc": sc.doc, "notes": notes}


@dataclass
class _Scored:
    """The maps of a report and their scores: every map (``entries``), the engine maps (``cands``) and
    the references they are judged against, the score document (None when nothing could be scored),
    the engines' own η, and notes for the page."""

    entries: list
    cands: list
    refs: list
    doc: dict | None
    own_eta: dict
    notes: list

    @classmethod
    def of(cls, run_dirs, against, experiments, allow_incomplete=False) -> "_Scored":
        entries, run_of = load_runs(run_dirs)
        refs = load_entries(against) if against else [e for e in entries if e.is_reference]
        cands = entries if against else [e for e in entries if not e.is_reference]
        pair_with, notes = (None, []) if against else pair_within_runs(cands, refs, run_of)
        doc = None
        own_eta = load_own_eta(list(run_dirs) + [Path(d).parent for d in run_dirs])
        try:
            doc = score_entries(cands, refs, experiments, own_eta=own_eta, pair_with=pair_with,
                                allow_incomplete=allow_incomplete)
            mark_runs(doc, run_of, against=bool(against), notes=notes)
        except IncomparableError as e:
            notes.append(f"No scores: {e}")
        return cls(entries, cands, refs, doc, own_eta, notes)


def _trajectory_figures(cases, cands, labels, save, log, notes: list) -> list:
    """``[(case, image name)]`` of the θ(t) comparisons drawn; a case that cannot be drawn is a note."""
    out = []
    for case in cases:
        try:
            name, case_notes = _trajectory_figure(case, cands, labels, save, log)
            notes += case_notes
            if name:
                out.append((case, name))
        except RockbenchError as e:
            notes.append(f"θ(t) for {case.title or case.block}: not drawn ({e})")
    return out


def _speed_figure(speed: list[dict], labels: dict, save) -> str | None:
    """The speed-against-accuracy picture of the engines, accuracy by the primary metric (None when no
    engine has wall times)."""
    if not any(r.get("ms_per_cell") for r in speed if r["variant"] != "reference"):
        return None
    from .plots.speed import plot_speed_accuracy
    drawn = plot_speed_accuracy([{**r, "label": labels.get(r["variant"], r["variant"])} for r in speed
                                 if r["variant"] != "reference"], metric=PRIMARY_METRIC)
    return save(drawn["ax"].figure, "speed_accuracy.png")


def _write_report(out: Path, images: dict, doc: dict | None, md: str, page: str) -> dict:
    """Write the pictures, score.json, report.md and index.html (each atomically); their paths."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "img").mkdir(exist_ok=True)
    written = [write_bytes_atomic(out / "img" / name, data) for name, data in images.items()]
    paths = {"images": [str(p) for p in written]}
    if doc is not None:
        paths["score"] = str(write_json(out / "score.json", doc))
    paths["markdown"] = str(write_bytes_atomic(out / "report.md", md.encode()))
    paths["html"] = str(write_bytes_atomic(out / "index.html", page.encode()))
    return paths


# -- pieces ----------------------------------------------------------------------------------------

def _slug(s: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in str(s)).strip("-").lower()


def _like_pairs(doc) -> dict:
    """``engine_dir`` → its like-for-like scored pair."""
    out = {}
    for p in (doc or {}).get("pairs", []):
        if p["like_for_like"]:
            out[p["engine_dir"]] = p
    return out


def _ref_order(r: MapEntry):
    from ..blocks.presets import PRESETS
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
    from .plots.stability import REFERENCE_STYLES
    role = _ref_order(r)[0]
    label = {0: "reference, η_H", 1: "reference, η_M with the average k", 2: "reference, η_M with the exact k",
             3: f"reference, {restitution_symbol(r.restitution, r.block)}"}.get(role, f"reference, η = {r.eta:.4g}")
    return label, REFERENCE_STYLES[min(role, 2) if role < 3 else 4]


def _panel(e: MapEntry | None, std: list[MapEntry], own: list[MapEntry], experiments, pair, title: str,
           block: str, pulse: str) -> dict:
    """Keyword arguments of :func:`~rockbench.harness.report.plots.stability.plot_panel` for one map."""
    from ..blocks.presets import PRESETS

    from .plots.stability import REFERENCE_STYLES

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
            "domain": domain, "points": pts, "st_limit": st if block.upper() in PRESETS else None, "title": title,
            "note": note}


def _panel_note(sc: dict) -> str:
    """The scores under a panel's title in words (:data:`_READ_GRAPHS` explains them): the share of
    cells with the reference's outcome, the boundary distance in the chart's own normalised units,
    and the share of the cells outside the rigid model's domain that the engine flags."""
    def num(m, f):
        x = sc.get(m)
        return f(x) if x is not None and math.isfinite(x) else "n/a"

    return (f"agrees {num('agreement', lambda x: f'{100 * x:.1f} %')}, "
            f"boundary off {num('boundary_mean', lambda x: f'{x:.2f}')}, "
            f"flags {num('consistency', lambda x: f'{100 * x:.0f} %')} off-model")


def _groups(cands, refs, own_eta):
    """``{(block, pulse): (standard references, {variant: own-η references}, {variant: engine map})}``."""
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
        else:
            std.append(r)
    for std, _, _ in out.values():
        std.sort(key=_ref_order)
    return out


def _variant_order(label: str):
    """Variants by engine, calibrated before "as shipped"."""
    return (label.split(",")[0], "as shipped" in label, label)


def _case_order(key):
    """Blocks in Table 1's order (custom blocks after them), then sine, cosine, half-sine."""
    from ..blocks.presets import PRESETS
    block, pulse = key
    order = list(PRESETS)
    return (order.index(block) if block in order else len(order), block,
            {"sine": 0, "cosine": 1, "half-sine": 2}.get(pulse, 3), pulse)


def _variant_figures(cands, refs, own_eta, experiments, labels, pair_of, save) -> list[tuple[str, str, str]]:
    """One figure per engine variant: a panel per block and pulse. Returns ``(variant, label, image)``."""
    from .plots.stability import plot_panels

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
        drawn = plot_panels(panels, ncols=min(len(pulses), 3) if len(keys) > 1 else 1,
                            suptitle=f"{labels[v]}: overturn region against the reference boundaries")
        out.append((v, labels[v], save(drawn["figure"], f"variant_{_slug(v)}.png")))
    return out


def _case_figures(cands, refs, own_eta, experiments, labels, pair_of, save) -> list[tuple[str, str, str, int]]:
    """One figure per block and pulse: a panel per engine variant (or the references alone).
    Returns ``(block, pulse, image, number of experimental points)``."""
    from .plots.stability import plot_panels

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
        drawn = plot_panels(panels, ncols=min(len(panels), 3), suptitle=case_title(block, pulse))
        pts, _ = _points_and_limit(experiments, block, pulse)
        out.append((block, pulse, save(drawn["figure"], f"stability_{_slug(block)}_{_slug(pulse)}.png"), len(pts)))
    return out


def _points_and_limit(points, block, pulse):
    from ..blocks.experiments import st_limit_a_ratio
    from ..blocks.presets import PRESETS

    if block.upper() not in PRESETS:
        return [], None
    sel = [(p.w_ratio, p.a_ratio, p.outcome, p.repetitions) for p in (points or [])
           if p.block == block.upper() and p.pulse == pulse]
    return sel, st_limit_a_ratio(block)


def _trajectory_figure(case: TrajectoryCase, cands: list[MapEntry], labels: dict, save, log):
    """Simulate ``case`` with the reference (each relevant η) and every engine variant; draw θ(t)."""
    import numpy as np

    from ...engines.registry import get_adapter
    from .histories import impact_times, picture_span_s, trajectory_for_picture
    from .plots.trajectories import plot_theta
    from ..blocks.presets import get_preset

    notes = []
    block = get_preset(case.block).block()
    pulse = make_pulse(case.pulse, a_ratio_to_amplitude(block, case.a_ratio), case.w_ratio * block.p_rad_s)
    runs = [("reference", {}, Restitution("modified", k=k)) for k in case.reference_k]
    variants = {}
    for e in cands:
        settings = dict((e.run.get("spec") or {}).get("engine_settings") or {})
        variants.setdefault((e.variant, e.restitution), (e.engine, settings, e))
    for (variant, rest_label), (engine, settings, e) in sorted(variants.items()):
        rest = _restitution_from_label(rest_label)
        if rest is None:
            notes.append(f"θ(t): restitution {rest_label!r} of {variant} not understood; skipped")
            continue
        if not any(r[0] == "reference" and r[2] == rest for r in runs):
            runs.append(("reference", {}, rest))
        runs.append((variant, (engine, settings), rest))
    hist, ends, overturns = [], [], []
    for name, how, rest in runs:
        engine, settings = ("reference", {}) if name == "reference" else how
        law = f"{restitution_symbol(rest.label, case.block)} = {rest.eta(block.alpha_rad):.4f}"
        label = f"reference, {law}" if name == "reference" else labels.get(name, name)
        try:
            log(f"θ(t): {label}")
            c = Case(block, pulse, rest)
            tr, mode = trajectory_for_picture(engine, settings, c)
            judge = get_adapter(engine, **({**settings, "mode": mode} if mode else settings))
            res = judge.judge(c, tr)
            if name != "reference":
                ends.append(float(np.asarray(tr.t_s)[-1]))
            if res.outcome == "overturn" and res.t_overturn_s is not None:
                overturns.append(res.t_overturn_s)
            hist.append({"label": f"{label}: {res.outcome or 'failed'}", "t_s": tr.t_s, "theta_rad": tr.theta_rad,
                         "impacts_s": impact_times(tr), "reference": name == "reference", "outcome": res.outcome})
        except Exception as ex:  # noqa: BLE001 - one engine failing must not sink the report
            notes.append(f"θ(t) {label}: {type(ex).__name__}: {ex}")
    if not hist:
        return None, notes
    # every engine curve runs to its own decision; the references are drawn over the same span
    span = picture_span_s(pulse, max(overturns) if overturns else None)
    t_end = max([span] + ends)
    drawn = plot_theta(hist, alpha_rad=block.alpha_rad, pulse=pulse, t_end_s=t_end, title=case.title)
    return save(drawn["figure"], f"theta_{_slug(case.block)}_{_slug(case.pulse)}_{case.w_ratio:g}_{case.a_ratio:g}.png"), notes


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


def _split_own_eta_refs(refs: list[MapEntry], engines: list[MapEntry], own_eta: dict) -> tuple[list, list]:
    """The standard references of one graph, and the references at an engine's own η as
    ``(label, map, engine index)``: a reference whose η is an engine variant's measured η
    (the pairing the scores call ``own-eta``) goes with the first such engine of ``engines``; one
    matching no engine of the graph stays a standard reference."""
    std, own = [], []
    for r in refs:
        owners = [k for k, e in enumerate(engines) if at_own_eta(r, e, own_eta)]
        if not owners:
            std.append(r)
            continue
        names = ", ".join(dict.fromkeys(engines[k].variant for k in owners))
        own.append((f"reference at own η of {names} (η = {r.eta:.4f})", r.map, owners[0]))
    return std, own


def _calibration_rows(cands: list[MapEntry], own_eta: dict | None = None) -> list[dict]:
    """η measured per engine map against Housner, the modified η and the experiment.

    The η comes from the calibration recorded in the map's run.json (calibrated settings), else
    from the free-rocking measurement of ``rockbench run`` (``own_eta``).
    """
    from ..blocks.experiments import restitution_targets
    from ..blocks.presets import PRESETS

    rows, seen = [], set()
    for e in cands:
        key = (e.variant, e.block, e.restitution)
        if key in seen:
            continue
        seen.add(key)
        eng = e.run.get("engine") or {}
        measured = _find_key(eng.get("resolved_settings") or {}, "eta_measured")
        if measured is None:
            measured = (own_eta or {}).get((e.variant, e.block))
        resolved = eng.get("resolved_settings") or {}
        points = _find_key(resolved, "contact_points")
        r = {"variant": e.variant, "block": e.block, "restitution": e.restitution, "eta_target": e.eta,
             "eta_measured": float(measured) if measured is not None else math.nan,
             "reached": _find_key(resolved, "reached"), "price": _find_key(resolved, "price"),
             "contact": f"{int(points)} points along the base" if points and int(points) > 2 else "corners"}
        if e.block.upper() in PRESETS:
            for k, v in restitution_targets(e.block).items():
                r[f"{k}_eta"] = v
                r[f"{k}_rel_error"] = (r["eta_measured"] - v) / v
        rows.append(r)
    return rows


def _speed_rows(entries: list[MapEntry], doc) -> list[dict]:
    """Wall time per simulated cell (from cells.csv) and the mean like-for-like agreement per variant."""
    acc = summary(doc) if doc else {}
    per: dict[str, list[float]] = {}
    for e in entries:
        try:
            rows = map_cell_rows(e.path)
        except (OSError, ConfigError):
            continue
        for row in rows:
            try:
                w = float(row.get("wall_s") or "nan")
            except ValueError:
                continue
            if math.isfinite(w) and row.get("status", "ok") == "ok":
                per.setdefault(e.variant, []).append(w)
    rows = []
    for v in sorted({e.variant for e in entries}):
        ws = per.get(v, [])
        ms = 1e3 * sum(ws) / len(ws) if ws else math.nan
        rows.append({"variant": v, "cells": len(ws), "ms_per_cell": ms,
                     **{m: acc.get(v, {}).get(m, math.nan) for m in _SPEED_METRICS}})
    return rows


# -- tables ------------------------------------------------------------------------------------------

def _num(x, spec=".4f", why: str | None = None):
    """``x`` formatted, or "n/a" with the reason where one is given."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return f"n/a ({why})" if why else "n/a"
    return format(x, spec)


def _summary_rows(doc, labels) -> tuple[list[str], list[list[str]], list[str], dict]:
    """Head, body and the variant key of each row, in the verdict's order (rank, then the primary
    value), and per metric which rows to highlight (:func:`~rockbench.harness.scoring.tables.best_group_marks`)."""

    ranked = ranked_summary(doc)
    second = [m for m in METRICS if m != PRIMARY_METRIC]
    head = (["rank", "engine variant", "pairs", f"{METRICS[PRIMARY_METRIC].title} [95 % interval] (primary)"]
            + [METRICS[m].title for m in second])
    body = []
    for r, row in ranked:
        body.append([str(r["rank"] or "-"), row_label(r, labels.get(r["variant"])), str(row["pairs"]), primary_cell(r)]
                    + [fmt(m, row[m]) for m in second])
    cols = {PRIMARY_METRIC: 3, **{m: 4 + k for k, m in enumerate(second)}}
    marks = {cols[m]: flags for m, flags in best_group_marks(ranked).items()}
    return head, body, [r["variant"] for r, _ in ranked], marks


def _verdict(doc) -> list[str]:
    """The verdict's sentences (score.json's ``verdict.text``)."""
    return verdict_text(doc)


def _calib_table(rows, labels):
    head = ["engine variant", "block", "calibrated to", "η target", "η measured in free rocking",
            "measured vs η_H (Housner)", "measured vs η_M (size's average k)",
            "measured vs the block's own free-rocking test (η_M, exact k)"]
    body = [[labels.get(r["variant"], r["variant"]), r["block"], restitution_symbol(r["restitution"], r["block"]),
             _num(r["eta_target"], why="no target: the engine runs as shipped"),
             _num(r["eta_measured"], why="not measured (no calibration or own-η measurement recorded)"),
             *(_pct(r.get(f"{k}_rel_error"), "η not measured" if math.isfinite(r["eta_measured"]) is False
                    else "a custom block has no published η") for k in ("housner", "modified_average_k", "experiment"))]
            for r in rows]
    return head, body


def _pct(x, why: str) -> str:
    """A relative difference in per cent, or "n/a (why)"."""
    return _num(None if x is None else 100 * x, "+.2f", why=why) + (" %" if x is not None and math.isfinite(x) else "")


def _price_table(rows, labels):
    """Per engine variant and block with a measured contact price (issue 18): reached or not, the
    contact, and what it costs."""
    from ...engines.price import UPLIFT_RTOL

    head = ["engine variant", "block", "target", "η measured", "reached", "contact", "static uplift / g·tanα",
            "slip / jump cells", "quarter period vs rigid", "steps/s"]
    body = []
    for r in rows:
        pr = r.get("price")
        if not pr:
            continue
        up, sl = pr.get("uplift") or {}, pr.get("anti_slip") or {}
        ratio = up.get("ratio", math.nan)
        counts = pr.get("counts")
        body.append([labels.get(r["variant"], r["variant"]), r["block"], restitution_symbol(r["restitution"], r["block"]),
                     _num(r["eta_measured"]), "yes" if r.get("reached") and counts else "no", r["contact"],
                     _num(ratio) + ("" if up.get("within") else f" (outside {100 * UPLIFT_RTOL:g} %)"),
                     f"{sl.get('n_slip', '–')} / {sl.get('n_jump', '–')} of {sl.get('cells', '–')}",
                     (_num(100 * pr["period_change"], "+.2f") + " %") if pr.get("period_change") is not None else "–",
                     f"{pr['steps_per_s']:.3g}" if pr.get("steps_per_s") else "–"])
    return head, body


_PRICE_WORDS = ("Where an engine variant was calibrated to a target its corner contact cannot reach (the modified "
                "η_M), the calibration searched a contact along the base and measured its price: the table "
                "acceleration at which the block lifts under a slow ramp (must be within 2 % of g·tanα), slip and "
                "jump flags of the one validity rule in default-suite cells the rigid model rocks through without "
                "lift or slip, the free-rocking quarter period against the rigid model's, and engine steps per "
                "second. See docs/contact.md.")


#: The scores the speed table shows beside the wall time: the primary one and the plain agreement.
_SPEED_METRICS = (PRIMARY_METRIC, "agreement")


def _speed_table(rows, labels):
    head = ["engine variant", "simulated cells", "wall time per simulated cell [ms]",
            *(METRICS[m].title + (" (primary)" if m == PRIMARY_METRIC else "") for m in _SPEED_METRICS)]
    body = [[labels.get(r["variant"], r["variant"]), str(r["cells"]),
             _num(r["ms_per_cell"], ".2f", why="no wall times in cells.csv"),
             *(_speed_score(r, m) for m in _SPEED_METRICS)] for r in rows]
    return head, body


def _speed_score(row: dict, metric: str) -> str:
    """A score of the speed table, or "n/a" with the reason."""
    x = row.get(metric)
    if x is not None and math.isfinite(x):
        return fmt(metric, x)
    return "n/a (the yardstick itself)" if row["variant"] == "reference" else "n/a (no like-for-like reference map)"


def _exp_table(doc, labels):
    head = ["map", "restitution", "runs", "outside", "accuracy", "overturn accuracy",
            "confusion T/R/O → rest/rocking/overturn/failed"]
    body = []
    for e in (doc or {}).get("experiments", []):
        conf = "; ".join(f"{k}: " + "/".join(str(v) for v in row.values()) for k, row in e["confusion"].items())
        body.append([f"{labels.get(e['variant'], e['variant'])}, {e['block']} {e['pulse']}",
                     restitution_symbol(e["restitution"], e["block"]), str(e["runs"]), str(e["outside"]),
                     *(_num(e[k], ".3f", why="no shaking-table run inside the map") for k in
                       ("accuracy", "overturn_accuracy")), conf])
    return head, body


def _pairs_table(doc, labels):
    head = ["engine variant", "block", "pulse", "restitution", "vs reference", "like for like"] + \
        [METRICS[m].title for m in METRICS]
    body = [[labels.get(p["variant"], p["variant"]) + incomplete_note(p), p["block"], p["pulse"],
             restitution_symbol(p["restitution"], p["block"]),
             reference_label(p), "yes" if p["like_for_like"] else "", *(fmt(m, p["scores"].get(m)) for m in METRICS)]
            for p in (doc or {}).get("pairs", [])]
    return head, body


def _flat(d, prefix="") -> list[str]:
    """Nested settings as ``key = value`` lines (lists and long texts shortened)."""
    out = []
    for k, v in (d or {}).items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out += _flat(v, key + ".")
        elif v is None:
            continue
        else:
            if isinstance(v, float):
                t = f"{v:.6g}"
            elif isinstance(v, (list, tuple)):
                t = ", ".join(f"{x:.6g}" if isinstance(x, float) else str(x) for x in v)
            else:
                t = str(v)
            out.append(f"{key} = {t if len(t) <= 90 else t[:87] + '...'}")
    return out


def _settings_tables(entries: list[MapEntry], labels) -> dict:
    """The versions and settings as tables: one row per engine variant, one per map, and the run
    environment (values shared by every map once)."""
    variants, maps, env = {}, [], {}
    for e in entries:
        r = e.run or {}
        eng = r.get("engine") or {}
        spec = r.get("spec") or {}
        if e.variant not in variants:
            resolved = dict(eng.get("resolved_settings") or {})
            variants[e.variant] = [labels.get(e.variant, "reference solver" if e.is_reference else e.variant), e.variant,
                                   str(eng.get("version") or ""), "\n".join(_flat(spec.get("engine_settings"))) or
                                   "(engine defaults)", "\n".join(_flat(resolved)) or "-"]
        g = e.describe()["grid"]
        opts = r.get("options") or {}
        summ = r.get("summary") or {}
        maps.append([labels.get(e.variant, e.variant) if not e.is_reference else "reference solver", e.block, e.pulse,
                     restitution_symbol(e.restitution, e.block), f"{e.eta:.4f}",
                     f"{g['n_w']}×{g['n_a']}: ω/p {g['w_lo']:g}–{g['w_hi']:g}, a {g['a_lo']:g}–{g['a_hi']:g}",
                     ("adaptive, " + _num(100 * summ.get("fraction_simulated", math.nan), ".0f") + " % simulated")
                     if opts.get("adaptive") else "full", _num(spec.get("dt_s"), "g") if spec.get("dt_s") else "default",
                     str(r.get("created_utc") or ""), _num(summ.get("wall_s"), ".1f")])
        git = r.get("git") or {}
        for k, v in (("rockbench", r.get("rockbench_version")),
                     ("git commit", (git.get("commit") or "") + (" (uncommitted changes)" if git.get("dirty") else "")),
                     ("Python", r.get("python")), ("platform", r.get("platform"))):
            if v:
                env.setdefault(k, set()).add(str(v))
    return {"variants": (["engine variant", "key", "version", "settings given", "settings used (resolved)"],
                         list(variants.values())),
            "maps": (["engine variant", "block", "pulse", "restitution", "η", "grid", "cells", "Δt [s]", "created",
                      "wall [s]"], maps),
            "env": (["", "value"], [[k, ", ".join(sorted(v))] for k, v in env.items()])}


# -- Markdown ----------------------------------------------------------------------------------------

def _md_table(head, body):
    if not body:
        return "_none_"
    esc = [[c.replace("|", "\\|").replace("\n", "<br>") for c in r] for r in body]
    return render(head, esc, markdown=True)


def _metric_words(doc) -> list[tuple[str, str, str]]:
    """``(title, how read, question and definition)`` of each metric, the primary first (score.json's
    definitions, else this version's)."""
    ms = (doc or {}).get("metrics") or [m.to_dict() for m in METRICS.values()]
    ms = sorted(ms, key=lambda m: m.get("role") != "primary")
    return [((m.get("title") or m["name"]) + f" ({m['name']}, {m.get('role', 'secondary')})",
             f"{m['direction']} is better, perfect {m['perfect']:g}" + _unit_words(m["unit"]),
             (m.get("question", "") + " " + m["definition"]).strip()) for m in ms]


#: Units of score.json's metrics in words for the report (the keys stay score.json's).
UNIT_WORDS = {"w/a units": "measured in the normalised plane (ω/p, a₀/(g·tanα))",
              "a units": "measured in a₀/(g·tanα)", "-": ""}


def _unit_words(unit: str) -> str:
    words = UNIT_WORDS.get(unit, f"unit {unit}")
    return f", {words}" if words else ""


_HIGHLIGHTS = ("Rows are ranked by the primary measure, the mean distance between the overturning boundaries: "
               "a variant's rank is 1 + the number of variants resolved closer to the reference (the paired 95 % "
               "interval of their ratio over the scenarios both have excludes 1), so equal ranks tie. Bold: the "
               "best group (rank 1), and within it the best value of each other column; no other row is "
               "highlighted.")

_INTRO = ("Each row is one engine variant; each number is the mean over its like-for-like pairs (its map "
          "against the reference map with the same restitution law, same block, pulse and grid); counts are "
          "summed. The outcome scores judge only cells inside the rigid model's domain, where the reference is "
          "valid; outside it (where the rigid model would need the table to pull the block down, or more "
          "friction than μ) an engine is right to flag a jump or slip, which consistency measures.")


def _markdown(ctx) -> str:
    doc, labels = ctx["doc"], ctx["labels"]
    L = ["# rockbench report", "", f"Generated {ctx['created']} from {', '.join(ctx['run_dirs'])}.", ""]
    for n in ctx["notes"]:
        L.append(f"> {n}")
    if doc:
        L += ["", "## Verdict", ""] + [f"- {s}" for s in _verdict(doc)] + [""]
    L += ["", "## Summary: which engine is how faithful", ""]
    if doc:
        head, body, _, marks = _summary_rows(doc, labels)
        for col, flags in marks.items():
            for row, is_best in zip(body, flags):
                if is_best:
                    row[col] = f"**{row[col]}**"
        L += [_INTRO + " " + _HIGHLIGHTS, "", _md_table(head, body), ""]
        L += ["What each column measures:", ""]
        L += [f"- **{t}**, {how}: {d}" for t, how, d in _metric_words(doc)] + [""]
    else:
        L += ["_no scores_", ""]
    L += ["## Stability graphs, one per engine variant", "", _READ_GRAPHS, ""]
    for v, label, img in ctx["variant_graphs"]:
        L += [f"### {label}", "", f"![{label}](img/{img})", ""]
    L += ["## θ(t) comparison", ""]
    L += [f"![{c.title}](img/{img})" for c, img in ctx["traj"]] or ["_not drawn_"]
    L += ["", "## Calibration: η per engine", "", _md_table(*_calib_table(ctx["calib"], labels)), ""]
    ph, pb = _price_table(ctx["calib"], labels)
    if pb:
        L += ["### What reaching the target costs", "", _PRICE_WORDS, "", _md_table(ph, pb), ""]
    L += ["## Speed and accuracy", "", _md_table(*_speed_table(ctx["speed"], labels)), ""]
    if ctx["speed_img"]:
        L += [f"![speed and accuracy](img/{ctx['speed_img']})", ""]
    if doc and doc.get("experiments"):
        L += ["## Experiments", "", _md_table(*_exp_table(doc, labels)), ""]
    L += ["<details><summary>Stability graphs by case: every engine variant side by side</summary>", ""]
    for block, pulse, img, _ in ctx["case_graphs"]:
        L += [f"### {case_title(block, pulse)}", "", f"![{block} {pulse}](img/{img})", ""]
    L += ["</details>", "", "<details><summary>Every scored pair</summary>", "",
          _md_table(*_pairs_table(doc, labels)) if doc else "_none_", "", "</details>", "",
          "<details><summary>Versions and settings</summary>", ""]
    t = _settings_tables(ctx["entries"], labels)
    L += ["Run environment:", "", _md_table(*t["env"]), "", "Engine variants:", "", _md_table(*t["variants"]), "",
          "Maps:", "", _md_table(*t["maps"]), "", "</details>", ""]
    return "\n".join(L)


_READ_GRAPHS = ("How to read them: the engine's overturn region is filled; the reference's overturn boundaries "
                "are lines (η_H solid black, η_M with the block's average k dashed, with its exact k dash-dotted, "
                "at the engine's own measured η dotted), and where a boundary encloses only one or a few cells "
                "those cells are outlined; cells where the engine disagrees with the reference of its own "
                "restitution law are marked by kind (▲ overturns where the reference does not, ○ misses an "
                "overturn, ■ failed); dotted areas are where the engine flagged slip, jump or energy gain (on an "
                "adaptive grid, the cells each flagged simulation stands for); the hatched region is outside the "
                "rigid model's domain (it would need lift-off or sliding), so the reference is not valid there; "
                "the dashed ST limit is the shaking table's faithful limit (25 m/s²); T, R, O are experimental "
                "outcomes when given. Under each panel's title: the share of cells with the reference's outcome "
                "(agrees), the mean distance between the two overturn boundaries in the chart's normalised units "
                "(boundary off), and the share of the cells outside the rigid model's domain where the engine "
                "flags slip or jump, as a real block would (flags ... off-model).")


# -- HTML --------------------------------------------------------------------------------------------

_CSS = """body{font-family:system-ui,sans-serif;margin:1.2em auto;max-width:1200px;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.5em;margin:.2em 0}h2{font-size:1.2em;margin:1.2em 0 .4em}h3{font-size:1em;margin:1em 0 .3em}
.meta{color:#555;font-size:13px;margin:.2em 0 .6em}.lead{font-size:14px;margin:.3em 0 .5em}
table{border-collapse:collapse;font-size:13px;margin:.4em 0}td,th{border:1px solid #ccc;padding:3px 6px;text-align:left;vertical-align:top}
th{background:#f0f0f0;font-weight:600}td.num{text-align:right;font-variant-numeric:tabular-nums}td.best{font-weight:700;background:#eef6ee}
#summary-table th{font-size:12px;max-width:7.5em}#summary-table td:first-child{white-space:nowrap}
td.pre{white-space:pre-line;font-size:12px}img{max-width:100%;border:1px solid #ddd}
.wrap{overflow-x:auto;max-width:100%}.wide-note{display:none;color:#7a5b00;font-size:12px;margin:.2em 0}
.wrap.wide + .wide-note, .wide-note.shown{display:block}
.verdict{font-size:14px;margin:.4em 0 .6em;padding-left:1.2em}
dl.metrics{font-size:12.5px;columns:2 30em;column-gap:2em;margin:.4em 0}dl.metrics dt{font-weight:600;break-after:avoid}
dl.metrics dd{margin:0 0 .5em 0;break-inside:avoid}dl.metrics dt span{font-weight:400;color:#555}
details{margin:.8em 0;border:1px solid #ddd;border-radius:4px;padding:.3em .7em}summary{cursor:pointer;font-weight:600}
figure{margin:.6em 0 1.2em}figure img{width:100%;height:auto;display:block}figcaption{font-size:12.5px;color:#444}
.note{background:#fff6d6;padding:.3em .6em}#img-warning{display:none;background:#fdd;padding:.5em}"""

# After load: mark the page when a picture fails to load (a visible warning, and attributes a headless
# browser can read), and give every table wider than its column a visible note.
_CHECK = """<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var bad = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); });
  document.body.setAttribute('data-images', String(imgs.length));
  document.body.setAttribute('data-images-ok', bad.length === 0 ? 'yes' : 'no');
  if (bad.length) { var w = document.getElementById('img-warning'); w.style.display = 'block';
    w.textContent = bad.length + ' picture(s) failed to load.'; }
  var wide = 0;
  Array.prototype.forEach.call(document.querySelectorAll('details'), function (d) { d.open = true; });
  Array.prototype.forEach.call(document.querySelectorAll('.wrap'), function (w) {
    if (w.scrollWidth > w.clientWidth + 1) { w.classList.add('wide'); wide += 1; }
  });
  Array.prototype.forEach.call(document.querySelectorAll('details'), function (d) { d.open = false; });
  document.body.setAttribute('data-wide-tables', String(wide));
  var s = document.getElementById('summary-table');
  if (s) { var r = s.getBoundingClientRect();
    document.body.setAttribute('data-summary-bottom', String(Math.round(r.bottom + window.scrollY)));
    document.body.setAttribute('data-viewport', window.innerWidth + 'x' + window.innerHeight); }
});
</script>"""


def _h_table(head, body, *, id_=None, num_from=None, best=None):
    """An HTML table in a scrolling wrapper with a note shown when it is wider than the page."""
    if not body:
        return "<p><em>none</em></p>"
    th = "".join(f"<th>{for_html(h)}</th>" for h in head)
    rows = []
    for ri, r in enumerate(body):
        cells = []
        for ci, c in enumerate(r):
            cls = []
            if num_from is not None and ci >= num_from:
                cls.append("num")
            if best and best.get(ci) and best[ci][ri]:
                cls.append("best")
            if "\n" in c:
                cls.append("pre")
            attr = f" class='{' '.join(cls)}'" if cls else ""
            cells.append(f"<td{attr}>{for_html(c)}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    ident = f" id='{id_}'" if id_ else ""
    return (f"<div class='wrap'><table{ident}><thead><tr>{th}</tr></thead><tbody>{''.join(rows)}</tbody></table></div>"
            "<p class='wide-note'>This table is wider than the page: scroll it sideways.</p>")


def _page_share(width_in: float | None) -> float:
    """How much of the page's width a figure takes [%]: a double-column figure (175 mm) the whole
    width, a narrower one in proportion, so that every figure's text shows at one size."""
    from .plots.style import DOUBLE_COLUMN_IN
    if not width_in:
        return 100.0
    return min(100.0, 100.0 * width_in / DOUBLE_COLUMN_IN)


def _html(ctx, images: dict) -> str:
    doc, labels = ctx["doc"], ctx["labels"]

    def img(name, alt, caption=None):
        b64 = base64.b64encode(images[name]).decode()
        cap = f"<figcaption>{for_html(caption)}</figcaption>" if caption else ""
        return (f'<figure style="width:{_page_share(ctx["fig_widths"].get(name)):.0f}%"><img alt="{html.escape(alt)}" '
                f'src="data:image/png;base64,{b64}">{cap}</figure>')

    n_var = len(labels)
    P = ["<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
         "<meta name='viewport' content='width=device-width, initial-scale=1'><title>rockbench report</title>",
         f"<style>{_CSS}</style></head><body>", "<div id='img-warning'></div>", "<h1>rockbench report</h1>",
         f"<p class='meta'>Generated {html.escape(ctx['created'])} from {html.escape(', '.join(ctx['run_dirs']))}: "
         f"{len(ctx['entries'])} maps, {n_var} engine variant(s)"
         + (f", metrics version {html.escape(str(doc['metrics_version']))}" if doc else "") + ".</p>"]
    if doc:
        P.append("<section id='verdict'><h2>Verdict</h2><ul class='verdict'>"
                 + "".join(f"<li>{for_html(s)}</li>" for s in _verdict(doc)) + "</ul></section>")
    P += [f"<p class='note'>{html.escape(n)}</p>" for n in ctx["notes"]]
    P.append("<section id='summary'><h2>Summary: which engine is how faithful</h2>")
    if doc:
        head, body, _, marks = _summary_rows(doc, labels)
        P.append(f"<p class='lead'>{html.escape(_INTRO)} {html.escape(_HIGHLIGHTS)}</p>")
        P.append(_h_table(head, body, id_="summary-table", num_from=2, best=marks))
        P.append("<dl class='metrics'>" + "".join(
            f"<dt>{for_html(t)} <span>({html.escape(how)})</span></dt><dd>{html.escape(d)}</dd>"
            for t, how, d in _metric_words(doc)) + "</dl>")
    else:
        P.append("<p><em>no scores</em></p>")
    P.append("</section>")
    P += ["<section id='stability'><h2>Stability graphs, one per engine variant</h2>",
          f"<p class='lead'>{for_html(_READ_GRAPHS)}</p>"]
    for v, label, name in ctx["variant_graphs"]:
        P.append(img(name, f"stability graphs of {label}"))
    if not ctx["variant_graphs"]:
        P.append("<p><em>no engine maps</em></p>")
    P.append("</section><section id='trajectories'><h2>θ(t) comparison</h2>")
    P += [img(name, c.title, "The reference (black and grey, in front) and every engine; circles on the zero line "
              "are impacts, × where a curve passes |θ| = α (overturn), ● where a run ended, decided not to overturn; the table's "
              "acceleration beneath.") for c, name in ctx["traj"]] or ["<p><em>not drawn</em></p>"]
    P += ["</section><section id='calibration'><h2>Calibration: η per engine</h2>",
          _h_table(*_calib_table(ctx["calib"], labels), num_from=3)]
    ph, pb = _price_table(ctx["calib"], labels)
    if pb:
        P += ["<h3>What reaching the target costs</h3>", f"<p>{for_html(_PRICE_WORDS)}</p>", _h_table(ph, pb, num_from=3)]
    P += ["</section><section id='speed'><h2>Speed and accuracy</h2>",
          _h_table(*_speed_table(ctx["speed"], labels), num_from=1)]
    if ctx["speed_img"]:
        P.append(img(ctx["speed_img"], "speed and accuracy", "Each point is one engine variant: its wall time per "
                     "simulated cell across, the primary measure up (the mean distance between its overturning "
                     "boundary and the reference's, lower is better), both on logarithmic axes where the range "
                     "calls for it; a variant whose boundary matches the reference's exactly sits on the dotted "
                     "line marked “none”."))
    P.append("</section>")
    if doc and doc.get("experiments"):
        P += ["<section id='experiments'><h2>Experiments</h2>", _h_table(*_exp_table(doc, labels), num_from=2),
              "</section>"]
    P.append("<details><summary>Stability graphs by case: every engine variant side by side</summary>")
    for block, pulse, name, _ in ctx["case_graphs"]:
        P += [f"<h3>{html.escape(case_title(block, pulse))}</h3>", img(name, f"stability graph {block} {pulse}")]
    P.append("</details>")
    if doc:
        P += [f"<details><summary>Every scored pair ({len(doc['pairs'])})</summary>",
              _h_table(*_pairs_table(doc, labels), num_from=6), "</details>"]
    t = _settings_tables(ctx["entries"], labels)
    P += ["<details><summary>Versions and settings</summary><h3>Run environment</h3>", _h_table(*t["env"]),
          "<h3>Engine variants</h3>", _h_table(*t["variants"]), "<h3>Maps</h3>", _h_table(*t["maps"], num_from=4),
          "</details>", _CHECK, "</body></html>"]
    return "\n".join(P)
