"""Engines by name: the built-in adapters plus any registered under the entry-point group
``rockbench.engines`` by a third-party package (value ``"package.module:AdapterClass"``).

Adapters are named by ``"module:Class"`` strings and imported only when asked for, so listing the
engines never imports an engine library.
"""

from __future__ import annotations

import difflib
import importlib
from importlib.metadata import entry_points

from ..reference_solver.errors import ConfigError, EngineUnavailableError
from .support import install_command, outside_range, supported_range

#: built-in adapters, imported lazily
BUILTIN = {
    "reference": "rockbench.engines.reference_adapter:ReferenceAdapter",
    "exudyn": "rockbench.engines.exudyn_adapter:ExudynAdapter",
    "mujoco": "rockbench.engines.mujoco_adapter:MujocoAdapter",
    "mujoco_warp": "rockbench.engines.mujoco_warp_adapter:MujocoWarpAdapter",
    "pybullet": "rockbench.engines.pybullet_adapter:PybulletAdapter",
    "drake": "rockbench.engines.drake_adapter:DrakeAdapter",
    "dart": "rockbench.engines.dart_adapter:DartAdapter",
    "newton": "rockbench.engines.newton_adapter:NewtonAdapter",
    "genesis": "rockbench.engines.genesis_adapter:GenesisAdapter",
    "physx": "rockbench.engines.physx_adapter:PhysxAdapter",
}

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
    class in its module) or when the class's ``name`` is not ``name`` (the one name of an engine: its
    entry point's, the class's, and what run.json, labels and the calibration cache record),
    EngineUnavailableError when its module cannot be imported.
    """
    from .base import EngineAdapter  # not at import time: listing engines stays light

    target = _target(name)
    if isinstance(target, type):
        cls = target
    else:
        mod_name, _, cls_name = str(target).partition(":")
        try:
            mod = importlib.import_module(mod_name)
        except ImportError as e:
            raise EngineUnavailableError(f"engine {name!r}: cannot import its adapter {mod_name!r} ({e}).") from None
        cls = getattr(mod, cls_name, None)
        if cls is None:
            raise ConfigError(f"engine {name!r}: module {mod_name!r} has no {cls_name!r}; register it as "
                              "'module:Class'.")
    if not (isinstance(cls, type) and issubclass(cls, EngineAdapter)):
        raise ConfigError(f"engine {name!r}: {target!r} is not a subclass of rockbench.engines.base.EngineAdapter; "
                          "an adapter must derive from it (see the contract in engines/base.py).")
    if cls.name != name:
        raise ConfigError(f"engine {name!r}: its adapter {cls.__module__}:{cls.__qualname__} has name = {cls.name!r}; "
                          f"an engine has one name: set the class's name = {name!r}, or register it as {cls.name!r}.")
    return cls


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
