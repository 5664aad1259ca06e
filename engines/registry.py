"""Engines by name: the built-in adapters plus any registered under the entry-point group
``rockbench.engines`` by a third-party package (value ``"package.module:AdapterClass"``).

Adapters are named by ``"module:Class"`` strings and imported only when asked for, so listing the
engines never imports an engine library. A plugin declares the engine contract it is written to
(``CONTRACT_VERSION``); one written to another contract is refused here, in one line naming what
changed and where docs/engines.md says how to port it (:func:`contract_refusal`).
"""

from __future__ import annotations

import difflib
import importlib
from importlib.metadata import entry_points

from rockbench.reference_solver.errors import ConfigError

from rockbench.engines.errors import EngineUnavailableError
from rockbench.engines import CONTRACT_VERSION
from rockbench.engines.support import install_command, outside_range, supported_range

#: built-in adapters, imported lazily
BUILTIN = {
    "reference": "rockbench.engines.adapters.reference:ReferenceAdapter",
    "exudyn": "rockbench.engines.adapters.exudyn:ExudynAdapter",
    "mujoco": "rockbench.engines.adapters.mujoco:MujocoAdapter",
    "mujoco_warp": "rockbench.engines.adapters.mujoco_warp:MujocoWarpAdapter",
    "pybullet": "rockbench.engines.adapters.pybullet:PybulletAdapter",
    "drake": "rockbench.engines.adapters.drake:DrakeAdapter",
    "dart": "rockbench.engines.adapters.dart:DartAdapter",
    "newton": "rockbench.engines.adapters.newton:NewtonAdapter",
    "genesis": "rockbench.engines.adapters.genesis:GenesisAdapter",
    "physx": "rockbench.engines.adapters.physx:PhysxAdapter",
}

#: where docs/engines.md says how to port an adapter written to an older contract
PORTING = "docs/engines.md#porting-an-adapter-to-contract-2"

#: what contract 1 (before contracts were declared) called its hooks and declarations, which contract 2
#: does not have: an adapter that defines one was written to contract 1
CONTRACT_1_NAMES = ("_world", "_start", "_advance", "_angles", "_motion", "_resolved_settings", "_calibrate_corners",
                    "_calibrate_distributed_n", "_validate_engine_settings", "_base_settings", "_knobs_note",
                    "_knobs_base", "_knobs_key", "_knobs_settings", "_evaluate", "_distributed_grid",
                    "_distributed_rows", "_describe_contact", "_damping_ratio", "_sample_steps", "_halted", "_retire",
                    "_trajectory", "_step_worlds", "_run", "_run_worlds", "_run_native", "run_grid", "CALIBRATION_KNOBS",
                    "CALIBRATED_SETTINGS", "MEASURED_SETTINGS", "default_dt_s", "shipped_dt_s", "distributed_contact")

#: what changed in contract 2, for the refusal of an adapter written to contract 1
CONTRACT_2_CHANGES = ("a contact engine implements four batch-shaped methods (build, start, advance, read) and "
                      "declares SHIPPED and KNOBS; settings, calibration and the time step are the base's")

#: the entry-point group third parties register under
ENTRY_POINT_GROUP = "rockbench.engines"

_extra: dict[str, str | type] = {}


def register(name: str, target) -> None:
    """Register an adapter class (or a ``"module:Class"`` string) under ``name`` for this process."""
    _extra[name] = target


def unregister(name: str) -> None:
    """Forget an adapter registered in this process (nothing happens for an unknown name)."""
    _extra.pop(name, None)


def registered() -> dict[str, str]:
    """The adapters registered in this process, as ``"module:Class"`` strings (what a worker
    process needs to register them again)."""
    return {name: f"{t.__module__}:{t.__qualname__}" if isinstance(t, type) else str(t)
            for name, t in _extra.items()}


def names() -> list[str]:
    """Every known engine name: built-in, entry points, and registered in this process."""
    eps = {ep.name for ep in entry_points(group=ENTRY_POINT_GROUP)}
    return sorted(set(BUILTIN) | eps | set(_extra))


def _target(name: str):
    if name in _extra:
        return _extra[name]
    if name in BUILTIN:
        return BUILTIN[name]
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name == name:
            return ep.value
    close = difflib.get_close_matches(name, names(), n=1)
    hint = f" Did you mean {close[0]!r}?" if close else ""
    raise ConfigError(f"unknown engine {name!r}; known engines: {', '.join(names())}.{hint}")


