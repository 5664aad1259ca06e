"""One module per ``rockbench`` subcommand, each with ``register(subparsers)``."""
