"""Figures for print: every format written and readable, text as text, journal sizes,
fonts of at least 7 pt, and one colour-blind-safe palette."""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.maps.result import MapResult
from rockbench.reference_solver.errors import ConfigError

matplotlib = pytest.importorskip("matplotlib")
sys.path.insert(0, str(Path(__file__).parent))
from colour_vision import delta_e  # noqa: E402

SVG = "{http://www.w3.org/2000/svg}"


def _panel_figure():
    from rockbench.benchmark.report.plots.stability import plot_panels
    n = 24
    w, a = np.linspace(1, 12, n), np.linspace(1, 10, n)
    ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    ref = MapResult.from_outcomes(w, a, np.where(ii > jj, 2, 1))
    ref.outcome[5, 18] = 2                                  # an island of the reference
    codes = ref.outcome.copy()
    codes[3, 3] = 2
    valid = np.ones(codes.shape, bool)
    valid[20, 2] = False
    eng = MapResult.from_outcomes(w, a, codes, valid=valid)
    drawn = plot_panels([{"engine": eng, "references": [("reference, η_H", ref)], "like": ref, "st_limit": 6.0,
                          "title": "MuJoCo 4.0, calibrated to η_H"}] * 2, suptitle="B3M, one sine wave")
    return drawn


def check_file(path: Path, fmt: str, words=()):
    """``path`` is a readable file of format ``fmt``; in SVG and PDF ``words`` are text, not paths."""
    data = path.read_bytes()
    if fmt == "png":
        assert data[:8] == b"\x89PNG\r\n\x1a\n"
        from matplotlib import image
        assert image.imread(path).shape[1] >= 200 * 3.3   # at least 200 dpi over a column's width
    elif fmt == "pdf":
        assert data[:5] == b"%PDF-" and b"%%EOF" in data[-64:]
        assert b"/FontFile2" in data and b"/Type3" not in data   # TrueType embedded, not glyph outlines
    else:
        root = ET.fromstring(data)                          # parses as XML
        assert root.tag == f"{SVG}svg"
        text = " ".join("".join(t.itertext()) for t in root.iter(f"{SVG}text"))
        for w in words:
            assert w in text, (w, text[:300])


@pytest.mark.parametrize("fmt", ["png", "svg", "pdf"])
def test_each_format_is_written_and_readable(tmp_path, fmt):
    from rockbench.benchmark.report.plots.output import save_formats
    drawn = _panel_figure()
    (p,) = save_formats(drawn["figure"], tmp_path / "panels", (fmt,))
    assert p == tmp_path / f"panels.{fmt}"
    check_file(p, fmt, words=("engine overturns", "B3M, one sine wave", "ST limit"))


def test_formats_are_parsed_and_checked():
    from rockbench.benchmark.report.plots.output import format_of, parse_formats
    assert parse_formats("png") == ("png",) and parse_formats(" PDF, svg,pdf ") == ("pdf", "svg")
    for bad in ("", "jpg", "png,eps"):
        with pytest.raises(ConfigError, match="--figure-format"):
            parse_formats(bad)
    assert format_of("a/b.SVG", "--plot") == "svg"
    with pytest.raises(ConfigError, match=r"\.png, \.svg or \.pdf"):
        format_of("x.jpg", "--plot")


@pytest.mark.parametrize("fmt", ["png", "svg", "pdf"])
def test_simulate_plot_takes_the_format_from_the_suffix(tmp_path, capsys, fmt):
    p = tmp_path / f"theta.{fmt}"
    code = main(["simulate", "--block", "B3M", "--w-ratio", "6", "--a-ratio", "6.1", "--plot", str(p)])
    assert code == 0, capsys.readouterr().err
    check_file(p, fmt, words=("t [s]", "end of the pulse"))


