"""The setting names a stored run recorded, checked against this rockbench's adapters.

A run folder records each engine's settings by name. A name this rockbench's adapter does not have
(or a ``settings`` mode other than ``calibrated`` or ``shipped``) was written by an older rockbench
under older names: :func:`stored_settings` refuses it in one line (IncomparableError, exit 5) rather
than read an old name as a new one. Both the grid of a map (:mod:`rockbench.benchmark.maps.grid`) and
the run folders (:mod:`rockbench.benchmark.store`) ask it.
"""

from __future__ import annotations

from rockbench.engines.contract import SETTINGS_MODES
from rockbench.engines.registry import adapter_class
from rockbench.reference_solver.errors import RockbenchError
from rockbench.benchmark.errors import IncomparableError

__all__ = ["stored_settings"]


def stored_settings(engine: str, settings: dict, where: str) -> dict:
    """``settings`` of ``engine`` as a stored run recorded them, checked against this rockbench's
    names: a value of ``settings`` that is not ``calibrated`` or ``shipped``, or a setting the engine's
    adapter does not have (an engine whose adapter is not installed here is not checked for names),
    is an IncomparableError (exit 5) in one line saying that ``where`` was stored under older names
    and must be computed again. Old names are never read as new ones."""
    mode, names = settings.get("settings"), _settings_of(engine)
    bad = (f"settings = {mode!r}" if mode is not None and mode not in SETTINGS_MODES else
           next((f"the setting {k!r}" for k in settings if names is not None and k not in names), None))
    if bad:
        raise IncomparableError(f"{where} names {bad}, which engine {engine!r} does not have here: it was stored by "
                                "an older rockbench under older names; compute it again with this one (a new --out "
                                "folder).")
    return dict(settings)


def _settings_of(engine: str):
    """The setting names of ``engine``'s adapter; None where the adapter cannot be loaded here."""
    try:
        return adapter_class(engine).SETTINGS
    except (RockbenchError, ImportError):
        return None
