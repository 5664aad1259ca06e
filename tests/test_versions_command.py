"""``rockbench versions``: its input, its cached environments and its flow, with
the processes faked (no environment is built here; docs/versions.md has a real run)."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.cli.commands import versions as versions_cmd
from rockbench.benchmark.engine_info.envs import VersionSpec, build_env, parse_pair, plan_env
from rockbench.engines.errors import EngineUnavailableError


@pytest.mark.parametrize("argv, needle", [
    (["mujoco", "mujoco==4.0.0"], "ENGINE==VERSION"),
    (["mujooc==3.3.7", "mujoco==4.0.0"], "Did you mean 'mujoco'"),
    (["mujoco==3.3.7", "pybullet==3.2.7"], "one engine"),
    (["mujoco==4.0.0", "mujoco==4.0.0"], "twice"),
    (["reference==1", "reference==2"], "distribution"),
    (["mujoco==x.y", "mujoco==4.0.0"], "not a version"),
    (["mujoco==3.3.7"], "two ENGINE==VERSION"),
    (["mujoco==3.3.7", "mujoco==4.0.0", "quick", "--quick"], "not both"),
    (["mujoco==3.3.7", "mujoco==4.0.0", "--source", "/no/such/dir"], "not a rockbench source tree"),
])
def test_bad_input_exits_2_with_one_line(argv, needle, capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path))
    assert main(["versions", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err, err
    assert not (tmp_path / "versions").exists()          # nothing built


def _ok(cmd, **kw):
    return subprocess.CompletedProcess(cmd, 0, "", "")


def test_plan_builds_once_reinstalls_rockbench_when_it_changed_and_rebuilds_for_another_version(tmp_path):
    a, _ = parse_pair(["mujoco_warp==4.0.0", "mujoco_warp==4.0.1"])
    src = tmp_path / "src"
    plan = plan_env(a, src, tmp_path, python="py", fingerprint="f1")
    assert plan.state == "new" and plan.path.name.startswith("mujoco_warp-4.0.0-py3.")
    assert plan.steps[0] == ["py", "-m", "venv", "--clear", str(plan.path)]
    assert plan.steps[1][-2:] == [str(src), "mujoco-warp==4.0.0"]        # the engine pinned, not rockbench's extra
    (plan.path / "bin").mkdir(parents=True)
    (plan.path / "bin" / "python").write_text("")
    build_env(plan, runner=_ok)
    assert plan_env(a, src, tmp_path, fingerprint="f1").steps == []       # cached
    again = plan_env(a, src, tmp_path, fingerprint="f2")
    assert again.state == "rockbench changed" and again.steps == [
        [str(plan.python), "-m", "pip", "install", "-q", "--no-deps", "--force-reinstall", str(src)]]
    other = plan_env(VersionSpec("mujoco_warp", "4.0.1"), src, tmp_path, fingerprint="f1")
    assert other.state == "new" and other.path != plan.path


def test_an_environment_that_cannot_be_built_is_exit_3(tmp_path):
    plan = plan_env(VersionSpec("mujoco", "9.9.9"), tmp_path, tmp_path, fingerprint="f")

    def fail(cmd, **kw):
        return subprocess.CompletedProcess(cmd, 1, "", "ERROR: No matching distribution found for mujoco==9.9.9\n")
    with pytest.raises(EngineUnavailableError, match="No matching distribution found for mujoco==9.9.9"):
        build_env(plan, runner=fail)
    assert not (plan.path / "rockbench-versions.json").exists()


def test_the_command_builds_runs_both_and_prints_the_verdict_with_the_versions(write_map, band, tmp_path, capsys,
                                                                              monkeypatch):
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path / "cache"))
    calls = []

    def fake(cmd, **kw):
        calls.append(cmd)
        if cmd[1:3] == ["-m", "venv"]:
            (Path(cmd[-1]) / "bin").mkdir(parents=True, exist_ok=True)
            (Path(cmd[-1]) / "bin" / "python").write_text("")
        if cmd[1] == "run":                       # <venv>/bin/rockbench run ... --out DIR: write a scored run
            out = Path(cmd[cmd.index("--out") + 1])
            version = Path(cmd[0]).parents[1].name.split("-")[1]
            write_map(out / "maps" / "ref", band(12, 10, 6))
            write_map(out / "maps" / "eng", band(12, 10, 6), engine="mujoco")
            run = json.loads((out / "maps" / "eng" / "run.json").read_text())
            run["engine"]["version"] = version
            (out / "maps" / "eng" / "run.json").write_text(json.dumps(run))
        return subprocess.CompletedProcess(cmd, 0, "", "")

    monkeypatch.setattr(versions_cmd, "_runner", lambda: fake)
    code = main(["versions", "mujoco==3.3.7", "mujoco==4.0.0", "--quick", "--out", str(tmp_path / "out")])
    out = capsys.readouterr().out
    assert code == 0, out
    runs = [c for c in calls if c[1] == "run"]
    assert [c[c.index("--out") + 1] for c in runs] == [str(tmp_path / "out" / "mujoco-3.3.7"),
                                                       str(tmp_path / "out" / "mujoco-4.0.0")]
    assert all(c[2] == "--quick" and c[c.index("--engines") + 1] == "mujoco" for c in runs)
    assert "engine versions differ: mujoco 3.3.7 (baseline) → 4.0.0 (current)" in out
    assert out.strip().splitlines()[-1] == "versions: mujoco 3.3.7 (baseline) → 4.0.0 (candidate): no regression"
    # a second call reuses both environments: only the two runs
    calls.clear()
    assert main(["versions", "mujoco==3.3.7", "mujoco==4.0.0", "--quick", "--out", str(tmp_path / "out")]) == 0
    assert [c[1] for c in calls] == ["run", "run"]
