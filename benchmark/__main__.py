"""``python -m rockbench.benchmark``: the command line, the same as the ``rockbench`` console script."""

import sys

from rockbench.benchmark.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
