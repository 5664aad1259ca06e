"""Damaged and impossible inputs: every one gives one line on stderr naming the file and
what is wrong, and exit 2 (5 for results of another version); never exit 70, never a traceback."""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rockbench.benchmark.cli.main import main


pytestmark = pytest.mark.usefixtures("fake_engines")


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line(code, err, expected, *needles):
    assert code == expected, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err and "internal error" not in err, err
    for n in needles:
        assert n in err, err


@pytest.fixture
def run(write_map, band, tmp_path):
    """A run folder with a reference map and an engine map (hand-made, 6 × 5 cells)."""
    root = tmp_path / "run"
    write_map(root / "ref", band(6, 5, 3))
    write_map(root / "eng", band(6, 5, 3), engine="mujoco")
    return root


def _edit_json(path: Path, change) -> None:
    doc = json.loads(path.read_text())
    doc = change(doc)
    path.write_text(json.dumps(doc))


def _del(key):
    def f(d):
        del d[key]
        return d
    return f


def _set_x_n(d):
    d["spec"]["x"]["n"] = "six"
    return d


RUN_JSON = [("[]", lambda d: []), ("null", lambda d: None), ("no spec", _del("spec")), ("x.n six", _set_x_n)]


@pytest.mark.parametrize("name, change", RUN_JSON, ids=[c[0] for c in RUN_JSON])
def test_damaged_run_json(run, capsys, name, change):
    _edit_json(run / "eng" / "run.json", change)
    code, _, err = run_cli(capsys, "score", run, "--no-write")
    assert_one_line(code, err, 2, "run.json", "eng")


def _edit_cells(path: Path, col: str, value: str, line: int = 1) -> None:
    lines = path.read_text().splitlines()
    head = lines[0].split(",")
    fields = lines[line].split(",")
    fields[head.index(col)] = value
    lines[line] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("col, value, needle", [
    ("outcome", "wobble", "outcome 'wobble'"),
    ("i", "x", "i 'x'"),
    ("j", "99", "j '99'"),
    ("n_impacts", "many", "n_impacts 'many'"),
    ("status", "maybe", "status 'maybe'"),
    ("valid", "perhaps", "valid 'perhaps'"),
    ("max_abs_theta_rad", "big", "max_abs_theta_rad 'big'"),
])
def test_damaged_cells_csv_field(run, capsys, col, value, needle):
    _edit_cells(run / "eng" / "cells.csv", col, value, line=3)
    code, _, err = run_cli(capsys, "score", run, "--no-write")
    assert_one_line(code, err, 2, "cells.csv", "line 4", needle)


def test_cells_csv_not_utf8_or_a_folder(run, tmp_path, capsys):
    p = run / "eng" / "cells.csv"
    p.write_bytes(p.read_bytes() + b"\xff\xfe,\xfa\n")
    code, _, err = run_cli(capsys, "score", run, "--no-write")
    assert_one_line(code, err, 2, "cells.csv", "UTF-8")
    p.unlink()
    p.mkdir()
    code, _, err = run_cli(capsys, "score", run, "--no-write")
    assert_one_line(code, err, 2, "cells.csv", "folder")


def test_cells_csv_with_a_byte_order_mark_is_read(run, capsys):
    """A spreadsheet that saved cells.csv with a BOM did not make it "another version"."""
    p = run / "eng" / "cells.csv"
    code, before, err = run_cli(capsys, "score", run, "--no-write", "--json")
    assert code == 0, err
    p.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    code, after, err = run_cli(capsys, "score", run, "--no-write", "--json")
    assert code == 0, err
    strip = lambda out: [{k: v for k, v in q.items() if k != "cells"} | {"scores": q["scores"]}
                         for q in json.loads(out)["pairs"]]
    assert strip(after) == strip(before)


def test_results_of_another_version_exit_5(write_map, band, run, capsys):
    _edit_json(run / "eng" / "run.json", lambda d: {**d, "schema_version": 99})
    code, _, err = run_cli(capsys, "score", run, "--no-write")
    assert_one_line(code, err, 5, "schema")
    write_map(run / "eng", band(6, 5, 3), engine="mujoco")
    p = run / "eng" / "cells.csv"
    p.write_text(p.read_text().replace("engine,", "engine_name,", 1))
    code, _, err = run_cli(capsys, "score", run, "--no-write")
    assert_one_line(code, err, 5, "another version")


