"""Where rockbench has one rule for every engine, no built-in adapter brings its own (issue 45).

An adapter implements the contract's hooks and nothing else of the shared bases: every method, class
method and property a registered adapter's own classes define that the bases also have is listed
against the allowed set (:data:`ALLOWED`), so an adapter that overrides the settings' resolution, the
loop, the free-rocking test, the calibration or the step rule fails here, naming it. An adapter whose
loop runs on its device (MuJoCo Warp) is listed in :data:`OWN_LOOP` with the test that holds its loop
to the one end-of-run rule. Each entry of :data:`ONE_RULES` is one shared rule: the one function that
is it, and the names an adapter may not define, in its classes or its module.
"""

from __future__ import annotations

import inspect
import sys
from pathlib import Path

import pytest

from rockbench.engines.calibration.knobs import Knob
from rockbench.engines.calibration import time_step
from rockbench.engines.calibration.free_rocking import measure_restitution
from rockbench.engines.calibration.knobs import search as knob_search
from rockbench.engines.calibration.routine import calibrate
from rockbench.engines.contact import ContactEngine
from rockbench.engines.contract import EngineAdapter
from rockbench.engines.registry import BUILTIN, adapter_class
from rockbench.reference_solver.classify import run_end

#: what a contact engine may define of the bases: its four methods, the optional hooks (its settings'
#: values, a search of its own, stopping a retired world, a quiet import, where it runs, why the
#: default suite leaves it out, how many worlds a batch of given settings holds) and declarations computed from its settings (KNOBS, START_KEEP_RTOL)
CONTACT_HOOKS = frozenset({"build", "start", "advance", "read", "validate", "candidates", "retire", "load_engine",
                           "device_note", "default_suite_exclusion", "worlds_per_batch", "stop_angles", "KNOBS", "START_KEEP_RTOL"})

#: what an engine that is no contact engine may define of the base: contract items 3, 4 and 7
GENERAL_HOOKS = frozenset({"_simulate", "_simulate_many", "_native_verdicts", "solve_grid", "validate",
                           "load_engine", "device_note", "default_suite_exclusion", "measure_restitution"})

#: adapters with a loop of their own, the hooks that loop takes over, and the test that checks it
#: applies the shared rules
OWN_LOOP = {"mujoco_warp": ({"run_worlds", "measure_many", "_simulate_many", "_native_verdicts"},
                            "tests/engines/test_mujoco_warp.py::test_the_device_stops_where_run_end_does")}

#: the shared rules: the one function, and the names no built-in adapter may define (the policy that
#: is functions of the adapter, docs/engines.md's "whole public surface", among them: a method of that
#: name would be a second rule nothing calls, or one a reader takes for the rule)
ONE_RULES = {
    "end of a run": (run_end, ("run_end", "_stop", "_segment_end", "stop_at", "_decided", "turned_back")),
    "calibration search": (knob_search, ("_calibrate_knobs", "_knob_rows", "_search", "Search", "bisection",
                                         "bracket")),
    "time step": (time_step.step_for, ("step_for", "rule_step", "free_rocking_step", "dt_for", "converged_step_s")),
    "calibration": (calibrate, ("calibrate", "contact_layout", "fixed", "with_contact", "calibration_block",
                                "calibration_target", "calibration_price", "contact_price")),
    "free-rocking test": (measure_restitution, ("measure_restitution", "free_rocking_run")),
}

CONTACT_ENGINES = sorted(name for name in BUILTIN if name != "reference")


def _own_classes(cls: type) -> list[type]:
    """The adapter's classes above the shared bases (its own, and an adapter it extends)."""
    return [c for c in cls.__mro__ if c not in (ContactEngine, EngineAdapter, object)]


def allowed(name: str) -> frozenset:
    """What adapter ``name`` may define of the shared bases."""
    cls = adapter_class(name)
    base = CONTACT_HOOKS if issubclass(cls, ContactEngine) else GENERAL_HOOKS
    return base | frozenset(OWN_LOOP.get(name, (set(),))[0])


