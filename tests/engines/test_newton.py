"""The Newton adapter with the real engine on Warp's CPU device (no GPU needed).

Kept small: Warp's first kernel compile takes a minute or two (then the kernel cache in
``$ROCKBENCH_CACHE/warp`` serves it), and its CPU device steps one block about 1000 times a second,
so the cells use explicit settings (no calibration) and a short tail. Each cell lies well inside
the reference map's regions.
"""

from __future__ import annotations

import numpy as np
import pytest

from cells import cell_case

pytest.importorskip("warp", reason="warp-lang is not installed (pip install 'rockbench[newton]')")
pytest.importorskip("newton", reason="newton is not installed (pip install 'rockbench[newton]')")

from rockbench.benchmark.blocks.presets import PRESETS  # noqa: E402
from rockbench.engines.adapters.warp_start import warp_cache_dir  # noqa: E402
from rockbench.engines.registry import get_adapter  # noqa: E402
from rockbench.reference_solver.errors import ConfigError  # noqa: E402
from rockbench.reference_solver.restitution import housner_eta  # noqa: E402
from rockbench.engines.calibration import free_rocking, routine  # noqa: E402
from rockbench.engines.calibration.free_rocking import measure_restitution  # noqa: E402
from rockbench.engines.calibration.routine import calibrate  # noqa: E402

pytestmark = pytest.mark.engine

SHORT = {"tail_s": 0.6, "min_tail_s": 0.2}
#: XPBD as calibrated for B3M at Δt 0.5 ms would pick; given explicitly, so nothing is calibrated
XPBD = {**SHORT, "solver": "xpbd", "iterations": 2, "contact_relaxation": 0.8}
#: a penalty contact of the semi-implicit solver that rocks regularly (ke 3e4 N/m, damping ratio 0.2)
PENALTY = {**SHORT, "contact_stiffness_n_m": 3e4, "contact_damping_n_s_m": 51.1, "friction_gain_n_s_m": 108.9}
#: VBD with about the softest contact its calibration tries for B3M (1.5 × 1.28e4 N/m, Newton's damping
#: 100 N s/m; given, so nothing is calibrated)
VBD = {**SHORT, "solver": "vbd", "contact_stiffness_n_m": 2e4}

#: (ω/p, a₀/(g·tanα), reference outcome) for B3M under one sine wave
CELLS = [(4.0, 0.8, "rest"), (6.0, 2.0, "rocking"), (3.0, 2.5, "overturn")]


def _case(w, a, kind="sine", block="B3M"):
    return cell_case(block, kind, w, a)


@pytest.fixture(scope="module", autouse=True)
def _own_calibration_cache(tmp_path_factory):
    """Calibrations of this module's own, Warp's kernels in the session's shared cache."""
    mp = pytest.MonkeyPatch()
    mp.setenv("WARP_CACHE_PATH", warp_cache_dir())
    mp.setenv("ROCKBENCH_CACHE", str(tmp_path_factory.mktemp("rockbench-cache")))
    yield
    mp.undo()


@pytest.mark.parametrize("bad, words", [
    ({"solver": "mujoco"}, "'solver' must be one of xpbd, semi_implicit, featherstone, vbd"),
    ({"solver": "semi_implicit", "contact_relaxation": 0.9}, "needs solver=xpbd"),
    ({"solver": "featherstone", "iterations": 4}, "does not apply to solver=featherstone"),
    ({"iterations": 0}, "iterations"),
    ({"sticky_contacts": "maybe"}, "true or false"),
])
def test_bad_settings_are_one_line_config_errors(bad, words):
    with pytest.raises(ConfigError) as e:
        get_adapter("newton", **bad)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_xpbd_cells_match_the_reference_and_a_batch_equals_one_by_one():
    ad = get_adapter("newton", **XPBD)
    cases = [_case(w, a) for w, a, _ in CELLS]
    many = ad.run_many(cases)
    assert [r.outcome for r in many] == [o for _, _, o in CELLS]
    assert all(r.valid for r in many), [r.flags for r in many]
    for c, m in zip(cases, many):
        one = ad.run(c)
        assert (one.outcome, one.n_impacts) == (m.outcome, m.n_impacts)
        assert one.max_abs_theta_rad == m.max_abs_theta_rad   # the same kernels: bit for bit


def test_vbd_cells_match_the_reference_and_a_batch_equals_one_by_one():
    """VBD steps one world about 200 times a CPU second, so two cells (27 s with a cold kernel cache,
    its own kernels' compile included, 15 s warm)."""
    cells = [c for c in CELLS if c[2] != "rocking"]
    ad = get_adapter("newton", **VBD)
    cases = [_case(w, a) for w, a, _ in cells]
    many = ad.run_many(cases)
    assert [r.outcome for r in many] == [o for _, _, o in cells]
    assert many[0].valid, many[0].flags   # the overturning corner may hop (`jump`, docs/newton.md)
    for c, m in zip(cases, many):
        one = ad.run(c)
        assert (one.outcome, one.n_impacts, one.flags) == (m.outcome, m.n_impacts, m.flags)
        assert one.max_abs_theta_rad == m.max_abs_theta_rad   # the same kernels: bit for bit


