"""The rule set's version: in the calibration cache key, run.json and score.json; maps and scores of
another version are refused with one line saying to rerun (exit 5), and a map folder of another
version is not resumed (exit 2)."""

import json

import pytest

from rockbench.benchmark.cli.main import main
from rockbench.reference_solver.model import Block
from rockbench.reference_solver.rules import RULES_VERSION, rules_mismatch


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def run(write_map, band, tmp_path):
    root = tmp_path / "run"
    write_map(root / "ref-h", band(12, 10, 6))
    write_map(root / "eng", band(12, 10, 7), engine="mujoco", settings={"settings": "calibrated"})
    return root


def _set_rules(map_dir, version):
    meta = json.loads((map_dir / "run.json").read_text())
    if version is None:
        meta.pop("rules_version", None)
    else:
        meta["rules_version"] = version
    (map_dir / "run.json").write_text(json.dumps(meta))


def test_mismatch_names_both_versions_and_a_record_without_one_is_version_1():
    assert rules_mismatch(RULES_VERSION, "x") is None
    line = rules_mismatch(None, "the map 'm'")
    assert "rules version 1" in line and f"rules version {RULES_VERSION}" in line


def test_the_cache_key_changes_with_the_rules_version(monkeypatch):
    from rockbench.engines.calibration import routine
    from rockbench.engines.registry import get_adapter

    ad, b = get_adapter("dart"), Block(width_m=0.05, height_m=0.1125, depth_m=0.05, mass_kg=1.0)
    key = routine.cache_key(ad, b, 0.75, 5e-4, "corners")
    monkeypatch.setattr(routine, "RULES_VERSION", "test-other")
    assert routine.cache_key(ad, b, 0.75, 5e-4, "corners") != key


def test_score_json_records_the_rules_version(run, capsys):
    code, _, err = run_cli(capsys, "score", run)
    assert code == 0, err
    assert json.loads((run / "score.json").read_text())["rules_version"] == RULES_VERSION


@pytest.mark.parametrize("which", ["eng", "ref-h"])
def test_a_map_of_other_rules_is_not_scored(run, which, capsys):
    _set_rules(run / which, None)
    code, _, err = run_cli(capsys, "score", run)
    assert code == 5 and len(err.strip().splitlines()) == 1 and "rules version 1" in err, err
    assert "Traceback" not in err and "again" in err


def test_compare_refuses_across_rules_versions_and_says_to_rerun(run, capsys, tmp_path):
    assert run_cli(capsys, "score", run)[0] == 0
    cur = json.loads((run / "score.json").read_text())
    old = dict(cur)
    old.pop("rules_version")
    (tmp_path / "old.json").write_text(json.dumps(old))
    code, _, err = run_cli(capsys, "compare", tmp_path / "old.json", run / "score.json")
    assert code == 5 and len(err.strip().splitlines()) == 1 and "rerun" in err, err
    assert run_cli(capsys, "compare", run / "score.json", run / "score.json")[0] == 0


def test_a_map_folder_of_other_rules_is_not_resumed(tmp_path, capsys):
    out = tmp_path / "m"
    argv = ["map", "--engine", "reference", "--block", "B3M", "--pulse", "sine", "--w-ratio", "2:4:3",
            "--a-ratio", "1:3:3", "--out", out]
    assert run_cli(capsys, *argv)[0] == 0
    assert json.loads((out / "run.json").read_text())["rules_version"] == RULES_VERSION
    _set_rules(out, "1")
    before = (out / "cells.csv").read_text()
    code, _, err = run_cli(capsys, *argv)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "delete" in err, err
    assert (out / "cells.csv").read_text() == before
