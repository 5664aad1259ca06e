"""The MuJoCo Warp adapter with the real engine on Warp's CPU device (no GPU needed).

Kept tiny for CI: Warp's CPU device steps about 50 worlds-steps per millisecond at best and its first
kernel compile takes about a minute (then the kernel cache in ``$ROCKBENCH_CACHE/warp`` serves
it), so the cells run at Δt = 1 ms with a short tail, a few worlds per batch. Each cell lies well
inside the reference map's regions (checked against the reference in a ±10 % neighbourhood, as in
``test_mujoco.py``).
"""

from __future__ import annotations

import numpy as np
import pytest

from cells import cell_case
from end_of_run import assert_ends_by_run_end

pytest.importorskip("warp", reason="warp-lang is not installed (pip install 'rockbench[warp]')")
pytest.importorskip("mujoco_warp", reason="mujoco-warp is not installed (pip install 'rockbench[warp]')")

from rockbench.benchmark.blocks.presets import PRESETS  # noqa: E402
from rockbench.benchmark.suites.model import load_suite, suite_path
from rockbench.benchmark.suites.plan import engine_names  # noqa: E402
from rockbench.engines.adapters.mujoco_warp import MujocoWarpAdapter  # noqa: E402
from rockbench.engines.registry import adapter_class, get_adapter  # noqa: E402
from rockbench.engines.adapters.warp_start import warp_cache_dir  # noqa: E402
from rockbench.reference_solver.errors import ConfigError  # noqa: E402
from rockbench.reference_solver.restitution import housner_eta  # noqa: E402
from rockbench.engines.calibration.free_rocking import measure_restitution  # noqa: E402
from rockbench.engines.calibration.routine import calibrate  # noqa: E402

pytestmark = pytest.mark.engine

DT = 1e-3
#: explicit contact (B3M's calibrated solref at Δt 0.5 ms is 0.001 s, 1.0): no calibration needed
CONTACT = {"timeconst_s": 0.002, "dampratio": 1.0, "tail_s": 1.0, "min_tail_s": 0.3, "device": "cpu"}

#: (block, pulse, ω/p, a₀/(g·tanα), reference outcome)
CELLS = [
    ("B3M", "sine", 4.0, 0.8, "rest"),
    ("B3M", "sine", 6.0, 2.0, "rocking"),
    ("B3M", "sine", 3.0, 2.5, "overturn"),
]

#: cells near CPU MuJoCo's own boundaries at :data:`CONTACT` (ω/p 3: it overturns from a₀ 1.5 on, lifts
#: off from 1.16 on): the last rocking cell below the overturn, trapped late, and the first lift-off
NEAR = [("B3M", "sine", 3.0, 1.48), ("B3M", "sine", 3.0, 1.16)]


def _case(block_name, kind, w, a, dt=DT):
    return cell_case(block_name, kind, w, a, dt_s=dt)


@pytest.fixture(scope="module", autouse=True)
def _own_calibration_cache(tmp_path_factory):
    """Calibrations of this module's own (really run here), Warp's kernels in the shared cache."""
    kernels = warp_cache_dir()   # the session's cache: compiled once, reused by every test run
    mp = pytest.MonkeyPatch()
    mp.setenv("WARP_CACHE_PATH", kernels)
    mp.setenv("ROCKBENCH_CACHE", str(tmp_path_factory.mktemp("rockbench-cache")))
    yield
    mp.undo()


@pytest.fixture(scope="module")
def warp_results():
    """The device loop's verdicts and trajectories of :data:`CELLS` then :data:`NEAR`, one batch."""
    ad = get_adapter("mujoco_warp", **CONTACT)
    cases = [ad.posed(_case(*c[:4])) for c in CELLS + NEAR]
    return ad, cases, ad.run_many(cases), ad._simulate_many(cases)


@pytest.fixture(scope="module")
def cpu_results(warp_results):
    """CPU MuJoCo's verdicts and trajectories of the same cases (the contact base's loop, float64)."""
    cases = warp_results[1]
    cpu = get_adapter("mujoco", **{k: v for k, v in CONTACT.items() if k != "device"})
    return cpu.run_many(cases), cpu._simulate_many([cpu.posed(c) for c in cases])


def test_cells_are_far_from_the_reference_boundary():
    ref = get_adapter("reference")
    for b, k, w, a, expected in CELLS:
        res = ref.run_many([_case(b, k, w * f, a * g, None) for f in (0.9, 1.0, 1.1) for g in (0.9, 1.0, 1.1)])
        assert {r.outcome for r in res} == {expected}, (b, k, w, a)


