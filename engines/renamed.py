"""Old names of settings and of their values, and the one function that reads settings under the new ones.

A setting or a value renamed (units in names, one name per concept, names that say what they hold) is
accepted for one release under its old spelling with a :class:`RenamedWarning`; :data:`RENAMED_SETTINGS`
and :data:`RENAMED_VALUES` are the one record of each rename, and :func:`canonical_settings` the one
place that applies them: to an adapter's settings (:class:`~rockbench.engines.contact.ContactEngineAdapter`),
to its class defaults, and to what the benchmark reads back from stored runs and cached records. An
adapter's hooks and attributes renamed warn the same way (:func:`warn_renamed`). A module of its own,
with nothing to import, so that reading a stored run does not load the engines' machinery.
"""

from __future__ import annotations

import warnings
from typing import Any, Mapping

from ..reference_solver.errors import ConfigError

__all__ = ["RENAMED_SETTINGS", "RENAMED_VALUES", "RENAMED_METHODS", "RenamedWarning", "canonical_settings",
           "canonical_changes", "warn_renamed", "adopt_renamed_methods"]


class RenamedWarning(DeprecationWarning):
    """An old name or value, accepted for one release: the command line shows each as one note."""


def warn_renamed(message: str, stacklevel: int = 2) -> None:
    """Warn (:class:`RenamedWarning`) that something was renamed; ``message`` says from what to what and
    ends in "the old ... goes in the next release." (``stacklevel`` frames above the caller)."""
    warnings.warn(message, RenamedWarning, stacklevel=stacklevel + 1)

#: Old setting names → new names, per engine (units in names; one name per concept: a contact's
#: restitution coefficient is ``contact_restitution`` in every engine). Accepted for one release with
#: a :class:`RenamedWarning`; the one place where a rename is recorded.
RENAMED_SETTINGS: Mapping[str, Mapping[str, str]] = {
    "mujoco": {"timeconst": "timeconst_s"},
    "pybullet": {"contact_stiffness": "contact_stiffness_n_m", "contact_damping": "contact_damping_n_s_m",
                 "contact_breaking_threshold": "contact_breaking_threshold_m",
                 "restitution_coef": "contact_restitution"},
    "dart": {"restitution_coeff": "contact_restitution"},
    "physx": {"restitution_coeff": "contact_restitution"},
    "exudyn": {"chunk_s": "segment_s", "max_tail_s": "tail_s", "stiffness_n_m": "contact_stiffness_n_m",
               "damping_n_s_m": "contact_damping_n_s_m"},
}

#: Old values → new values, per setting, in every engine: the engine as shipped was ``defaults``. Accepted
#: for one release with a :class:`RenamedWarning`; the one place where a value's rename is recorded.
RENAMED_VALUES: Mapping[str, Mapping[str, str]] = {
    "settings": {"defaults": "shipped"},
}


#: Old method names → new names, per base class whose subclasses may define them: a hook or an optional
#: method an adapter implements under its old name is taken under the new one for one release, with a
#: :class:`RenamedWarning` where the class is made (:func:`adopt_renamed_methods`).
RENAMED_METHODS: Mapping[str, Mapping[str, str]] = {
    "EngineAdapter": {"_run_native": "_native_verdicts", "run_grid": "solve_grid"},
    "SteppedContactAdapter": {"_run": "_trajectory", "_run_worlds": "_step_worlds"},
}


def adopt_renamed_methods(cls: type, base: str) -> None:
    """Give ``cls`` each method it defines under an old name (:data:`RENAMED_METHODS` of ``base``) under
    the new name too, with a :class:`RenamedWarning`; called when a subclass of ``base`` is made."""
    for old, new in RENAMED_METHODS[base].items():
        if old in cls.__dict__ and new not in cls.__dict__:
            warn_renamed(f"{cls.__name__}.{old} is now called {new}; the old name goes in the next release.", 3)
            setattr(cls, new, cls.__dict__[old])


def canonical_settings(engine: str | None, settings: Mapping[str, Any], *, warn: bool = False,
                       stacklevel: int = 2, stored: bool = False) -> dict:
    """``settings`` of ``engine`` with old names (:data:`RENAMED_SETTINGS`) and old values
    (:data:`RENAMED_VALUES`) replaced by the new ones: what an adapter is built with and what a stored
    run's settings are read as (its engine need not be installed). ``engine`` None: the renames every
    engine shares (the values), for settings not yet given to one engine (a suite's variants).

    Giving both an old name and its new name is a ConfigError; ``warn`` emits a :class:`RenamedWarning` per
    old name or value (user input; not for stored runs or cached records), ``stacklevel`` frames above
    the caller. ``stored``: settings a run recorded (``resolved_settings``, calibration records), where
    an old name beside its new one is a key of its own and stays as stored (Exudyn's resolved settings
    hold its model's ``stiffness_n_m`` beside the setting ``contact_stiffness_n_m``).
    """
    out = dict(settings)
    for old, new in RENAMED_SETTINGS.get(engine, {}).items():
        if old not in out:
            continue
        if new in out:
            if stored:
                continue
            raise ConfigError(f"{engine} setting {old!r} is the old name of {new!r}; give only {new!r}.")
        if warn:
            warn_renamed(f"{engine} setting {old!r} is now called {new!r}; the old name goes in the next release.",
                         stacklevel + 1)
        out[new] = out.pop(old)
    for key, values in RENAMED_VALUES.items():
        old = out.get(key)
        if isinstance(old, str) and old in values:
            if warn:
                warn_renamed(f"{key} = {old!r} is now {key} = {values[old]!r} (the same thing, a clearer name); "
                             "the old value goes in the next release.", stacklevel + 1)
            out[key] = values[old]
    return out


def canonical_changes(engine: str, settings: Mapping[str, Any]) -> str:
    """What :func:`canonical_settings` changes in ``settings``, in words: ``settings = 'defaults' → 'shipped'``."""
    new = canonical_settings(engine, settings)
    gone = [k for k in settings if k not in new]
    names = [f"{old} → {RENAMED_SETTINGS[engine][old]}" for old in gone]
    values = [f"{k} = {settings[k]!r} → {new[k]!r}" for k in settings if k in new and new[k] != settings[k]]
    return ", ".join(names + values)
