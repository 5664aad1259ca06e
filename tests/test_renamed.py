"""Old names and values, accepted for one release: ``settings = "defaults"`` is ``settings = "shipped"``.

What a user gives under the old spelling is read under the new one with one note; what a run stored
under it (run.json, cells.csv, calibration.json, score.json, a map folder's name) loads, scores,
compares and resumes as the same variant a run made after the rename names ``settings=shipped``.
"""

import json

import pytest

from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.benchmark.cli.main import main
from rockbench.benchmark.maps.grid import MapSpec, parse_range
from rockbench.benchmark.request import CaseRequest
from rockbench.benchmark.scoring.score_runs import load_score
from rockbench.benchmark.store.files import canonical_variant
from rockbench.benchmark.store.loading import load_own_eta
from rockbench.benchmark.suites.plan import MapJob, resume_renamed
from rockbench.engines.base import Case
from rockbench.engines.registry import get_adapter
from rockbench.engines.renamed import RENAMED_VALUES, RenamedWarning, canonical_settings
from rockbench.engines.skeleton import SteppedContactAdapter
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_one_table_names_the_old_value():
    assert RENAMED_VALUES == {"settings": {"defaults": "shipped"}}
    assert canonical_settings("mujoco", {"settings": "defaults", "friction": 1.0}) == {"settings": "shipped",
                                                                                      "friction": 1.0}
    assert canonical_settings(None, {"settings": "calibrated"}) == {"settings": "calibrated"}


def test_an_adapter_given_the_old_value_runs_as_shipped_with_a_warning():
    with pytest.warns(RenamedWarning, match="settings = 'defaults' is now settings = 'shipped'"):
        ad = get_adapter("mujoco", settings="defaults")
    assert ad.settings["settings"] == "shipped" and ad.as_shipped()
    assert ad.describe()["settings"]["settings"] == "shipped"


def test_a_class_default_under_the_old_value_warns_where_the_class_is_made():
    shared = SteppedContactAdapter.SHARED_SETTINGS
    with pytest.warns(RenamedWarning, match="SETTINGS uses an old name or value"):
        cls = type("OldShipped", (SteppedContactAdapter,),
                   {"name": "old_shipped", "SETTINGS": {**shared, "settings": "defaults", "stiffness_n_m": 1e6}})
    assert cls.SETTINGS["settings"] == "shipped"


def test_only_a_rename_becomes_a_note_a_library_s_deprecation_stays_where_it_was(monkeypatch, capsys):
    """The command line shows a RenamedWarning as one note; a library's own DeprecationWarning raised
    while a command runs (pyparsing's under an older matplotlib, at the declared floors) is not turned
    into notes: it goes to the warnings display in force (pytest records it here)."""
    import warnings

    from rockbench.benchmark.cli.commands import blocks as blocks_command

    real = blocks_command.run

    def noisy(args):
        warnings.warn("'parseString' deprecated - use 'parse_string'", DeprecationWarning)
        warnings.warn("settings = 'defaults' is now settings = 'shipped'", RenamedWarning)
        return real(args)

    monkeypatch.setattr(blocks_command, "run", noisy)
    with pytest.warns(DeprecationWarning, match="parseString"):
        code, _, err = run_cli(capsys, "blocks")
    assert code == 0
    assert [line for line in err.splitlines() if line.startswith("rockbench: note:")] == [
        "rockbench: note: settings = 'defaults' is now settings = 'shipped'"]


