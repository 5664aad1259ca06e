"""The real engines: one judge, fed by what each engine measured.

Calibrated to Housner's η, every engine must flag jump or slip where the rigid reference needs the
table to pull the block down (``lift-required``), and come back valid with the reference's outcome
where the reference is valid (no spurious energy gain from a soft contact's tilt at rest).
"""

from __future__ import annotations

import importlib.util

import pytest

from cells import cell_case

from rockbench.engines.registry import get_adapter

pytestmark = pytest.mark.engine

LIFT = [("B3M", "sine", 2.22, 4.27), ("B3M", "sine", 1.78, 9.36), ("B3L", "sine", 2.6, 6.0)]
VALID = [("B3M", "sine", 3.0, 2.5), ("B3M", "sine", 7.44, 5.27), ("B6M", "cosine", 3.0, 4.27)]
ENGINES = [pytest.param(n, marks=pytest.mark.skipif(importlib.util.find_spec(n) is None, reason=f"{n} not installed"))
           for n in ("mujoco", "pybullet", "exudyn")]


_case = cell_case


@pytest.fixture(scope="module")
def reference():
    return get_adapter("reference")


@pytest.mark.parametrize("engine", ENGINES)
def test_engines_flag_lift_off_where_the_rigid_model_needs_it(engine, reference):
    eng = get_adapter(engine)
    for cell in LIFT:
        case = _case(*cell)
        ref = reference.run(case)
        assert "lift-required" in ref.flags and not ref.valid, cell
        res = eng.run(case)
        assert res.status == "ok", (cell, res.message)
        assert {"jump", "slip"} & set(res.flags), (cell, res.flags, res.diagnostics.get("max_jump_m"))


@pytest.mark.parametrize("engine", ENGINES)
def test_engines_are_valid_where_the_reference_is(engine, reference):
    eng = get_adapter(engine)
    for cell in VALID:
        case = _case(*cell)
        ref = reference.run(case)
        assert ref.valid, cell
        res = eng.run(case)
        assert res.valid and res.flags == [], (cell, res.flags, res.diagnostics)
        assert res.outcome == ref.outcome, cell
