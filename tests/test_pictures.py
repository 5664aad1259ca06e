"""What each picture draws: artists, labels, nothing off the axes, legends clear of the data."""

import re

import numpy as np
import pytest

from rockbench.benchmark.maps.result import MapResult


matplotlib = pytest.importorskip("matplotlib")
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.collections import LineCollection, QuadMesh  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

INTERNAL_KEY = re.compile(r"\w+\[[^\]]*=[^\]]*\]|modified\(k=|housner\b")


def _renderer(fig):
    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def assert_nothing_off_axes(ax, tol=1e-6):
    """Every line, marker, line collection and text of ``ax`` lies within its limits (cell fills are
    clipped at the frame)."""
    x0, x1 = sorted(ax.get_xlim())
    y0, y1 = sorted(ax.get_ylim())
    dx, dy = tol * (x1 - x0) + 1e-12, tol * (y1 - y0) + 1e-12
    for line in ax.lines:
        if line.get_transform() != ax.transData:
            # axhline/axvline: the data coordinate they sit at must be on the chart
            x, y = line.get_xdata(), line.get_ydata()
            if line.get_transform() == ax.get_yaxis_transform():
                assert all(y0 - dy <= v <= y1 + dy for v in y), f"{line} off the axes"
            elif line.get_transform() == ax.get_xaxis_transform():
                assert all(x0 - dx <= v <= x1 + dx for v in x), f"{line} off the axes"
            continue
        x = np.asarray(line.get_xdata(), float)
        y = np.asarray(line.get_ydata(), float)
        assert np.all((x >= x0 - dx) & (x <= x1 + dx)), f"{line.get_label()} leaves the x range"
        assert np.all((y >= y0 - dy) & (y <= y1 + dy)), f"{line.get_label()} leaves the y range"
    for c in ax.collections:
        if isinstance(c, QuadMesh):
            assert c.get_clip_on()
            continue
        if isinstance(c, LineCollection):
            for seg in c.get_segments():
                seg = np.asarray(seg)
                assert np.all((seg[:, 0] >= x0 - dx) & (seg[:, 0] <= x1 + dx))
                assert np.all((seg[:, 1] >= y0 - dy) & (seg[:, 1] <= y1 + dy))
    r = _renderer(ax.figure)
    box = ax.get_window_extent(r).expanded(1.0, 1.0).padded(2)
    for t in ax.texts:
        if t.get_text():
            bb = t.get_window_extent(r)
            assert box.x0 <= bb.x0 and bb.x1 <= box.x1 and box.y0 <= bb.y0 and bb.y1 <= box.y1, t.get_text()


def assert_legend_clear(fig, legend):
    """The legend lies inside the figure and overlaps no axes (so it covers no data)."""
    r = _renderer(fig)
    bb = legend.get_window_extent(r)
    fb = fig.bbox
    assert fb.x0 - 1 <= bb.x0 and bb.x1 <= fb.x1 + 1 and fb.y0 - 1 <= bb.y0 and bb.y1 <= fb.y1 + 1, "legend cut off"
    for ax in fig.axes:
        if ax.get_visible():
            assert not bb.overlaps(ax.get_window_extent(r)), "legend over an axes"


def _labels(legend):
    return [t.get_text() for t in legend.get_texts()]


# -- maps for the pictures ---------------------------------------------------------------------

def _maps(band):
    w = np.linspace(1.0, 10.0, 12)
    a = np.linspace(1.0, 8.0, 10)
    ref_codes = band(10, 12, 5)
    ref_valid = np.ones((10, 12), bool)
    ref_valid[8:, :3] = False                       # lift-required in the top left
    ref = MapResult.from_outcomes(w, a, ref_codes, ref_valid, ~ref_valid)
    mod = MapResult.from_outcomes(w, a, band(10, 12, 6))
    eng_codes = band(10, 12, 5)
    eng_codes[5, 7] = 1                              # misses an overturn
    eng_codes[4, 2] = 2                              # overturns where the reference does not
    eng_codes[2, 9] = -1                             # failed
    eng_valid = eng_codes >= 0
    eng_valid[9, 0] = False                          # flagged (outside the domain: the right answer)
    eng = MapResult.from_outcomes(w, a, eng_codes, eng_valid, ~eng_valid & (eng_codes >= 0))
    return w, a, ref, mod, eng