def test_outcomes_match_the_reference_and_cpu_mujoco(warp_results, cpu_results):
    res, cpu = warp_results[2], cpu_results[0]
    for cell, r, c in zip(CELLS, res, cpu):
        assert r.status == "ok", r.message
        assert r.outcome == cell[4] == c.outcome, (cell, r.outcome, c.outcome, r.flags)
        assert r.valid, (cell, r.flags, r.diagnostics)
        assert r.diagnostics["device"] == "cpu" and r.diagnostics["precision"] == "float32"


def test_the_device_loop_ends_runs_where_cpu_mujoco_does(warp_results, cpu_results):
    """The same rule on the device (float32 states) and on the CPU (float64): each cell stops for the
    same reason at the same step, with the same outcome and impacts; the largest tilt agrees closely."""
    _, cases, res, many = warp_results
    cpu, cpu_tr = cpu_results
    for case, r, c, tr, ctr in zip(cases, res, cpu, many, cpu_tr):
        cell = (case.pulse.omega_rad_s, case.pulse.amplitude_mps2)
        assert tr.diagnostics["ended_by"] == ctr.diagnostics["ended_by"], cell
        assert tr.t_s.size == ctr.t_s.size, (cell, tr.t_s.size, ctr.t_s.size)
        assert (r.outcome, r.n_impacts, r.valid) == (c.outcome, c.n_impacts, c.valid), cell
        assert r.max_abs_theta_rad == pytest.approx(c.max_abs_theta_rad, rel=0.02, abs=1e-4), cell
    assert {tr.diagnostics["ended_by"] for tr in many} == {"overturn", "trapped"}


def test_the_device_stops_where_run_end_does(warp_results):
    """Exactly floor 1's ``run_end`` on the device's own samples: each world's last sample is the first
    the rule names (with its reason), or the run's last step when none is."""
    ad, cases, _, many = warp_results
    for case, tr in zip(cases, many):
        assert_ends_by_run_end(tr, case, DT, ad.settings["tail_s"], ad.settings["min_tail_s"])


def test_results_do_not_depend_on_the_batch(warp_results):
    ad, cases, _, many = warp_results
    # another batch: other companions, another order, and one world alone
    other = ad._simulate_many([cases[2], cases[0]])
    alone = ad._simulate_many([cases[1]])
    for k, tr in ((2, other[0]), (0, other[1]), (1, alone[0])):
        assert np.array_equal(tr.t_s, many[k].t_s)
        assert np.array_equal(tr.theta_rad, many[k].theta_rad)
        assert np.array_equal(tr.theta_dot_rad_s, many[k].theta_dot_rad_s)
        assert np.array_equal(tr.corner_x_m, many[k].corner_x_m)


def test_trajectory_contract_and_end_of_run(warp_results):
    ad, cases, res, many = warp_results
    for c, tr in zip(cases, many):
        assert tr.t_s[0] == 0.0 and np.all(np.diff(tr.t_s) > 0)
        assert tr.t_s[-1] >= tr.t_pulse_end_s
        assert tr.t_s[-1] <= tr.t_pulse_end_s + ad.settings["tail_s"] + ad.settings["segment_s"] + 1e-9
        assert tr.corner_x_m.shape == (tr.t_s.size, 2) and tr.energy_j_kg.shape == tr.t_s.shape
    # the overturn is decided early: the run stops at the sample where it became certain
    assert res[2].outcome == "overturn" and many[2].diagnostics["ended_by"] == "overturn"
    assert many[2].t_s[-1] < many[2].t_pulse_end_s + ad.settings["tail_s"]


def test_the_table_drive_poses_the_inertial_drive_s_problem(warp_results, cpu_results):
    """The table moved along u(t) (not −u): the rocking cell's θ starts on the side of the inertial
    drive's and CPU MuJoCo's table drive, its largest tilt within 2 % of theirs."""
    cases, many = warp_results[1], warp_results[3]
    i = next(i for i, c in enumerate(CELLS) if c[4] == "rocking")
    table = get_adapter("mujoco_warp", **CONTACT, drive="table").simulate(cases[i])
    cpu = get_adapter("mujoco", **{k: v for k, v in CONTACT.items() if k != "device"}, drive="table").simulate(cases[i])
    for tr in (table, cpu, many[i]):
        th = np.asarray(tr.theta_rad)
        assert th[np.argmax(np.abs(th) > tr.uplift_tol_rad)] < 0
    assert np.max(np.abs(table.theta_rad)) == pytest.approx(np.max(np.abs(many[i].theta_rad)), rel=0.02)
    assert np.max(np.abs(table.theta_rad)) == pytest.approx(np.max(np.abs(cpu.theta_rad)), rel=0.02)