def adapter_class(name: str) -> type:
    """The adapter class registered under ``name`` (imports its module, not the engine).

    Raises ConfigError when the target is not a subclass of :class:`EngineAdapter` (or names no
    class in its module), when the class's ``name`` is not ``name`` (the one name of an engine: its
    entry point's, the class's, and what run.json, labels and the calibration cache record), or when
    a plugin is written to another engine contract (:func:`contract_refusal`); EngineUnavailableError
    when its module cannot be imported.
    """
    from rockbench.engines.contract import EngineAdapter  # not at import time: listing engines stays light

    target = _target(name)
    if isinstance(target, type):
        cls = target
    else:
        mod_name, _, cls_name = str(target).partition(":")
        try:
            mod = importlib.import_module(mod_name)
        except ImportError as e:
            own = str(getattr(e, "name", "") or "")
            if own == "rockbench" or own.startswith("rockbench."):
                raise ConfigError(f"engine {name!r}: its adapter module {mod_name!r} imports {own}, which this "
                                  f"rockbench does not have: the adapter is written to an older engine contract (1); "
                                  f"this rockbench runs contract {CONTRACT_VERSION} ({CONTRACT_2_CHANGES}): port it as "
                                  f"{PORTING} says.") from None
            raise EngineUnavailableError(f"engine {name!r}: cannot import its adapter {mod_name!r} ({e}).") from None
        cls = getattr(mod, cls_name, None)
        if cls is None:
            raise ConfigError(f"engine {name!r}: module {mod_name!r} has no {cls_name!r}; register it as "
                              "'module:Class'.")
    if not (isinstance(cls, type) and issubclass(cls, EngineAdapter)):
        raise ConfigError(f"engine {name!r}: {target!r} is not a subclass of rockbench.engines.contract.EngineAdapter; "
                          "an adapter must derive from it (see the contract in engines/contract.py).")
    if cls.name != name:
        raise ConfigError(f"engine {name!r}: its adapter {cls.__module__}:{cls.__qualname__} has name = {cls.name!r}; "
                          f"an engine has one name: set the class's name = {name!r}, or register it as {cls.name!r}.")
    refusal = contract_refusal(cls)
    if refusal:
        raise ConfigError(f"engine {name!r}: {refusal}")
    return cls


def declared_contract(cls: type):
    """The engine contract an adapter class declares: ``CONTRACT_VERSION`` set on it or on a class it
    derives from outside rockbench's own bases (a built-in adapter is written to this contract);
    None where nothing declares one (an adapter written before contracts were declared: contract 1)."""
    for c in cls.__mro__:
        module = getattr(c, "__module__", "")
        if module.startswith("rockbench.engines.adapters."):
            return CONTRACT_VERSION
        if "CONTRACT_VERSION" in vars(c) and not module.startswith("rockbench."):
            return vars(c)["CONTRACT_VERSION"]
    return None


def contract_refusal(cls: type) -> str | None:
    """Why an adapter class cannot run on this rockbench's engine contract, in one line naming what
    changed and where docs/engines.md says how to port it; None when it declares this contract."""
    where = f"its adapter {cls.__module__}:{cls.__qualname__}"
    declared = declared_contract(cls)
    if declared == CONTRACT_VERSION:
        return None
    if declared is None:
        old = sorted({n for c in cls.__mro__ if not c.__module__.startswith("rockbench.") for n in vars(c)}
                     & set(CONTRACT_1_NAMES))
        hooks = f"; it defines {', '.join(old)}, contract 1's" if old else ""
        return (f"{where} is written to engine contract 1 (it declares no CONTRACT_VERSION{hooks}); this rockbench "
                f"runs contract {CONTRACT_VERSION} ({CONTRACT_2_CHANGES}): port it as {PORTING} says, then declare "
                f"CONTRACT_VERSION = {CONTRACT_VERSION}.")
    return (f"{where} declares CONTRACT_VERSION = {declared!r}, an engine contract this rockbench does not know (it "
            f"runs contract {CONTRACT_VERSION}): use the rockbench the adapter was written for, or port it as "
            f"{PORTING} says.")


def get_adapter(name: str, **settings):
    """An adapter instance; raises ConfigError (bad name/settings) or EngineUnavailableError."""
    cls = adapter_class(name)
    cls.version()  # fail early, with the install hint, if the engine cannot be imported
    return cls(**settings)


def availability(name: str) -> dict:
    """``{"engine", "available", "version", "reason", "missing", "install", "install_hint", "supported",
    "outside_range"}`` for one engine: ``reason`` the whole error where it is not available, ``missing``
    the module that failed to import ("" where the adapter itself is wrong: a ConfigError), ``install``
    the command that installs it (a built-in engine's extra; else the adapter's ``install_hint``),
    ``supported`` the range rockbench declares ("" if none, :mod:`.support`: a built-in engine's extra,
    a plugin's ``SUPPORTED_VERSIONS``), ``outside_range`` a phrase when the installed version is outside
    it (else None)."""
    def rng(engine) -> dict:
        return {"supported": supported_range(engine), "outside_range": outside_range(engine)}

    cls = None
    try:
        cls = adapter_class(name)
        v = cls.version()
        return {"engine": name, "available": True, "version": v, "reason": "", "missing": "", "install": "",
                "install_hint": getattr(cls, "install_hint", ""), **rng(cls)}
    except Exception as e:  # noqa: BLE001 - reported, not raised
        hint = getattr(cls, "install_hint", "")
        target = _target(name)
        missing = ("" if isinstance(e, ConfigError) else cls.module if cls is not None and cls.module else
                   getattr(target, "__module__", str(target)).partition(":")[0])
        return {"engine": name, "available": False, "version": None, "reason": str(e), "missing": missing,
                "install": install_command(name) or hint, "install_hint": hint, **rng(cls or name)}
