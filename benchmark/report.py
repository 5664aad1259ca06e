"""The benchmark report: ``index.html`` (self-contained) and ``report.md`` with its pictures.

Contents, in order: the summary table (engine × metric, best in bold), every scored pair, the
experiments (when a set is given), one stability graph per block and pulse (reference boundaries,
every engine's boundary, T/R/O markers, the shaking-table limit), θ(t) of the reference and every
engine for chosen cases (the paper's Fig. 17 case by default), the calibration results (η per
engine against Housner, the modified η and the experiment), speed against accuracy, and the
versions and settings of every map (from run.json).

Pictures are written to ``OUT/img/`` (report.md links them) and embedded as base64 in
index.html, so that one file can be mailed or attached to a CI run. Every file is written through
a temporary file and a rename.
"""

from __future__ import annotations

import base64
import csv
import html
import io
import json
import math
import sys
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from ..reference_solver.errors import ConfigError, IncomparableError, RockbenchError
from .atomic import write_bytes_atomic
from .scoring import MapEntry, at_own_eta, load_entries, score_entries, write_json_atomic
from .tables import _vs, fmt, pairs_table, summary, summary_table


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
#: overturns with k = 0.7595 (DOMAIN.md §6).
FIG17 = TrajectoryCase("B3M", "sine", 6.0, 6.1, (0.8608, 0.7595),
                       "Fig. 17 case: B3M, sine, ω/p = 6, a₀/(g·tanα) = 6.1")


