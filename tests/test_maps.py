"""Map specs, ranges, adaptive refinement (on a known analytic picture), the map command's input
checks, and the pictures."""

import csv
import json

import numpy as np
import pytest

from rockbench.benchmark.maps import adaptive
from rockbench.benchmark.cli.main import main
from rockbench.benchmark.maps.grid import MapSpec, make_axis, parse_range
from rockbench.benchmark.maps.result import MISSING
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.store.loading import load_map
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import G
from rockbench.reference_solver.restitution import Restitution


pytestmark = pytest.mark.usefixtures("fake_engines")


def test_parse_range():
    ax = parse_range("--w-ratio", "1:10:10", "w_ratio")
    assert ax.values()[0] == 1 and ax.values()[-1] == 10 and ax.values().size == 10
    assert parse_range("--a-ratio", "2:2:1", "a_ratio").values().tolist() == [2.0]


@pytest.mark.parametrize("text, match", [
    ("1:10", "LO:HI:N"), ("a:10:5", "must be numbers"), ("1:10:x", "whole number"), ("1:10:2.5", "whole number"),
    ("10:1:5", "reversed"), ("3:3:5", "empty"), ("1:10:0", "at least one point"), ("1:10:-4", "at least one point"),
    ("0:10:5", "> 0"), ("1:inf:5", "finite"), ("1:10:1", "one point"),
])
def test_bad_ranges(text, match):
    with pytest.raises(ConfigError, match=match):
        parse_range("--w-ratio", text, "w_ratio")


def test_physical_axes_match_normalised():
    b = get_preset("B3L").block()
    s = MapSpec(b, "cosine", Restitution(), make_axis("--omega", "omega_rad_s", 10.0, 50.0, 5),
                make_axis("--amplitude-g", "amplitude_g", 0.5, 2.5, 3))
    assert s.omegas().tolist() == [10.0, 20.0, 30.0, 40.0, 50.0]
    assert s.w_ratios() == pytest.approx(s.omegas() / b.p_rad_s)
    assert s.amplitudes() == pytest.approx([0.5 * G, 1.5 * G, 2.5 * G])
    assert s.a_ratios() == pytest.approx(s.amplitudes() / (G * np.tan(b.alpha_rad)))
    c = s.case(2, 4)
    assert c.pulse.omega_rad_s == 50.0 and c.pulse.amplitude_mps2 == pytest.approx(2.5 * G)
    assert MapSpec.from_dict(json.loads(json.dumps(s.to_dict()))).identity() == s.identity()


def test_dt_too_coarse_for_the_map_is_refused():
    b = get_preset("B3M").block()
    with pytest.raises(ConfigError, match="too coarse for the highest frequency"):
        MapSpec(b, "sine", Restitution(), make_axis("--w-ratio", "w_ratio", 1, 40, 5),
                make_axis("--a-ratio", "a_ratio", 1, 5, 5), dt_s=0.01)


def test_coarse_index():
    assert adaptive.coarse_index(10, 4).tolist() == [0, 4, 8, 9]
    assert adaptive.coarse_index(9, 4).tolist() == [0, 4, 8]


def _refine_grid(truth, stride):
    out = np.full(truth.shape, MISSING, np.int8)
    sim = np.zeros(truth.shape, bool)
    runs = np.zeros(truth.shape, int)

    def evaluate(cells):
        # neighbouring refined blocks share their borders: each cell comes once per call
        assert len(set(cells)) == len(cells)
        for i, j in cells:
            if not sim[i, j]:
                runs[i, j] += 1
            out[i, j] = truth[i, j]
            sim[i, j] = True

    adaptive.refine(out, sim, evaluate, stride)
    assert runs.max() == 1 and runs.sum() == sim.sum()
    adaptive.fill(out, sim, stride)
    return out, sim


@pytest.mark.parametrize("n", [100, 157])
def test_adaptive_equals_full_on_the_analytic_picture(fake_engines, n):
    # thin features: a safe band 0.1 wide (about 1 cell at n = 100) and a tongue 0.12 wide
    w = np.linspace(0.5, 10.0, n)
    a = np.linspace(0.5, 12.0, n)
    truth = fake_engines.analytic_grid(w, a)
    out, sim = _refine_grid(truth, adaptive.DEFAULT_STRIDE)
    assert np.array_equal(out, truth)
    assert sim.mean() < 0.5


def test_adaptive_cannot_see_an_island_between_nodes():
    # the documented limit: a feature touching no simulated cell is invisible
    truth = np.zeros((41, 41), np.int8)
    truth[21:23, 21:23] = 2
    out, sim = _refine_grid(truth, 4)
    assert (out == 0).all() and sim.sum() == 11 * 11


