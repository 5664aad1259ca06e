"""The suite's yardstick: the reference solver as an engine with a planted restitution error
(``planted_eta_factor`` = 1 − δ), mapped and scored as an engine map (docs/scores.md, "The suite's power")."""

import math

import numpy as np
import pytest

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.cli.main import main
from rockbench.benchmark.engine_info.adapters import build_adapter
from rockbench.benchmark.maps.grid import MapSpec, make_axis
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.scoring.labels import PLANTED_CLASS, settings_class, variant_label
from rockbench.benchmark.scoring.score_runs import score_dirs
from rockbench.benchmark.store.loading import load_entry
from rockbench.benchmark.suites.model import load_suite
from rockbench.benchmark.suites.plan import in_sample_blocks, plan, planted_factor
from rockbench.engines.adapters.reference import PLANTED, is_planted
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.restitution import Restitution
from rockbench.benchmark.report.verdict_words import sentences

X = make_axis("--w-ratio", "w_ratio", 1.0, 16.0, 26)
Y = make_axis("--a-ratio", "a_ratio", 1.0, 12.0, 26)


def _spec(block="B6M", pulse="sine", factor=None, rest=None):
    settings = {} if factor is None else {PLANTED: factor}
    return MapSpec(get_preset(block).block(), pulse, rest or Restitution(), X, Y, engine="reference",
                   engine_settings=settings)


@pytest.mark.parametrize("bad", [0, 0.0, -0.1, 1.01, 2, "abc", math.nan, math.inf, None])
def test_the_planted_factor_is_a_number_in_0_1(bad):
    with pytest.raises(ConfigError) as e:
        build_adapter("reference", planted_eta_factor=bad)
    assert "planted_eta_factor" in str(e.value) and "\n" not in str(e.value)


def test_the_planted_factor_multiplies_the_eta_a_case_asks_for_and_is_recorded():
    assert get_adapter("reference").settings[PLANTED] == 1.0
    ad = get_adapter("reference", planted_eta_factor=0.99)
    assert ad.settings[PLANTED] == 0.99 and ad.describe()["settings"][PLANTED] == 0.99
    assert ad._eta(0.8) == pytest.approx(0.792)
    assert is_planted("reference", {PLANTED: 1.0}) and not is_planted("reference", {})
    assert not is_planted("mujoco", {PLANTED: 0.99}) and planted_factor(0.005) == 0.995