def test_panel_draws_every_layer_where_it_belongs(band):
    from rockbench.benchmark.report.plots.stability import plot_panel
    w, a, ref, mod, eng = _maps(band)
    d = plot_panel(eng, [("reference, η_H", ref), ("reference, η_M with the average k", mod)], like=ref,
                   points=[(3.0, 2.0, "R", 1), (9.0, 7.0, "O", 2), (50.0, 2.0, "T", 1)], st_limit=6.5,
                   title="MuJoCo 4.0, calibrated to η_H")
    ax = d["ax"]
    assert d["fill"] is not None and d["hatch"] is not None
    assert set(d["references"]) == {"reference, η_H", "reference, η_M with the average k"}
    assert all(isinstance(v, LineCollection) for v in d["references"].values())
    # each disagreement marked at its cell, by kind
    got = {k: list(zip(np.round(v.get_xdata(), 6), np.round(v.get_ydata(), 6))) for k, v in d["marks"].items()}
    assert got["missed_overturn"] == [(round(w[7], 6), round(a[5], 6))]
    assert got["false_overturn"] == [(round(w[2], 6), round(a[4], 6))]
    assert got["failed"] == [(round(w[9], 6), round(a[2], 6))]
    # the flagged cell as a dotted area over that cell, its edges half-way to the neighbours
    (box,) = [p.get_extents() for p in d["flags"].get_paths()]
    x0, y0, x1, y1 = box.x0, box.y0, box.x1, box.y1
    assert x0 == pytest.approx(w[0]) and x1 == pytest.approx((w[0] + w[1]) / 2)
    assert y0 == pytest.approx((a[8] + a[9]) / 2) and y1 == pytest.approx(a[9])
    assert "engine flagged slip, jump or energy gain (dotted)" in d["handles"]
    # the ST limit on the chart, the point outside it left out
    assert d["st_limit"] is not None and d["st_limit"][1].get_text() == "ST limit"
    assert set(d["points"]) == {"R", "O"}
    assert "calibrated to" in ax.get_title(loc="left") and not INTERNAL_KEY.search(ax.get_title(loc="left"))
    assert_nothing_off_axes(ax)


def test_panel_leaves_out_an_st_limit_off_the_chart(band):
    from rockbench.benchmark.report.plots.stability import plot_panel
    _, _, ref, _, eng = _maps(band)
    d = plot_panel(eng, [("reference, η_H", ref)], st_limit=20.0)
    assert d["st_limit"] is None and "st" not in d["handles"]
    assert not any("ST limit" in t.get_text() for t in d["ax"].texts)


def test_small_multiples_share_one_legend_below_the_panels(band):
    from rockbench.benchmark.report.plots.stability import plot_panels
    _, _, ref, mod, eng = _maps(band)
    panels = [{"engine": eng, "references": [("reference, η_H", ref), ("reference, η_M with the average k", mod)],
               "like": ref, "st_limit": 6.5, "title": t} for t in ("MuJoCo 4.0, calibrated to η_H",
                                                                   "PyBullet 3.2.7, as shipped",
                                                                   "Exudyn 1.9, calibrated to η_H", "Drake 1.51")]
    d = plot_panels(panels, suptitle="B3M, one sine wave")
    fig = d["figure"]
    assert len(d["axes"]) == 4 and sum(ax.get_visible() for ax in fig.axes) == 4
    labels = _labels(d["legend"])
    assert labels[:2] == ["engine overturns", "outside the rigid model's domain (lift-off or sliding)"]
    assert "overturns where the reference does not" in labels and "ST limit (shaking table, 25 m/s²)" in labels
    assert len(labels) == len(set(labels))
    assert not any(INTERNAL_KEY.search(t) for t in labels)
    assert_legend_clear(fig, d["legend"])
    for ax in d["axes"]:
        assert_nothing_off_axes(ax)
    # readable at the size the report shows it (110 dpi, shown 1:1)
    assert min(t.get_fontsize() for t in d["legend"].get_texts()) >= 7


