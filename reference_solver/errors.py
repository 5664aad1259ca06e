"""The root of rockbench's exceptions and the one error of bad input, for every floor.

Each floor's errors live on that floor and derive from :class:`RockbenchError`: this floor's
:class:`ConfigError` (bad user input, exit 2, raised on every floor), the engines' in
:mod:`rockbench.engines.errors` (an engine unavailable, an engine failing), the benchmark's in
:mod:`rockbench.benchmark.errors` (results that cannot be compared). Users catch them all from the
front door, ``rockbench.benchmark`` (``rb.ConfigError``; docs/architecture.md). Each subclass also
inherits the builtin it refines, so ``except ValueError`` keeps working for callers who do not know
rockbench. Messages say what was wrong, what was given and what to do.
"""

import math


class RockbenchError(Exception):
    """Base class of every error rockbench raises on purpose."""

    exit_code = 70


class ConfigError(RockbenchError, ValueError):
    """Bad user input: a size, a range, a setting, a file. The CLI exits with code 2."""

    exit_code = 2


def check_positive(name: str, value, unit: str = "", hint: str = "") -> float:
    """Return ``value`` as a float if it is finite and > 0, else raise :class:`ConfigError`.

    Parameters
    ----------
    name : str
        How the user knows the quantity (an option name such as ``--width``).
    value : float
        The value given.
    unit : str
        Unit shown in the message, e.g. ``"m"``.
    hint : str
        What to do instead; appended to the message.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} must be a number, got {value!r}.{' ' + hint if hint else ''}") from None
    if not math.isfinite(v) or v <= 0.0:
        u = f" {unit}" if unit else ""
        raise ConfigError(f"{name} must be a finite number > 0{u}, got {value!r}.{' ' + hint if hint else ''}")
    return v
