"""The adapter contract, one test for every contact engine (MuJoCo, PyBullet, Exudyn, Drake, DART, Genesis,
PhysX).

What each engine's own test file used to check the same way: the conformance suite passes, the
shared settings are checked, a bad time step is a ConfigError, the command line says what was
wrong in one line, calibration through the command line reaches Housner's η, a low friction is
flagged ``slip``, the trajectory keeps the contract's conventions and mirror symmetry. Where the
engines differ (the case, a tolerance, an engine-specific key) :data:`SPEC` says so; what only one
engine has stays in its own file.
"""

from __future__ import annotations

import importlib.util
import json
import math

import numpy as np
import pytest

from cells import cell_case

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.contract import FLAGS, Trajectory
from rockbench.engines.registry import adapter_class, get_adapter
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.restitution import housner_eta

pytestmark = pytest.mark.engine

#: engine name → the Python modules that must be importable for the engine to run (genesis-world
#: imports torch without declaring it, docs/genesis.md)
MODULES = {"mujoco": ("mujoco",), "pybullet": ("pybullet",), "exudyn": ("exudyn",), "drake": ("pydrake",),
           "dart": ("dartpy",), "genesis": ("genesis", "torch"), "physx": ("sapien",)}

ENGINES = [pytest.param(n, marks=pytest.mark.skipif(any(importlib.util.find_spec(m) is None for m in ms),
                                                    reason=f"{n} not installed"))
           for n, ms in MODULES.items()]

#: per engine: the rocking case of the trajectory test (block, pulse, ω/p, a₀/(g·tanα)), the mirror
#: test's case and tolerance (max |θ(ü) + θ(−ü)| over α, or over max |θ| for PyBullet, whose
#: sequential-impulse solver visits the contacts in one order), the low-friction case and settings
#: (explicit or shipped contact: a calibration at that friction finds only sliding free rocking), the
#: block the CLI calibrates and what its settings must hold; where given, the step the conformance suite runs at
#: (``check_dt_s``: Genesis, whose time-step rule calibrates at each step of the ladder, 11 minutes on 2 cores;
#: at its fixed step the suite calibrates once, on B6M at η_H, and the CLI's calibration of B6M finds it cached)
SPEC = {
    "mujoco": dict(
        trajectory=("B3M", "sine", 6.0, 2.0),
        mirror=(("B3M", "sine", 6.0, 2.0), 1e-3, "alpha"),
        slip=(("B3M", "sine", 5.0, 3.0), dict(friction=0.2, timeconst_s=0.001, dampratio=1.0)),
        cli_block="B6M",
        cli_settings=lambda s: {"timeconst_s", "dampratio"} <= set(s)),
    "pybullet": dict(
        trajectory=("B3M", "sine", 4.0, 3.0),
        mirror=(("B3M", "sine", 4.0, 3.0), 5e-3, "peak"),
        slip=(("B3M", "sine", 3.0, 5.0), dict(friction=0.2, settings="shipped")),
        cli_block="B6M",
        cli_settings=lambda s: isinstance(s, dict)),
    "exudyn": dict(
        trajectory=("B3M", "sine", 2.0, 2.0),
        mirror=(("B3M", "sine", 6.0, 3.0), 0.02, "alpha"),
        slip=(("B3M", "sine", 6.0, 3.0), dict(friction=0.2, contact_restitution=0.05)),
        cli_block="B3M",
        cli_settings=lambda s: math.isfinite(s["contact_restitution"])),
    "drake": dict(
        trajectory=("B3M", "sine", 4.0, 3.0),
        mirror=(("B3M", "sine", 4.0, 3.0), 1e-6, "peak"),
        slip=(("B3M", "sine", 3.0, 5.0), dict(friction=0.2, point_stiffness_n_m=1e6, relaxation_time_s=1e-3)),
        cli_block="B6M",
        cli_settings=lambda s: s["point_stiffness_n_m"] > 0 and s["relaxation_time_s"] > 0),
    "dart": dict(
        trajectory=("B3M", "sine", 4.0, 3.0),
        mirror=(("B3M", "sine", 4.0, 3.0), 1e-9, "peak"),
        slip=(("B3M", "sine", 3.0, 5.0), dict(friction=0.2, settings="shipped")),
        cli_block="B6M",
        cli_settings=lambda s: s["collision_detector"] == "fcl" and s["contact_restitution"] == 0.0),
    "genesis": dict(
        trajectory=("B3M", "sine", 6.0, 2.0),
        mirror=(("B3M", "sine", 4.0, 3.0), 1e-3, "alpha"),
        slip=(("B3M", "sine", 3.0, 5.0), dict(friction=0.2, timeconst_s=0.002)),
        cli_block="B6M",
        cli_settings=lambda s: s["timeconst_s"] > 0,
        check_dt_s=5e-4),
    "physx": dict(
        trajectory=("B3M", "sine", 4.0, 3.0),
        mirror=(("B3M", "sine", 6.0, 2.0), 3e-3, "alpha"),
        slip=(("B3M", "sine", 3.0, 5.0), dict(friction=0.2, settings="shipped")),
        cli_block="B6M",
        cli_settings=lambda s: s["substeps"] > 1),
}