def test_boundary_lines_are_smooth_and_keep_every_cell_on_its_side():
    from matplotlib.path import Path as MPath

    from rockbench.benchmark.report.plots.stability import boundary_lines
    n = 30
    w = a = np.linspace(0.0, 29.0, n)
    ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    codes = np.where(ii > jj + 0.5, 2, 1)            # an oblique staircase boundary
    codes[5, 20] = 2                                  # an isolated overturn cell
    lines = boundary_lines(MapResult.from_outcomes(w, a, codes))
    assert len(lines) == 2
    loop = next(p for p in lines if np.allclose(p[0], p[-1]))
    path = MPath(loop)
    inside = [(i, j) for i in range(n) for j in range(n) if path.contains_point((w[j], a[i]))]
    assert inside == [(5, 20)]                        # the isolated cell, and only it, inside its loop
    diag = next(p for p in lines if p is not loop)
    # the staircase is smoothed: the line stays within a third of a cell of the diagonal a = w + 0.5
    mid = diag[5:-5]
    assert np.max(np.abs(mid[:, 1] - mid[:, 0] - 0.5)) < 0.34
    # and every cell stays on its side of it
    order = np.argsort(diag[:, 0])
    line_a = np.interp(w, diag[order, 0], diag[order, 1])      # the line's height over each column
    for i in range(n):
        for j in range(n):
            if (i, j) != (5, 20):
                assert (a[i] > line_a[j]) == (codes[i, j] == 2), (i, j)


def test_map_picture_overlays_the_reference_and_marks_invalid_cells(band, tmp_path):
    from types import SimpleNamespace

    from rockbench.benchmark.maps.grid import MapSpec, make_axis
    from rockbench.benchmark.report.plots.stability import plot_map, plot_map_files
    from rockbench.benchmark.blocks.presets import get_preset
    from rockbench.reference_solver.restitution import Restitution
    _, _, ref, _, eng = _maps(band)
    spec = MapSpec(get_preset("B3M").block(), "sine", Restitution(), make_axis("--w-ratio", "w_ratio", 1, 10, 12),
                   make_axis("--a-ratio", "a_ratio", 1, 8, 10), engine="mujoco", engine_settings={"settings": "calibrated"})
    res = SimpleNamespace(spec=spec, outcome=eng.outcome, valid=eng.valid, left_model=eng.left_model,
                          simulated=np.ones(eng.outcome.shape, bool), w_ratio=eng.w_ratio, a_ratio=eng.a_ratio,
                          adaptive=False, fraction_simulated=1.0)
    fig = Figure(figsize=(6.4, 5.6), layout="constrained")
    d = plot_map(res, reference=ref, ax=fig.add_subplot())
    assert d["boundary"] is not None and d["hatch"] is not None
    assert len(d["flags"].get_paths()) == 1 and len(d["marks"]["failed"].get_xdata()) == 1
    labels = _labels(d["legend"])
    assert "reference boundary ($\\eta_\\mathrm{H}$)" in labels and any(t.startswith("engine flagged") for t in labels)
    assert d["ax"].get_title(loc="left").startswith("MuJoCo, calibrated to")
    assert_legend_clear(fig, d["legend"])
    assert_nothing_off_axes(d["ax"])
    (p,) = plot_map_files(res, tmp_path / "map", reference=ref)
    assert p.name == "map.png" and p.read_bytes()[:4] == b"\x89PNG"


