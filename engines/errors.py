"""The engines' errors (floor 2): an engine that cannot start, an engine that fails a case.

Both derive from :class:`~rockbench.reference_solver.errors.RockbenchError` (the root, with bad input's
``ConfigError``, on floor 1) and from the builtin they refine.
"""

from rockbench.reference_solver.errors import RockbenchError

__all__ = ["EngineUnavailableError", "EngineError"]


class EngineUnavailableError(RockbenchError, ImportError):
    """A requested engine is not installed or cannot start. The CLI exits with code 3."""

    exit_code = 3


class EngineError(RockbenchError, RuntimeError):
    """An engine raised or diverged while simulating one case (recorded per cell in maps)."""

    exit_code = 70