def test_bad_figure_format_is_one_line_and_exit_2(tmp_path, capsys):
    code = main(["figures", "--out", str(tmp_path / "f"), "--figure-format", "png,tiff"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "'tiff'" in err and not (tmp_path / "f").exists()
    code = main(["simulate", "--block", "B3M", "--w-ratio", "6", "--a-ratio", "6.1", "--plot", str(tmp_path / "x.eps")])
    assert code == 2 and ".png, .svg or .pdf" in capsys.readouterr().err


def _texts(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text
    FigureCanvasAgg(fig).draw()
    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]


def _all_figures():
    from rockbench.benchmark.report.plots.speed import plot_accuracy_cost
    from rockbench.benchmark.report.plots.trajectories import plot_theta
    from rockbench.reference_solver.pulses import make_pulse
    t = np.linspace(0, 0.6, 200)
    theta = plot_theta([{"label": "reference, η_H: rocking", "t_s": t, "theta_rad": 0.1 * np.sin(20 * t),
                         "reference": True, "outcome": "rocking"}], alpha_rad=0.2,
                       pulse=make_pulse("sine", 5.0, 12.0), title="B3M, sine")
    speed = plot_accuracy_cost({"engines": [{"engine": "a", "label": "MuJoCo 4.0", "points": [
        {"dt_s": 1e-3, "value": 0.2, "cost": 0.5}, {"dt_s": 1e-4, "value": 0.05, "cost": 5.0}]}],
        "declared": {"matched_distance": 0.037}})
    return {"panels": _panel_figure()["figure"], "theta": theta["figure"], "speed": speed["figure"],
            "paper figure": _paper_figure(), "map.png": _map_figure()}


def _maps():
    n = 20
    w, a = np.linspace(1, 12, n), np.linspace(1, 10, n)
    ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    return (MapResult.from_outcomes(w, a, np.where(ii > jj, 2, 1)),
            MapResult.from_outcomes(w, a, np.where(ii > jj + 2, 2, 1)))


def _paper_figure():
    from rockbench.benchmark.report.plots.stability import plot_stability
    return plot_stability(list(_maps()), ["B3M, η_H = 0.7526", "B3L, η_H = 0.7526"], st_limit_mps2=None,
                          title="Fig. 6: one sine wave")["ax"].figure


def _map_figure():
    from types import SimpleNamespace

    from rockbench.benchmark.maps.grid import MapSpec, make_axis
    from rockbench.benchmark.report.plots.stability import map_figure
    from rockbench.benchmark.blocks.presets import get_preset
    from rockbench.reference_solver.restitution import Restitution
    ref, eng = _maps()
    spec = MapSpec(get_preset("B3M").block(), "sine", Restitution(), make_axis("--w-ratio", "w_ratio", 1, 12, 20),
                   make_axis("--a-ratio", "a_ratio", 1, 10, 20), engine="mujoco", engine_settings={})
    res = SimpleNamespace(spec=spec, outcome=eng.outcome, valid=eng.valid, left_model=eng.left_model,
                          simulated=np.ones(eng.outcome.shape, bool), w_ratio=eng.w_ratio, a_ratio=eng.a_ratio,
                          adaptive=False, fraction_simulated=1.0)
    return map_figure(res, reference=ref)


def test_figures_suit_a_journal_column_with_fonts_of_7_pt_or_more():
    from rockbench.benchmark.report.plots.style import DOUBLE_COLUMN_IN, MIN_FONT_PT
    for name, fig in _all_figures().items():
        assert fig.get_figwidth() <= DOUBLE_COLUMN_IN + 1e-9, name
        small = [(t.get_text(), t.get_fontsize()) for t in _texts(fig) if t.get_fontsize() < MIN_FONT_PT]
        assert not small, (name, small)


def test_one_palette_stays_apart_under_colour_vision_deficiencies():
    """Colours a picture sets side by side keep a CIE76 ΔE of at least 12 (clearly apart; 2.3 is
    just noticeable) under simulated protanopia, deuteranopia and tritanopia (Machado et al. 2009)."""
    from rockbench.benchmark.report.plots import stability as s
    from rockbench.benchmark.report.plots.style import CYCLE
    groups = {"reference lines": [st["color"] for st in s.REFERENCE_STYLES[:4]], "curves": CYCLE,
              "marks on the fill": [s.MARKS["false_overturn"][1]["color"], s.MARKS["missed_overturn"][1]["color"],
                                    s.ENGINE_FILL, "#ffffff"],
              "outcomes": list(s.OUTCOME_COLOURS), "experiment letters": [c for _, c in s.POINT_STYLE.values()]}
    for group, colours in groups.items():
        for kind in (None, "protanopia", "deuteranopia", "tritanopia"):
            worst = min(delta_e(a, b, kind) for k, a in enumerate(colours) for b in colours[k + 1:])
            assert worst >= 12.0, (group, kind, worst)
    # the first four engine curves of a θ(t) plot against the reference's black and greys
    from rockbench.benchmark.report.plots.trajectories import REFERENCE_STYLES
    for kind in (None, "protanopia", "deuteranopia", "tritanopia"):
        worst = min(delta_e(c, r["color"], kind) for c in CYCLE[:4] for r in REFERENCE_STYLES)
        assert worst >= 12.0, (kind, worst)
