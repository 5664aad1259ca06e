"""The suite's power against an engine's own restitution error (docs/scores.md, "The suite's power against
an engine's own restitution error"): the suite keys that ask for an engine calibrated to η·(1 + δ), the
maps they plan, and on hand-built maps where the truth is known, which shifted boundaries are resolved
from the engine's own δ = 0 variant across problems, by the distance and by the signed offset."""

import json

import numpy as np
import pytest

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.report.verdict_words import sentences
from rockbench.benchmark.scoring.labels import ENGINE_PLANTED_CLASS
from rockbench.benchmark.suites.model import load_suite
from rockbench.benchmark.suites.plan import plan
from rockbench.reference_solver.errors import ConfigError

SUITE = """[grid]
w_ratio = "1:16:6"
a_ratio = "1:12:6"
[cases]
blocks = ["B3M", "B6M"]
pulses = ["sine"]
[engines]
names = ["mujoco"]
variants = [{ settings = "calibrated" }, { settings = "shipped" }]
"""


def _suite(tmp_path, power: str, engines: str = SUITE):
    p = tmp_path / "s.toml"
    p.write_text(engines + power)
    return p


# -- the suite keys ------------------------------------------------------------------------------------------------

def test_engine_offsets_add_the_engines_calibrated_variant_with_its_target_moved(tmp_path):
    s = load_suite(_suite(tmp_path, '[power]\nengine_eta_offsets = [-0.01, 0.02]\nengines = ["mujoco"]\n'))
    assert s.engines.variants[2:] == [{"settings": "calibrated", "engines": ["mujoco"], "planted_eta_factor": 0.99},
                                      {"settings": "calibrated", "engines": ["mujoco"], "planted_eta_factor": 1.02}]
    jobs = [j for j in plan(s, ["mujoco"]) if "planted_eta_factor" in j.settings]
    assert [(j.block, j.settings["planted_eta_factor"]) for j in jobs] == [("B3M", 0.99), ("B6M", 0.99),
                                                                          ("B3M", 1.02), ("B6M", 1.02)]
    assert jobs[0].subdir == "maps/mujoco-planted-eta-factor=0.99-settings=calibrated/B3M-sine-housner"
    assert {j.restitution.label for j in jobs} == {"housner"}


@pytest.mark.parametrize("power, message", [
    ("engine_eta_offsets = 0.01\nengines = [\"mujoco\"]",
     "power.engine_eta_offsets must be a list of numbers δ ≠ 0 from -0.5 to 0.5 (the engine is calibrated to "
     "η·(1 + δ); δ = 0 is its calibrated variant), got 0.01."),
    ("engine_eta_offsets = [0.0, 0.01]\nengines = [\"mujoco\"]",
     "power.engine_eta_offsets must hold numbers δ ≠ 0 from -0.5 to 0.5 (the engine is calibrated to η·(1 + δ); "
     "δ = 0 is its calibrated variant), got 0.0; e.g. [-0.02, -0.01, 0.01, 0.02]."),
    ("engine_eta_offsets = [0.6]\nengines = [\"mujoco\"]", "got 0.6; e.g. [-0.02, -0.01, 0.01, 0.02]."),
    ("engine_eta_offsets = [0.01, 0.01]\nengines = [\"mujoco\"]",
     "power.engine_eta_offsets lists δ = 0.01 twice; list each offset once."),
    ("engine_eta_offsets = [0.01]\nengines = [\"nosuch\"]",
     "power.engines names 'nosuch', which is not an engine with a calibration (the reference solver's planted "
     "variants are power.eta_reductions); `rockbench engines` lists the engines."),
    ("engine_eta_offsets = [0.01]\nengines = [\"reference\"]", "power.engines names 'reference', which is not"),
    ("engine_eta_offsets = [0.01]", "power.engine_eta_offsets and power.engines go together"),
    ("engines = [\"mujoco\"]", "power.engine_eta_offsets and power.engines go together"),
])
def test_a_bad_engine_offset_is_one_line(tmp_path, power, message):
    with pytest.raises(ConfigError) as e:
        load_suite(_suite(tmp_path, f"[power]\n{power}\n"))
    assert message in str(e.value) and str(e.value).startswith("suite s.toml: ") and "\n" not in str(e.value)


