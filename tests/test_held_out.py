"""The held-out check: ``calibrate_on`` names another block (``sibling``: the other size of the same
slenderness; ``neighbour``: the nearest other slenderness of the same size among Table 1's blocks; or a
preset's name), and anything else is refused with one line. The engines take the blocks themselves (a
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
from rockbench.reference_solver.restitution import Restitution, housner_eta

SIBLING = calibrate_on("sibling", "mujoco")
NEIGHBOUR = calibrate_on("neighbour", "mujoco")


@pytest.mark.parametrize("mapped, sibling", [("B3L", "B3M"), ("B6L", "B6M"), ("B3M", "B3L"), ("B6M", "B6L")])
def test_the_sibling_is_the_other_size_of_the_same_slenderness(mapped, sibling):
    block = PRESETS[mapped].block()
    assert held_out.calibration_block(SIBLING, block).name == sibling
    assert held_out.calibration_block(calibrate_on(sibling, "mujoco"), block).name == sibling
    assert held_out.calibration_block(None, block) is block


@pytest.mark.parametrize("mapped, neighbour", [("B2M", "B3M"), ("B8M", "B6M"), ("B3M", "B6M"), ("B6M", "B3M"),
                                               ("B3L", "B6L"), ("B6L", "B3L")])
def test_the_neighbour_is_the_nearest_other_slenderness_of_table_1_in_the_same_size(mapped, neighbour):
    """B2M (h/b 1.5) is 0.75 from B3M and 3.0 from B6M; B8M (6.0) 1.5 from B6M and 3.75 from B3M; the
    measured-range blocks are never picked (Table 1's blocks only), nor the mapped block itself."""
    on = held_out.calibration_block(NEIGHBOUR, PRESETS[mapped].block())
    assert on.name == neighbour and on.width_m == PRESETS[mapped].width_m
    assert held_out.slenderness(on) != pytest.approx(PRESETS[mapped].h_over_b)


def test_a_held_out_calibration_aims_at_the_laws_eta_for_the_block_it_is_made_on():
    """B2M calibrated on B3M: the calibration is B3M's own (η_H 0.7526), not one of B3M at B2M's η_H (0.5385)."""
    b2m, b3m = PRESETS["B2M"].block(), PRESETS["B3M"].block()
    on, eta = held_out.calibration_target(NEIGHBOUR, b2m, Restitution())
    assert on.name == "B3M" and eta == housner_eta(b3m.alpha_rad) and round(eta, 4) == 0.7526
    assert housner_eta(b2m.alpha_rad) == pytest.approx(1 - 1.5 / 3.25)   # sin²α = 1/(1 + 1.5²)
    on, eta = held_out.calibration_target(None, b2m, Restitution("modified", k=0.8608))
    assert on is b2m and round(eta, 4) == 0.6363


def test_names_are_resolved_by_the_benchmark_and_checked_when_the_setting_is_given():
    assert str(calibrate_on("b3m", "mujoco")) == "B3M" and calibrate_on("b3m", "mujoco").block == PRESETS["B3M"].block()
    assert str(calibrate_on("Sibling", "mujoco")) == held_out.SIBLING and calibrate_on("Sibling", "mujoco").block is None
    assert str(calibrate_on("Neighbour", "mujoco")) == held_out.NEIGHBOUR
    assert {b.name for b in NEIGHBOUR.among} == {"B3M", "B6M", "B3L", "B6L"}   # Table 1's blocks
    assert calibrate_on(None, "mujoco") is None
    assert engine_settings("mujoco", {"calibrate_on": "B3M", "friction": 1.0})["calibrate_on"].block.name == "B3M"
    with pytest.raises(ConfigError, match="'calibrate_on' must be 'sibling', 'neighbour' or a block name"):
        calibrate_on("B9X", "mujoco")
    with pytest.raises(ConfigError, match="'calibrate_on' must be 'sibling', 'neighbour' or a block name"):
        build_adapter("mujoco", calibrate_on="neighbor")
    with pytest.raises(ConfigError, match="rule must be one of sibling, neighbour"):
        held_out.CalibrateOn(None, (), "nearest")


def test_the_engines_take_the_block_itself_and_refuse_a_name_with_what_to_pass():
    """No names on the engines' floor: a Block (or a CalibrateOn) is taken, a name is refused in one line."""
    pytest.importorskip("mujoco")
    ad = get_adapter("mujoco", calibrate_on=PRESETS["B3M"].block())
    assert held_out.calibration_block(ad.settings["calibrate_on"], PRESETS["B3L"].block()).name == "B3M"
    assert held_out.calibration_block(ad.settings["calibrate_on"], PRESETS["B2M"].block()).name == "B3M"   # a transfer
    assert ad.describe()["settings"]["calibrate_on"] == "B3M"   # run.json records it as written
    assert held_out.check_setting(None, "mujoco") is None and held_out.check_setting("", "mujoco") is None
    with pytest.raises(ConfigError, match="a name .* is the benchmark's: rockbench.benchmark.engine_info.adapters"):
        get_adapter("mujoco", calibrate_on="B3M")
    assert build_adapter("mujoco", calibrate_on="sibling").describe()["settings"]["calibrate_on"] == "sibling"
    assert build_adapter("mujoco", calibrate_on="neighbour").describe()["settings"]["calibrate_on"] == "neighbour"


def test_a_block_of_another_slenderness_is_taken():
    assert held_out.calibration_block(calibrate_on("B6M", "mujoco"), PRESETS["B3L"].block()).name == "B6M"
    assert held_out.calibration_block(calibrate_on("B3M", "mujoco"), PRESETS["B8M"].block()).name == "B3M"


def test_a_block_calibrating_on_itself_is_refused():
    with pytest.raises(ConfigError) as e:
        held_out.calibration_block(calibrate_on("b2m", "mujoco"), PRESETS["B2M"].block())
    assert str(e.value) == ("calibrate_on = B2M: that is the mapped block B2M (h/b 1.5) itself; a held-out calibration "
                            "is made on another block (leave calibrate_on out to calibrate on the block itself).")


def test_a_sibling_that_is_not_one_block_is_refused():
    """A custom block of h/b 2.25 has two named blocks of its slenderness; one of 3.3 has none; nor has B2M."""
    with pytest.raises(ConfigError, match=r"found 2 \(B3M, B3L\); name the block"):
        held_out.calibration_block(SIBLING, Block(0.05, 0.1125))
    with pytest.raises(ConfigError, match="found none"):
        held_out.calibration_block(SIBLING, Block(0.05, 0.165))
    with pytest.raises(ConfigError, match="block B2M .* found none"):
        held_out.calibration_block(SIBLING, PRESETS["B2M"].block())


def test_a_neighbour_that_is_not_one_block_is_refused():
    """A width no Table 1 block has; a medium block exactly between B3M (2.25) and B6M (4.5)."""
    with pytest.raises(ConfigError, match=r"no named block of its width \(50 mm\)"):
        held_out.calibration_block(NEIGHBOUR, Block(0.05, 0.15))
    with pytest.raises(ConfigError, match="lies as near to B3M as to B6M; name the block"):
        held_out.calibration_block(NEIGHBOUR, Block(0.045, 0.045 * 3.375))


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


def test_the_default_suite_holds_out_b2m_and_b8m_on_their_neighbours():
    from rockbench.benchmark.suites.model import suite_path
    s = load_suite(suite_path("default", False))
    held = [j for j in plan(s, ["mujoco"]) if j.settings.get("calibrate_on")]
    assert sorted({j.block for j in held}) == ["B2M", "B8M"] and len(held) == 4
    assert {j.settings["calibrate_on"] for j in held} == {"neighbour"}
    ad = build_adapter("mujoco", calibrate_on="neighbour")
    on = {j.block: held_out.calibration_block(ad.settings["calibrate_on"], PRESETS[j.block].block()).name for j in held}
    assert on == {"B2M": "B3M", "B8M": "B6M"}


@pytest.mark.parametrize("variants, blocks, needle", [
    ('[{ calibrate_on = "B3M" }]', '["B3M", "B3L"]', "calibrate_on = B3M: that is the mapped block B3M"),
    ('[{ calibrate_on = "sibling", blocks = ["B6L"] }]', '["B3M", "B3L"]', "names B6L, which is not in cases.blocks"),
    ('[{ calibrate_on = "B9X" }]', '["B3M", "B3L"]', "'calibrate_on' must be 'sibling', 'neighbour' or a block name"),
    ('[{ calibrate_on = "sibling" }]', '["B2M"]', "calibrate_on = sibling: block B2M (h/b 1.5) needs exactly one"),
])
def test_a_bad_held_out_variant_stops_the_suite_with_exit_2(tmp_path, capsys, variants, blocks, needle):
    pytest.importorskip("mujoco")
    assert main(["run", str(_suite(tmp_path, variants, blocks)), "--plan", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and "\n" not in err and "Traceback" not in err
