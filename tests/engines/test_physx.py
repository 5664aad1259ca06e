"""The PhysX adapter with the real engine (marked ``engine``; skipped when sapien is not installed).

The contract's shared checks (check-adapter, shared settings, the CLI's one-line errors, CLI
calibration to η_H, low friction flagged slip, trajectory conventions, mirror symmetry) run for
PhysX in ``tests/engines/test_contract.py``; this file keeps what is PhysX's own, on a few cells.

What must hold: outcomes match the reference far from its boundary with both drives;
PhysX as shipped gives an η below Housner's that rises as its step shrinks, and only the PhysX step
matters (substeps or a finer benchmark step give the same motion); the calibration reaches η_H with
PGS and substeps; PGS holds the pivot corner where TGS lets it creep; restitution below the bounce threshold changes nothing; the planar model is mirror-symmetric
to float32 round-off; the free body stays in the plane; importing the engine prints no renderer
warning; a tiny map runs through ``rockbench map``.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from cells import cell_case

pytest.importorskip("sapien", reason="sapien is not installed (pip install 'rockbench[physx]')")

from rockbench.benchmark.cli.main import main  # noqa: E402
from rockbench.benchmark.blocks.presets import get_preset  # noqa: E402
from rockbench.engines.contract import CellResult  # noqa: E402
from rockbench.engines.adapters.physx import SHIPPED_CONTACT, SUBSTEPS_TRIED  # noqa: E402
from rockbench.engines.registry import get_adapter  # noqa: E402
from rockbench.reference_solver.errors import ConfigError  # noqa: E402
from rockbench.reference_solver.model import G  # noqa: E402
from rockbench.reference_solver.restitution import Restitution, housner_eta  # noqa: E402

pytestmark = pytest.mark.engine


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    """Every test calibrates for itself: no stored calibration from elsewhere leaks in."""
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path / "cache"))


case = cell_case

#: (block, pulse, ω/p, a₀/(g·tanα)): overturn, rocking and rest, both blocks and pulses, far from the
#: reference's boundary
CELLS = [("B3M", "sine", 8.0, 2.0), ("B3M", "sine", 5.0, 0.7), ("B6L", "sine", 4.0, 3.0), ("B6L", "cosine", 8.0, 3.0)]


@pytest.mark.parametrize("cell", CELLS, ids=["-".join(map(str, c)) for c in CELLS])
def test_outcome_matches_reference_with_both_drives(cell):
    ref = get_adapter("reference").run(case(*cell))
    for drive in ("inertial", "table"):
        r = get_adapter("physx", drive=drive).run(case(*cell))
        assert r.valid, (drive, r.flags)
        assert r.outcome == ref.outcome, (drive, r.outcome, ref.outcome)
        if drive == "table":
            # the kinematic table reaches its target u(t) at every PhysX step (float32 round-off)
            assert r.diagnostics["table_track_err_rel"] < 1e-5


def test_shipped_eta_is_below_housner_and_rises_as_the_step_shrinks():
    block = get_preset("B3M").block()
    eta_h = housner_eta(block.alpha_rad)
    # at the benchmark's 0.5 ms (as shipped, a case that poses no step runs at SAPIEN's own 10 ms)
    shipped = get_adapter("physx", settings="shipped").measure_restitution(block, dt_s=5e-4)
    assert len(shipped.etas) == 4 and 0.93 * eta_h < shipped.eta_mean < 0.97 * eta_h
    assert shipped.settings["substeps"] == 1 and shipped.settings["solver"] == "tgs"
    finer = get_adapter("physx", substeps=6).measure_restitution(block)
    coarser = get_adapter("physx", settings="shipped").measure_restitution(block, dt_s=1e-3)
    assert coarser.eta_mean < shipped.eta_mean < finer.eta_mean
    assert abs(finer.eta_mean - eta_h) < 0.01 * eta_h


def test_only_the_physx_step_matters():
    # 2 substeps of a 0.5 ms step and 1 of a 0.25 ms step are the same PhysX run, sampled differently
    block = get_preset("B6L").block()
    a, b = get_adapter("physx", substeps=2), get_adapter("physx", substeps=1)
    th0 = 0.5 * block.alpha_rad
    ta, _ = a.run_worlds(block, a.resolve(block, Restitution(), 5e-4), 5e-4, [None], th0, 0.5)[0]
    tb, _ = b.run_worlds(block, b.resolve(block, Restitution(), 2.5e-4), 2.5e-4, [None], th0, 0.5)[0]
    assert np.array_equal(ta.theta_rad, tb.theta_rad[::2])


def test_calibration_reaches_housner_with_substeps_and_is_cached():
    block = get_preset("B6L").block()
    target = housner_eta(block.alpha_rad)
    ad = get_adapter("physx")
    res = ad.calibrate(block, target)
    assert res.reached and abs(res.eta_measured - target) <= 0.01 * target, res.note
    assert res.settings["substeps"] in SUBSTEPS_TRIED[1:] and res.settings["solver"] == "pgs"
    assert set(res.settings) == set(SHIPPED_CONTACT)   # the whole contact: None, as shipped, but solver and substeps
    assert {k: v for k, v in res.settings.items() if v is not None} == {"solver": "pgs",
                                                                       "substeps": res.settings["substeps"]}
    assert res.evaluations == SUBSTEPS_TRIED.index(res.settings["substeps"]) + 1
    assert f"with solver pgs, substeps {res.settings['substeps']};" in res.note
    again = get_adapter("physx").calibrate(block, target)
    assert again.settings == res.settings and again.eta_measured == res.eta_measured
    resolved = ad.resolve(block, Restitution(), dt_s=5e-4)   # the calibration's step, not the step rule's
    assert resolved["substeps"] == res.settings["substeps"] and resolved["solver"] == "pgs"
    assert resolved["position_iterations"] == 10 and resolved["contact_offset_m"] == 0.01  # the rest as shipped


def test_pgs_holds_the_pivot_where_tgs_lets_it_creep():
    # B3M sine, a cell inside the rigid model's domain (no lift, no slip required at friction 10)
    c = case("B3M", "sine", 9.4375, 7.875, dt_s=5e-4)   # the benchmark's step, not SAPIEN's 10 ms
    assert get_adapter("reference").run(c).valid
    tgs = get_adapter("physx", settings="shipped").run(c)
    pgs = get_adapter("physx", settings="shipped", solver="pgs").run(c)
    assert "slip" in tgs.flags and pgs.valid, (tgs.flags, pgs.flags)
    assert pgs.diagnostics["max_slip_m"] < 0.5 * tgs.diagnostics["max_slip_m"]


def test_restitution_below_the_bounce_threshold_changes_nothing():
    # the landing corner arrives far below PhysX's 2 m/s bounce threshold
    block = get_preset("B3M").block()
    shipped = get_adapter("physx", settings="shipped").measure_restitution(block, dt_s=5e-4)
    bouncy = get_adapter("physx", contact_restitution=1.0).measure_restitution(block, dt_s=5e-4)
    assert bouncy.etas == shipped.etas


def test_mirror_and_the_free_body_stays_in_the_plane():
    c, m = case("B6L", "cosine", 8.0, 3.0), case("B6L", "cosine", 8.0, 3.0, sign=-1.0)
    for planar in (True, False):
        a = get_adapter("physx", planar=planar)
        t1, t2 = a.simulate(c), a.simulate(m)
        n = min(t1.theta_rad.size, t2.theta_rad.size)
        assert np.max(np.abs(t1.theta_rad[:n] + t2.theta_rad[:n])) < 5e-3 * c.block.alpha_rad, planar
    d = get_adapter("physx", planar=False).simulate(c).diagnostics
    assert d["max_lateral_drift_m"] < 1e-4 and d["max_out_of_plane_tilt_rad"] < 1e-3


def test_record_at_rest():
    c = case("B3M", "sine", 4.0, 3.0)
    tr = get_adapter("physx", settings="shipped").simulate(c)
    b = c.block.width_m
    assert tr.corner_x_m[0] == pytest.approx([b / 2, -b / 2], abs=1e-6)
    assert tr.energy_j_kg[0] == pytest.approx(G * c.block.height_m / 2, rel=1e-5)
    assert 0.0 <= tr.diagnostics["max_penetration_m"] < 1e-4
    assert tr.diagnostics["solver"] == "tgs" and tr.diagnostics["substeps"] == 1


def test_engine_exception_becomes_engine_error(monkeypatch):
    from rockbench.engines.adapters import physx as pa

    def broken(*args, **kwargs):
        raise RuntimeError("simulated engine failure")

    monkeypatch.setattr(pa._Worlds, "advance", broken)
    r = get_adapter("physx", settings="shipped").run(case("B3M", "sine", 4.0, 3.0))
    assert isinstance(r, CellResult) and r.status == "failed" and r.flags == ["engine-error"] and not r.valid


def test_import_prints_no_renderer_warning():
    code = ("import warnings; warnings.simplefilter('always'); from rockbench.engines.registry import get_adapter; "
            "print(get_adapter('physx').version())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() and "vulkan" not in out.stderr.lower()


@pytest.mark.parametrize("key, value", [
    ("solver", "jacobi"), ("position_iterations", 0), ("velocity_iterations", 1.5), ("substeps", 0),
    ("contact_offset_m", -0.01), ("contact_restitution", 1.5), ("bounce_threshold_m_s", 0), ("bogus", 1),
])
def test_bad_settings_are_a_config_error_and_one_cli_line(key, value, capsys):
    with pytest.raises(ConfigError):
        get_adapter("physx", **{key: value})
    assert main(["calibrate", "--engine", "physx", "--block", "B3M", "--set", f"{key}={value}"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error" in err[0]


def test_tiny_map_through_the_cli(tmp_path):
    out = tmp_path / "m"
    assert main(["map", "--engine", "physx", "--block", "B6L", "--pulse", "cosine", "--w-ratio", "2:8:3",
                 "--a-ratio", "1:5:3", "--out", str(out), "--jobs", "1", "--no-plot"]) == 0
    lines = (out / "cells.csv").read_text().splitlines()
    assert len(lines) == 1 + 9 and all("physx" in ln for ln in lines[1:])
    assert json.loads((out / "run.json").read_text())["engine"]["engine"] == "physx"
