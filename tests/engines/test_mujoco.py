"""The MuJoCo adapter with the real engine: outcomes, calibration, checks, drives, contract, errors.

Kept small for CI (about a minute on two cores): a handful of cells well inside the reference
map's regions (each test first checks that the reference gives the same outcome in a ±10 %
neighbourhood, so a cell that drifts onto the boundary fails loudly rather than silently).
"""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest

from cells import cell_case
from end_of_run import assert_ends_by_run_end

mujoco = pytest.importorskip("mujoco")

from rockbench.benchmark.cli.main import main as cli_main  # noqa: E402
from rockbench.benchmark.blocks.presets import PRESETS  # noqa: E402
from rockbench.benchmark.engine_info.adapters import build_adapter  # noqa: E402
from rockbench.engines.adapters.mujoco import MujocoAdapter  # noqa: E402
from rockbench.engines.registry import get_adapter  # noqa: E402
from rockbench.reference_solver.errors import ConfigError  # noqa: E402
from rockbench.reference_solver.restitution import Restitution, housner_eta  # noqa: E402
from rockbench.engines.calibration.free_rocking import measure_restitution  # noqa: E402
from rockbench.engines.calibration.routine import calibrate  # noqa: E402
from rockbench.benchmark.report.verdict_words import sentences

pytestmark = pytest.mark.engine

#: (block, pulse, ω/p, a₀/(g·tanα), reference outcome, one-impact overturn?)
CELLS = [
    ("B3M", "sine", 4.0, 0.8, "rest", False),
    ("B3M", "sine", 6.0, 2.0, "rocking", False),
    ("B3M", "sine", 2.0, 3.0, "overturn", False),
    ("B3M", "sine", 3.0, 2.5, "overturn", True),
    ("B3M", "cosine", 5.0, 2.5, "rocking", False),
    ("B3M", "cosine", 2.0, 2.5, "overturn", True),
    ("B6M", "cosine", 3.0, 0.8, "rest", False),
    ("B6M", "cosine", 6.0, 2.5, "rocking", False),
    ("B6M", "cosine", 3.0, 3.0, "overturn", True),
    ("B6M", "sine", 8.0, 2.0, "rocking", False),
    ("B6M", "sine", 2.0, 3.0, "overturn", False),
    ("B6M", "sine", 3.0, 2.5, "overturn", True),
]


_case = cell_case
# the cells MuJoCo runs at the benchmark's 0.5 ms, pinned: which step a calibrated map takes is the
# time-step rule's (tests/engines/test_step_rule.py)
_pinned_case = functools.partial(cell_case, dt_s=5e-4)


@pytest.fixture(scope="module", autouse=True)
def _fresh_cache(tmp_path_factory):
    """A calibration cache of this module's own, so calibrations are really run once here."""
    mp = pytest.MonkeyPatch()
    mp.setenv("ROCKBENCH_CACHE", str(tmp_path_factory.mktemp("rockbench-cache")))
    yield
    mp.undo()


@pytest.fixture(scope="module")
def reference():
    return get_adapter("reference")


@pytest.fixture(scope="module")
def inertial_results():
    cases = [_pinned_case(b, k, w, a) for b, k, w, a, _, _ in CELLS]
    return get_adapter("mujoco").run_many(cases)


def test_cells_are_far_from_the_reference_boundary(reference):
    for b, k, w, a, expected, one_impact in CELLS:
        res = reference.run_many([_case(b, k, w * f, a * g) for f in (0.9, 1.0, 1.1) for g in (0.9, 1.0, 1.1)])
        assert {r.outcome for r in res} == {expected}, (b, k, w, a)
        centre = res[4]
        if one_impact:
            assert centre.outcome == "overturn" and centre.n_impacts == 1, (b, k, w, a)


def test_outcomes_match_the_reference_with_housner(inertial_results):
    for (b, k, w, a, expected, _), r in zip(CELLS, inertial_results):
        assert r.status == "ok", r.message
        assert r.outcome == expected, (b, k, w, a, r.outcome, r.flags)
        assert r.valid, (b, k, w, a, r.flags, r.diagnostics)


def test_one_impact_overturn_has_an_impact_in_mujoco_too(inertial_results):
    for (b, k, w, a, expected, one_impact), r in zip(CELLS, inertial_results):
        if one_impact:
            assert r.outcome == "overturn" and r.n_impacts >= 1, (b, k, w, a, r.n_impacts)


def test_table_drive_agrees_with_inertial_drive(inertial_results):
    table = get_adapter("mujoco", drive="table")
    res = table.run_many([_pinned_case(b, k, w, a) for b, k, w, a, _, _ in CELLS])
    for cell, ri, rt in zip(CELLS, inertial_results, res):
        assert rt.outcome == ri.outcome, (cell, rt.outcome, ri.outcome)
        assert rt.valid, (cell, rt.flags)
        # the heavy table follows u(t) closely
        assert rt.diagnostics["table_track_err_rel"] < 0.05


