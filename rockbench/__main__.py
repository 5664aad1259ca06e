"""``python -m rockbench``: the command line, the same as the ``rockbench`` console script."""

import sys

from .harness.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
