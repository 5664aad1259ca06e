"""Reference maps: cell for cell equal to the batch solver, whatever executes them; adaptive
refinement equal to the full grid on the four Table 1 blocks × sine/cosine × Housner/modified."""

import json

import numpy as np
import pytest

from rockbench.benchmark.maps import adaptive
from rockbench.benchmark.cli.main import main
from rockbench.benchmark.maps.grid import MapSpec, make_axis
from rockbench.benchmark.maps.result import MISSING
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.store.loading import load_map
from rockbench.benchmark.blocks.presets import PRESETS, TABLE_1, get_preset
from rockbench.engines.checker import check_adapter
from rockbench.reference_solver.restitution import Restitution
from rockbench.reference_solver.solver import solve_batch

W, A = (0.5, 10.0), (0.5, 10.0)


def spec(block, pulse, rest, n):
    return MapSpec(get_preset(block).block(), pulse, rest, make_axis("--w-ratio", "w_ratio", *W, n),
                   make_axis("--a-ratio", "a_ratio", *A, n))


def batch(s):
    om, am = np.meshgrid(s.omegas(), s.amplitudes())
    return solve_batch(s.block.alpha_rad, s.block.p_rad_s, s.eta, s.pulse, om, am, dt_s=1e-3)


def test_reference_map_equals_batch_solver_whatever_runs_it(tmp_path):
    s = spec("B3M", "sine", Restitution("modified", k=0.8608), 30)
    b = batch(s)
    for name, kw in [("serial", dict(serial=True)), ("proc", dict(jobs=2))]:
        r = run_map(s, tmp_path / name, **kw)
        assert np.array_equal(r.outcome, b.outcome.astype(np.int8)), name
        assert np.array_equal(r.n_impacts, b.n_impacts), name
        assert np.array_equal(r.max_abs_theta_rad, b.max_abs_theta_rad), name
        back = load_map(tmp_path / name)
        assert np.array_equal(back.max_abs_theta_rad, b.max_abs_theta_rad)   # the CSV round-trips exactly


def _adaptive_on(truth_outcome, truth_impacts, stride=adaptive.DEFAULT_STRIDE):
    key_truth = adaptive.regime_key(truth_outcome, truth_impacts)
    out = np.full(truth_outcome.shape, MISSING, np.int8)
    key = np.full(truth_outcome.shape, MISSING, np.int16)
    sim = np.zeros(truth_outcome.shape, bool)

    def evaluate(cells):
        for i, j in cells:
            out[i, j], key[i, j], sim[i, j] = truth_outcome[i, j], key_truth[i, j], True

    adaptive.refine(key, sim, evaluate, stride)
    adaptive.fill(out, sim, stride)
    return out, sim.mean()


CASES = [(b, p, r) for b in TABLE_1 for p in ("sine", "cosine") for r in ("housner", "modified")]


def _law(block, r):
    return Restitution() if r == "housner" else Restitution("modified", k=PRESETS[block].k_average)


@pytest.mark.parametrize("n", [100])
def test_adaptive_equals_full_on_table1(n):
    for block, pulse, r in CASES:
        s = spec(block, pulse, _law(block, r), n)
        b = batch(s)
        out, frac = _adaptive_on(b.outcome.astype(np.int8), b.n_impacts)
        assert np.array_equal(out, b.outcome), (block, pulse, r)
        assert frac < 0.4


@pytest.mark.slow
def test_adaptive_equals_full_on_table1_200x200_under_a_quarter():
    for block, pulse, r in CASES:
        s = spec(block, pulse, _law(block, r), 200)
        b = batch(s)
        out, frac = _adaptive_on(b.outcome.astype(np.int8), b.n_impacts)
        assert np.array_equal(out, b.outcome), (block, pulse, r)
        assert frac <= 0.25, (block, pulse, r, frac)


def test_adaptive_run_map_equals_full_run_map(tmp_path):
    s = spec("B6M", "sine", Restitution(), 60)
    full = run_map(s, tmp_path / "full", serial=True)
    ad = run_map(s, tmp_path / "ad", serial=True, adaptive=True)
    assert np.array_equal(ad.outcome, full.outcome)
    assert ad.n_simulated < s.n_cells
    sim = ad.simulated
    assert np.array_equal(ad.n_impacts[sim], full.n_impacts[sim])
    assert np.array_equal(load_map(tmp_path / "ad").outcome, full.outcome)


def test_map_command_reference(tmp_path, capsys):
    out = tmp_path / "m"
    assert main(["map", "--block", "B3L", "--pulse", "cosine", "--restitution", "modified", "--w-ratio", "1:8:12",
                 "--a-ratio", "0.5:6:10", "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["n_cells"] == 120 and summary["complete"] and summary["counts"]["failed"] == 0
    meta = json.loads((out / "run.json").read_text())
    assert meta["spec"]["restitution"] == {"kind": "modified", "k": 0.7306, "value": None}
    assert meta["engine"]["engine"] == "reference" and meta["engine"]["version"]
    assert (out / "map.png").stat().st_size > 1000
    # the same command again: nothing to do, nothing duplicated
    assert main(["map", "--block", "B3L", "--pulse", "cosine", "--restitution", "modified", "--w-ratio", "1:8:12",
                 "--a-ratio", "0.5:6:10", "--out", str(out), "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["n_simulated"] == 120 and again["n_resumed"] == 120
    assert (out / "cells.csv").read_text().count("\n") == 121


def test_check_adapter_reference_passes():
    rep = check_adapter("reference")
    assert rep.passed, rep.text()


def test_figures_command(tmp_path, capsys):
    assert main(["figures", "--out", str(tmp_path), "--resolution", "12", "--figure", "4", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert sorted(out["figures"]["4"]) == [str(tmp_path / "fig4.png"), str(tmp_path / "fig4.svg")]
    assert all((tmp_path / f).stat().st_size > 1000 for f in ("fig4.png", "fig4.svg"))
    assert len(out["maps"]) == 2          # Housner and modified k = 0.75 on B3M
    meta = json.loads((tmp_path / "maps" / "B3M-sine-k0.75-12" / "run.json").read_text())
    assert meta["spec"]["restitution"]["k"] == 0.75
    assert main(["figures", "--out", str(tmp_path), "--figure", "3"]) == 2
    assert "4–9" in capsys.readouterr().err