def test_theta_plot_draws_references_in_front_and_each_curve_to_its_own_end():
    from rockbench.benchmark.report.plots.trajectories import plot_theta
    from rockbench.reference_solver.pulses import make_pulse
    alpha = 0.2
    t1, t2 = np.linspace(0, 0.6, 300), np.linspace(0, 0.35, 100)
    runs = [{"label": "reference, η_H: rocking", "t_s": t1, "theta_rad": 0.1 * np.sin(20 * t1), "reference": True,
             "impacts_s": [np.pi / 20, 2 * np.pi / 20], "outcome": "rocking"},
            {"label": "MuJoCo 4.0, calibrated to η_H: rocking", "t_s": t2, "theta_rad": 0.08 * np.sin(20 * t2),
             "outcome": "rocking"}]
    d = plot_theta(runs, alpha_rad=alpha, pulse=make_pulse("sine", 10.0, 40.0))
    ax = d["ax"]
    ref, eng = d["lines"]["reference, η_H: rocking"], d["lines"]["MuJoCo 4.0, calibrated to η_H: rocking"]
    assert ref.get_zorder() > eng.get_zorder()                      # the reference in front
    assert eng.get_xdata()[-1] == pytest.approx(0.35) and ax.get_xlim()[1] == pytest.approx(0.6)
    assert list(d["impacts"]["reference, η_H: rocking"].get_xdata()) == pytest.approx([np.pi / 20, np.pi / 10])
    assert set(d["ends"]) == {"reference, η_H: rocking", "MuJoCo 4.0, calibrated to η_H: rocking"}
    # the y range fits the data (|θ/α| ≤ 0.5 here: no ±1 threshold stretched in)
    assert d["ylim"][1] == pytest.approx(0.5 * 1.08)
    assert d["ax_pulse"] is not None and d["ax_pulse"].get_shared_x_axes().joined(ax, d["ax_pulse"])
    assert_legend_clear(d["figure"], d["legend"])
    assert_nothing_off_axes(ax)
    assert_nothing_off_axes(d["ax_pulse"])


def test_theta_plot_caps_the_range_of_an_overturning_curve():
    from rockbench.benchmark.report.plots.trajectories import plot_theta
    t = np.linspace(0, 1, 200)
    d = plot_theta([{"label": "x", "t_s": t, "theta_rad": 3 * t, "outcome": "overturn"}], alpha_rad=1.0)
    # the range ends just above the threshold: the fall after it would squash the rest
    assert d["ylim"][1] == pytest.approx(1.08, rel=0.02)
    assert d["ends"]["x"].get_ydata()[0] == pytest.approx(1.0)


def test_accuracy_cost_curves_one_per_engine_the_rule_circled():
    from rockbench.benchmark.report.plots.speed import plot_accuracy_cost
    pts = [{"dt_s": 1e-3, "value": 0.4, "cost": 0.3}, {"dt_s": 5e-4, "value": 0.12, "cost": 0.6},
           {"dt_s": 1e-4, "value": 0.03, "cost": 3.0}]
    speed = {"engines": [
        {"engine": "mujoco", "label": "MuJoCo 4.0", "points": pts, "band": {"value": 0.01, "source": "verdict"},
         "matched": {"finest": pts[-1]}, "rule": {"on_curve": 5e-4, "value": 0.12, "cost": 0.6}},
        {"engine": "drake", "label": "Drake 1.51", "points": [{**p, "cost": 10 * p["cost"]} for p in pts],
         "rule": {"on_curve": None, "value": 0.06, "cost": 12.0}},
        {"engine": "none", "label": "Nothing", "points": [{"dt_s": 1e-3, "value": None, "cost": None}]}],
        "declared": {"matched_distance": 0.037}}
    d = plot_accuracy_cost(speed)
    ax = d["ax"]
    assert set(d["curves"]) == {"mujoco", "drake"}   # an engine without a point to draw has no curve
    assert ax.get_xscale() == "log" and d["logy"] and ax.get_yscale() == "log"   # 0.03 to 0.4: a decade
    assert list(d["curves"]["mujoco"].get_xdata()) == [0.3, 0.6, 3.0]   # coarsest step first
    assert d["rule"]["mujoco"].get_xdata()[0] == 0.6 and d["rule"]["drake"].get_xdata()[0] == 12.0
    assert set(d["bands"]) == {"mujoco"}             # the band needs the engine's detectable difference
    texts = [t.get_text() for t in d["legend"].get_texts()]
    assert texts[:2] == ["MuJoCo 4.0", "Drake 1.51"] and "step 0.5 ms" in texts and "declared distance 0.037" in texts
    assert "finest step ± the verdict's detectable difference (0.010)" in texts   # the band says whose it is
    assert {t.get_text() for t in d["labels"]} <= {"1 ms", "0.5 ms", "0.1 ms"} and d["labels"]
    ticks = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
    assert ticks and all(re.fullmatch(r"[0-9.]+", t) for t in ticks), ticks   # plain numbers, no 10^x