def test_adaptive_run_map_and_load_agree(analytic_truth, tmp_path):
    b = get_preset("B6M").block()
    s = MapSpec(b, "sine", Restitution(), make_axis("--w-ratio", "w_ratio", 0.5, 10, 50),
                make_axis("--a-ratio", "a_ratio", 0.5, 12, 50), engine="analytic-batch")
    r = run_map(s, tmp_path / "m", adaptive=True, serial=True)
    assert np.array_equal(r.outcome, analytic_truth(s))
    assert r.n_simulated < s.n_cells
    # every simulated cell was simulated once: one row each in cells.csv
    with open(tmp_path / "m" / "cells.csv") as f:
        ij = [(row["i"], row["j"]) for row in csv.DictReader(f)]
    assert len(ij) == len(set(ij)) == r.n_simulated
    back = load_map(tmp_path / "m")
    assert np.array_equal(back.outcome, r.outcome) and back.adaptive
    assert back.fraction_simulated == pytest.approx(r.fraction_simulated)
    # a full run into the same directory reuses the adaptive cells and adds the rest
    full = run_map(s, tmp_path / "m", serial=True)
    assert full.n_simulated == s.n_cells and np.array_equal(full.outcome, r.outcome)


BASE = ["map", "--engine", "analytic", "--block", "B6M", "--serial", "--no-plot", "--json"]


@pytest.mark.parametrize("extra, match", [
    (["--w-ratio", "1:5", "--a-ratio", "1:3:3"], "LO:HI:N"),
    (["--w-ratio", "5:1:3", "--a-ratio", "1:3:3"], "reversed"),
    (["--w-ratio", "1:5:3", "--a-ratio", "2:2:3"], "empty"),
    (["--w-ratio", "1:5:0", "--a-ratio", "1:3:3"], "at least one point"),
    (["--w-ratio", "1:5:3000", "--a-ratio", "1:3:3000"], "cells"),
    (["--w-ratio", "1:5:3", "--a-ratio", "1:3:3", "--pulse", "quake.csv"], "harmonic"),
    (["--w-ratio", "1:5:3", "--omega", "1:5:3", "--a-ratio", "1:3:3"], "given twice"),
    (["--a-ratio", "1:3:3"], "no frequency axis"),
    (["--w-ratio", "1:5:3", "--a-ratio", "1:3:3", "--jobs", "0"], "--jobs"),
    (["--w-ratio", "1:5:3", "--a-ratio", "1:3:3", "--cell-timeout", "-1"], "--cell-timeout"),
    (["--w-ratio", "1:5:3", "--a-ratio", "1:3:3", "--locate-depth", "13"], "--locate-depth must be a whole number"),
    (["--w-ratio", "1:5:3", "--a-ratio", "1:3:3", "--engine", "refrence"], "Did you mean"),
])
def test_map_bad_input_exit_2_one_line(tmp_path, capsys, extra, match):
    args = [a for a in BASE if a != "--engine" and a != "analytic"] + ["--out", str(tmp_path / "m")] + extra
    if "--engine" not in extra:
        args += ["--engine", "analytic"]
    assert main(args) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err.count("\n") == 1 and match in cap.err and "Traceback" not in cap.err
    assert not (tmp_path / "m").exists()


def test_map_cli_json(tmp_path, capsys):
    assert main(BASE + ["--w-ratio", "1:5:6", "--a-ratio", "0.5:3:5", "--out", str(tmp_path / "m")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n_cells"] == 30 and out["n_simulated"] == 30 and out["complete"]
    assert sum(out["counts"].values()) == 30 and out["counts"]["rest"] == 6   # a0/(g·tanα) = 0.5 is the only row below uplift


def test_stability_plot_png_svg(tmp_path):
    from rockbench.benchmark.blocks.experiments import st_limit_a_ratio
    from rockbench.benchmark.report.plots.stability import plot_stability, save
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    b = get_preset("B6M").block()
    maps = []
    for eng in ("analytic", "analytic-batch"):
        s = MapSpec(b, "sine", Restitution(), make_axis("--w-ratio", "w_ratio", 0.5, 10, 30),
                    make_axis("--a-ratio", "a_ratio", 0.5, 12, 30), engine=eng)
        maps.append(run_map(s, tmp_path / eng, serial=True))
    fig, ax = plt.subplots()
    got = plot_stability(maps, ["one", "two"], ax=ax, experiments=[{"w_ratio": 3, "a_ratio": 4, "outcome": "O"},
                                                                   {"w_ratio": 6, "a_ratio": 2, "outcome": "R"}])
    assert got["st_limit_a_ratio"] == pytest.approx(25.0 / (G * np.tan(b.alpha_rad)))
    assert got["st_limit_a_ratio"] == pytest.approx(st_limit_a_ratio(b))
    assert len(got["boundaries"]) == 2
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "one" in labels and "two" in labels and any("ST limit" in t for t in labels)
    paths = save(fig, tmp_path / "fig")
    plt.close(fig)
    assert [p.suffix for p in paths] == [".png", ".svg"] and all(p.stat().st_size > 1000 for p in paths)


def test_guided_chunks_fall_in_size_and_keep_every_item_in_order():
    from rockbench.benchmark.maps.executors import _guided_chunks
    items = list(range(169))
    chunks = _guided_chunks(items, 2, 64)
    assert [x for c in chunks for x in c] == items
    sizes = [len(c) for c in chunks]
    assert sizes[0] == 43 and sizes == sorted(sizes, reverse=True) and sizes[-1] == 1
    assert max(len(c) for c in _guided_chunks(list(range(1000)), 2, 64)) == 64
    assert _guided_chunks([], 2) == [] and _guided_chunks([7], 3) == [[7]]
