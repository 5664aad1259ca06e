"""rockbench's benchmark: how faithfully do physics engines reproduce a rigid block rocking and
overturning on a shaking table (Čeh, Jelenić et al., Engineering Review 42 (2022) 149–162)?

Floor 3 of three (:mod:`rockbench.reference_solver` < :mod:`rockbench.engines` < this package):
presets, maps, executors, the results store, scores, reports, plots and the command line. Its
top level is the notebook front door::

    import rockbench.benchmark as rb
    sim = rb.simulate("B3M", w_ratio=6, a_ratio=6.1, restitution="modified", k=0.7595)
    sim.outcome, sim.t_s, sim.theta_rad          # 'overturn', θ(t) as arrays
    ds = rb.stability_map("B3M", w_ratio=(1, 12, 40), a_ratio=(1, 10, 40))   # xarray.Dataset
    run = rb.load_run("rockbench-results/quick")                              # a finished run

``python -m rockbench.benchmark`` is the command line (the ``rockbench`` console script). Importing
this package is cheap: the solver, the engines and plotting load on first use.
"""


from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version

# the presets' names, handed down to the engines' ``calibrate_on`` wherever this floor runs (map workers too)
from rockbench.benchmark.blocks import presets as _presets  # noqa: F401

#: the exceptions a user catches, by name, and the floor each lives on (docs/architecture.md, "Errors")
ERRORS = {"RockbenchError": "rockbench.reference_solver.errors", "ConfigError": "rockbench.reference_solver.errors",
          "EngineUnavailableError": "rockbench.engines.errors", "EngineError": "rockbench.engines.errors",
          "IncomparableError": "rockbench.benchmark.errors"}

__all__ = ["__version__", "simulate", "stability_map", "load_run", "Simulation", "Run", *ERRORS]


def _version() -> str:
    try:
        return version("rockbench")
    except PackageNotFoundError:  # a source tree that was never installed
        return "0+source"


__version__ = _version()

_LAZY = {"simulate", "stability_map", "load_run", "Simulation", "Run"}


def __getattr__(name: str):
    if name in _LAZY:
        # the API pulls in numpy, numba and the engines' registry: load it on first use only
        from rockbench.benchmark import api
        return getattr(api, name)
    if name in ERRORS:
        return getattr(importlib.import_module(ERRORS[name]), name)
    raise AttributeError(f"module 'rockbench.benchmark' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | _LAZY | set(ERRORS))