def test_calibration_reaches_housner_on_b3m():
    blk = PRESETS["B3M"].block()
    target = housner_eta(blk.alpha_rad)
    ad = get_adapter("mujoco_warp", device="cpu")
    c = calibrate(ad, blk, target, dt_s=DT)
    assert abs(c.eta_measured - target) <= 0.015 * target, c.note
    assert c.settings["timeconst_s"] >= 2 * DT
    again = calibrate(get_adapter("mujoco_warp", device="cpu"), blk, target, dt_s=DT)
    assert again.to_dict() == c.to_dict()          # from the cache, not run again


def test_free_rocking_is_cpu_mujocos():
    """The free-rocking η of the same contact in both engines: float32 and a different solver path
    move it by a fraction of a per cent."""
    blk = PRESETS["B6M"].block()
    s = {"timeconst_s": 0.002, "dampratio": 1.0}
    mw = measure_restitution(get_adapter("mujoco_warp", device="cpu", **s), blk, dt_s=DT)
    mc = measure_restitution(get_adapter("mujoco", **s), blk, dt_s=DT)
    assert len(mw.etas) >= 4 and len(mc.etas) >= 4
    assert mw.eta_mean == pytest.approx(mc.eta_mean, rel=0.01)


def test_settings_are_checked():
    import warp as wp
    bad = [{"solver": "pgs"}, {"device": "tpu"}, {"iterations": 0}, {"threads": 2}, {"timeconst_s": -1.0},
           {"device": "cuda:7"}]
    if not wp.is_cuda_available():
        bad.append({"device": "cuda"})      # asked for, absent: one line, not failed cells later
    for b in bad:
        with pytest.raises(ConfigError):
            get_adapter("mujoco_warp", **b)


def test_default_suite_leaves_it_out_without_cuda_and_says_why():
    import warp as wp
    cls = adapter_class("mujoco_warp")
    assert cls is MujocoWarpAdapter
    why = cls.default_suite_exclusion()
    suite = load_suite(suite_path("default", False))
    engines, notes = engine_names(suite)
    if wp.is_cuda_available():
        assert why is None and "mujoco_warp" in engines
    else:
        assert "CUDA" in why
        assert "mujoco_warp" not in engines
        assert [n for n in notes if n.startswith("engine mujoco_warp skipped") and "CUDA" in n]
        # asked for by name it runs
        assert engine_names(suite, ["mujoco_warp"])[0] == ["mujoco_warp"]


def test_kernel_cache_is_in_rockbenchs_cache(monkeypatch, tmp_path):
    monkeypatch.delenv("WARP_CACHE_PATH", raising=False)
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path))
    assert warp_cache_dir() == str(tmp_path / "warp")


def test_drive_arrays_per_world():
    """The drive kernel's inputs: closed-form pulses by code and parameters, a record pulse by its
    row of table velocities at every step, free rocking (None) still."""
    from rockbench.engines.adapters.mujoco_warp import _KIND_CODES, _KIND_STILL, _KIND_TABLE, _drive_arrays
    from rockbench.reference_solver.pulses import RecordPulse, make_pulse

    sine = make_pulse("sine", 2.0, 10.0)
    rec = RecordPulse(np.array([0.0, 0.1, 0.2]), np.array([0.0, 1.0, 0.0]), source="test")
    kind, amp, omega, dur, row, vtab = _drive_arrays([sine, None, rec], 40, 0.005)
    assert kind.tolist() == [_KIND_CODES["sine"], _KIND_STILL, _KIND_TABLE]
    assert amp.tolist() == [2.0, 0.0, 0.0] and omega.tolist() == [10.0, 1.0, 1.0]
    assert dur.tolist() == [sine.duration_s, 0.0, rec.duration_s]
    assert row.tolist() == [0, 0, 0] and vtab.shape == (1, 41)
    np.testing.assert_array_equal(vtab[0], rec.vel(np.arange(41) * 0.005))
    assert _drive_arrays([sine], 10, 0.01)[5].shape == (1, 1)
