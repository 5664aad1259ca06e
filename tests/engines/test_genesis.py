"""The Genesis adapter with the real engine on Genesis's CPU backend (marked ``engine``; skipped when
``genesis-world`` is not installed: it is not in the ``engines`` extra, docs/genesis.md).

Kept small: a process's first Genesis scene compiles kernels (minutes on a cold disk cache), so the
cells use explicit contact settings (no calibration) and a short tail; each lies well inside the
reference map's regions.
"""

from __future__ import annotations

import numpy as np
import pytest

from cells import cell_case

pytest.importorskip("torch", reason="torch is not installed (install torch's CPU wheel, then 'rockbench[genesis]')")
pytest.importorskip("genesis", reason="genesis-world is not installed (pip install 'rockbench[genesis]', docs/genesis.md)")

from rockbench.benchmark.blocks.presets import PRESETS  # noqa: E402
from rockbench.engines.registry import get_adapter  # noqa: E402
from rockbench.reference_solver.errors import ConfigError  # noqa: E402
from rockbench.reference_solver.model import G  # noqa: E402
from rockbench.engines.calibration.free_rocking import measure_restitution  # noqa: E402
from rockbench.engines.calibration.routine import calibrate  # noqa: E402

pytestmark = pytest.mark.engine

#: the stiffest contact Genesis allows at Δt = 0.5 ms (2·Δt): what B3M's calibration picks region
SHORT = {"tail_s": 0.6, "min_tail_s": 0.2, "timeconst_s": 0.001}

#: (ω/p, a₀/(g·tanα), reference outcome) for B3M under one sine wave
CELLS = [(4.0, 0.8, "rest"), (6.0, 2.0, "rocking"), (3.0, 2.5, "overturn")]


def _case(w, a, kind="sine", block="B3M"):
    return cell_case(block, kind, w, a)


@pytest.fixture(scope="module", autouse=True)
def _own_calibration_cache(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("ROCKBENCH_CACHE", str(tmp_path_factory.mktemp("rockbench-cache")))
    yield
    mp.undo()


@pytest.mark.parametrize("bad, words", [
    ({"timeconst_s": -1.0}, "timeconst_s"),
    ({"table_mass_ratio": 0.0}, "table_mass_ratio"),
])
def test_bad_settings_are_one_line_config_errors(bad, words):
    with pytest.raises(ConfigError) as e:
        get_adapter("genesis", **bad)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_cells_match_the_reference_and_a_batch_equals_one_by_one():
    ad = get_adapter("genesis", **SHORT)
    cases = [_case(w, a) for w, a, _ in CELLS]
    many = ad.run_many(cases)
    assert [r.outcome for r in many] == [o for _, _, o in CELLS]
    for c, m in zip(cases, many):
        one = ad.run(c)
        assert (one.outcome, one.n_impacts, one.flags) == (m.outcome, m.n_impacts, m.flags)
        assert one.max_abs_theta_rad == m.max_abs_theta_rad   # the same kernels per environment: bit for bit


def test_the_planar_chain_agrees_with_the_free_body():
    c = _case(6.0, 2.0)
    free = get_adapter("genesis", **SHORT).simulate(c)
    planar = get_adapter("genesis", planar=True, **SHORT).simulate(c)
    n = min(len(free.theta_rad), len(planar.theta_rad))
    assert np.max(np.abs(free.theta_rad[:n] - planar.theta_rad[:n])) < 0.01
    assert planar.diagnostics["max_lateral_drift_m"] == 0.0


def test_table_drive_agrees_with_the_inertial_drive():
    c = _case(6.0, 2.0)
    a = get_adapter("genesis", **SHORT).simulate(c)
    t = get_adapter("genesis", drive="table", **SHORT).simulate(c)
    n = min(len(a.theta_rad), len(t.theta_rad))
    assert np.max(np.abs(a.theta_rad[:n] - t.theta_rad[:n])) < 0.01
    assert t.diagnostics["table_track_err_rel"] < 0.05


def test_rest_state_and_free_rocking():
    c = _case(4.0, 0.8)
    tr = get_adapter("genesis", **SHORT).simulate(c)
    b = c.block.width_m
    assert tr.corner_x_m[0] == pytest.approx([b / 2, -b / 2], abs=1e-6)
    assert tr.energy_j_kg[0] == pytest.approx(G * c.block.height_m / 2, rel=1e-5)
    assert tr.diagnostics["max_lateral_drift_m"] < 1e-4
    m = measure_restitution(get_adapter("genesis", timeconst_s=0.001), c.block)
    assert len(m.etas) == 4 and 0.7 < m.eta_mean < 0.8


@pytest.mark.parametrize("name, tol", [("B3M", 0.015), ("B6M", 0.01)])
def test_calibration_reaches_housner(name, tol):
    from rockbench.reference_solver.restitution import housner_eta

    block = PRESETS[name].block()
    target = housner_eta(block.alpha_rad)
    res = calibrate(get_adapter("genesis"), block, target)
    assert res.reached, res.note
    assert abs(res.eta_measured - target) <= tol * target
    assert res.settings["timeconst_s"] < 0.01   # stiffer than Genesis as shipped
