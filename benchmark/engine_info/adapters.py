"""The benchmark's one door to an engine adapter: :func:`build_adapter`.

What a user writes for an engine (``--set``, a suite's variant, the notebook API, a stored run) names
blocks by the benchmark's preset names: ``calibrate_on = "sibling"`` or ``"B3M"``, the held-out check.
The engines know no names (they are a floor below the presets), so every adapter the benchmark builds
is built here, with :func:`engine_settings` turning the names into the blocks themselves
(:func:`rockbench.benchmark.blocks.presets.calibrate_on`). The settings a map records (its spec, its
variant's name) stay as written; an adapter records them so too (``describe``).

An adapter built directly from the engines' registry takes the block itself:
``get_adapter("mujoco", calibrate_on=get_preset("B3M").block())``; ``build_adapter("mujoco",
calibrate_on="B3M")`` (or ``"sibling"``) takes the name.
"""

from __future__ import annotations

from typing import Any, Mapping

from rockbench.engines.contract import EngineAdapter
from rockbench.engines.registry import get_adapter
from rockbench.benchmark.blocks.presets import calibrate_on

__all__ = ["build_adapter", "engine_settings"]


def engine_settings(engine: str, settings: Mapping[str, Any]) -> dict:
    """``settings`` of ``engine`` as the adapter takes them: a ``calibrate_on`` block name resolved among
    the presets (a ConfigError, one line, for an unknown name)."""
    out = dict(settings)
    if "calibrate_on" in out:
        out["calibrate_on"] = calibrate_on(out["calibrate_on"], engine)
    return out


def build_adapter(engine: str, **settings) -> EngineAdapter:
    """:func:`~rockbench.engines.registry.get_adapter` with the settings as written (:func:`engine_settings`)."""
    return get_adapter(engine, **engine_settings(engine, settings))