def parse_case(text: str, where: str = "--case"):
    """``BLOCK:PULSE:W_RATIO:A_RATIO`` into a TrajectoryCase (ConfigError when malformed).

    ``where`` names the option or suite key the text came from, for messages. The reference
    curves use the modified η with the block's average and exact k.
    """
    from .presets import get_preset

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
                 trajectories: bool = True, log=None) -> dict:
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

    Returns
    -------
    dict
        Paths written (``html``, ``markdown``, ``score``, ``images``), the score document and notes.

    Raises
    ------
    ConfigError
        ``out_dir`` is a file, or no map was found.
    """
    log = log or (lambda msg: print(f"rockbench: {msg}", file=sys.stderr))
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {str(out)!r} is a file; give a directory for the report.")
    from .scoring import load_own_eta, load_runs, mark_runs, pair_within_runs
    entries, run_of = load_runs(run_dirs)
    refs = load_entries(against) if against else [e for e in entries if e.is_reference]
    cands = entries if against else [e for e in entries if not e.is_reference]
    pair_with, notes = (None, []) if against else pair_within_runs(cands, refs, run_of)
    doc = None
    own_eta = load_own_eta(list(run_dirs) + [Path(d).parent for d in run_dirs])
    try:
        doc = score_entries(cands, refs, experiments, own_eta=own_eta, pair_with=pair_with)
        mark_runs(doc, run_of, against=bool(against), notes=notes)
    except IncomparableError as e:
        notes.append(f"No scores: {e}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    images: dict[str, bytes] = {}

    def save(fig, name):
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
        plt.close(fig)
        images[name] = buf.getvalue()
        return name

    # stability graphs, one per block and pulse
    graphs = []
    groups: dict[tuple, dict] = {}
    for e in refs + [c for c in cands if c not in refs]:
        g = groups.setdefault((e.block, e.pulse), {"refs": [], "engines": []})
        (g["refs"] if e in refs else g["engines"]).append(e)
    for (block, pulse), g in sorted(groups.items()):
        fig, ax = plt.subplots(figsize=(7.5, 5.5))
        from .plots.boundaries import plot_boundaries
        pts, st = _points_and_limit(experiments, block, pulse)
        std_refs, own_refs = _split_own_eta_refs(g["refs"], g["engines"], own_eta)
        plot_boundaries([(r.restitution, r.label_map) for r in std_refs],
                        [(f"{e.variant} ({e.restitution})", e.label_map) for e in g["engines"]],
                        own_eta=own_refs, points=pts, st_limit_a_ratio=st,
                        title=f"{block}, {pulse}: overturn boundaries", ax=ax)
        graphs.append((block, pulse, save(fig, f"stability_{_slug(block)}_{_slug(pulse)}.png"), len(pts)))

    # θ(t) comparisons
    traj_imgs = []
    if trajectories:
        for case in cases:
            try:
                name, case_notes = _trajectory_figure(case, cands, save, log)
                notes += case_notes
                if name:
                    traj_imgs.append((case, name))
            except RockbenchError as e:
                notes.append(f"θ(t) for {case.title or case.block}: not drawn ({e})")

    calib = _calibration_rows(cands, own_eta)
    speed = _speed_rows(entries, doc)
    if any(r.get("ms_per_cell") for r in speed if r["variant"] != "reference"):
        from .plots.speed import plot_speed_accuracy
        fig, ax = plt.subplots(figsize=(6.5, 4.0))
        plot_speed_accuracy([r for r in speed if r["variant"] != "reference"], ax=ax)
        speed_img = save(fig, "speed_accuracy.png")
    else:
        speed_img = None

    ctx = {"entries": entries, "refs": refs, "doc": doc, "graphs": graphs, "traj": traj_imgs, "calib": calib,
           "speed": speed, "speed_img": speed_img, "notes": notes, "run_dirs": [str(d) for d in run_dirs],
           "created": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}
    md = _markdown(ctx)
    page = _html(ctx, images)

    out.mkdir(parents=True, exist_ok=True)
    (out / "img").mkdir(exist_ok=True)
    written = []
    for name, data in images.items():
        written.append(write_bytes_atomic(out / "img" / name, data))
    paths = {"images": [str(p) for p in written]}
    if doc is not None:
        paths["score"] = str(write_json_atomic(out / "score.json", doc))
    paths["markdown"] = str(write_bytes_atomic(out / "report.md", md.encode()))
    paths["html"] = str(write_bytes_atomic(out / "index.html", page.encode()))
    log(f"report written to {out / 'index.html'} and {out / 'report.md'}")
    return {**paths, "doc": doc, "notes": notes}


# -- pieces ----------------------------------------------------------------------------------------

def _slug(s: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in str(s)).strip("-").lower()


def _points_and_limit(points, block, pulse):
    from .experiments import st_limit_a_ratio
    from .presets import PRESETS

    if block.upper() not in PRESETS:
        return [], None
    sel = [(p.w_ratio, p.a_ratio, p.outcome, p.repetitions) for p in (points or [])
           if p.block == block.upper() and p.pulse == pulse]
    return sel, st_limit_a_ratio(block)


def _trajectory_figure(case: TrajectoryCase, cands: list[MapEntry], save, log):
    """Simulate ``case`` with the reference (each relevant η) and every engine variant; draw θ(t)."""
    import math as _m

    import matplotlib.pyplot as plt
    import numpy as np

    from ..engines.base import Case
    from ..engines.registry import get_adapter
    from ..reference_solver.model import G
    from ..reference_solver.pulses import make_pulse
    from ..reference_solver.restitution import Restitution
    from .plots.trajectories import plot_theta
    from .presets import get_preset

    notes = []
    block = get_preset(case.block).block()
    omega = case.w_ratio * block.p_rad_s
    amp = case.a_ratio * G * _m.tan(block.alpha_rad)
    pulse = make_pulse(case.pulse, amp, omega)
    runs = [("reference", {}, Restitution("modified", k=k)) for k in case.reference_k]
    variants = {}
    for e in cands:
        settings = dict((e.run.get("spec") or {}).get("engine_settings") or {})
        variants.setdefault((e.variant, e.restitution), (e.engine, settings, e))
    for (variant, rest_label), (engine, settings, e) in sorted(variants.items()):
        rest = _restitution_from_label(rest_label, case.block)
        if rest is None:
            notes.append(f"θ(t): restitution {rest_label!r} of {variant} not understood; skipped")
            continue
        if not any(r[0] == "reference" and r[2] == rest for r in runs):
            runs.append(("reference", {}, rest))
        runs.append((variant, (engine, settings), rest))
    hist = []
    for name, how, rest in runs:
        engine, settings = ("reference", {}) if name == "reference" else how
        label = f"{name} ({rest.label}, η={rest.eta(block.alpha_rad):.4f})"
        try:
            adapter = _history_adapter(engine, settings, get_adapter)
            log(f"θ(t): {label}")
            tr = adapter.simulate(Case(block, pulse, rest))
            hist.append((label, tr.t_s, tr.theta_rad))
        except Exception as ex:  # noqa: BLE001 - one engine failing must not sink the report
            notes.append(f"θ(t) {label}: {type(ex).__name__}: {ex}")
    if not hist:
        return None, notes
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    plot_theta(hist, alpha_rad=block.alpha_rad, t_pulse_end_s=pulse.duration_s, title=case.title, ax=ax)
    # long enough to see the free rocking after the pulse, not the whole decay to rest
    t_end = max(float(np.asarray(t)[-1]) for _, t, _ in hist)
    ax.set_xlim(0.0, min(t_end, max(1.0, 10.0 * pulse.duration_s)))
    return save(fig, f"theta_{_slug(case.block)}_{_slug(case.pulse)}_{case.w_ratio:g}_{case.a_ratio:g}.png"), notes


def _history_adapter(engine: str, settings: dict, get_adapter):
    """The adapter for a θ(t) curve: the reference integrates on after the pulse (``mode="to-rest"``)
    so the curve shows the free rocking, instead of stopping with the energy decision."""
    if engine == "reference":
        try:
            return get_adapter("reference", mode="to-rest")
        except ConfigError:  # a reference adapter without that setting: its default history
            pass
    return get_adapter(engine, **settings)


def _restitution_from_label(label: str, block: str):
    from ..reference_solver.restitution import Restitution
    t = label.strip().lower()
    if t == "housner":
        return Restitution()
    if t.startswith("modified(k=") and t.endswith(")"):
        return Restitution("modified", k=float(t[len("modified(k="):-1]))
    try:
        return Restitution("constant", value=float(t))
    except (ValueError, RockbenchError):
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
    ``(label, label_map, engine index)``: a reference whose η is an engine variant's measured η
    (the pairing the scores call ``own-eta``) goes with the first such engine of ``engines``; one
    matching no engine of the graph stays a standard reference."""
    std, own = [], []
    for r in refs:
        owners = [k for k, e in enumerate(engines) if at_own_eta(r, e, own_eta)]
        if not owners:
            std.append(r)
            continue
        names = ", ".join(dict.fromkeys(engines[k].variant for k in owners))
        own.append((f"reference at own η of {names} (η = {r.eta:.4f})", r.label_map, owners[0]))
    return std, own


