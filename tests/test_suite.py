"""Suite files of `rockbench run`: the shipped ones parse, bad ones are refused with one line."""

import pytest

from rockbench.benchmark.cli import main
from rockbench.benchmark.run import load_suite, plan, restitution_for, suite_path
from rockbench.reference_solver.errors import ConfigError


def test_shipped_suites_parse_and_plan():
    d = load_suite(suite_path(None, quick=False))
    q = load_suite(suite_path(None, quick=True))
    assert d.name == "default" and q.name == "quick"
    assert d.blocks == ["B3M", "B6M", "B3L", "B6L"] and d.pulses == ["sine", "cosine"]
    assert q.blocks == ["B3M", "B6L"]  # one block per slenderness
    jobs = plan(d, ["mujoco", "pybullet"])
    refs = [j for j in jobs if j.engine == "reference"]
    assert len(refs) == 4 * 2 * 3  # blocks × pulses × (Housner, modified average k, modified exact k)
    assert len(jobs) - len(refs) == 2 * 2 * 4 * 2  # engines × variants × blocks × pulses
    assert len({j.subdir for j in jobs}) == len(jobs)
    b3m = {j.restitution.label for j in refs if j.block == "B3M"}
    assert b3m == {"housner", "modified(k=0.8608)", "modified(k=0.7595)"}
    assert {j.settings["settings"] for j in jobs if j.engine == "mujoco"} == {"calibrated", "defaults"}


def test_restitution_tokens():
    assert restitution_for("modified-exact", "B6L").k == 0.7214
    assert restitution_for("modified:0.5", "B6L").k == 0.5
    assert restitution_for("0.9", "B6L").value == 0.9
    with pytest.raises(ConfigError, match="not one of"):
        restitution_for("bouncy", "B3M")


@pytest.mark.parametrize("text, match", [
    ("[grid]\nw_ratio = '1:2:3'\na_ratio = '1:2:3'\n[colours]\nx = 1\n", "unknown table"),
    ("[grid]\nw_ratio = '1:2:3'\na_ratio = '1:2:3'\nzoom = 2\n", "unknown key grid.zoom"),
    ("[grid]\nw_ratio = 5\na_ratio = '1:2:3'\n", "grid.w_ratio must be a string"),
    ("[grid]\nw_ratio = '1:2:3'\na_ratio = '1:2:3'\n[cases]\nblocks = ['B9X']\n", "unknown block"),
    ("[grid]\nw_ratio = '1:2:3'\na_ratio = '1:2:3'\n[cases]\npulses = ['square']\n", "cases.pulses"),
    ("[grid]\nw_ratio = '1:2:3'\na_ratio = '1:2:3'\n[engines]\nnames = 3\n", "engines.names"),
    ("[grid\n", "not valid TOML"),
])
def test_bad_suites(tmp_path, text, match):
    p = tmp_path / "s.toml"
    p.write_text(text)
    with pytest.raises(ConfigError, match=match):
        load_suite(p)


def test_run_cli_usage(tmp_path, capsys):
    assert main(["run", "--plan", "--quick", "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "maps/reference/B3M-sine-housner" in out and not (tmp_path / "o").exists()
    assert main(["run", str(tmp_path / "missing.toml")]) == 2
    assert main(["run", "nosuchsuite"]) == 2
    assert main(["run", "default", "--quick"]) == 2
    assert main(["run", "--quick", "--jobs", "0"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 4
