"""Floor 3: presets, maps, executors, the results store, scores, reports, plots and the CLI."""
