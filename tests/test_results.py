"""The one module that reads and writes run folders: one JSON writer (one NaN rule), one stamp, one reader."""

import json
import math
import re

import numpy as np
import pytest

from rockbench.benchmark.store.files import (COLUMNS, REQUIRED_COLUMNS, json_safe, read_cell_table, read_json,
                                           utc_stamp, write_json)
from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.errors import IncomparableError


def test_json_has_no_nan_so_non_finite_numbers_are_written_null(tmp_path):
    doc = {"a": math.nan, "b": [math.inf, -math.inf, 1.5], "c": np.float64("nan"), "d": np.int64(3),
           "e": np.array([0.5, np.nan]), "f": (True, None), 7: "key"}
    p = write_json(tmp_path / "sub" / "x.json", doc)
    text = p.read_text()
    assert "NaN" not in text and "Infinity" not in text and text.endswith("\n")
    assert json.loads(text) == {"a": None, "b": [None, None, 1.5], "c": None, "d": 3, "e": [0.5, None],
                                "f": [True, None], "7": "key"}
    assert json_safe(doc) == json.loads(text)        # --json prints by the same rule


def test_read_json_names_the_file_and_what_to_do(tmp_path):
    p = tmp_path / "run.json"
    p.write_text("[1, 2]")
    with pytest.raises(ConfigError, match=r"run\.json.*holds list, not a JSON object; give a new --out"):
        read_json(p, "give a new --out directory.")
    p.write_text("{not json")
    with pytest.raises(ConfigError, match="cannot read .*is it a rockbench file"):
        read_json(p)
    with pytest.raises(ConfigError, match="is a folder"):
        read_json(tmp_path)


def test_utc_stamp_is_iso_8601_with_z():
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", utc_stamp())


def test_the_stores_columns_hold_the_cli_columns_in_order():
    assert [c for c in COLUMNS if c in REQUIRED_COLUMNS] == list(REQUIRED_COLUMNS)


def test_a_foreign_cell_table_needs_the_cli_columns(tmp_path):
    p = tmp_path / "cells.csv"
    p.write_text(",".join(REQUIRED_COLUMNS[:-1]) + "\n")
    with pytest.raises(IncomparableError, match="lacks the column 'flags'"):
        read_cell_table(p)
    row = "mujoco,B3M,sine,housner,0.75,2.0,3.0,10.0,5.0,rest,0,0.0,true,"
    p.write_text(",".join(REQUIRED_COLUMNS) + "\n" + row + "\n" + row[:20])   # a torn last line is no row
    rows = read_cell_table(p)
    assert len(rows) == 1 and rows[0]["outcome"] == "rest"