def _calibration_rows(cands: list[MapEntry], own_eta: dict | None = None) -> list[dict]:
    """η measured per engine map against Housner, the modified η and the experiment.

    The η comes from the calibration recorded in the map's run.json (calibrated settings), else
    from the free-rocking measurement of ``rockbench run`` (``own_eta``).
    """
    from .experiments import restitution_targets
    from .presets import PRESETS

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
        r = {"variant": e.variant, "block": e.block, "restitution": e.restitution, "eta_target": e.eta,
             "eta_measured": float(measured) if measured is not None else math.nan}
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
        path = e.path / "cells.csv"
        try:
            with open(path, newline="") as f:
                for row in csv.DictReader(f):
                    try:
                        w = float(row.get("wall_s") or "nan")
                    except ValueError:
                        continue
                    if math.isfinite(w) and row.get("status", "ok") == "ok":
                        per.setdefault(e.variant, []).append(w)
        except OSError:
            continue
    rows = []
    for v in sorted({e.variant for e in entries}):
        ws = per.get(v, [])
        ms = 1e3 * sum(ws) / len(ws) if ws else math.nan
        rows.append({"variant": v, "cells": len(ws), "ms_per_cell": ms,
                     "agreement": acc.get(v, {}).get("agreement", math.nan),
                     "boundary_mean": acc.get(v, {}).get("boundary_mean", math.nan)})
    return rows