def test_an_engine_without_a_calibrated_variant_has_nothing_to_compare_with(tmp_path, capsys):
    shipped_only = SUITE.replace('{ settings = "calibrated" }, ', "")
    p = _suite(tmp_path, '[power]\nengine_eta_offsets = [0.01]\nengines = ["mujoco"]\n', shipped_only)
    assert main(["run", str(p), "--plan", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("power.engines names 'mujoco', but engines.variants has no calibrated variant of it "
                        "(settings = \"calibrated\", no calibrate_on) to compare its planted variants with; add one.")
    assert "\n" not in err


# -- on hand-built maps -----------------------------------------------------------------------------------------------

BLOCKS, PULSES = ("B2M", "B3M", "B6M", "B8M"), ("sine", "cosine")


def _first_rows(n_w: int, first: int) -> np.ndarray:
    return np.round(first + 12 * np.linspace(0, 1, n_w) ** 2).astype(int)


def _codes(n_a: int, rows: np.ndarray) -> np.ndarray:
    codes = np.ones((n_a, len(rows)), int)
    for j, r in enumerate(rows):
        codes[r:, j] = 2
    return codes


def test_a_shifted_boundary_is_resolved_across_problems_as_the_statistics_say(write_map, tmp_path, capsys):
    """Eight problems on a 46 × 61 grid (a row 0.125 in a0/(g·tanα)). MuJoCo's δ = 0 maps lie on the
    reference's boundary but in two columns each; its δ = +2 % maps lie one row above its own everywhere
    (resolved by the distance and by the offset); its δ = −2 % maps one row above in four problems and one
    below in the other four (resolved by the distance, whose move is unsigned, not by the offset, whose
    mean move is 0 with a spread of a row); its δ = +1 % maps are its δ = 0 maps (resolved by neither)."""
    rng = np.random.default_rng(5)
    n_w, n_a, grid = 46, 61, dict(w=(1.0, 10.0), a=(0.5, 8.0))
    root = tmp_path / "run"
    for k, (block, pulse) in enumerate((b, p) for b in BLOCKS for p in PULSES):
        ref = _first_rows(n_w, 20 + 2 * k)
        base = ref.copy()
        base[rng.choice(n_w, 2, replace=False)] += 1
        kw = dict(block=block, pulse=pulse, **grid)
        write_map(root / f"ref-{block}-{pulse}", _codes(n_a, ref), **kw)
        for factor, rows in ((None, base), (1.01, base), (1.02, base + 1), (0.98, base + (1 if k % 2 else -1))):
            settings = {} if factor is None else {"settings": "calibrated", "planted_eta_factor": factor}
            write_map(root / f"mujoco-{factor}-{block}-{pulse}", _codes(n_a, rows), engine="mujoco",
                      settings=settings, **kw)
    code, _, err = main(["score", str(root)]), *capsys.readouterr()
    assert code == 0, err
    v = json.loads((root / "score.json").read_text())["verdict"]
    groups = {r["variant"]: r["group"] for r in v["variants"]}
    assert sorted(groups.values()) == ["calibrated", "engine-planted", "engine-planted", "engine-planted"]
    assert set(v["mcb"]["calibrated"]["entries"]) == {"mujoco"}       # never in the calibrated standing
    p = v["engine_power"]
    assert p["scope"] == "across problems"
    e = p["engines"]["mujoco"]
    rows = {r["delta"]: r for r in e["rows"]}
    assert e["against"] == "mujoco" and sorted(rows) == [-0.02, 0.01, 0.02]
    up, mixed, same = rows[0.02], rows[-0.02], rows[0.01]
    assert up["distance"]["difference"] == pytest.approx(0.125, abs=0.01) and up["distance"]["resolved"]
    assert up["offset"]["difference"] == pytest.approx(-0.125, abs=0.01) and up["offset"]["resolved"]
    assert up["offset"]["df"] == 7 and up["offset"]["problems"] == 8
    assert mixed["distance"]["resolved"] and not mixed["offset"]["resolved"]
    assert mixed["offset"]["ci95"][0] < 0 < mixed["offset"]["ci95"][1]
    assert same["distance"]["difference"] == 0.0 and not same["distance"]["resolved"] and not same["offset"]["resolved"]
    assert e["resolved_abs_delta"] == {"distance": [0.02], "offset": []}
    labels = {r["variant"]: r["label"] for r in v["variants"] if r["group"] == ENGINE_PLANTED_CLASS}
    assert sorted(labels.values())[0].endswith("calibrated to η_H × 0.980 (planted)")
    text = next(t for t in sentences(v) if t.startswith("The suite's power against MuJoCo's own restitution error"))
    assert "t on 7 degrees of freedom" in text and "δ = +2 %: distance +0.1" in text
    assert text.endswith("by the distance, |δ| 2 % resolved; by the offset, no |δ| resolved.")
