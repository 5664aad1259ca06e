"""A script of ``tests/measurements/`` loaded by its path, for the tests of its tables, records and
command line (the scripts are run as files, not imported as a package)."""

import importlib.util
from pathlib import Path

#: the folder of the measurement scripts
MEASUREMENTS = Path(__file__).resolve().parent / "measurements"


def load_script(name: str):
    """The module of ``tests/measurements/<name>.py``, executed afresh."""
    spec = importlib.util.spec_from_file_location(name, MEASUREMENTS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
