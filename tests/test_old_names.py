"""Names this rockbench does not have are refused, never read as today's (issue 45, item 4).

The settings and values renamed before version 0.1.0 was ever released (``settings = "defaults"``,
MuJoCo's ``timeconst``, PyBullet's ``restitution_coef``, ...) are no longer read under their new
names: given on the command line or in a suite, they are a bad setting (exit 2); stored in a run
(run.json, cells.csv, calibration.json, score.json), the run is refused in one line that says to
compute it again (exit 5); a calibration cached under an older contract is never found (the contract
is part of its key).
"""

import json

import pytest

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.engine_info.setting_names import stored_settings
from rockbench.benchmark.store.files import stored_variant
from rockbench.engines import CONTRACT_VERSION
from rockbench.benchmark.errors import IncomparableError


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("argv, said", [
    (("--settings", "defaults"), "--settings must be calibrated or shipped, got 'defaults'"),
    (("--set", "timeconst=0.002"), "engine 'mujoco' has no setting 'timeconst'"),
])
def test_an_old_name_given_is_a_bad_setting_in_one_line(capsys, argv, said):
    code, out, err = run_cli(capsys, "simulate", "--engine", "mujoco", "--block", "B3M", "--w-ratio", "4",
                             "--a-ratio", "2", *argv)
    assert code == 2 and out == "" and err.count("\n") == 1 and said in err, err


@pytest.mark.parametrize("variant", ["dart[settings=defaults]", "pybullet[restitution_coef=0.5,settings=shipped,dt=0.001]",
                                     "mujoco[timeconst=0.002]"])
def test_a_stored_variant_under_an_old_name_is_refused(variant):
    with pytest.raises(IncomparableError, match="stored by an older rockbench under older names; compute it again"):
        stored_variant(variant, "somewhere")


@pytest.mark.parametrize("variant", ["dart[settings=shipped]", "dart[calibrate_on=sibling,settings=calibrated]",
                                     "reference", "mujoco[dt=0.001,timeconst_s=0.002]", "not a [variant",
                                     "some_plugin[its_own_setting=1]"])
def test_a_stored_variant_under_today_s_names_reads_as_stored(variant):
    assert stored_variant(variant, "somewhere") == variant


def test_a_stored_run_under_old_names_scores_and_compares_with_exit_5(write_map, band, tmp_path, capsys):
    old, new = tmp_path / "old", tmp_path / "new"
    for root, value in ((old, "defaults"), (new, "shipped")):
        write_map(root / "maps" / "ref", band(8, 8, 3))
        write_map(root / "maps" / f"mujoco-settings={value}", band(8, 8, 4), engine="mujoco",
                  settings={"settings": value})
    code, out, err = run_cli(capsys, "score", old, "--json", "--no-write")
    assert code == 5 and out == "" and err.count("\n") == 1, err
    assert "settings = 'defaults'" in err and "compute it again" in err
    code, out, err = run_cli(capsys, "score", new, "--json")
    assert code == 0, err
    stored = json.loads((new / "score.json").read_text().replace("settings=shipped", "settings=defaults"))
    (old / "score.json").write_text(json.dumps(stored))
    code, out, err = run_cli(capsys, "compare", old, new)
    assert code == 5 and err.count("\n") == 1 and "compute it again" in err, err


def test_a_map_folder_stored_under_old_names_is_not_resumed(write_map, band, tmp_path, capsys):
    old = write_map(tmp_path / "m", band(5, 5, 2), engine="dart", settings={"settings": "defaults"},
                    w=(1.0, 4.0), a=(1.0, 4.0))
    code, out, err = run_cli(capsys, "map", "--engine", "dart", "--settings", "shipped", "--block", "B6M",
                             "--w-ratio", "1:4:5", "--a-ratio", "1:4:5", "--out", old)
    assert code == 5 and err.count("\n") == 1 and "compute it again" in err, err


def test_a_calibration_is_cached_under_the_contract_it_was_made_with(monkeypatch):
    """The cache key names the engine contract: a record made under another contract is never found."""
    from rockbench.engines.calibration import routine
    from rockbench.engines.registry import get_adapter
    from rockbench.reference_solver.model import Block

    ad, block = get_adapter("dart"), Block(0.045, 0.2025, mass_kg=1.0896, name="B6M")
    key = routine.cache_key(ad, block, 0.9, 5e-4, "corners")
    monkeypatch.setattr(routine, "CONTRACT_VERSION", CONTRACT_VERSION - 1)
    assert routine.cache_key(ad, block, 0.9, 5e-4, "corners") != key


def test_stored_settings_of_an_engine_it_cannot_load_are_not_checked_for_names():
    assert stored_settings("not_installed_here", {"anything": 1}, "x") == {"anything": 1}
    with pytest.raises(IncomparableError):
        stored_settings("not_installed_here", {"settings": "defaults"}, "x")
