"""``python -m rockbench``: the command line, the same as the ``rockbench`` console script."""

import sys

from .benchmark.cli import main

if __name__ == "__main__":
    sys.exit(main())