def test_the_command_line_reads_the_old_value_with_one_note(tmp_path, capsys):
    with pytest.warns(RenamedWarning):
        given = CaseRequest(engine="mujoco", settings="defaults", set=("drive=table",)).engine_settings()
    assert given == {"settings": "shipped", "drive": "table"}
    with pytest.warns(RenamedWarning):
        assert CaseRequest(engine="mujoco", set=("settings=defaults",)).engine_settings() == {"settings": "shipped"}
    suite = tmp_path / "old.toml"
    suite.write_text('[suite]\nname = "old"\n[grid]\nw_ratio = "1:16:5"\na_ratio = "1:12:5"\n[cases]\n'
                     'blocks = ["B3M"]\npulses = ["sine"]\n[reference]\nrestitutions = ["housner"]\n[engines]\n'
                     'names = ["mujoco"]\nvariants = [{ settings = "defaults" }, { settings = "defaults", friction = 1 }]\n'
                     'own_eta = false\n')
    code, out, err = run_cli(capsys, "run", suite, "--plan", "--out", tmp_path / "out")
    assert code == 0, err
    assert "maps/mujoco-settings=shipped/B3M-sine-housner" in out and "defaults" not in out
    notes = [line for line in err.splitlines() if line.startswith("rockbench: note:")]
    assert notes == ["rockbench: note: settings = 'defaults' is now settings = 'shipped' (the same thing, a clearer "
                     "name); the old value goes in the next release."]


@pytest.mark.parametrize("old, new", [
    ("dart[settings=defaults]", "dart[settings=shipped]"),
    ("pybullet[restitution_coef=0.5,settings=defaults,dt=0.001]", "pybullet[contact_restitution=0.5,settings=shipped,dt=0.001]"),
    ("dart[calibrate_on=sibling,settings=calibrated]", "dart[calibrate_on=sibling,settings=calibrated]"),
    ("reference", "reference"), ("not a [variant", "not a [variant")])
def test_a_stored_variant_name_is_read_under_the_new_names(old, new):
    assert canonical_variant(old) == new


def _score(capsys, root) -> dict:
    code, out, err = run_cli(capsys, "score", root, "--json", "--no-write")
    assert code == 0, err
    return json.loads(out)


def test_a_run_stored_before_the_rename_scores_and_compares_as_the_same_variant(write_map, band, tmp_path, capsys):
    old, new = tmp_path / "old", tmp_path / "new"
    for root, value in ((old, "defaults"), (new, "shipped")):
        write_map(root / "maps" / "ref", band(8, 8, 3))
        write_map(root / "maps" / f"mujoco-settings={value}", band(8, 8, 4), engine="mujoco",
                  settings={"settings": value})
        (root / "calibration.json").write_text(json.dumps({"kind": "rockbench-calibration", "measurements": [
            {"variant": f"mujoco[settings={value}]", "engine": "mujoco", "settings": {"settings": value},
             "block": "B6M", "eta_measured": 0.97}]}))
    scored_old, scored_new = _score(capsys, old), _score(capsys, new)
    assert [p["variant"] for p in scored_old["pairs"]] == ["mujoco[settings=shipped]"]
    assert scored_old["pairs"][0]["settings"] == "as-shipped"
    assert [(p["key"], p["scores"]) for p in scored_old["pairs"]] == [(p["key"], p["scores"]) for p in scored_new["pairs"]]
    assert load_own_eta([old]) == load_own_eta([new]) == {("mujoco[settings=shipped]", "B6M"): 0.97}
    # a score.json written before the rename names the old variant: read under the new name, it pairs with itself
    stored = json.loads(json.dumps(scored_new).replace("settings=shipped", "settings=defaults"))
    (old / "score.json").write_text(json.dumps(stored))
    assert load_score(old / "score.json")["verdict"]["variants"][0]["variant"] == "mujoco[settings=shipped]"
    for a, b in ((old, new), (new, old)):
        code, out, err = run_cli(capsys, "compare", a, b, "--json")
        assert code == 0, err
        res = json.loads(out)
        assert res["compared"] == 1 and res["missing"] == [] and res["new"] == []


