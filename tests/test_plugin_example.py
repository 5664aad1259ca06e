"""A third-party engine plugin, installed the way its users would install it, found by its entry
point and run through `rockbench check-adapter` (tests/plugin_example/: its pyproject.toml declares
the entry point, its adapter uses only the public contract of docs/engines.md)."""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).parent / "plugin_example"


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The folder the plugin is installed into: ``pip install --no-deps --target`` (rockbench and
    numpy come from this environment), built from a copy so the build leaves nothing in the tree."""
    if importlib.util.find_spec("wheel") is None:   # setuptools before 70.1 builds wheels with it
        pytest.skip("building the example plugin offline needs wheel: pip install 'rockbench[test]'")
    tmp = tmp_path_factory.mktemp("plugin")
    src, target = tmp / "src", tmp / "site"
    shutil.copytree(EXAMPLE, src)
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
                    "--no-index", "--target", str(target), str(src)], check=True)
    return target


def test_the_installed_plugin_is_found_by_its_entry_point(site, monkeypatch):
    from rockbench.engines.registry import availability, names

    monkeypatch.syspath_prepend(str(site))   # what the plugin's users have: it on their path
    assert "toy" in names()
    a = availability("toy")
    assert a["available"] and a["version"] == "0.1.0", a


def test_the_installed_plugin_passes_check_adapter(site):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(site), os.environ.get("PYTHONPATH")) if p)}
    out = subprocess.run([sys.executable, "-m", "rockbench.benchmark", "check-adapter", "toy"], env=env, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "FAIL" not in out.stdout and "checks passed." in out.stdout
    assert out.stdout.splitlines()[1].split()[:2] == ["PASS", "hooks"]


def test_the_contract_page_shows_the_example_s_entry_point():
    import re
    import tomllib

    page = (EXAMPLE.parents[1] / "docs" / "engines.md").read_text()
    shown = tomllib.loads(re.search(r"```toml\n(.*?)```", page, re.S).group(1))
    declared = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())["project"]
    assert shown["project"]["entry-points"] == declared["entry-points"] == {
        "rockbench.engines": {"toy": "rockbench_toy.adapter:ToyEngine"}}