@pytest.mark.parametrize("name", ["B3M", "B6M"])
def test_calibration_reaches_housner_within_one_percent(name):
    blk = PRESETS[name].block()
    target = housner_eta(blk.alpha_rad)
    c = calibrate(get_adapter("mujoco"), blk, target, dt_s=5e-4)
    assert c.reached
    assert abs(c.eta_measured - target) <= 0.01 * target
    assert c.settings["timeconst_s"] >= 2 * 5e-4
    # the calibrated settings are what free rocking then shows, impact by impact
    m = measure_restitution(get_adapter("mujoco"), blk, dt_s=5e-4)
    assert len(m.etas) >= 2
    assert m.eta_mean == pytest.approx(c.eta_measured, rel=1e-12)


def test_calibration_is_cached_and_reused():
    blk = PRESETS["B3M"].block()
    ad = get_adapter("mujoco")
    first = calibrate(ad, blk, housner_eta(blk.alpha_rad), dt_s=5e-4)
    again = calibrate(get_adapter("mujoco"), blk, housner_eta(blk.alpha_rad), dt_s=5e-4)
    assert again.to_dict() == first.to_dict()


def test_free_rocking_is_read_by_the_one_reader_with_sink_and_hop():
    # the native batch reads η as every engine does, and what the pick reads from the corners
    from rockbench.engines.calibration.free_rocking import PEAK_RATIO

    block = PRESETS["B6L"].block()
    ok = measure_restitution(MujocoAdapter(timeconst_s=0.001, dampratio=1.0), block, dt_s=5e-4)
    hops = measure_restitution(MujocoAdapter(timeconst_s=0.001, dampratio=0.5), block, dt_s=5e-4)
    assert ok.method == PEAK_RATIO.method and len(ok.etas) == 4
    assert 0.0 < ok.sink_m < 1e-5 and ok.hop_m < 1e-5
    assert hops.hop_m > 2e-4        # ζ 0.5 lets both corners rise a quarter of a millimetre


def test_batches_equal_single_runs_bit_for_bit():
    ad = get_adapter("mujoco")
    cases = [_case("B3M", "sine", 6.0, 2.0), _case("B3M", "sine", 3.0, 2.5), _case("B3M", "sine", 4.0, 0.8)]
    many = ad._simulate_many([ad.posed(c) for c in cases])
    for c, tr in zip(cases, many):
        one = ad.simulate(c)
        assert np.array_equal(one.theta_rad, tr.theta_rad)
        assert np.array_equal(one.theta_dot_rad_s, tr.theta_dot_rad_s)


@pytest.mark.parametrize("settings", ["calibrated", "shipped"])
def test_segments_that_end_at_the_marks_change_no_run(settings, monkeypatch):
    """Segments ending at each run's marks (``near_segment_s``) give every run bit for bit as fixed
    segments do: each world's solver warm start is carried across a segment's end and zeroed on the
    fixed segments' grid. The runs at the marks use two threads, every segment on the pool."""
    from rockbench.engines.adapters import mujoco as adapter_module

    cells = [(b, w, a) for b in ("B3M", "B8M") for w, a in ((6.0, 2.0), (3.0, 2.5), (4.0, 0.8), (1.5, 1.3))]
    runs = {}
    for near, threads in ((None, 1), (MujocoAdapter.near_segment_s, 2)):
        monkeypatch.setattr(adapter_module, "_THREADED_STEPS", 0 if threads > 1 else adapter_module._THREADED_STEPS)
        ad = get_adapter("mujoco", settings=settings, threads=threads)
        ad.near_segment_s = near
        cases = [ad.posed(_pinned_case(b, "sine", w, a) if settings == "calibrated" else _case(b, "sine", w, a))
                 for b, w, a in cells]
        runs[near] = ad._simulate_many(cases)
    assert MujocoAdapter.near_segment_s is not None
    (fixed, near) = runs.values()
    for a, b in zip(fixed, near):
        assert a.diagnostics["ended_by"] == b.diagnostics["ended_by"]
        assert np.array_equal(a.theta_rad, b.theta_rad) and np.array_equal(a.theta_dot_rad_s, b.theta_dot_rad_s)
    assert len({tr.diagnostics["ended_by"] for tr in fixed}) >= 2


def test_run_ends_where_the_one_rule_says():
    # the contract's conventions and mirror symmetry: tests/engines/test_contract.py
    ad = get_adapter("mujoco")
    ended = set()
    for w, a in ((6.0, 2.0), (3.0, 2.5)):
        case = _case("B3M", "sine", w, a)
        tr = ad.simulate(case)
        ended.add(assert_ends_by_run_end(tr, case, tr.diagnostics["dt_s"], ad.settings["tail_s"],
                                         ad.settings["min_tail_s"]))
        assert tr.t_s[-1] <= tr.t_pulse_end_s + ad.settings["tail_s"] + tr.diagnostics["dt_s"]
    assert ended == {"trapped", "overturn"}
    assert isinstance(MujocoAdapter.version(), str)