@pytest.mark.parametrize("what", ["no pairs", "pairs text", "empty pair", "score text", "a list"])
def test_damaged_score_json(run, capsys, what):
    assert run_cli(capsys, "score", run)[0] == 0
    good = run / "score.json"
    bad = run.parent / "bad.json"
    doc = json.loads(good.read_text())
    if what == "no pairs":
        del doc["pairs"]
    elif what == "pairs text":
        doc["pairs"] = "x"
    elif what == "empty pair":
        doc["pairs"] = [{}]
    elif what == "score text":
        doc["pairs"][0]["scores"]["agreement"] = "high"
    else:
        doc = [doc]
    bad.write_text(json.dumps(doc))
    code, _, err = run_cli(capsys, "compare", bad, good)
    assert_one_line(code, err, 2, "bad.json")


def test_binary_pulse_and_suite_files(tmp_path, capsys):
    rec = tmp_path / "rec.csv"
    rec.write_bytes(b"\xff\xfe\x00\x01\x02")
    code, _, err = run_cli(capsys, "simulate", "--block", "B3M", "--pulse", rec)
    assert_one_line(code, err, 2, "rec.csv", "UTF-8")
    rec.write_bytes(b"t_s,accel_mps2\n0,\x00\x01\n")
    code, _, err = run_cli(capsys, "simulate", "--block", "B3M", "--pulse", rec)
    assert_one_line(code, err, 2, "rec.csv", "binary")
    suite = tmp_path / "s.toml"
    suite.write_bytes(b"\xff\xfe[grid]")
    code, _, err = run_cli(capsys, "run", suite, "--plan")
    assert_one_line(code, err, 2, "s.toml", "UTF-8")


def test_unwritable_outputs(run, tmp_path, capsys):
    m = ["map", "--engine", "analytic", "--block", "B6M", "--w-ratio", "1:5:3", "--a-ratio", "1:4:3", "--no-plot"]
    code, _, err = run_cli(capsys, *m, "--out", "/proc/rockbench-test")
    assert_one_line(code, err, 2, "/proc/rockbench-test")
    code, _, err = run_cli(capsys, *m, "--out", "/sys/rockbench-test")
    assert_one_line(code, err, 2, "/sys/rockbench-test")
    long = tmp_path / ("x" * 300)
    code, _, err = run_cli(capsys, *m, "--out", long)
    assert_one_line(code, err, 2, "too long")
    assert not any(p.name.startswith("x") for p in tmp_path.iterdir())
    (tmp_path / "folder").mkdir()
    code, _, err = run_cli(capsys, "score", run, "--out", tmp_path / "folder")
    assert_one_line(code, err, 2, "folder")
    code, _, err = run_cli(capsys, "simulate", "--block", "B3M", "--w-ratio", "6", "--a-ratio", "6.1",
                           "--plot", "/proc/rockbench-test.png")
    assert_one_line(code, err, 2, "/proc/rockbench-test.png")
    code, _, err = run_cli(capsys, "report", run, "--out", "/proc/rockbench-test", "--no-trajectories")
    assert_one_line(code, err, 2, "/proc/rockbench-test")
    code, _, err = run_cli(capsys, "run", "--quick", "--out", long)
    assert_one_line(code, err, 2, "too long")


def test_immutable_folder(tmp_path, capsys):
    d = tmp_path / "frozen"
    d.mkdir()
    if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", str(d)], capture_output=True).returncode:
        pytest.skip("chattr +i is not available here")
    try:
        code, _, err = run_cli(capsys, "map", "--engine", "analytic", "--block", "B6M", "--w-ratio", "1:5:3",
                               "--a-ratio", "1:4:3", "--no-plot", "--out", d / "m")
        assert_one_line(code, err, 2, str(d))
    finally:
        subprocess.run(["chattr", "-i", str(d)])


