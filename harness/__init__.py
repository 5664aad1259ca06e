"""Floor 3: presets, maps, executors, the results store, scores, reports, plots and the CLI."""

# Table 1's names, handed down to the engines' ``calibrate_on`` wherever this floor runs (map workers too)
from .blocks import presets as _presets  # noqa: F401
