"""Where rockbench has one rule for every engine, no built-in adapter brings its own.

Each entry of :data:`ONE_RULES` is one shared rule: the one function that is it, and the names an
adapter may not define, in its classes (an override) or in its module (a copy), because defining
them would make that rule its own. An adapter that steps its own loop instead of the skeleton's
(MuJoCo Warp, on the device) is listed in :data:`OWN_LOOP` with the test that holds its loop to the
rule. Another shared rule (the calibration pick, the η reader) is one more entry of ``ONE_RULES``.
Every contact engine declares its calibration knobs, which the one search
(:func:`~rockbench.engines.knobs.search`) walks.
"""

from __future__ import annotations

import sys

import pytest

from rockbench.engines.base import EngineAdapter
from rockbench.engines.contact import ContactEngineAdapter
from rockbench.engines.knobs import Knob
from rockbench.engines.knobs import search as knob_search
from rockbench.engines.registry import BUILTIN, adapter_class
from rockbench.engines.skeleton import SteppedContactAdapter
from rockbench.reference_solver.classify import run_end

#: the shared rules: the one function, and the names no built-in adapter may define
ONE_RULES = {
    "end of a run": (run_end, ("run_end", "_stop", "_step_worlds", "_run_worlds", "_segment_end", "stop_at",
                               "_decided", "turned_back")),
    "calibration search": (knob_search, ("_calibrate_knobs", "_knob_rows", "_search", "Search", "bisection",
                                         "bracket")),
}

#: where a loop of an adapter's own would live (the skeleton's loop runs behind them)
LOOP_METHODS = ("_simulate", "_simulate_many", "_native_verdicts", "_run_native")

#: adapters with a loop of their own, and the test that checks it applies the shared rules
OWN_LOOP = {"mujoco_warp": "tests/engines/test_mujoco_warp.py::test_the_device_stops_where_run_end_does"}

#: the shared base classes, where the rules live
_BASES = (SteppedContactAdapter, ContactEngineAdapter, EngineAdapter, object)

CONTACT_ENGINES = sorted(name for name in BUILTIN if name != "reference")


def _own_classes(cls: type) -> list[type]:
    """The adapter's classes above the shared bases (its own, and an adapter it extends)."""
    return [c for c in cls.__mro__ if c not in _BASES]


@pytest.mark.parametrize("name", CONTACT_ENGINES)
def test_a_contact_engine_is_on_the_shared_skeleton(name):
    assert issubclass(adapter_class(name), SteppedContactAdapter), name


@pytest.mark.parametrize("name", CONTACT_ENGINES)
@pytest.mark.parametrize("rule", sorted(ONE_RULES))
def test_no_adapter_defines_a_shared_rule_of_its_own(name, rule):
    one, forbidden = ONE_RULES[rule]
    for c in _own_classes(adapter_class(name)):
        defined = sorted(set(vars(c)) & set(forbidden))
        assert not defined, f"{name}: {c.__qualname__} defines {defined}, the {rule} is the shared one ({one.__name__})"
        module = vars(sys.modules[c.__module__])
        copies = [k for k in forbidden if module.get(k) not in (None, one)]
        assert not copies, f"{name}: module {c.__module__} defines {copies} of its own (the {rule})"


@pytest.mark.parametrize("name", CONTACT_ENGINES)
def test_a_contact_engine_declares_its_calibration_knobs(name):
    """The one search walks an adapter's declared knobs: none generates its candidates itself."""
    knobs = adapter_class(name)().CALIBRATION_KNOBS
    assert knobs and all(isinstance(k, Knob) for k in knobs), f"{name} declares no calibration knobs"


@pytest.mark.parametrize("name", CONTACT_ENGINES)
def test_only_a_listed_adapter_runs_a_loop_of_its_own(name):
    own = sorted({m for c in _own_classes(adapter_class(name)) for m in LOOP_METHODS if m in vars(c)})
    assert not own or name in OWN_LOOP, f"{name} overrides {own}: its own loop, with no test holding it to the rules"


def test_the_listed_loops_tests_exist():
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    for name, where in OWN_LOOP.items():
        path, _, test = where.partition("::")
        assert f"def {test}(" in (root / path).read_text(encoding="utf-8"), (name, where)
