"""A map on its full grid: one row per cell, simulated or inferred, as a CSV file, a tidy
``pandas.DataFrame`` or an ``xarray.Dataset``.

An adaptive map simulates only some cells of its grid (``cells.csv`` holds those) and infers the
others by its fill rule (:func:`rockbench.benchmark.maps.adaptive.fill`: a block whose four corners agree
takes their outcome). :func:`full_grid_rows` applies that rule and writes every cell of the grid,
the inferred ones marked ``filled = true`` with the outcome only (their impacts, θ and flags are
unknown, so those fields are empty). A full map has no filled cell.

pandas and xarray are optional (``pip install 'rockbench[notebook]'``); only the two converters
need them.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

from rockbench.benchmark.store.atomic import write_atomic
from rockbench.benchmark.store.files import COLUMNS
from rockbench.benchmark.store.frames import cell_text
from rockbench.benchmark.store.loading import full_grid_rows


#: The full-grid columns: cells.csv's, then ``filled`` and ``left_model``.
FULL_GRID_EXTRA = ("filled", "left_model")

#: Name of the full-grid file ``rockbench map --full-grid`` writes beside cells.csv.
FULL_GRID_FILE = "cells-full.csv"


def write_full_grid(map_dir, path=None) -> Path:
    """Write :func:`full_grid_rows` of ``map_dir`` as CSV (default ``map_dir/cells-full.csv``), atomically."""
    rows = full_grid_rows(map_dir)
    path = Path(path) if path is not None else Path(map_dir) / FULL_GRID_FILE
    cols = list(COLUMNS) + list(FULL_GRID_EXTRA)

    def write(tmp):
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(cols)
        for r in rows:
            w.writerow([cell_text(r[c]) for c in cols])
        Path(tmp).write_text(buf.getvalue())

    write_atomic(path, write)
    return path


# -- pandas and xarray ----------------------------------------------------------------------------


