"""A cell's answer does not depend on what its process ran before.

A sweep's worker runs many cells one after another, in an order the scheduler picks, and a
calibration tries contact settings far from the case's own. An engine that keeps state across cases
(a process-wide parameter, a reused scene) would give a cell an answer that depends on its
neighbours in the queue: different on another machine, under another ``--jobs``, or in a test run
beside other tests (PyBullet's process-wide contact-breaking distance did, until this
test). Each engine here runs one case as shipped, then cases with every kind of setting its
calibration or its users change, then the first case again: the two answers must be identical to
the last digit.
"""

from __future__ import annotations

import importlib.util

import pytest

from cells import cell_case

from rockbench.engines.registry import get_adapter

pytestmark = pytest.mark.engine

#: engine → (its Python module, the settings run in between): each knob its calibration turns and
#: each contact its users may ask for, at a value far from the shipped one
BETWEEN = {
    "pybullet": ("pybullet", [
        {"contact_restitution": 0.7, "contact_breaking_threshold_m": 1e-4},
        {"contact_stiffness_n_m": 2e5, "contact_damping_n_s_m": 300.0},
        {"contact": "distributed", "contact_points": 9, "contact_stiffness_n_m": 2e5, "contact_damping_n_s_m": 300.0},
        {"drive": "table"}, {"planar": False}, {"solver_iterations": 5}]),
    "mujoco": ("mujoco", [
        {}, {"timeconst_s": 0.01, "dampratio": 0.5},
        {"contact": "distributed", "contact_points": 9, "timeconst_s": 0.01, "dampratio": 1.0, "solimp_d": 0.5}]),
    "dart": ("dartpy", [{"collision_detector": "ode", "split_impulse": True, "contact_restitution": 0.5}]),
    "physx": ("sapien", [{"substeps": 4, "solver": "pgs"}, {"drive": "table"}]),
    "drake": ("pydrake", [{"point_stiffness_n_m": 1e5, "hunt_crossley_dissipation_s_m": 5.0},
                          {"approximation": "sap", "relaxation_time_s": 0.01}]),
    "exudyn": ("exudyn", [{}, {"contact_restitution": 0.5},
                          {"contact": "distributed", "contact_points": 9, "contact_restitution": 0.2}]),
}

#: the cell run twice: B3M rocking under a sine wave, two impacts and no overturn, where a changed
#: contact shows in every impact
CELL = ("B3M", "sine", 3.0, 1.4)

#: the settings the cell runs at first and last: as shipped where the engine rocks there as shipped;
#: MuJoCo's shipped contact (time constant 20 ms) lets the block topple and Exudyn's breaks through
#: on this cell, so these two start from a stiffer contact of their own
HOME = {"mujoco": {"timeconst_s": 0.004}, "exudyn": {"contact_restitution": 0.2, "contact_stiffness_n_m": 1e7}}

#: the fields compared, floats to the last digit
FIELDS = ("outcome", "n_impacts", "max_abs_theta_rad", "t_overturn_s", "t_uplift_s", "valid", "flags")


def _answer(result) -> dict:
    out = {k: getattr(result, k) for k in FIELDS}
    out["steps"] = (result.diagnostics or {}).get("steps")
    return out


@pytest.mark.parametrize("engine", [
    pytest.param(name, marks=pytest.mark.skipif(importlib.util.find_spec(module) is None, reason=f"{name} not installed"))
    for name, (module, _between) in BETWEEN.items()])
def test_a_cell_does_not_carry_over_from_the_cells_before_it(engine, tmp_path, monkeypatch):
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path))
    case = cell_case(*CELL)
    home = get_adapter(engine, settings="shipped", **HOME.get(engine, {}))
    first = _answer(home.run(case))
    assert first["outcome"] == "rocking" and first["n_impacts"] >= 1, first   # the cell exercises the contact
    for settings in BETWEEN[engine][1]:
        get_adapter(engine, settings="shipped", **settings).run(case)
    assert _answer(home.run(case)) == first