def _versions(entries: list[MapEntry]) -> list[dict]:
    out = []
    for e in entries:
        r = e.run or {}
        eng = r.get("engine") or {}
        out.append({"map": f"{e.variant} {e.block} {e.pulse} {e.restitution}", "dir": str(e.path),
                    "engine_version": eng.get("version"), "settings": eng.get("settings"),
                    "resolved_settings": eng.get("resolved_settings"), "rockbench": r.get("rockbench_version"),
                    "git": r.get("git"), "python": r.get("python"), "platform": r.get("platform"),
                    "created_utc": r.get("created_utc"), "grid": e.describe()["grid"],
                    "dt_s": (r.get("spec") or {}).get("dt_s"), "options": r.get("options")})
    return out


def _num(x, spec=".4f"):
    return "n/a" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, spec)


def _calib_table(rows):
    head = ["engine", "block", "target", "η target", "η measured", "vs Housner", "vs modified (avg k)",
            "vs experiment (exact k)"]
    body = [[r["variant"], r["block"], r["restitution"], _num(r["eta_target"]), _num(r["eta_measured"]),
             *(_num(100 * r.get(f"{k}_rel_error", math.nan), "+.2f") + (" %" if math.isfinite(
                 r.get(f"{k}_rel_error", math.nan)) else "")
               for k in ("housner", "modified_average_k", "experiment"))] for r in rows]
    return head, body


def _speed_table(rows):
    head = ["engine", "cells", "ms per cell", "agreement", "boundary mean"]
    body = [[r["variant"], str(r["cells"]), _num(r["ms_per_cell"], ".2f"), fmt("agreement", r["agreement"]),
             fmt("boundary_mean", r["boundary_mean"])] for r in rows]
    return head, body


def _exp_table(doc):
    head = ["map", "restitution", "runs", "outside", "accuracy", "overturn accuracy", "confusion T/R/O → rest/rocking/overturn/failed"]
    body = []
    for e in (doc or {}).get("experiments", []):
        conf = "; ".join(f"{k}: " + "/".join(str(v) for v in row.values()) for k, row in e["confusion"].items())
        body.append([f"{e['variant']} {e['block']} {e['pulse']}", e["restitution"], str(e["runs"]), str(e["outside"]),
                     _num(e["accuracy"], ".3f"), _num(e["overturn_accuracy"], ".3f"), conf])
    return head, body


def _md_table(head, body):
    from .tables import render
    return render(head, body, markdown=True) if body else "_none_"


def _markdown(ctx) -> str:
    doc = ctx["doc"]
    L = ["# rockbench report", "", f"Generated {ctx['created']} from {', '.join(ctx['run_dirs'])}.", ""]
    for n in ctx["notes"]:
        L.append(f"> {n}")
    L += ["", "## Summary", "",
          "Mean over each engine's like-for-like pairs (engine map vs the reference map with the same restitution "
          "law); counts are summed. Best value of each column in bold. Metric definitions: docs/scores.md.", ""]
    L.append(summary_table(doc, markdown=True) if doc else "_no scores_")
    L += ["", "## Every scored pair", "", pairs_table(doc, markdown=True) if doc else "_none_", ""]
    if doc and doc.get("experiments"):
        L += ["## Experiments", "", _md_table(*_exp_table(doc)), ""]
    L += ["## Stability graphs", ""]
    for block, pulse, img, n_pts in ctx["graphs"]:
        L += [f"### {block}, {pulse}", "", f"![{block} {pulse}](img/{img})", ""]
    L += ["## θ(t) comparison", ""]
    L += [f"![{c.title}](img/{img})" for c, img in ctx["traj"]] or ["_not drawn_"]
    L += ["", "## Calibration: η per engine", "", _md_table(*_calib_table(ctx["calib"])), ""]
    L += ["## Speed and accuracy", "", _md_table(*_speed_table(ctx["speed"])), ""]
    if ctx["speed_img"]:
        L += [f"![speed and accuracy](img/{ctx['speed_img']})", ""]
    L += ["## Versions and settings", "", "```json", json.dumps(_versions(ctx["entries"]), indent=1, default=str),
          "```", ""]
    return "\n".join(L)