def test_labels_in_words():
    from rockbench.benchmark.scoring.labels import restitution_symbol, short_version, variant_label
    assert variant_label("mujoco", {"settings": "calibrated"}, version="4.0.0", restitution="housner") == \
        "MuJoCo 4.0, calibrated to η_H"
    assert variant_label("pybullet", {"settings": "shipped"}, version="3.2.7") == "PyBullet 3.2.7, as shipped"
    assert variant_label("exudyn", {"drive": "table"}, restitution="modified(k=0.8608)", block="B3M",
                         dt_s=1e-4) == "Exudyn, calibrated to η_M (k = 0.8608, average k), table drive, Δt = 0.1 ms"
    assert restitution_symbol("0.9") == "η = 0.9" and short_version("1.9.1") == "1.9.1"


def test_labels_name_the_solver_of_an_engine_with_several():
    """Newton's variants say which solver ran, its default (XPBD) included; a solver given to
    another engine is named too; an engine whose adapter is unknown keeps what was given."""
    from rockbench.benchmark.scoring.labels import variant_label
    assert variant_label("newton", {"settings": "calibrated"}, version="1.8.0", restitution="housner") == \
        "Newton 1.8, calibrated to η_H, XPBD solver"
    assert variant_label("newton", {"settings": "shipped", "solver": "semi_implicit"}) == \
        "Newton, as shipped, semi-implicit solver"
    assert variant_label("mujoco_warp", {"solver": "cg"}, restitution="housner") == \
        "MuJoCo Warp, calibrated to η_H, CG solver"
    assert variant_label("no_such_engine", {"settings": "shipped"}) == "no_such_engine, as shipped"


def test_paper_figure_lists_the_st_limit_only_when_it_is_on_the_chart(tmp_path):
    """Fig. 5 (B6M): the table limit, a₀/(g·tanα) = 11.5, lies above the chart's 10: neither drawn nor
    listed; the legend sits below the axes and the labels read as the paper writes them."""
    from rockbench.benchmark.figures import FIGURES, curve_spec
    from rockbench.benchmark.sweep import run_map
    from rockbench.benchmark.report.plots.stability import plot_stability
    _, curves = FIGURES[5]
    maps = [run_map(curve_spec(c, 12), tmp_path / f"m{k}", serial=True) for k, c in enumerate(curves)]
    d = plot_stability(maps, [c.label() for c in curves], title="Fig. 5")
    labels = _labels(d["legend"])
    assert d["st_limit_a_ratio"] is None and not any("ST limit" in t for t in labels)
    assert "B6M, $\\eta_\\mathrm{H}$ = 0.9294" in labels and not any("(η =" in t for t in labels)
    assert len(d["boundaries"]) == 2
    assert_legend_clear(d["ax"].figure, d["legend"])
    assert_nothing_off_axes(d["ax"])


# -- the verdict as a picture ---------------------------------------------------------------------------------

