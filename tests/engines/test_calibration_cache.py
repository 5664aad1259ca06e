"""The calibration cache knows its adapter (engines/calibration/cache.py): a key holds the adapter's
distribution and the hash of its own source, so a plugin whose code changes is calibrated afresh
without a version bump; every record names its engine, and ``rockbench calibrate --clear ENGINE``
removes that engine's records only. No engine library runs: the adapter below fakes free rocking."""

from __future__ import annotations

import importlib
import sys
import textwrap

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.cli.main import main
from rockbench.engines.calibration import cache
from rockbench.engines.calibration.pick import Candidate, pick
from rockbench.engines.registry import adapter_class
from rockbench.engines.calibration.routine import calibrate

BLOCK = get_preset("B6L").block()
T = 0.9294

#: a plugin's adapter module; ``{scene}`` is what its author fixes between the two calibrations
PLUGIN = textwrap.dedent('''
    from rockbench.engines.calibration.knobs import Knob
    from rockbench.engines.contact import ContactEngine
    from rockbench.engines.contract import RestitutionMeasurement

    CALLS = []
    SCENE_FRICTION = {scene}

    class TinyAdapter(ContactEngine):
        CONTRACT_VERSION = 2
        name = "tiny"
        SHIPPED = {{"k": None}}
        KNOBS = (Knob("k", "N/m", (1.0, 2.0)),)

        def measure_many(self, block, settings, dt, theta0_frac=0.5):
            CALLS.append(len(settings))
            return [RestitutionMeasurement([{target}] * 4, {target}, 0.001, 0.1, dt, {{}}, sink_m=1e-3 / s["k"],
                                           hop_m=0.0) for s in settings]
''')


def _tiny(tmp_path, scene: str):
    """The plugin module written with ``scene`` and imported afresh; its adapter class."""
    (tmp_path / "tiny_plugin.py").write_text(PLUGIN.format(scene=scene, target=T))
    importlib.invalidate_caches()
    sys.modules.pop("tiny_plugin", None)
    return importlib.import_module("tiny_plugin").TinyAdapter


def test_a_plugin_whose_code_changes_is_calibrated_afresh(tmp_path, monkeypatch):
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path / "cache"))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    try:
        first = _tiny(tmp_path, "0.7")
        calibrate(first(), BLOCK, T, dt_s=1e-3)
        measured = list(sys.modules["tiny_plugin"].CALLS)
        assert measured, "the first calibration measures"
        calibrate(first(), BLOCK, T, dt_s=1e-3)
        assert sys.modules["tiny_plugin"].CALLS == measured, "the same code reads the stored calibration"
        fixed = _tiny(tmp_path, "0.8")   # the author fixes the scene and bumps nothing
        assert cache.adapter_identity(fixed) != cache.adapter_identity(first)
        calibrate(fixed(), BLOCK, T, dt_s=1e-3)
        assert sys.modules["tiny_plugin"].CALLS, "the changed code is calibrated again"
        assert cache.engines_stored() == {"tiny": 2}
    finally:
        sys.modules.pop("tiny_plugin", None)


def test_a_built_in_adapter_is_rockbench_s_own_distribution():
    ident = cache.adapter_identity(adapter_class("mujoco"))
    assert ident["distribution"] == "rockbench" and ident["distribution_version"]
    assert len(ident["source_sha256"]) == 16
    assert ident != cache.adapter_identity(adapter_class("pybullet"))


def test_clear_removes_one_engine_s_records_only(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path))
    for i, engine in enumerate(["mujoco", "mujoco", "pybullet"]):
        cache.store(cache.cache_key(i=i), {"result": {}}, engine)
    assert main(["calibrate", "--clear", "mujoco"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("removed 2 stored calibration records of mujoco")
    assert cache.engines_stored() == {"pybullet": 1}
    assert cache.load(cache.cache_key(i=2))["engine"] == "pybullet"


def test_clear_of_an_unknown_engine_is_one_line_and_exit_2(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path))
    cache.store(cache.cache_key(i=0), {"result": {}}, "pybullet")
    assert main(["calibrate", "--clear", "mujocco"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "unknown engine 'mujocco'" in err, err
    assert cache.engines_stored() == {"pybullet": 1}


def test_no_regular_setting_names_the_test_that_failed():
    def why(**kw):
        c = Candidate({}, kw.get("eta", T), kw.get("std", 0.002), kw.get("n", 4), 1e-6, kw.get("hop", 0.0))
        p = pick([c], T, BLOCK)
        assert not p.reached and p.why.startswith("no regular setting: the closest (")
        return p.why
    assert "spread above the bound" in why(std=0.1) and "hop" not in why(std=0.1)
    assert "fewer than two impacts: 1" in why(n=1)
    assert "a hop" in why(hop=1e-3) and "spread" not in why(hop=1e-3)
    both = why(std=0.1, hop=1e-3)
    assert "spread above the bound" in both and " and a hop" in both
