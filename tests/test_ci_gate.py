"""The README's CI gate, run as written there: it passes on the shipped engine and fails on a real
regression."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
README = HERE.parent / "README.md"


def _section() -> str:
    text = README.read_text()
    start = text.index("## A CI gate for engine projects")
    return text[start:text.index("\n## ", start + 3)]


def gate_steps() -> list[str]:
    """The ``run:`` steps of the README's workflow that call rockbench, in order."""
    yaml = re.search(r"```yaml\n(.*?)```", _section(), re.S).group(1)
    steps = [m.group(1).split("#")[0].strip() for m in re.finditer(r"- run: (.*)", yaml)]
    return [s for s in steps if s.startswith("rockbench ")]


def baseline_commands() -> list[str]:
    """The README's commands that make baseline/score.json."""
    block = re.search(r"```bash\n(.*?)```", _section(), re.S).group(1)
    return [ln.strip() for ln in block.splitlines() if ln.strip() and not ln.strip().startswith("#")]


def _shim(bin_dir: Path, regressed: bool) -> dict:
    """An environment whose ``rockbench`` is this checkout's, or the one with the regressed MuJoCo."""
    bin_dir.mkdir(exist_ok=True)
    exe = bin_dir / "rockbench"
    target = (f"import sys; sys.path.insert(0, {str(HERE)!r}); import ci_helpers; sys.exit(ci_helpers.main())"
              if regressed else "import sys; from rockbench.benchmark.cli.main import main; sys.exit(main())")
    exe.write_text(f"#!{sys.executable}\n{target}\n")
    exe.chmod(0o755)
    return dict(os.environ, PATH=f"{bin_dir}{os.pathsep}{os.environ['PATH']}",
                PYTHONPATH=str(HERE) + os.pathsep + os.environ.get("PYTHONPATH", ""))


def _sh(cmd: str, cwd: Path, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", "-c", cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=900)


def test_the_readme_names_its_commands():
    steps = gate_steps()
    assert [s.split()[1] for s in steps] == ["run", "score", "compare"]
    assert "--engines" in steps[0] and "baseline/score.json" in steps[2]
    assert any("cp rb/score.json baseline/score.json" in c for c in baseline_commands())


@pytest.mark.slow
@pytest.mark.engine
def test_readme_ci_gate_passes_on_the_shipped_engine_and_fails_on_a_regression(tmp_path):
    pytest.importorskip("mujoco")
    work = tmp_path / "engine-repo"
    work.mkdir()
    good = _shim(tmp_path / "bin-good", regressed=False)
    for cmd in baseline_commands():                       # on the main branch, once
        r = _sh(cmd, work, good)
        assert r.returncode == 0, (cmd, r.stderr[-2000:])
    shutil.rmtree(work / "rb")
    for cmd in gate_steps():                              # a pull request that changes nothing
        r = _sh(cmd, work, good)
        assert r.returncode == 0, (cmd, r.stdout[-2000:], r.stderr[-2000:])
    assert "compare: ok" in (work / "rb" / "compare.md").read_text()

    shutil.rmtree(work / "rb")
    bad = _shim(tmp_path / "bin-bad", regressed=True)     # a pull request that weakens the table drive
    codes = {}
    for cmd in gate_steps():
        codes[cmd.split()[1]] = _sh(cmd, work, bad).returncode
    assert codes["run"] == 0
    assert codes["compare"] == 1, codes
    md = (work / "rb" / "compare.md").read_text()
    assert "REGRESSION" in md and "mujoco[settings=calibrated]" in md
