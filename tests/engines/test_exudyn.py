"""The Exudyn adapter with the real engine: outcomes against the reference, calibration
to Housner's η, slip detection, the two drives, the contract and bad settings.

Kept small: a handful of cells far from the stability boundary (each a fraction of a second) and
one calibration per block, shared by every test through a per-module calibration cache.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from cells import cell_case
from end_of_run import assert_ends_by_run_end

pytest.importorskip("exudyn")

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.adapters import exudyn as exudyn_adapter
from rockbench.engines.motion import steps_of_times
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution, housner_eta
from rockbench.engines.calibration.free_rocking import measure_restitution
from rockbench.engines.calibration.routine import calibrate
from rockbench.engines.calibration.time_step import step_for

pytestmark = pytest.mark.engine

#: Cells far from the reference Housner boundary: (block, pulse, ω/p, a₀/(g·tanα), outcome, impacts).
#: ``impacts`` is checked only where it defines the cell (the one-impact overturning tongue).
CELLS = [
    ("B3M", "sine", 6.0, 0.7, "rest", None),
    ("B3M", "sine", 6.0, 3.0, "rocking", None),
    ("B3M", "sine", 2.0, 2.0, "overturn", 1),       # one-impact overturning tongue
    ("B3M", "cosine", 8.0, 4.0, "rocking", None),
    ("B3M", "cosine", 2.0, 3.0, "overturn", 1),     # one-impact overturning tongue
    ("B6M", "cosine", 6.0, 5.0, "rocking", None),
    ("B6M", "cosine", 3.0, 4.0, "overturn", 1),     # one-impact overturning tongue
    ("B6M", "sine", 6.0, 0.7, "rest", None),
    ("B6M", "sine", 7.0, 4.0, "rocking", None),
]


@pytest.fixture(scope="module", autouse=True)
def _calibration_cache(tmp_path_factory):
    """One calibration cache for the module, so each block is calibrated once."""
    mp = pytest.MonkeyPatch()
    mp.setenv("ROCKBENCH_CACHE", str(tmp_path_factory.mktemp("rockbench-cache")))
    yield
    mp.undo()


@pytest.fixture(scope="module")
def exudyn():
    return get_adapter("exudyn")


@pytest.fixture(scope="module")
def exudyn_table():
    return get_adapter("exudyn", drive="table")


_case = cell_case


def _reference_outcome(case):
    return get_adapter("reference").run(case)


@pytest.mark.parametrize("block,pulse,w,a,expected,impacts", CELLS)
def test_outcome_matches_reference(exudyn, block, pulse, w, a, expected, impacts):
    case = _case(block, pulse, w, a)
    ref = _reference_outcome(case)
    assert ref.outcome == expected, "the cell list is no longer far from the reference boundary"
    res = exudyn.run(case)
    assert res.status == "ok", res.message
    assert res.outcome == ref.outcome
    assert res.valid, res.flags
    if impacts is not None:
        assert ref.n_impacts == impacts
        assert res.n_impacts == impacts


@pytest.mark.parametrize("block,pulse,w,a,expected,impacts", [c for c in CELLS if c[4] != "rest"])
def test_table_drive_agrees_with_inertial(exudyn, exudyn_table, block, pulse, w, a, expected, impacts):
    case = _case(block, pulse, w, a)
    a_in, a_tb = exudyn.run(case), exudyn_table.run(case)
    assert a_tb.status == "ok", a_tb.message
    assert (a_tb.outcome, a_tb.valid) == (a_in.outcome, a_in.valid)
    # the same physics through two routes: the peak rotation agrees (soft impacts on a moving
    # table differ slightly in the late, small rocking cycles)
    assert a_tb.max_abs_theta_rad == pytest.approx(a_in.max_abs_theta_rad, rel=0.1)


@pytest.mark.parametrize("block", ["B3M", "B6M"])
def test_calibration_reaches_housner(exudyn, block):
    b = get_preset(block).block()
    target = housner_eta(b.alpha_rad)
    cal = calibrate(exudyn, b, target)
    assert cal.reached, cal.note
    assert abs(cal.eta_measured - target) <= 0.01 * target
    assert cal.eta_std < 0.02
    # the free-rocking measurement with the calibrated settings reproduces it, impact by impact
    m = measure_restitution(exudyn, b)
    assert len(m.etas) >= 3
    assert m.eta_mean == pytest.approx(cal.eta_measured, abs=1e-9)
    # a second call is served from the cache
    assert calibrate(exudyn, b, target) == cal


def test_modified_target_is_reported_not_reached(exudyn):
    """η_M of B3M (0.8106) is out of a corner contact's reach: a finding, with the closest η.
    (The default ``contact = auto`` reaches it with the contact along the base: test_eta_m.py.)"""
    b = get_preset("B3M").block()
    target = Restitution("modified", k=get_preset("B3M").k_average).eta(b.alpha_rad)
    cal = calibrate(get_adapter("exudyn", contact="corners"), b, target)
    assert not cal.reached
    assert "not reached" in cal.note and "η" in cal.note
    assert cal.eta_measured < target


def test_free_3d_body():
    """``planar=False``: a free 3-D body on four corner spheres rocks and keeps Housner's η.

    The 3-D body is less regular than the planar one (an impact of two landing spheres can set it
    spinning about the vertical), so this checks the slender block, whose free rocking is regular.
    """
    ad3 = get_adapter("exudyn", planar=False, contact_restitution=0.6)
    b = get_preset("B6M").block()
    fr = measure_restitution(ad3, b)
    assert abs(fr.eta_mean - housner_eta(b.alpha_rad)) < 0.01 * housner_eta(b.alpha_rad)
    res = ad3.run(_case("B6M", "sine", 7.0, 4.0))
    assert res.status == "ok", res.message
    assert res.outcome == "rocking"


def test_run_ends_at_the_row_the_one_rule_names(exudyn):
    """Exudyn's rows, counted as rows at their own times: the run ends at the first row floor 1's
    rule names, early once the overturn is certain."""
    # the contract's conventions and mirror symmetry: tests/engines/test_contract.py
    ended = set()
    for w, a in ((2.0, 2.0), (6.0, 2.0)):
        case = _case("B3M", "sine", w, a)
        tr = exudyn.simulate(case)
        dt = tr.diagnostics["dt_s"]
        assert "retried_at_dt_s" not in tr.diagnostics
        ended.add(assert_ends_by_run_end(tr, case, dt, exudyn.settings["tail_s"], exudyn.settings["min_tail_s"],
                                         steps=steps_of_times(tr.t_s[1:], dt)))
        assert tr.t_s[-1] < case.pulse.duration_s + exudyn.settings["tail_s"]
    assert ended == {"overturn", "trapped"}


def test_check_steps_lie_inside_the_segments_that_hold_a_mark():
    """The steps at which Exudyn's solver tests the end-of-run rule itself: segments of 500 steps, the
    pulse's end at step 1234, the trapped rule from 4234, every 100 steps after the pulse's end."""
    assert exudyn_adapter.check_steps(1234, 4234, 31234, 500, 100) == [1234, 1334, 1434, 4034, 4134, 4234, 4334,
                                                                       4434]
    # marks on segments' ends: the loop tests there itself
    assert exudyn_adapter.check_steps(1000, 4000, 31000, 500, 100) == []


def test_stopping_inside_a_segment_keeps_the_fixed_segments_runs(exudyn, monkeypatch):
    """Where the rule fires at a check, Exudyn's solver stops inside its segment: the runs are those of
    its plain fixed segments bit for bit (an overturn after the pulse, a block trapped at the trapped
    rule's first step), with fewer steps simulated."""
    cases = [_case("B3M", "sine", w, a) for w, a in ((2.0, 1.5), (4.0, 1.5))]
    checked = [exudyn.simulate(c) for c in cases]
    monkeypatch.setattr(exudyn_adapter, "check_steps", lambda *args: [])
    plain = [exudyn.simulate(c) for c in cases]
    for a, b in zip(checked, plain):
        for key in ("t_s", "theta_rad", "theta_dot_rad_s"):
            np.testing.assert_array_equal(getattr(a, key), getattr(b, key))
        assert a.diagnostics["ended_by"] == b.diagnostics["ended_by"]
        assert a.diagnostics["steps"] < b.diagnostics["steps"]
    assert {t.diagnostics["ended_by"] for t in checked} == {"overturn", "trapped"}


def test_shipped_settings_run_the_shipped_contact():
    ad = get_adapter("exudyn", settings="shipped")
    b = get_preset("B3M").block()
    res = ad.resolve(b, Restitution())
    assert res["contact_restitution"] is None and res["contact_damping_n_s_m"] == 0.0   # Exudyn's own contact
    contact = ad._contact(b, res)
    assert contact["impact_model"] == 0 and contact["restitution_coefficient"] == 1.0
    out = ad.run(cell_case("B3M", "sine", 6.0, 0.9, dt_s=1e-4))
    assert out.status == "ok" and out.outcome == "rest"


def test_as_shipped_runs_at_exudyns_own_step_where_the_case_poses_none():
    ad = get_adapter("exudyn", settings="shipped")
    case = cell_case("B3M", "sine", 2.0, 0.9)         # a wave of 0.27 s
    assert ad.posed(case).dt_s == 1e-2 == step_for(ad, case.block, case.eta)
    # a wave shorter than 20 of Exudyn's steps is followed at 1/20 of the wave
    fast = cell_case("B3M", "sine", 16.0, 0.9)
    assert ad.posed(fast).dt_s == pytest.approx(fast.pulse.duration_s / 20)
    # at 10 ms the stand-in stiffness (a static sink of 1.34 µm) is far too stiff for the step: the
    # corner breaks through, recorded for the cell like any engine error
    out = ad.run(case)
    assert out.status == "failed" and "broke through" in out.message
    given = get_adapter("exudyn", contact_restitution=0.05)    # a contact given: the benchmark's fixed step
    assert given.posed(case).dt_s == 1e-4 == given.fixed_dt_s


@pytest.mark.parametrize("settings", [
    {"contact_stiffness_n_m": -1.0}, {"contact_restitution": 1.5}, {"spectral_radius": 2},
    {"friction_zone_m_s": 0}, {"sphere_radius_m": -1e-3}, {"contact_damping_n_s_m": -1.0},
    {"modified_newton_iterations": 0}, {"modified_newton_iterations": 2.5},
    {"modified_newton_iterations": "many"}, {"modified_newton_iterations": True},
    {"modified_newton_iterations": "5"}, {"modified_newton_iterations": None},
    {"modified_newton_iterations": float("inf")},
])
def test_bad_settings_raise_config_error(settings):
    with pytest.raises(ConfigError):
        get_adapter("exudyn", **settings)


def test_modified_newton_iterations_reach_exudyns_solver():
    b = get_preset("B3M").block()
    for given, used in ((None, 3), (8, 8), (5.0, 5)):
        ad = get_adapter("exudyn", settings="shipped",
                         **({} if given is None else {"modified_newton_iterations": given}))
        res = ad.resolve(b, Restitution())
        assert res["modified_newton_iterations"] == used
        world = ad.build(b, res, 1e-4)
        ad.start(world, b, res, 1e-4, [make_pulse("sine", 1.0, 10.0)], 0.0, 10)
        assert world.model.ss.timeIntegration.newton.maxModifiedNewtonIterations == used


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "rockbench.benchmark.cli.main", *args], capture_output=True,
                          text=True, timeout=300)


@pytest.mark.parametrize("extra", [["--set", "contact_stiffness_n_m=-5"], ["--set", "contact_restitution=2"]])
def test_cli_bad_settings_exit_2_one_line(extra):
    r = _cli("calibrate", "--engine", "exudyn", "--block", "B3M", *extra)
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert "Traceback" not in r.stderr