@pytest.fixture(scope="module", autouse=True)
def _calibration_cache(tmp_path_factory):
    """A calibration cache of this module's own: calibrations run here, none leaks in."""
    mp = pytest.MonkeyPatch()
    mp.setenv("ROCKBENCH_CACHE", str(tmp_path_factory.mktemp("rockbench-cache")))
    yield
    mp.undo()


_case = cell_case


@pytest.mark.parametrize("engine", ENGINES)
def test_check_adapter_passes(engine, capsys):
    # the public conformance suite any adapter must pass (`rockbench check-adapter NAME`), at a step given
    # where SPEC names one (the time-step rule's calibrations are the engine's own test's to run)
    step = SPEC[engine].get("check_dt_s")
    assert main(["check-adapter", engine, *(["--dt", str(step)] if step else [])]) == 0
    assert "checks passed" in capsys.readouterr().out


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("settings", [
    {"nonsense": 1}, {"settings": "tuned"}, {"settings": "fast"}, {"drive": "mocap"}, {"drive": "belt"},
    {"friction": -1.0}, {"friction": 0}, {"planar": "maybe"}, {"planar": "yes"}, {"tail_s": "long"},
    {"min_tail_s": -1.0},
])
def test_bad_shared_settings_raise_config_error(engine, settings):
    with pytest.raises(ConfigError):
        get_adapter(engine, **settings)


@pytest.mark.parametrize("engine", ENGINES)
def test_negative_time_step_raises_config_error(engine):
    with pytest.raises(ConfigError):
        get_adapter(engine).run(_case("B3M", "sine", 6.0, 3.0, dt_s=-1e-4))


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("extra", [["--set", "no_such_setting=1"], ["--set", "colour=red"], ["--dt", "-0.001"],
                                   ["--settings", "nonsense"], ["--settings", "as-shipped"]])
def test_cli_bad_settings_exit_2_with_one_line(engine, extra, capsys):
    assert main(["calibrate", "--engine", engine, "--block", "B3M", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err and "\n" not in err and "Traceback" not in err and "error" in err


@pytest.mark.parametrize("engine", ENGINES)
def test_cli_calibrate_json(engine, capsys):
    spec = SPEC[engine]
    assert main(["calibrate", "--engine", engine, "--block", spec["cli_block"], "--target", "housner", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["reached"] is True
    assert out["eta_target"] == pytest.approx(housner_eta(get_preset(spec["cli_block"]).block().alpha_rad))
    assert abs(out["eta_measured"] - out["eta_target"]) <= 0.01 * out["eta_target"]
    assert "settings" in out and spec["cli_settings"](out["settings"])


@pytest.mark.parametrize("engine", ENGINES)
def test_low_friction_is_flagged_slip(engine):
    cell, settings = SPEC[engine]["slip"]
    r = get_adapter(engine, **settings).run(_case(*cell))
    assert r.status == "ok", r.message
    assert "slip" in r.flags and not r.valid
    assert r.diagnostics["max_slip_m"] > 0.01 * get_preset("B3M").block().width_m


@pytest.mark.parametrize("engine", ENGINES)
def test_trajectory_contract(engine):
    ad = get_adapter(engine)
    c = _case(*SPEC[engine]["trajectory"])
    tr = ad.simulate(c)
    assert isinstance(tr, Trajectory)
    assert tr.t_s[0] == 0.0 and np.all(np.diff(tr.t_s) > 0)
    assert tr.t_s.shape == tr.theta_rad.shape == tr.theta_dot_rad_s.shape
    assert tr.t_s[-1] >= c.pulse.duration_s - 1e-9 or np.max(np.abs(tr.theta_rad)) > c.block.alpha_rad
    assert set(tr.flags) <= set(FLAGS)
    json.dumps(tr.diagnostics)
    assert tr.uplift_tol_rad > 0
    # a positive table acceleration starts a negative θ
    lifted = np.flatnonzero(np.abs(tr.theta_rad) > tr.uplift_tol_rad)
    assert lifted.size and tr.theta_rad[lifted[0]] < 0
    assert isinstance(adapter_class(engine).version(), str)
    assert ad.describe()["engine"] == engine
    json.dumps(ad.resolve(c.block, c.restitution))


@pytest.mark.parametrize("engine", ENGINES)
def test_mirror_symmetry(engine):
    """ü → −ü gives θ → −θ (the model is symmetric; so must the engine's be)."""
    cell, tol, scale = SPEC[engine]["mirror"]
    ad = get_adapter(engine)
    # at the engine's benchmark step, where the tolerances were set (a calibrated map takes the time-step
    # rule's step; `rockbench check-adapter` checks the mirror there, to 2 %)
    c = _case(*cell, dt_s=ad.fixed_dt_s)
    ra, rm = ad.simulate(c), ad.simulate(_case(*cell, sign=-1.0, dt_s=ad.fixed_dt_s))
    n = min(ra.theta_rad.size, rm.theta_rad.size)
    ref = c.block.alpha_rad if scale == "alpha" else np.max(np.abs(ra.theta_rad))
    assert np.max(np.abs(ra.theta_rad[:n] + rm.theta_rad[:n])) < tol * ref
    # a positive table acceleration starts a negative θ
    i = int(np.argmax(np.abs(ra.theta_rad) > 0.05 * c.block.alpha_rad))
    assert ra.theta_rad[i] < 0
