"""The Drake adapter with the real engine (marked ``engine``; skipped when drake is not installed).

The contract's shared checks (check-adapter, shared settings, the CLI's one-line errors, CLI
calibration to η_H, low friction flagged slip, trajectory conventions, mirror symmetry) run for
Drake in ``tests/engines/test_contract.py``; this file keeps what is Drake's own.

What must hold: outcomes match the reference far from its boundary; calibration reaches
η_H within 1 % on B6M and 1.5 % on B3M; the inertial and table drives agree; the trajectory record
is the contract's (θ, θ̇, corners in the table frame, energy), results do not depend on the order of
cells; bad settings are a ConfigError (CLI exit 2, one line); ``check-adapter drake`` passes; a
tiny map runs through ``rockbench map``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from cells import cell_case

pytest.importorskip("pydrake", reason="drake is not installed (pip install 'rockbench[drake]')")

from rockbench.benchmark.cli.main import main  # noqa: E402
from rockbench.benchmark.blocks.presets import get_preset  # noqa: E402
from rockbench.engines.contract import CellResult, Trajectory  # noqa: E402
from rockbench.engines.registry import get_adapter  # noqa: E402
from rockbench.reference_solver.errors import ConfigError  # noqa: E402
from rockbench.reference_solver.model import G  # noqa: E402
from rockbench.reference_solver.restitution import Restitution, housner_eta  # noqa: E402
from rockbench.engines.calibration.free_rocking import measure_restitution  # noqa: E402
from rockbench.engines.calibration.routine import calibrate  # noqa: E402

pytestmark = pytest.mark.engine


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    """Every test calibrates for itself: no stored calibration from elsewhere leaks in."""
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path / "cache"))


case = cell_case


@pytest.fixture(scope="module")
def reference():
    return get_adapter("reference")


#: (block, pulse, ω/p, a₀/(g·tanα)): overturn after an impact (the one-impact tongue), rocking and
#: rest, both blocks and pulses; each checked to lie far from the reference's boundary
CELLS = [
    ("B3M", "sine", 8.0, 2.0), ("B3M", "sine", 5.0, 0.7), ("B3M", "cosine", 7.0, 2.5),
    ("B6M", "sine", 4.0, 3.0), ("B6M", "cosine", 3.0, 3.0), ("B6M", "cosine", 8.0, 3.0),
]


@pytest.fixture(scope="module")
def cells_cache(tmp_path_factory):
    """One calibration cache for the cells below: they share two blocks and two drives, so each
    calibration is made once for them, and none comes from outside this module."""
    return tmp_path_factory.mktemp("drake-cells-cache")


@pytest.mark.parametrize("cell", CELLS, ids=["-".join(map(str, c)) for c in CELLS])
def test_outcome_matches_reference_far_from_the_boundary(cell, reference, cells_cache, monkeypatch):
    monkeypatch.setenv("ROCKBENCH_CACHE", str(cells_cache))
    name, pulse, w, a = cell
    ref = reference.run(case(*cell))
    around = [reference.run(case(name, pulse, w * fw, a * fa)).outcome for fw in (0.85, 1.15) for fa in (0.85, 1.15)]
    assert all(o == ref.outcome for o in around), f"{cell} is not far from the reference boundary: {around}"
    for drive in ("inertial", "table"):
        r = get_adapter("drake", drive=drive).run(case(*cell))
        assert r.valid, (drive, r.flags)
        assert r.outcome == ref.outcome, (drive, r.outcome, ref.outcome, r.n_impacts, ref.n_impacts)
        if drive == "table":
            # the heavy table follows u(t): its velocity is exact at the step ends, its position
            # (semi-implicit Euler) is off by up to about ω·Δt/2 of the stroke, plus m/M_table
            assert r.diagnostics["table_track_err_rel"] < 0.05


def test_one_impact_tongue_overturns_after_an_impact(reference):
    c = case("B6M", "sine", 4.0, 3.0)
    ref, r = reference.run(c), get_adapter("drake").run(c)
    assert ref.outcome == r.outcome == "overturn"
    assert ref.n_impacts >= 1 and r.n_impacts >= 1


def test_lift_off_where_the_rigid_model_needs_it_is_flagged(reference):
    # B3M under a long, strong sine: the rigid motion needs the table to pull the block down
    c = case("B3M", "sine", 1.5, 3.0)
    ref, r = reference.run(c), get_adapter("drake").run(c)
    assert not ref.valid and "lift-required" in ref.flags
    assert r.outcome == "overturn" and ({"jump", "slip"} & set(r.flags))


# -- calibration -------------------------------------------------------------------------------

@pytest.mark.parametrize("name, tol", [("B3M", 0.015), ("B6M", 0.01)])
def test_calibration_reaches_housner(name, tol):
    block = get_preset(name).block()
    target = housner_eta(block.alpha_rad)
    res = calibrate(get_adapter("drake"), block, target)
    assert res.reached, res.note
    assert abs(res.eta_measured - target) <= tol * target
    # the measurement behind it is an impact-by-impact one, with the calibrated contact
    s = get_adapter("drake", **{k: v for k, v in res.settings.items() if v is not None})
    m = measure_restitution(s, block)
    assert len(m.etas) >= 3 and all(0.5 < e < 1.0 for e in m.etas)
    assert m.eta_mean == pytest.approx(res.eta_measured, rel=1e-9)
    # what the suites' own-η measurement gets from the adapter as configured (calibrated to η_H)
    assert measure_restitution(get_adapter("drake"), block).eta_mean == pytest.approx(res.eta_measured, rel=1e-9)


def test_higher_target_is_reached_with_a_softer_contact_and_cached(tmp_path):
    # B6M's modified η (0.947) lies above the plastic base contact's: less dissipation in a softer contact
    block = get_preset("B6M").block()
    ad = get_adapter("drake")
    first = calibrate(ad, block, 0.947)
    assert first.reached, first.note
    assert first.settings["point_stiffness_n_m"] < 1e6 and first.settings["relaxation_time_s"] is not None
    assert list((tmp_path / "cache" / "calibration").glob("*.json"))
    again = calibrate(ad, block, 0.947)
    assert again.evaluations == first.evaluations and again.settings == first.settings


def test_shipped_defaults_give_an_eta_and_no_calibration():
    ad = get_adapter("drake", settings="shipped")
    s = ad.resolve(get_preset("B6M").block(), Restitution())
    assert s["approximation"] == "lagged" and "calibration" not in s
    assert all(s[k] is None for k in ad.SHIPPED)
    m = measure_restitution(ad, get_preset("B6M").block())
    assert 0.85 < m.eta_mean < 1.0


# -- contract ----------------------------------------------------------------------------------

def test_record_sign_and_corners():
    c = case("B3M", "sine", 4.0, 3.0, dt_s=5e-4)   # posed: which step a map takes is the time-step rule's
    tr = get_adapter("drake").simulate(c)
    assert isinstance(tr, Trajectory)
    assert tr.t_s[0] == 0.0 and tr.t_s[-1] >= c.pulse.duration_s
    assert np.allclose(np.diff(tr.t_s), 5e-4)
    lifted = np.flatnonzero(np.abs(tr.theta_rad) > tr.uplift_tol_rad)
    assert lifted.size and tr.theta_rad[lifted[0]] < 0  # a positive table acceleration starts a negative θ
    assert tr.corner_x_m.shape == tr.corner_z_m.shape == (tr.t_s.size, 2)
    # at rest at t = 0: the corners at ±b/2 on the table (sunk by the contact's compliance only)
    b = c.block.width_m
    assert tr.corner_x_m[0] == pytest.approx([b / 2, -b / 2], abs=1e-9)
    assert np.all(np.abs(tr.corner_z_m[0]) < 1e-4)
    # energy per unit mass at rest: g·h/2
    assert tr.energy_j_kg[0] == pytest.approx(G * c.block.height_m / 2, rel=1e-3)
    # θ̇ is the derivative of θ
    d = np.gradient(tr.theta_rad, tr.t_s)
    assert np.median(np.abs(d - tr.theta_dot_rad_s)) < 0.02 * np.max(np.abs(tr.theta_dot_rad_s))


def test_results_do_not_depend_on_the_order_of_cells():
    a = get_adapter("drake")
    c = case("B6M", "cosine", 3.0, 2.0)
    first = a.simulate(c).theta_rad
    batch = a.run_many([case("B3M", "sine", 1.5, 3.0), c, case("B6M", "sine", 6.0, 6.0)])
    # another adapter in the same process (another diagram) in between
    get_adapter("drake", point_stiffness_n_m=3e5, relaxation_time_s=1e-3).simulate(c)
    again = a.simulate(c).theta_rad
    assert np.array_equal(first, again)
    assert batch[1].outcome == a.run(c).outcome and batch[1].n_impacts == a.run(c).n_impacts


def test_free_body_and_hydroelastic_run():
    c = case("B6M", "cosine", 3.0, 3.0)
    for settings in ({"planar": False}, {"contact": "hydroelastic", "point_stiffness_n_m": None,
                                         "hydroelastic_modulus_pa": 1e8, "relaxation_time_s": 1e-3}):
        r = get_adapter("drake", **settings).run(c)
        assert r.status == "ok" and r.outcome == "overturn", (settings, r.flags, r.message)
    tr = get_adapter("drake", planar=False).simulate(c)
    assert tr.diagnostics["max_lateral_drift_m"] < 1e-3


def test_engine_exception_becomes_engine_error(monkeypatch):
    from rockbench.engines.adapters import drake as da

    def broken(*args, **kwargs):
        raise RuntimeError("simulated engine failure")

    a = get_adapter("drake")
    monkeypatch.setattr(da.DrakeAdapter, "advance", broken)
    r = a.run(case("B3M", "sine", 4.0, 3.0))
    assert isinstance(r, CellResult) and r.status == "failed" and r.flags == ["engine-error"] and not r.valid


@pytest.mark.parametrize("settings", [
    {"settings": "tuned"}, {"drive": "mocap"}, {"contact": "mesh"}, {"approximation": "tamsi"}, {"bogus": 1},
    {"point_stiffness_n_m": -1.0}, {"relaxation_time_s": -1e-3}, {"friction": -1.0}, {"planar": "yes"},
    {"corner_radius_m": 0.01}, {"min_tail_s": 5.0},
])
def test_bad_settings_raise_config_error(settings):
    with pytest.raises(ConfigError):
        get_adapter("drake", **settings)


@pytest.mark.parametrize("argv", [
    ["calibrate", "--engine", "drake", "--block", "B3M", "--set", "point_stiffness_n_m=-5"],
    ["calibrate", "--engine", "drake", "--block", "B3M", "--set", "no_such_setting=1"],
    ["calibrate", "--engine", "drake", "--block", "B3M", "--dt", "-0.001"],
])
def test_cli_bad_settings_exit_2_with_one_line(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error" in err[0]


def test_tiny_map_through_the_cli(tmp_path):
    out = tmp_path / "m"
    assert main(["map", "--engine", "drake", "--block", "B6M", "--pulse", "cosine", "--w-ratio", "2:8:3",
                 "--a-ratio", "1:5:3", "--out", str(out), "--jobs", "1", "--no-plot"]) == 0
    lines = (out / "cells.csv").read_text().splitlines()
    assert len(lines) == 1 + 9 and all("drake" in ln for ln in lines[1:])
    assert json.loads((out / "run.json").read_text())["engine"]["engine"] == "drake"


def test_run_a_tiny_suite_with_drake_scores_and_reports_it(tmp_path):
    # the main job's path (calibration, engine maps in worker processes, scores, report) on a tiny grid
    suite = tmp_path / "tiny.toml"
    suite.write_text('[suite]\nname = "tiny"\n[grid]\nw_ratio = "2:8:4"\na_ratio = "1:5:3"\n'
                     '[cases]\nblocks = ["B6M"]\npulses = ["cosine"]\n[reference]\nrestitutions = ["housner"]\n'
                     '[engines]\nnames = ["drake"]\nvariants = [{ settings = "calibrated" }]\n'
                     '[report]\ncases = []\n')
    out = tmp_path / "out"
    assert main(["run", str(suite), "--out", str(out), "--jobs", "2"]) == 0
    doc = json.loads((out / "score.json").read_text())
    (pair,) = [p for p in doc["pairs"] if p["engine"] == "drake"]
    assert pair["scores"]["failed_cells"] == 0 and pair["scores"]["agreement"] >= 0.75
    assert "Drake 1.51.1" in (out / "report.md").read_text()


def test_results_do_not_depend_on_the_segment_length():
    # the simulator advances in segments between end-of-run tests; samples after the stop are dropped
    for c in (case("B6M", "sine", 4.0, 1.6), case("B6M", "cosine", 3.0, 3.0)):
        a = get_adapter("drake").simulate(c)
        b = get_adapter("drake", segment_s=0.037).simulate(c)
        fixed = get_adapter("drake", segment_s=0.1)
        fixed.near_segment_s = None   # fixed segments, not ending at the run's marks
        for other in (b, fixed.simulate(c)):
            assert np.array_equal(a.theta_rad, other.theta_rad) and a.diagnostics["ended_by"] == other.diagnostics["ended_by"]