def _verdict_doc(failing=True, planted=True, no_boundary=False):
    """A verdict object of a suite like the default one: two classes, held-out twins, planted δ, failures
    (with ``no_boundary``, the failing variant's maps have no boundary: its distance is the placeholder)."""
    from rockbench.benchmark.scoring.verdict import verdict
    probs = [(b, p) for b in ("B3M", "B6M") for p in ("sine", "cosine")]

    def pair(variant, engine, settings, block, pulse, value, **extra):
        return {"variant": variant, "engine": engine, "label": variant, "settings": settings, "block": block,
                "pulse": pulse, "like_for_like": True, "scores": {"boundary_mean": value},
                "cells": {"w_step": 0.05, "a_step": 0.05}, "cells_in_domain": 100, "reference_standing": 80,
                "reference_overturn": 20, "overturn_missed": 10, **extra}

    pairs = []
    for k, (engine, name) in enumerate([("mujoco", "MuJoCo 4.0"), ("pybullet", "PyBullet 3.2.7"), ("dart", "DART 6.20")]):
        for b, p in probs:
            pairs.append(pair(f"{name}, calibrated to η_H", engine, "calibrated", b, p, 0.01 + 0.02 * k))
            lost = failing and k == 0 and no_boundary
            pairs.append(pair(f"{name}, as shipped", engine, "as-shipped", b, p,
                              18.6 if lost else (0.9 if failing and k == 0 else 0.04 + 0.05 * k),
                              **({"cells": {"w_step": 0.05, "a_step": 0.05, "engine_crossings": 0,
                                            "reference_crossings": 12}} if lost else {})))
            pairs.append(pair(f"{name}, held out", engine, f"{name} held", b.replace("M", "L"), p, 0.02 + 0.02 * k,
                              held_out=True, in_sample_variant=f"{name}, calibrated to η_H"))
    if planted:
        for f in (1.0, 0.995, 0.99, 0.98):
            pairs += [pair(f"Reference solver, η_H × {f:g} (planted)", "reference", "planted", b, p,
                           (1 - f) * 1.5, planted_eta_factor=f) for b, p in probs]
    gaps = [{"block": b.replace("M", size), "pulse": p, "boundary_mean": 0.2} for b, p in probs for size in "ML"]
    return verdict({"pairs": pairs, "reference_gaps": gaps})     # fail limit 0.2, held-out margin 0.1


def _tick_boxes(fig, axes):
    r = _renderer(fig)
    return [t.get_window_extent(r) for ax in axes for t in ax.get_yticklabels() if t.get_text()]


def test_the_verdict_forest_plot_draws_every_variant_by_class():
    from rockbench.benchmark.report.plots.verdict import plot_verdict
    v = _verdict_doc()
    d = plot_verdict(v)
    rows = [r for r in d["rows"] if r["kind"] == "variant"]
    groups = [r["group"] for r in rows]
    # grouped as the verdict answers: classes, held out beside its twin, planted apart, failing at the bottom
    assert groups == sorted(groups, key=["calibrated", "as-shipped", "held-out", "planted", "fails"].index)
    assert groups[-1] == "fails" and rows[-1]["right"].startswith("0.900")
    marks = {r["variant"]: r["mark"] for r in rows}
    assert marks["MuJoCo 4.0, calibrated to η_H"] == "best" and marks["DART 6.20, calibrated to η_H"] == "behind"
    held = next(r for r in rows if r["variant"] == "MuJoCo 4.0, held out")
    assert held["value"] == pytest.approx(0.02) and held["twin"] == pytest.approx(0.01)
    assert held["right"] == "0.020 vs 0.010: carries over" and held["label"] == "MuJoCo 4.0, held out"
    assert len([r for r in rows if r["group"] == "planted"]) == 4
    # the detectable difference as a band from each class's best, the margin and the fail limit as lines
    fam = v["mcb"]["calibrated"]
    (x0, x1) = d["bands"]["calibrated"].get_paths()[0].get_extents().intervalx
    assert x0 == pytest.approx(0.01) and x1 == pytest.approx(0.01 + (fam.get("across") or {}).get("mdd", fam["mdd"]))
    assert d["lines"]["margin"].get_xdata()[0] == pytest.approx(0.2)
    assert d["lines"]["fail"].get_xdata()[0] == pytest.approx(0.2)          # the largest gap
    assert d["ax"].get_xscale() == "symlog"            # failing values reach past the limit
    assert_nothing_off_axes(d["ax"])
    assert_legend_clear(d["figure"], d["legend"])


def test_the_verdict_labels_are_words_that_never_overlap_or_leave_the_figure():
    from rockbench.benchmark.report.plots.verdict import plot_verdict
    d = plot_verdict(_verdict_doc())
    fig = d["figure"]
    for side in (d["ax"], d["right"]):
        boxes = _tick_boxes(fig, [side])
        assert len(boxes) >= 10
        for a, b in zip(boxes, boxes[1:]):
            assert not a.overlaps(b), "two labels overlap"
    r = _renderer(fig)
    from matplotlib.text import Text
    texts = [t for t in fig.findobj(Text) if t.get_text() and t.get_visible()]
    for t in texts:
        bb = t.get_window_extent(r)
        assert fig.bbox.x0 - 1 <= bb.x0 and bb.x1 <= fig.bbox.x1 + 1 and fig.bbox.y0 - 1 <= bb.y0 \
            and bb.y1 <= fig.bbox.y1 + 1, t.get_text()
        assert not INTERNAL_KEY.search(t.get_text()), t.get_text()
        assert t.get_fontsize() >= 7.0