_CSS = """body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1200px;color:#222}
table{border-collapse:collapse;font-size:13px;margin:.5em 0}td,th{border:1px solid #ccc;padding:3px 6px;text-align:left}
th{background:#f0f0f0}img{max-width:100%;border:1px solid #ddd}pre{background:#f7f7f7;padding:.5em;overflow:auto;font-size:12px}
.wrap{overflow-x:auto}.note{background:#fff6d6;padding:.3em .6em}#img-warning{display:none;background:#fdd;padding:.5em}"""

# Marks the page when a picture fails to load (a visible warning, and attributes a headless browser can read).
_CHECK = """<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var bad = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); });
  document.body.setAttribute('data-images', String(imgs.length));
  document.body.setAttribute('data-images-ok', bad.length === 0 ? 'yes' : 'no');
  if (bad.length) { var w = document.getElementById('img-warning'); w.style.display = 'block';
    w.textContent = bad.length + ' picture(s) failed to load.'; }
});
</script>"""


def _h_table(head, body):
    if not body:
        return "<p><em>none</em></p>"
    th = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    trs = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in body)
    return f"<div class='wrap'><table><thead><tr>{th}</tr></thead><tbody>{trs}</tbody></table></div>"


def _html(ctx, images: dict) -> str:
    doc = ctx["doc"]

    def img(name, alt):
        b64 = base64.b64encode(images[name]).decode()
        return f'<p><img alt="{html.escape(alt)}" src="data:image/png;base64,{b64}"></p>'

    P = ["<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>rockbench report</title>",
         f"<style>{_CSS}</style></head><body>", "<div id='img-warning'></div>", "<h1>rockbench report</h1>",
         f"<p>Generated {html.escape(ctx['created'])} from {html.escape(', '.join(ctx['run_dirs']))}.</p>"]
    P += [f"<p class='note'>{html.escape(n)}</p>" for n in ctx["notes"]]
    P += ["<h2>Summary</h2><p>Mean over each engine's like-for-like pairs (engine map vs the reference map with "
          "the same restitution law); counts are summed. Best value of each column in bold.</p>"]
    P.append(f"<div class='wrap'>{summary_table(doc, html=True)}</div>" if doc else "<p><em>no scores</em></p>")
    if doc:
        head = ["engine", "block", "pulse", "restitution", "vs reference", "like"] + list(doc["pairs"][0]["scores"])
        body = [[p["variant"], p["block"], p["pulse"], p["restitution"], _vs(p),
                 "yes" if p["like_for_like"] else "", *(fmt(k, v) for k, v in p["scores"].items())] for p in doc["pairs"]]
        P += ["<h2>Every scored pair</h2>", _h_table(head, body)]
        if doc.get("experiments"):
            P += ["<h2>Experiments</h2>", _h_table(*_exp_table(doc))]
        P += ["<h3>Metric definitions</h3><ul>"]
        P += [f"<li><b>{html.escape(m['name'])}</b> ({m['direction']} is better, perfect {m['perfect']:g}): "
              f"{html.escape(m['definition'])}</li>" for m in doc["metrics"]]
        P.append(f"</ul><p>Metrics version {html.escape(str(doc['metrics_version']))}.</p>")
    P.append("<h2>Stability graphs</h2>")
    for block, pulse, name, n_pts in ctx["graphs"]:
        P += [f"<h3>{html.escape(block)}, {html.escape(pulse)}</h3>", img(name, f"stability graph {block} {pulse}")]
    P.append("<h2>θ(t) comparison</h2>")
    P += [img(name, c.title) for c, name in ctx["traj"]] or ["<p><em>not drawn</em></p>"]
    P += ["<h2>Calibration: η per engine</h2>", _h_table(*_calib_table(ctx["calib"]))]
    P += ["<h2>Speed and accuracy</h2>", _h_table(*_speed_table(ctx["speed"]))]
    if ctx["speed_img"]:
        P.append(img(ctx["speed_img"], "speed and accuracy"))
    P += ["<h2>Versions and settings</h2>",
          f"<pre>{html.escape(json.dumps(_versions(ctx['entries']), indent=1, default=str))}</pre>",
          _CHECK, "</body></html>"]
    return "\n".join(P)