def test_table_drive_agrees_with_the_inertial_drive():
    case = _case(6.0, 2.0)
    inertial = get_adapter("newton", **XPBD).simulate(case)
    table = get_adapter("newton", **XPBD, drive="table").simulate(case)
    n = min(len(inertial.theta_rad), len(table.theta_rad))
    assert np.max(np.abs(inertial.theta_rad[:n] - table.theta_rad[:n])) < 0.02 * PRESETS["B3M"].block().alpha_rad
    assert get_adapter("newton", **XPBD, drive="table").run(case).outcome == "rocking"


def test_xpbd_calibration_comes_within_1_5_percent_of_housner_and_says_it_is_not_reached():
    """B3M: XPBD's η levels off about 1.3 % below η_H as its contact converges (docs/newton.md)."""
    blk = PRESETS["B3M"].block()
    target = housner_eta(blk.alpha_rad)
    cal = calibrate(get_adapter("newton", solver="xpbd"), blk, target)
    assert abs(cal.eta_measured / target - 1.0) < 0.015 and cal.eta_std < 0.01
    assert not cal.reached and cal.note.startswith("not reached") and cal.settings["iterations"] >= 2


def test_semi_implicit_penalty_contact_rocks_in_the_plane():
    ad = get_adapter("newton", solver="semi_implicit", **PENALTY)
    tr = ad.simulate(_case(6.0, 2.0))
    assert tr.diagnostics["max_lateral_drift_m"] == 0.0 and tr.diagnostics["max_out_of_plane_tilt_rad"] == 0.0
    assert ad.run(_case(6.0, 2.0)).outcome == "rocking"


@pytest.mark.parametrize("drive", ["inertial", "table"])
def test_featherstone_overturns_where_it_must(drive):
    """Featherstone moves its kinematic table through the table's free joint (generalised coordinates)."""
    res = get_adapter("newton", solver="featherstone", drive=drive, **PENALTY).run(_case(3.0, 2.5))
    assert res.outcome == "overturn"


def test_vbd_search_tries_stiff_contacts_only_and_stops_at_a_regular_hit():
    """VBD's declared knobs in the one search (no engine run): stiffnesses from 1.5 × the penalty
    solvers' softest, each with kd 100, 30, 10 N s/m; it stops at the first regular one within 0.25 %."""
    from rockbench.engines.calibration.knobs import search
    from rockbench.engines.adapters.newton import _penalty_ke_min
    from rockbench.engines.calibration.pick import Candidate, pick

    blk = PRESETS["B3M"].block()
    t = housner_eta(blk.alpha_rad)
    # η rises as kd falls; the kd-30 setting of the softest stiffness hits but scatters, the stiffer one's is regular
    table = {(1.5, 100.0): (0.74, 0.005), (1.5, 30.0): (t, 0.05), (1.5, 10.0): (0.79, 0.03),
             (3.0, 100.0): (0.739, 0.002), (3.0, 30.0): (t * 1.001, 0.006)}
    ke0 = _penalty_ke_min(blk)

    def evaluate(cands):
        out = []
        for c in cands:
            eta, std = table[(round(c["contact_stiffness_n_m"] / ke0, 6), c["contact_damping_n_s_m"])]
            out.append({**c, "eta": eta, "eta_std": std, "n": 4})
        return out

    ad = get_adapter("newton", solver="vbd")
    assert ad.START_KEEP_RTOL is None
    rows = search(ad.KNOBS, blk, t, ad.fixed_dt_s, evaluate)
    assert len(rows) == 5
    p = pick([Candidate.of_row(r) for r in rows], t, blk)
    assert p.reached and p.candidate.knobs["contact_damping_n_s_m"] == 30.0
    assert p.candidate.knobs["contact_stiffness_n_m"] == pytest.approx(3 * ke0)


def test_a_calibrated_variants_free_rocking_is_measured_with_its_calibration(monkeypatch):
    """What a suite records as a variant's own η (and the report draws as the reference at it) is the
    free rocking of the settings in force: a calibrated variant's calibration, the shipped solver
    otherwise (checked here without running the engine: the settings handed to the test)."""
    block = PRESETS["B3M"].block()
    seen = {}

    def measure(ad, b, s, dt, theta0_frac=0.5):
        seen[ad.settings["settings"]] = s
        raise StopIteration

    monkeypatch.setattr(free_rocking, "free_rocking_run", measure)
    monkeypatch.setattr(routine, "calibrate", lambda ad, b, t, **kw: type("Cal", (), {
        "settings": {"contact_stiffness_n_m": 1.0e5}, "reached": True, "note": "", "eta_measured": t,
        "eta_target": t, "eta_std": 0.0, "price": None, "evaluations": 1, "sink_m": None, "hop_m": None})())
    for kind in ("calibrated", "shipped"):
        ad = get_adapter("newton", settings=kind)
        with pytest.raises(StopIteration):
            measure_restitution(ad, block)
    assert seen["calibrated"].get("contact_stiffness_n_m") == 1.0e5
    assert seen["shipped"].get("contact_stiffness_n_m") is None