@pytest.mark.parametrize("err_no, needle", [(errno.ENOSPC, "No space left"), (errno.EROFS, "Read-only")])
def test_a_full_disk_or_read_only_file_system_mid_write(run, capsys, monkeypatch, err_no, needle):
    """The file system refuses the write after every check passed (it filled up meanwhile)."""
    import rockbench.benchmark.store.atomic as atomic

    def refuse(src, dst):
        raise OSError(err_no, os.strerror(err_no), str(src), None, str(dst))
    monkeypatch.setattr(atomic.os, "replace", refuse)
    code, _, err = run_cli(capsys, "score", run)
    assert_one_line(code, err, 2, needle, "score.json")
    assert [p.name for p in run.iterdir() if p.name.endswith(".tmp")] == []


def test_scheduler_port_out_of_range(tmp_path, capsys):
    code, _, err = run_cli(capsys, "map", "--engine", "analytic", "--block", "B6M", "--w-ratio", "1:5:3",
                           "--a-ratio", "1:4:3", "--out", tmp_path / "m", "--scheduler", "tcp://127.0.0.1:99999")
    assert_one_line(code, err, 2, "99999", "port")


def test_map_into_a_damaged_run_directory(tmp_path, capsys):
    m = ["map", "--engine", "analytic", "--block", "B6M", "--w-ratio", "1:5:3", "--a-ratio", "1:4:3", "--no-plot",
         "--serial", "--out", tmp_path / "m"]
    assert run_cli(capsys, *m)[0] == 0
    (tmp_path / "m" / "run.json").write_text("[]")
    code, _, err = run_cli(capsys, *m)
    assert_one_line(code, err, 2, "run.json")


def test_failed_resume_checks_cells_csv_before_writing(tmp_path, capsys):
    m = ["map", "--engine", "analytic", "--block", "B6M", "--w-ratio", "1:5:3", "--a-ratio", "1:4:3", "--no-plot",
         "--serial", "--out", tmp_path / "m"]
    assert run_cli(capsys, *m)[0] == 0
    _edit_cells(tmp_path / "m" / "cells.csv", "outcome", "wobble", line=2)
    before = {p.name: p.read_bytes() for p in (tmp_path / "m").iterdir() if p.is_file()}
    code, _, err = run_cli(capsys, *m)
    assert_one_line(code, err, 2, "cells.csv", "line 3")
    after = {p.name: p.read_bytes() for p in (tmp_path / "m").iterdir() if p.is_file()}
    assert after == before     # run.json keeps its summary and its runs: nothing was written


# -- fuzzing: any damage to a field of cells.csv or a value of run.json is exit 0, 2 or 5 --------------

_VALUES = st.one_of(st.text(max_size=8), st.sampled_from(["", "nan", "inf", "-1", "1e400", "true", "0", "99",
                                                           "rest", "ok", "failed", "\u00e9", '"', ","]))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(row=st.integers(1, 30), col=st.integers(0, 20), value=_VALUES)
def test_any_damaged_cells_csv_field_is_a_clean_error(write_map, band, tmp_path_factory, row, col, value):
    root = tmp_path_factory.mktemp("fuzz")
    write_map(root / "ref", band(6, 5, 3))
    write_map(root / "eng", band(6, 5, 3), engine="mujoco")
    p = root / "eng" / "cells.csv"
    import csv
    import io
    rows = list(csv.reader(io.StringIO(p.read_text())))
    rows[row][col] = value
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    p.write_text(buf.getvalue())
    _assert_clean(["score", str(root), "--no-write"])


_JSON = st.recursive(st.one_of(st.none(), st.booleans(), st.integers(-3, 99), st.floats(allow_nan=False),
                               st.text(max_size=5)),
                     lambda kids: st.one_of(st.lists(kids, max_size=3), st.dictionaries(st.text(max_size=4), kids,
                                                                                          max_size=3)),
                     max_leaves=6)


