"""A third-party engine plugin, installed the way its users would install it, found by its entry
point and run through `rockbench check-adapter` (tests/plugin_example/: its pyproject.toml declares
the entry point, its adapter uses only the public contract of docs/engines.md)."""

from __future__ import annotations

import importlib.util
import json
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


def _rockbench(site, *args):
    """``rockbench ARGS`` with the plugin on the path, as its users run it."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(site), os.environ.get("PYTHONPATH")) if p)}
    return subprocess.run([sys.executable, "-m", "rockbench.benchmark", *args], env=env, capture_output=True,
                          text=True, timeout=300)


def test_the_installed_plugin_passes_check_adapter(site):
    out = _rockbench(site, "check-adapter", "toy")
    assert out.returncode == 0, out.stdout + out.stderr
    assert "FAIL" not in out.stdout and "14 of 14 checks passed; 2 skipped." in out.stdout
    assert [ln.split()[:2] for ln in out.stdout.splitlines()[1:3]] == [["PASS", "contract"], ["PASS", "hooks"]]
    # the modes it does not declare in SUPPORTED_MODES are skipped, each with a line saying so
    skipped = {ln.split()[1]: ln for ln in out.stdout.splitlines() if ln.split()[:1] == ["SKIP"]}
    assert set(skipped) == {"drive", "planar"}
    assert "supports drive = inertial only (SUPPORTED_MODES): drive = table not checked" in skipped["drive"]
    assert "planar = false not checked" in skipped["planar"]


def test_a_mode_the_plugin_does_not_support_is_one_line_and_exit_2_before_anything_runs(site):
    for setting in ("drive=table", "planar=false"):
        out = _rockbench(site, "check-adapter", "toy", "--set", setting)
        key, value = setting.split("=")
        assert out.returncode == 2 and out.stdout == "" and out.stderr.count("\n") == 1, out.stderr
        assert f"toy does not run {key} = {value} (its SUPPORTED_MODES): use {key} = " in out.stderr


def test_calibrating_while_fixing_the_contact_a_calibration_chooses_is_one_line_and_exit_2(site):
    out = _rockbench(site, "calibrate", "--engine", "toy", "--block", "B6M", "--target", "housner",
                     "--set", "contact_stiffness_n_m=2e6")
    assert out.returncode == 2 and out.stdout == "" and out.stderr.count("\n") == 1, out.stderr
    assert "toy: contact_stiffness_n_m = 2000000.0 is given" in out.stderr
    assert "leave out --target to measure η with it, or leave it out to calibrate" in out.stderr
    measured = _rockbench(site, "calibrate", "--engine", "toy", "--block", "B6M", "--set", "contact_stiffness_n_m=2e6",
                          "--json")   # without --target: η measured with the contact given
    assert measured.returncode == 0, measured.stderr
    assert json.loads(measured.stdout)["settings"]["contact_stiffness_n_m"] == 2e6


def test_the_plugin_s_supported_range_is_shown_and_checked_like_a_built_in_s(site, monkeypatch):
    from rockbench.engines import support
    from rockbench.engines.registry import adapter_class, availability

    monkeypatch.syspath_prepend(str(site))
    a = availability("toy")
    assert a["supported"] == "numpy>=1.24" and a["outside_range"] is None, a
    toy = adapter_class("toy")
    monkeypatch.setattr(toy, "SUPPORTED_VERSIONS", {"numpy": "<1"})
    assert availability("toy")["outside_range"] == f"numpy {support.version('numpy')} is outside the supported range numpy<1"
    assert support.install_advice(toy) == "pip install 'numpy<1'"
    out = _rockbench(site, "engines")
    row = next(ln for ln in out.stdout.splitlines() if ln.startswith("toy "))
    assert row.split()[:4] == ["toy", "yes", "0.1.0", "numpy>=1.24"]


def test_the_contract_page_shows_the_example_s_entry_point():
    import re
    import tomllib

    page = (EXAMPLE.parents[1] / "docs" / "engines.md").read_text()
    shown = tomllib.loads(re.search(r"```toml\n(.*?)```", page, re.S).group(1))
    declared = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())["project"]
    assert shown["project"]["entry-points"] == declared["entry-points"] == {
        "rockbench.engines": {"toy": "rockbench_toy.adapter:ToyEngine"}}