def test_a_bad_planted_factor_stops_a_map_with_exit_2(tmp_path, capsys):
    code = main(["map", "--engine", "reference", "--set", "planted_eta_factor=1.5", "--block", "B3M",
                 "--w-ratio", "1:16:3", "--a-ratio", "1:12:3", "--out", str(tmp_path / "m")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "planted_eta_factor must be in (0, 1]" in err and "\n" not in err
    assert not (tmp_path / "m").exists()


def test_a_planted_map_with_factor_1_is_the_reference_map_cell_for_cell(tmp_path):
    ref = run_map(_spec(), tmp_path / "ref", serial=True)
    one = run_map(_spec(factor=1.0), tmp_path / "one", serial=True)
    assert np.array_equal(one.outcome, ref.outcome) and np.array_equal(one.n_impacts, ref.n_impacts)
    assert np.array_equal(one.max_abs_theta_rad, ref.max_abs_theta_rad)
    assert np.array_equal(one.valid, ref.valid)
    run = load_entry(tmp_path / "one")
    assert run.settings == {PLANTED: 1.0} and not run.is_reference and load_entry(tmp_path / "ref").is_reference
    assert run.run["engine"]["settings"][PLANTED] == 1.0     # run.json records it


@pytest.mark.parametrize("block, pulse", [("B6M", "sine"), ("B8M", "cosine")])
def test_a_planted_reduction_is_the_reference_at_that_eta_and_shrinks_the_overturn_region(tmp_path, block, pulse):
    """η·0.98 is the reference solver at the constant η = 0.98·η_H, cell for cell (an independent path:
    the constant law); and less restitution loses more energy at each impact, so cells that overturned
    after an impact stop overturning, and hardly any starts (26 × 26 over ω/p 1–16, a₀/(g·tanα) 1–12:
    none; on 101 × 101 the probe tests/measurements/probes/probe_planted.py finds at most 2 against 78–321)."""
    eta_h = Restitution().eta(get_preset(block).block().alpha_rad)
    ref = run_map(_spec(block, pulse), tmp_path / "ref", serial=True)
    low = run_map(_spec(block, pulse, factor=0.98), tmp_path / "low", serial=True)
    const = run_map(_spec(block, pulse, rest=Restitution("constant", value=0.98 * eta_h)), tmp_path / "c", serial=True)
    assert np.array_equal(low.outcome, const.outcome) and np.array_equal(low.n_impacts, const.n_impacts)
    over_ref, over_low = ref.outcome == 2, low.outcome == 2
    lost, gained = (over_ref & ~over_low).sum(), (over_low & ~over_ref).sum()
    assert lost >= 3 and 10 * gained <= lost


def _power_suite(tmp_path, extra=""):
    p = tmp_path / "s.toml"
    p.write_text('[grid]\nw_ratio = "1:16:26"\na_ratio = "1:12:26"\nadaptive = true\ncoarse_stride = 3\n'
                 '[cases]\nblocks = ["B6M", "B8M"]\npulses = ["sine"]\n[reference]\nrestitutions = ["housner"]\n'
                 '[engines]\nnames = []\nvariants = [{}, { calibrate_on = "neighbour", blocks = ["B8M"] }]\n' + extra)
    return p


def test_power_variants_are_planned_on_the_in_sample_blocks(tmp_path):
    s = load_suite(_power_suite(tmp_path, "[power]\neta_reductions = [0.0, 0.01]\n"))
    assert in_sample_blocks(s) == ["B6M", "B8M"]
    planted = [j for j in plan(s, []) if j.settings]
    assert [(j.block, j.settings[PLANTED]) for j in planted] == [("B6M", 1.0), ("B8M", 1.0), ("B6M", 0.99), ("B8M", 0.99)]
    assert planted[2].subdir == "maps/reference-planted-eta-factor=0.99/B6M-sine-housner"
    s = load_suite(_power_suite(tmp_path, "[power]\neta_reductions = []\n"))
    assert not [j for j in plan(s, []) if j.settings]


def test_power_variants_run_whatever_engines_run(tmp_path, capsys):
    """They are the suite's yardstick: `run --engines NAME` keeps them (decided: they cost milliseconds)."""
    pytest.importorskip("mujoco")
    p = _power_suite(tmp_path, "[power]\neta_reductions = [0.0, 0.01]\n")
    assert main(["run", str(p), "--plan", "--engines", "mujoco", "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert out.count("maps/reference-planted-eta-factor=") == 4 and "maps/mujoco" in out


@pytest.mark.parametrize("table, line", [
    ("[power]\neta_reductions = 0.01\n",
     "suite s.toml: power.eta_reductions must be a list of numbers δ in [0, 1) (the planted η is η·(1 − δ)), got 0.01."),
    ("[power]\neta_reductions = [0.0, 1.0]\n",
     "suite s.toml: power.eta_reductions must hold numbers δ in [0, 1) (the planted η is η·(1 − δ)), got 1.0; "
     "e.g. [0.0, 0.005, 0.01, 0.02]."),
    ("[power]\neta_reductions = [-0.01]\n",
     "suite s.toml: power.eta_reductions must hold numbers δ in [0, 1) (the planted η is η·(1 − δ)), got -0.01; "
     "e.g. [0.0, 0.005, 0.01, 0.02]."),
    ("[power]\neta_reductions = [0.01, 0.01]\n", "suite s.toml: power.eta_reductions lists δ = 0.01 twice; list each "
                                                 "reduction once."),
    ("[power]\neta_reductions = ['1%']\n",
     "suite s.toml: power.eta_reductions must be a list of numbers δ in [0, 1) (the planted η is η·(1 − δ)), got ['1%']."),
    ("[power]\ndeltas = [0.01]\n", "suite s.toml: unknown key power.deltas; [power] takes engine_eta_offsets, engines, eta_reductions."),
])
def test_a_bad_power_table_is_one_line_and_exit_2(tmp_path, capsys, table, line):
    p = _power_suite(tmp_path, table)
    with pytest.raises(ConfigError) as e:
        load_suite(p)
    assert str(e.value) == line
    assert main(["run", str(p), "--plan", "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.strip() == f"rockbench: error: {line}"


def test_planted_maps_are_scored_as_engine_maps_in_their_own_class(tmp_path):
    """In a run folder beside the reference map, a planted map is a candidate (not a reference), paired like
    for like with the η_H reference, labelled in words, of the class ``planted`` and ranked with no engine."""
    out = tmp_path / "run"
    run_map(_spec(), out / "maps" / "reference" / "B6M-sine-housner", serial=True)
    for f in (1.0, 0.98):
        run_map(_spec(factor=f), out / "maps" / f"planted-{f}" / "B6M-sine-housner", serial=True, adaptive=True,
                coarse_stride=3)
    doc = score_dirs([out]).to_json()
    pairs = {p["variant"]: p for p in doc["pairs"]}
    assert set(pairs) == {"reference[planted_eta_factor=1.0]", "reference[planted_eta_factor=0.98]"}
    one, low = pairs["reference[planted_eta_factor=1.0]"], pairs["reference[planted_eta_factor=0.98]"]
    assert one["settings"] == low["settings"] == PLANTED_CLASS and one["like_for_like"]
    assert one["scores"]["boundary_mean"] == 0.0 and one["scores"]["agreement"] == 1.0
    assert low["scores"]["boundary_mean"] > 0.0 and low["label"] == "Reference solver, η_H × 0.980 (planted)"
    rows = {r["variant"]: r for r in doc["verdict"]["variants"]}
    assert all(r["rank"] is None for r in rows.values())   # the yardstick is not an engine to rank
    assert any(t.startswith("The suite's power, measured") for t in sentences(doc["verdict"]))
    assert settings_class({PLANTED: 0.99}, "x", "reference") == PLANTED_CLASS
    assert variant_label("reference", {PLANTED: 0.995}, restitution="housner") == "Reference solver, η_H × 0.995 (planted)"
