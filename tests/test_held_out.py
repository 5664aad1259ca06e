"""The held-out check: ``calibrate_on`` names a block of the same slenderness (``sibling``: the other
size), and anything else is refused with one line. The engines take the blocks themselves (a
:class:`~rockbench.engines.calibration.held_out.CalibrateOn`, or a Block); the names are the benchmark's presets,
resolved before they reach an adapter (:mod:`rockbench.benchmark.engine_info.adapters`)."""

import pytest

from rockbench.engines.calibration import held_out
from rockbench.engines.registry import get_adapter
from rockbench.benchmark.blocks.presets import PRESETS, calibrate_on
from rockbench.benchmark.cli.main import main
from rockbench.benchmark.engine_info.adapters import build_adapter, engine_settings
from rockbench.benchmark.suites.model import load_suite
from rockbench.benchmark.suites.plan import plan
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import Block

SIBLING = calibrate_on("sibling", "mujoco")


@pytest.mark.parametrize("mapped, sibling", [("B3L", "B3M"), ("B6L", "B6M"), ("B3M", "B3L"), ("B6M", "B6L")])
def test_the_sibling_is_the_other_size_of_the_same_slenderness(mapped, sibling):
    block = PRESETS[mapped].block()
    assert held_out.calibration_block(SIBLING, block).name == sibling
    assert held_out.calibration_block(calibrate_on(sibling, "mujoco"), block).name == sibling
    assert held_out.calibration_block(None, block) is block


def test_names_are_resolved_by_the_benchmark_and_checked_when_the_setting_is_given():
    assert str(calibrate_on("b3m", "mujoco")) == "B3M" and calibrate_on("b3m", "mujoco").block == PRESETS["B3M"].block()
    assert str(calibrate_on("Sibling", "mujoco")) == held_out.SIBLING and calibrate_on("Sibling", "mujoco").block is None
    assert calibrate_on(None, "mujoco") is None
    assert engine_settings("mujoco", {"calibrate_on": "B3M", "friction": 1.0})["calibrate_on"].block.name == "B3M"
    with pytest.raises(ConfigError, match="'calibrate_on' must be 'sibling' or a block name"):
        calibrate_on("B9X", "mujoco")
    with pytest.raises(ConfigError, match="'calibrate_on' must be 'sibling' or a block name"):
        build_adapter("mujoco", calibrate_on="B9X")


def test_the_engines_take_the_block_itself_and_refuse_a_name_with_what_to_pass():
    """No names on the engines' floor: a Block (or a CalibrateOn) is taken, a name is refused in one line."""
    pytest.importorskip("mujoco")
    ad = get_adapter("mujoco", calibrate_on=PRESETS["B3M"].block())
    assert ad.calibration_block(PRESETS["B3L"].block()).name == "B3M"
    assert ad.describe()["settings"]["calibrate_on"] == "B3M"   # run.json records it as written
    assert held_out.check_setting(None, "mujoco") is None and held_out.check_setting("", "mujoco") is None
    with pytest.raises(ConfigError, match="a name .* is the benchmark's: rockbench.benchmark.engine_info.adapters"):
        get_adapter("mujoco", calibrate_on="B3M")
    assert build_adapter("mujoco", calibrate_on="sibling").describe()["settings"]["calibrate_on"] == "sibling"


def test_a_block_of_another_slenderness_is_refused_with_the_one_that_would_do():
    with pytest.raises(ConfigError) as e:
        held_out.calibration_block(calibrate_on("B6M", "mujoco"), PRESETS["B3L"].block())
    assert str(e.value) == ("calibrate_on = B6M: B6M has h/b 4.5, the mapped block B3L (h/b 2.25); a held-out "
                            "calibration needs a block of the same slenderness (B3M).")


def test_a_sibling_that_is_not_one_block_is_refused():
    """A custom block of h/b 2.25 has two named blocks of its slenderness; one of 3 has none."""
    with pytest.raises(ConfigError, match=r"found 2 \(B3M, B3L\); name the block"):
        held_out.calibration_block(SIBLING, Block(0.05, 0.1125))
    with pytest.raises(ConfigError, match="found none"):
        held_out.calibration_block(SIBLING, Block(0.05, 0.15))


def _suite(tmp_path, variants, blocks='["B3M", "B3L"]'):
    p = tmp_path / "s.toml"
    p.write_text(f'[grid]\nw_ratio = "1:16:5"\na_ratio = "1:12:5"\n[cases]\nblocks = {blocks}\npulses = ["sine"]\n'
                 f'[engines]\nnames = ["mujoco"]\nvariants = {variants}\n')
    return p


def test_a_suite_variant_maps_only_its_blocks(tmp_path):
    s = load_suite(_suite(tmp_path, '[{}, { calibrate_on = "sibling", blocks = ["b3l"] }]'))
    jobs = [j for j in plan(s, ["mujoco"]) if j.engine == "mujoco"]
    held = [j for j in jobs if "calibrate_on" in j.settings]
    assert [j.block for j in held] == ["B3L"] and held[0].settings == {"calibrate_on": "sibling"}
    assert len(jobs) == 3 and len({j.subdir for j in jobs}) == 3


@pytest.mark.parametrize("variants, needle", [
    ('[{ calibrate_on = "B6M" }]', "calibrate_on = B6M: B6M has h/b 4.5, the mapped block B3M"),
    ('[{ calibrate_on = "sibling", blocks = ["B6L"] }]', "names B6L, which is not in cases.blocks"),
    ('[{ calibrate_on = "B9X" }]', "'calibrate_on' must be 'sibling' or a block name"),
])
def test_a_bad_held_out_variant_stops_the_suite_with_exit_2(tmp_path, capsys, variants, needle):
    pytest.importorskip("mujoco")
    assert main(["run", str(_suite(tmp_path, variants)), "--plan", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and "\n" not in err and "Traceback" not in err
