"""The DART adapter with the real engine (marked ``engine``; skipped when dartpy is not installed).

The contract's shared checks (check-adapter, shared settings, the CLI's one-line errors, CLI
calibration to η_H, low friction flagged slip, trajectory conventions, mirror symmetry) run for
DART in ``tests/engines/test_contract.py``; this file keeps what is DART's own, on a few cells.

What must hold: outcomes match the reference far from its boundary with both drives;
calibration reaches η_H within 1 % on B6M and 1.5 % on B3M with DART as shipped; η_M is out of reach
and the calibration says why; the planar model is mirror-exact; bad settings are a ConfigError
(CLI exit 2, one line); a tiny map runs through ``rockbench map``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from cells import cell_case

pytest.importorskip("dartpy", reason="dartpy is not installed (pip install 'rockbench[dart]')")

from rockbench.benchmark.cli.main import main  # noqa: E402
from rockbench.benchmark.blocks.presets import get_preset  # noqa: E402
from rockbench.engines.contract import CellResult  # noqa: E402
from rockbench.engines.registry import get_adapter  # noqa: E402
from rockbench.reference_solver.errors import ConfigError  # noqa: E402
from rockbench.reference_solver.model import G, Block  # noqa: E402
from rockbench.reference_solver.restitution import Restitution, housner_eta, modified_eta  # noqa: E402
from rockbench.engines.calibration.free_rocking import measure_restitution  # noqa: E402
from rockbench.engines.calibration.routine import calibrate  # noqa: E402

pytestmark = pytest.mark.engine


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    """Every test calibrates for itself: no stored calibration from elsewhere leaks in."""
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path / "cache"))


case = cell_case


#: (block, pulse, ω/p, a₀/(g·tanα)): overturn after an impact, rocking and rest, both blocks and
#: pulses, far from the reference's boundary (the cells Drake's tests check the same way)
CELLS = [
    ("B3M", "sine", 8.0, 2.0), ("B3M", "sine", 5.0, 0.7), ("B3M", "cosine", 7.0, 2.5),
    ("B6M", "sine", 4.0, 3.0), ("B6M", "cosine", 3.0, 3.0), ("B6M", "cosine", 8.0, 3.0),
]


@pytest.mark.parametrize("cell", CELLS, ids=["-".join(map(str, c)) for c in CELLS])
def test_outcome_matches_reference_with_both_drives(cell):
    ref = get_adapter("reference").run(case(*cell))
    for drive in ("inertial", "table"):
        r = get_adapter("dart", drive=drive).run(case(*cell))
        assert r.valid, (drive, r.flags)
        assert r.outcome == ref.outcome, (drive, r.outcome, ref.outcome)
        if drive == "table":
            # the kinematic table's velocity is exact at the step ends, its position off by u̇·Δt/2
            assert r.diagnostics["table_track_err_rel"] < 0.05


@pytest.mark.parametrize("name, tol", [("B3M", 0.015), ("B6M", 0.01)])
def test_calibration_to_housner_keeps_dart_as_shipped(name, tol):
    block = get_preset(name).block()
    target = housner_eta(block.alpha_rad)
    res = calibrate(get_adapter("dart"), block, target)
    assert res.reached, res.note
    assert abs(res.eta_measured - target) <= tol * target
    assert res.settings == {"collision_detector": "fcl", "split_impulse": False, "contact_restitution": 0.0}
    assert res.evaluations == 1 and "as shipped" in res.note
    # as shipped at the calibration's step (its own step is DART's 1 ms)
    m = measure_restitution(get_adapter("dart", settings="shipped"), block, dt_s=5e-4)
    assert len(m.etas) == 4 and m.eta_mean == pytest.approx(res.eta_measured, rel=1e-12)


def test_modified_eta_is_out_of_reach_and_the_note_says_why(tmp_path):
    block = get_preset("B3M").block()
    target = modified_eta(block.alpha_rad, get_preset("B3M").k_average)
    ad = get_adapter("dart")
    res = calibrate(ad, block, target)
    assert not res.reached and res.eta_measured < 0.99 * target
    assert "0.1 m/s" in res.note and "not exposed" in res.note
    assert list((tmp_path / "cache" / "calibration").glob("*.json"))
    again = calibrate(ad, block, target)
    assert again.evaluations == res.evaluations and again.settings == res.settings


def test_restitution_below_the_bounce_threshold_changes_nothing():
    # B6M's landing corner arrives at 0.07 m/s: e·v_n stays under DART's 0.1 m/s, so no bounce at all
    block = get_preset("B6M").block()
    shipped = measure_restitution(get_adapter("dart", settings="shipped"), block, dt_s=5e-4)
    bouncy = measure_restitution(get_adapter("dart", contact_restitution=1.0), block, dt_s=5e-4)
    assert bouncy.etas == shipped.etas


def test_restitution_above_the_threshold_makes_the_block_hop():
    # a large block lands fast enough (0.64 m/s) for DART to apply e = 0.6: the block leaves the table
    block = Block(0.4, 0.8, mass_kg=100.0)
    ad = get_adapter("dart", contact_restitution=0.6)
    tr, motion = ad.run_worlds(block, ad.resolve(block, Restitution()), 5e-4, [None], 0.5 * block.alpha_rad, 0.4)[0]
    assert np.max(motion.vz_m_s) > 0.3
    assert np.max(np.min(tr.corner_z_m, axis=1)) > 1e-3  # both corners above the table at once


def test_mirror_exact_in_the_plane_and_the_free_body_stays_in_the_plane():
    c, m = case("B6M", "sine", 4.0, 1.6), case("B6M", "sine", 4.0, 1.6, sign=-1.0)
    for planar in (True, False):
        a = get_adapter("dart", planar=planar)
        t1, t2 = a.simulate(c), a.simulate(m)
        assert np.max(np.abs(t1.theta_rad + t2.theta_rad)) < 1e-9 * np.max(np.abs(t1.theta_rad)), planar
    tr = get_adapter("dart", planar=False).simulate(c)
    assert tr.diagnostics["max_lateral_drift_m"] < 1e-9


def test_record_at_rest_and_speed_figures():
    c = case("B3M", "sine", 4.0, 3.0)
    tr = get_adapter("dart").simulate(c)
    b = c.block.width_m
    assert tr.corner_x_m[0] == pytest.approx([b / 2, -b / 2], abs=1e-9)
    assert tr.energy_j_kg[0] == pytest.approx(G * c.block.height_m / 2, rel=1e-9)
    # the corner spheres (0.1 mm) sink a few µm at most
    assert 0.0 <= tr.diagnostics["max_penetration_m"] < 1e-4
    assert tr.diagnostics["steps_per_cpu_s"] > 0 and tr.diagnostics["collision_detector"] == "fcl"


def test_results_do_not_depend_on_the_order_of_cells():
    a = get_adapter("dart")
    c = case("B6M", "cosine", 3.0, 2.0)
    first = a.simulate(c).theta_rad
    a.run_many([case("B3M", "sine", 1.5, 3.0), c, case("B6M", "sine", 6.0, 6.0)])
    get_adapter("dart", drive="table").simulate(c)  # another world in between
    assert np.array_equal(first, a.simulate(c).theta_rad)


def test_a_run_does_not_depend_on_the_run_before_it_on_the_same_world():
    # Bullet's collision detector (the calibrated B8M contact) kept its contact manifolds from the last
    # run on a reused world: this cell after the one before it moved by 5e-5 rad
    from rockbench.engines.adapters import dart as dart_adapter

    before, c = (cell_case("B8M", "sine", 6.0, a) for a in (1.2 + 8.8 / 7, 1.2 + 2 * 8.8 / 7))
    dart_adapter._scene.cache_clear()   # a new world: nothing ran on it
    alone = get_adapter("dart").simulate(c).theta_rad
    a = get_adapter("dart")
    a.simulate(before)
    assert np.array_equal(alone, a.simulate(c).theta_rad)


def test_engine_exception_becomes_engine_error(monkeypatch):
    from rockbench.engines.adapters import dart as da

    def broken(*args, **kwargs):
        raise RuntimeError("simulated engine failure")

    monkeypatch.setattr(da._Scene, "advance", broken)
    r = get_adapter("dart").run(case("B3M", "sine", 4.0, 3.0))
    assert isinstance(r, CellResult) and r.status == "failed" and r.flags == ["engine-error"] and not r.valid


@pytest.mark.parametrize("key, value", [
    ("collision_detector", "gjk"), ("split_impulse", "maybe"), ("contact_restitution", -0.1), ("contact_restitution", 1.5),
    ("corner_radius_m", 0.01), ("corner_radius_m", -1e-4), ("bogus", 1),
])
def test_bad_settings_are_a_config_error_and_one_cli_line(key, value, capsys):
    with pytest.raises(ConfigError):
        get_adapter("dart", **{key: value})
    assert main(["calibrate", "--engine", "dart", "--block", "B3M", "--set", f"{key}={value}"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error" in err[0]


def test_tiny_map_through_the_cli(tmp_path):
    out = tmp_path / "m"
    assert main(["map", "--engine", "dart", "--block", "B6M", "--pulse", "cosine", "--w-ratio", "2:8:3",
                 "--a-ratio", "1:5:3", "--out", str(out), "--jobs", "1", "--no-plot"]) == 0
    lines = (out / "cells.csv").read_text().splitlines()
    assert len(lines) == 1 + 9 and all("dart" in ln for ln in lines[1:])
    assert json.loads((out / "run.json").read_text())["engine"]["engine"] == "dart"


def test_a_calibration_that_keeps_the_shipped_contact_at_the_shipped_step_says_so():
    # B6L: the time-step rule's 1 ms is DART's own step, and the calibration keeps DART as shipped
    block = get_preset("B6L").block()
    res = get_adapter("dart").resolve(block, Restitution())
    assert res["calibration"]["step_rule"]["dt_s"] == 1e-3
    assert res["calibration"]["equals_shipped"] is True
    # at another step than its own it is not the engine as shipped
    assert get_adapter("dart").resolve(block, Restitution(), dt_s=5e-4)["calibration"]["equals_shipped"] is False


@pytest.mark.parametrize("engine", ["dart", "mujoco"])
def test_as_shipped_resolves_with_its_note_and_no_step_rule(engine):
    res = get_adapter(engine, settings="shipped").resolve(get_preset("B3M").block(), Restitution())
    assert "error" not in res and not (res.get("calibration") or {}).get("step_rule")
    assert ("shipped_note" in res) == (engine == "mujoco")