def test_a_failure_without_a_boundary_keeps_the_verdict_picture_in_its_frame():
    """A failing variant whose maps have no boundary is named short on the right (the verdict's text says
    what its cells do): every word stays inside the figure and the axes keep their width."""
    from rockbench.benchmark.report.plots.verdict import plot_verdict
    d = plot_verdict(_verdict_doc(no_boundary=True))
    fig = d["figure"]
    lost = next(r for r in d["rows"] if r["group"] == "fails" and r["kind"] == "variant")
    assert "no boundary (4 of 4 maps)" in lost["right"], lost
    r = _renderer(fig)
    from matplotlib.text import Text
    for t in (t for t in fig.findobj(Text) if t.get_text() and t.get_visible()):
        bb = t.get_window_extent(r)
        assert fig.bbox.x0 - 1 <= bb.x0 and bb.x1 <= fig.bbox.x1 + 1, t.get_text()
    assert d["ax"].get_window_extent(r).width > 0.3 * fig.bbox.width


def test_the_verdict_axis_is_linear_without_failures(tmp_path):
    """Without a failing variant the axis is linear from 0; the picture is written as PNG, SVG (text as
    text) and PDF like every figure."""
    from rockbench.benchmark.report.plots.output import save_formats
    from rockbench.benchmark.report.plots.verdict import plot_verdict
    from test_figure_formats import check_file
    d = plot_verdict(_verdict_doc(failing=False, planted=False))
    assert d["ax"].get_xscale() == "linear" and d["ax"].get_xlim()[0] == 0.0
    assert not any(r["group"] in ("fails", "planted") for r in d["rows"])
    for path, fmt in zip(save_formats(d["figure"], tmp_path / "verdict", ("png", "svg", "pdf")), ("png", "svg", "pdf")):
        check_file(path, fmt, words=("As shipped (out of the box)", "best of its class", "fail limit 0.2 (largest η_H–η_M gap, B6M sine)"))


def test_the_planted_rows_say_whether_each_delta_is_resolved():
    from rockbench.benchmark.report.plots.verdict import verdict_rows
    rows = [r for r in verdict_rows(_verdict_doc()) if r["group"] == "planted" and r["kind"] == "variant"]
    assert [r["label"] for r in rows] == ["δ = 0 % (η_H × 1)", "δ = 0.5 % (η_H × 0.995)", "δ = 1 % (η_H × 0.99)",
                                          "δ = 2 % (η_H × 0.98)"]
    assert rows[0]["right"] == "0.000" and rows[-1]["right"].endswith(": resolved")


@pytest.mark.parametrize("fork", [True, False])
def test_pictures_drawn_by_helper_processes_are_the_bytes_drawn_here(monkeypatch, fork):
    from rockbench.benchmark.report.plots import drawing
    from rockbench.benchmark.report.plots.trajectories import plot_theta
    t = np.linspace(0, 1, 200)
    pics = drawing.Drawings(("png", "pdf"))   # (an SVG's ids differ from one drawing to the next even here)
    for k in (1, 2, 3):
        pics.add(f"theta_{k}.png", plot_theta, [{"label": "x", "t_s": t, "theta_rad": k * t, "outcome": "overturn"}],
                 alpha_rad=1.0, cost=k)
    here = [drawing.draw(d, pics.formats) for d in pics.todo]
    monkeypatch.setattr(drawing, "cpu_count", lambda: 2)   # helpers even on one core
    monkeypatch.setattr(drawing, "can_fork_helper", lambda: fork)
    images, widths = pics.draw_all()
    assert list(images) == [f"theta_{k}.{f}" for k in (1, 2, 3) for f in ("png", "pdf")]   # in the order added
    assert images == {n: b for files, _ in here for n, b in files.items()}
    assert widths == {f"theta_{k}.png": w for k, (_, w) in zip((1, 2, 3), here)}