def test_a_suite_resumes_a_map_in_its_folder_of_the_old_name(write_map, band, tmp_path):
    x, y = parse_range("grid.w_ratio", "1:10:8", "w_ratio"), parse_range("grid.a_ratio", "0.5:8:8", "a_ratio")
    block = PRESETS["B6M"].block()
    spec = MapSpec(block, "sine", Restitution(), x, y, engine="mujoco", engine_settings={"settings": "shipped"})
    old = write_map(tmp_path / "maps" / "mujoco-settings=defaults" / "B6M-sine-housner", band(8, 8, 4),
                    engine="mujoco", settings={"settings": "defaults"})
    run = json.loads((old / "run.json").read_text())
    run["spec_identity"] = {**spec.identity(), "engine_settings": {"settings": "defaults"}}   # as a run stored it
    (old / "run.json").write_text(json.dumps(run))
    assert MapSpec.from_dict(run["spec"]).identity() == spec.identity()
    job = MapJob("mujoco", {"settings": "shipped"}, "B6M", "sine", Restitution(), None,
                 "maps/mujoco-settings=shipped/B6M-sine-housner")
    assert resume_renamed([job], [spec], tmp_path)[0].subdir == "maps/mujoco-settings=defaults/B6M-sine-housner"
    other = MapSpec(block, "cosine", Restitution(), x, y, engine="mujoco", engine_settings={"settings": "shipped"})
    assert resume_renamed([job], [other], tmp_path)[0].subdir == job.subdir   # another map: a folder of its own


def test_a_hook_under_its_old_name_is_taken_under_the_new_one_with_a_warning():
    from rockbench.engines.base import EngineAdapter
    from rockbench.engines.reference_adapter import ReferenceAdapter

    called = []

    def verdicts(self, cases):
        called.append(len(cases))
        return ReferenceAdapter._native_verdicts(self, cases)

    with pytest.warns(RenamedWarning, match="_run_native is now called _native_verdicts"):
        cls = type("OldBatch", (ReferenceAdapter,), {"name": "old_batch", "_run_native": verdicts})
    assert cls._native_verdicts is verdicts
    with pytest.warns(RenamedWarning, match="run_grid is now called solve_grid"):
        grid = type("OldGrid", (EngineAdapter,), {"name": "old_grid", "run_grid": lambda self, *a, **k: None})
    assert grid.solve_grid is grid.__dict__["run_grid"]
    shared = SteppedContactAdapter.SHARED_SETTINGS
    with pytest.warns(RenamedWarning, match="_run is now called _trajectory"):
        stepped = type("OldStep", (SteppedContactAdapter,), {"name": "old_step", "_run": lambda self, *a: None,
                                                               "SETTINGS": {**shared, "settings": "shipped"}})
    assert stepped._trajectory is stepped.__dict__["_run"]
    # a class of its own with a helper named like the skeleton's old method, outside the skeleton: left alone
    plain = type("Plain", (EngineAdapter,), {"name": "plain", "_run": lambda self: 1})
    assert not hasattr(plain, "_trajectory")
    # the old-named hook really runs, and gives the reference's verdicts
    block = PRESETS["B3M"].block()
    case = Case(block, make_pulse("sine", 6.0, 6.0 * block.p_rad_s), Restitution())
    old, new = cls().run_many([case])[0], ReferenceAdapter().run_many([case])[0]
    assert called == [1] and (old.outcome, old.n_impacts) == (new.outcome, new.n_impacts)


def test_stored_resolved_settings_keep_a_key_that_shares_an_old_name():
    """Exudyn's resolved settings hold its model's stiffness_n_m beside the setting
    contact_stiffness_n_m (the setting's old name): a stored record reads as stored, while user input
    giving both is still refused."""
    from rockbench.engines.renamed import canonical_settings
    from rockbench.reference_solver.errors import ConfigError
    stored = {"contact_stiffness_n_m": None, "stiffness_n_m": 1.99e6, "settings": "defaults"}
    assert canonical_settings("exudyn", stored, stored=True) == {**stored, "settings": "shipped"}
    with pytest.raises(ConfigError, match="old name of 'contact_stiffness_n_m'"):
        canonical_settings("exudyn", stored)
