"""The benchmark's errors (floor 3): stored results that cannot be compared.

:class:`IncomparableError` derives from :class:`~rockbench.reference_solver.errors.RockbenchError` (the
root, with bad input's ``ConfigError``, on floor 1) and from ``ValueError``.
"""

from rockbench.reference_solver.errors import RockbenchError

__all__ = ["IncomparableError"]


class IncomparableError(RockbenchError, ValueError):
    """Two result sets cannot be compared (other schema or scenario). The CLI exits with code 5."""

    exit_code = 5