def test_free_3d_body_gives_the_same_outcomes():
    ad = get_adapter("mujoco", planar=False)
    cells = [CELLS[1], CELLS[2], CELLS[3]]
    res = ad.run_many([_case(b, k, w, a) for b, k, w, a, _, _ in cells])
    for (b, k, w, a, expected, _), r in zip(cells, res):
        assert r.outcome == expected, (b, k, w, a, r.outcome, r.flags)


@pytest.mark.parametrize("settings", [
    {"timeconst_s": -0.004}, {"dampratio": 0}, {"cone": "round"}, {"noslip_iterations": -2},
    {"threads": -1}, {"table_mass_ratio": 0}, {"calibrate_on": "B9X"}, {"settings": "shipped", "calibrate_on": "B3M"},
])
def test_bad_settings_raise_config_error(settings):
    with pytest.raises(ConfigError):
        get_adapter("mujoco", **settings)


@pytest.mark.parametrize("argv", [
    ["calibrate", "--engine", "mujoco", "--block", "B3M", "--set", "timeconst_s=-0.004"],
    ["calibrate", "--engine", "mujoco", "--block", "B3M", "--set", "stiffness=1e6"],
    ["calibrate", "--engine", "mujoco", "--block", "B3L", "--set", "calibrate_on=sibling"],
])
def test_cli_bad_settings_exit_2_with_one_line(argv, capsys):
    assert cli_main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err and "\n" not in err and "Traceback" not in err


def test_shipped_defaults_with_friction_10_are_flagged_not_scored():
    # MuJoCo's shipped pyramidal cone with friction 10 lets the block sink through the table and
    # gain energy: the run must come back invalid, with the checks saying why
    r = get_adapter("mujoco", settings="shipped").run(_case("B3M", "sine", 6.0, 2.0))
    assert not r.valid
    assert {"jump", "energy-gain"} <= set(r.flags)
    assert r.diagnostics["energy_gain_rel"] > 0.05


def test_a_map_calibrated_on_the_other_size_is_held_out_in_its_scores(tmp_path, capsys):
    """``calibrate_on``: B3L runs with the contact settings and the step of B3M's calibration; its
    run.json names the block, `score` counts the map as held out and says so in its own line, and the
    mapped block itself stops the map with exit 2 and one line."""
    b3m, b3l = PRESETS["B3M"].block(), PRESETS["B3L"].block()
    own = get_adapter("mujoco").resolve(b3m, Restitution())
    held = build_adapter("mujoco", calibrate_on="sibling").resolve(b3l, Restitution())
    # the block itself (run.json writes the setting as given: the block's name, not "sibling")
    assert get_adapter("mujoco", calibrate_on=b3m).resolve(b3l, Restitution()) == {**held, "calibrate_on": "B3M"}
    assert held["calibration"]["calibrated_on"] == "B3M" and "calibrated_on" not in own["calibration"]
    assert held["calibration"]["step_rule"] == own["calibration"]["step_rule"]
    assert {k: held[k] for k in ("timeconst_s", "dampratio")} == {k: own[k] for k in ("timeconst_s", "dampratio")}

    root, grid = tmp_path / "run", ["--block", "B3L", "--pulse", "sine", "--w-ratio", "2:10:3", "--a-ratio", "1:6:3"]
    assert cli_main(["map", *grid, "--out", str(root / "reference"), "--no-plot"]) == 0
    assert cli_main(["map", "--engine", "mujoco", *grid, "--set", "calibrate_on=B3M", "--serial", "--no-plot",
                     "--out", str(root / "held")]) == 0
    run = json.loads((root / "held" / "run.json").read_text())
    assert run["engine"]["resolved_settings"]["calibration"]["calibrated_on"] == "B3M"
    assert cli_main(["score", str(root)]) == 0
    doc = json.loads((root / "score.json").read_text())
    pair = next(p for p in doc["pairs"] if p["engine"] == "mujoco")
    assert pair["held_out"] and pair["calibrated_on"] == "B3M" and pair["in_sample_variant"] == "mujoco"
    assert any(t.startswith("Held-out check") for t in sentences(doc["verdict"]))
    capsys.readouterr()
    assert cli_main(["map", "--engine", "mujoco", *grid, "--set", "calibrate_on=B3L", "--out", str(tmp_path / "no")]) == 2
    err = capsys.readouterr().err.strip()
    assert "calibrate_on = B3L: that is the mapped block B3L" in err and "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "no").exists()