def overrides(name: str) -> dict[str, list[str]]:
    """Every method, class method, static method and property adapter ``name``'s own classes define
    that the shared bases have too: ``{class: [names]}``."""
    cls = adapter_class(name)
    bases = ContactEngine if issubclass(cls, ContactEngine) else EngineAdapter
    out = {}
    for c in _own_classes(cls):
        found = [k for k, v in vars(c).items() if hasattr(bases, k) and not k.startswith("__")
                 and (inspect.isfunction(v) or isinstance(v, (classmethod, staticmethod, property)))]
        if found:
            out[c.__qualname__] = sorted(found)
    return out


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_an_adapter_overrides_nothing_but_the_contract_s_hooks(name):
    """The override test of issue 45: every override of every registered adapter, against the allowed set."""
    extra = {c: sorted(set(ks) - allowed(name)) for c, ks in overrides(name).items()}
    extra = {c: ks for c, ks in extra.items() if ks}
    assert not extra, f"{name} overrides {extra} of the shared bases; an adapter implements the contract's hooks only"


def test_the_override_test_sees_an_override():
    class Sneaky(ContactEngine):
        CONTRACT_VERSION = 2
        name = "sneaky"

        def resolve(self, block, restitution, dt_s=None):
            return {}

    from rockbench.engines import registry
    registry.register("sneaky", Sneaky)
    try:
        assert overrides("sneaky") == {"test_the_override_test_sees_an_override.<locals>.Sneaky": ["resolve"]}
        assert "resolve" not in allowed("sneaky")
    finally:
        registry.unregister("sneaky")


@pytest.mark.parametrize("name", CONTACT_ENGINES)
def test_a_contact_engine_is_on_the_shared_base(name):
    assert issubclass(adapter_class(name), ContactEngine), name


def rules_of_its_own(cls: type, rule: str) -> list[str]:
    """What adapter class ``cls`` (its own classes and their modules) defines of shared rule ``rule``'s
    names, one line each."""
    one, forbidden = ONE_RULES[rule]
    out = []
    for c in _own_classes(cls):
        defined = sorted(set(vars(c)) & set(forbidden))
        out += [f"{c.__qualname__} defines {defined}, the {rule} is the shared one ({one.__name__})"] if defined else []
        module = vars(sys.modules[c.__module__])
        copies = [k for k in forbidden if module.get(k) not in (None, one)]
        out += [f"module {c.__module__} defines {copies} of its own (the {rule})"] if copies else []
    return out


@pytest.mark.parametrize("name", CONTACT_ENGINES)
@pytest.mark.parametrize("rule", sorted(ONE_RULES))
def test_no_adapter_defines_a_shared_rule_of_its_own(name, rule):
    assert not rules_of_its_own(adapter_class(name), rule), (name, rules_of_its_own(adapter_class(name), rule))


def test_a_method_named_after_a_policy_function_is_seen():
    """The time step, the calibration and free rocking are functions of the adapter: a method of that name is a
    rule of its own."""
    class Sneaky(ContactEngine):
        CONTRACT_VERSION = 2
        name = "sneaky"

        def step_for(self, block, eta, pulse=None, dt_s=None, restitution=None):
            return 1.0

        def contact_layout(self, block, target):
            return "corners"

    assert rules_of_its_own(Sneaky, "time step") and rules_of_its_own(Sneaky, "calibration")
    assert not rules_of_its_own(Sneaky, "free-rocking test")


@pytest.mark.parametrize("name", CONTACT_ENGINES)
def test_a_contact_engine_declares_its_calibration_knobs(name):
    """The one search walks an adapter's declared knobs: none generates its corner candidates itself."""
    knobs = adapter_class(name)().KNOBS
    assert knobs and all(isinstance(k, Knob) for k in knobs), f"{name} declares no calibration knobs"


def test_the_listed_loops_tests_exist():
    root = Path(__file__).resolve().parents[2]
    for name, (_, where) in OWN_LOOP.items():
        path, _, test = where.partition("::")
        assert f"def {test}(" in (root / path).read_text(encoding="utf-8"), (name, where)