def _paths(d, prefix=()):
    out = [prefix] if prefix else []
    if isinstance(d, dict):
        for k, v in d.items():
            out += _paths(v, prefix + (k,))
    return out


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(pick=st.integers(0, 10_000), value=_JSON)
def test_any_damaged_run_json_value_is_a_clean_error(write_map, band, tmp_path_factory, pick, value):
    root = tmp_path_factory.mktemp("fuzz")
    write_map(root / "ref", band(6, 5, 3))
    write_map(root / "eng", band(6, 5, 3), engine="mujoco")
    p = root / "eng" / "run.json"
    doc = json.loads(p.read_text())
    paths = _paths(doc)
    path = paths[pick % len(paths)]
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    p.write_text(json.dumps(doc))
    _assert_clean(["score", str(root), "--no-write"])


def _assert_clean(argv, allowed=(0, 2, 5)):
    import contextlib
    import io
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    text = err.getvalue()
    assert code in allowed, text
    if code in (2, 5):
        assert len(text.strip().splitlines()) == 1 and "internal error" not in text, text


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(pick=st.integers(0, 10_000), value=_JSON)
def test_any_damaged_score_json_value_is_a_clean_error(write_map, band, tmp_path_factory, pick, value):
    root = tmp_path_factory.mktemp("fuzz")
    write_map(root / "ref", band(6, 5, 3))
    write_map(root / "eng", band(6, 5, 3), engine="mujoco")
    assert main(["score", str(root)]) == 0
    doc = json.loads((root / "score.json").read_text())
    paths = _paths(doc) + [("pairs", 0, k) for k in doc["pairs"][0]] + [("pairs", 0, "scores", k)
                                                                         for k in doc["pairs"][0]["scores"]]
    path = paths[pick % len(paths)]
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    (root / "base.json").write_text(json.dumps(doc))
    # a changed value may be a regression (exit 1): that is an answer, not a crash
    _assert_clean(["compare", str(root / "base.json"), str(root / "score.json")], (0, 1, 2, 5))
    _assert_clean(["compare", str(root / "base.json"), str(root / "score.json"), "--markdown"], (0, 1, 2, 5))


def test_a_full_disk_while_writing_cells_names_the_file_and_the_rerun_resumes(fake_engines, tmp_path, capsys, monkeypatch):
    import builtins

    import rockbench.benchmark.store.run_folder as store

    class Full:
        """cells.csv on a disk that fills up after the header and one batch of rows."""
        def __init__(self, f):
            self.f, self.writes = f, 0

        def write(self, text):
            self.writes += 1
            if self.writes > 2:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            return self.f.write(text)

        def __getattr__(self, name):
            return getattr(self.f, name)

    def fake_open(path, *a, **k):
        f = builtins.open(path, *a, **k)
        return Full(f) if str(path).endswith("cells.csv") else f
    monkeypatch.setattr(store, "open", fake_open, raising=False)
    m = ["map", "--engine", "analytic", "--block", "B6M", "--w-ratio", "1:5:40", "--a-ratio", "1:4:40",
         "--no-plot", "--serial", "--out", tmp_path / "m"]
    code, _, err = run_cli(capsys, *m)
    assert_one_line(code, err, 2, "cells.csv", "No space left")
    monkeypatch.undo()
    fake_engines.register_all()
    code, _, err = run_cli(capsys, *m)
    assert code == 0 and "resuming" in err, err
    rows = (tmp_path / "m" / "cells.csv").read_text().splitlines()[1:]
    assert len(rows) == len({tuple(r.split(",")[-2:]) for r in rows}) == 1600


def test_an_error_naming_a_value_with_line_breaks_stays_one_line(run, capsys):
    """A key or value with a line break in it (``\\x85`` counts for str.splitlines) is shown escaped."""
    assert run_cli(capsys, "score", run)[0] == 0
    doc = json.loads((run / "score.json").read_text())
    doc["pairs"][0]["grid"]["n_w\x85x"] = doc["pairs"][0]["grid"].pop("n_w")
    (run / "bad.json").write_text(json.dumps(doc))
    code, _, err = run_cli(capsys, "compare", run / "bad.json", run / "score.json")
    assert_one_line(code, err, 2, "bad.json")
    from rockbench.benchmark.cli.main import _one_line
    assert _one_line("grid.\x85 is None\n") == "grid.\\x85 is None"
    assert _one_line("plain") == "plain"
