"""The results store: resume after kill -9, torn lines, refusal of another spec, provenance."""

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.maps.grid import MapSpec, make_axis
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.report.plots.picture import MapPicture
from rockbench.benchmark.store.loading import load_map
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.store.files import COLUMNS, SCHEMA_VERSION
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.restitution import Restitution

HERE = Path(__file__).resolve().parent


pytestmark = pytest.mark.usefixtures("fake_engines")


def spec(n=20, engine="analytic", settings=None, pulse="sine"):
    return MapSpec(get_preset("B6M").block(), pulse, Restitution(), make_axis("--w-ratio", "w_ratio", 0.5, 8.0, n),
                   make_axis("--a-ratio", "a_ratio", 0.5, 9.0, n), engine=engine, engine_settings=settings or {})


def rows_of(d):
    """The whole rows of cells.csv (a torn last line, left by a kill, is not a row)."""
    data = (Path(d) / "cells.csv").read_text()
    return list(csv.DictReader(data[: data.rfind("\n") + 1].splitlines()))


def test_run_dir_contents_and_provenance(analytic_truth, tmp_path):
    s = spec(12)
    r = run_map(s, tmp_path / "m", jobs=1, picture=MapPicture())
    meta = json.loads((tmp_path / "m" / "run.json").read_text())
    assert meta["schema_version"] == SCHEMA_VERSION
    for key in ("created_utc", "rockbench_version", "git", "python", "platform", "engine", "spec", "summary"):
        assert key in meta
    assert set(meta["git"]) == {"commit", "dirty"}
    assert meta["engine"]["engine"] == "analytic" and "resolved_settings" in meta["engine"]
    assert meta["summary"]["n_simulated"] == 144 and meta["summary"]["complete"]
    rows = rows_of(tmp_path / "m")
    assert len(rows) == 144 and list(rows[0]) == COLUMNS
    assert (tmp_path / "m" / "map.png").stat().st_size > 1000
    # the physical and normalised coordinates agree row by row
    for row in rows[:20]:
        assert float(row["omega_rad_s"]) == pytest.approx(float(row["w_ratio"]) * s.block.p_rad_s)
    back = load_map(tmp_path / "m")
    assert np.array_equal(back.outcome, r.outcome)
    assert np.array_equal(back.outcome, analytic_truth(s))


def test_torn_last_line_is_cut_and_recomputed(analytic_truth, tmp_path):
    s = spec(10)
    run_map(s, tmp_path / "m", serial=True)
    path = tmp_path / "m" / "cells.csv"
    lines = path.read_text().splitlines(keepends=True)
    # drop the last three rows and leave half of one, as a kill in mid-write would
    path.write_text("".join(lines[:-3]) + lines[-3][: len(lines[-3]) // 2])
    r = run_map(s, tmp_path / "m", serial=True)
    rows = rows_of(tmp_path / "m")
    keys = [(int(x["i"]), int(x["j"])) for x in rows]
    assert len(keys) == len(set(keys)) == 100
    assert np.array_equal(r.outcome, analytic_truth(s))


def test_other_spec_is_refused(tmp_path):
    run_map(spec(8), tmp_path / "m", serial=True)
    before = (tmp_path / "m" / "cells.csv").read_bytes()
    with pytest.raises(ConfigError, match="different map"):
        run_map(spec(9), tmp_path / "m", serial=True)
    assert (tmp_path / "m" / "cells.csv").read_bytes() == before


def test_other_spec_refused_by_cli_exit_2(tmp_path, capsys):
    args = ["map", "--engine", "analytic", "--block", "B6M", "--w-ratio", "1:5:4", "--a-ratio", "1:4:4",
            "--out", str(tmp_path / "m"), "--serial", "--no-plot", "--json"]
    assert main(args) == 0
    capsys.readouterr()
    args[args.index("--w-ratio") + 1] = "1:6:4"
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "different map" in err and "x.hi" in err


def test_not_a_map_directory_is_refused(tmp_path):
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match="not a rockbench map directory"):
        run_map(spec(4), tmp_path / "d", serial=True)
    assert sorted(p.name for p in (tmp_path / "d").iterdir()) == ["notes.txt"]


def test_resume_after_kill_9(analytic_truth, tmp_path):
    out = tmp_path / "m"
    n = 24
    cmd = [sys.executable, "-c",
           "import sys, maps_helpers as mh; mh.register_all(); from rockbench.benchmark.cli.main import main; "
           "sys.exit(main(sys.argv[1:]))",
           "map", "--engine", "analytic", "--set", "sleep_s=0.01", "--block", "B6M", "--w-ratio", f"0.5:8:{n}",
           "--a-ratio", f"0.5:9:{n}", "--out", str(out), "--jobs", "2", "--no-plot", "--json"]
    env = dict(os.environ, PYTHONPATH=str(HERE) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen(cmd, cwd=HERE, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    csv_path = out / "cells.csv"
    t0 = time.monotonic()
    while time.monotonic() - t0 < 60:
        if csv_path.exists() and csv_path.read_bytes().count(b"\n") > 120:
            break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)   # the map process and its workers, mid-map
    proc.wait()
    first = rows_of(out)
    assert 100 < len(first) < n * n, "the kill must land mid-map"
    s = spec(n, settings={"sleep_s": 0.01})
    r = run_map(s, out, jobs=2)
    rows = rows_of(out)
    keys = [(int(x["i"]), int(x["j"])) for x in rows]
    assert len(keys) == len(set(keys)) == n * n          # no duplicates, every cell
    assert rows[: len(first)] == first                   # finished cells were kept, not recomputed
    assert np.array_equal(r.outcome, analytic_truth(s))
    meta = json.loads((out / "run.json").read_text())
    assert len(meta["runs"]) == 2 and meta["summary"]["complete"]


def test_cells_carry_their_variant_so_concatenated_maps_stay_apart(tmp_path):
    run_map(spec(5, settings={"sleep_s": 0}), tmp_path / "a", serial=True)
    run_map(spec(5), tmp_path / "b", serial=True)
    a, b = rows_of(tmp_path / "a"), rows_of(tmp_path / "b")
    assert COLUMNS[:3] == ["engine", "variant", "block"]
    assert {r["variant"] for r in a} == {"analytic[sleep_s=0]"} and {r["variant"] for r in b} == {"analytic"}
    assert {r["engine"] for r in a + b} == {"analytic"}


def test_an_adaptive_map_written_out_on_its_full_grid(analytic_truth, tmp_path, capsys):
    from rockbench.benchmark.store.export import FULL_GRID_FILE
    from rockbench.benchmark.store.loading import full_grid_rows
    s = spec(13)
    r = run_map(s, tmp_path / "m", serial=True, adaptive=True, coarse_stride=4)
    assert 0 < r.n_simulated < 169
    rows = full_grid_rows(tmp_path / "m")
    assert len(rows) == 169 and [(int(x["i"]), int(x["j"])) for x in rows] == [(i, j) for i in range(13)
                                                                              for j in range(13)]
    filled = [x for x in rows if x["filled"]]
    assert len(filled) == 169 - r.n_simulated
    # the fill rule's outcomes, and nothing invented about those cells' runs
    assert all(x["status"] == "filled" and x["n_impacts"] == "" and x["flags"] == "" for x in filled)
    grid = analytic_truth(s)
    names = {0: "rest", 1: "rocking", 2: "overturn"}
    assert [x["outcome"] for x in rows] == [names[int(grid[int(x["i"]), int(x["j"])])] for x in rows]
    # the CLI writes it beside cells.csv
    assert main(["map", "--engine", "analytic", "--block", "B6M", "--serial", "--no-plot", "--adaptive",
                 "--w-ratio", "0.5:8:13", "--a-ratio", "0.5:9:13", "--out", str(tmp_path / "c"), "--full-grid",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    with open(out["full_grid"]) as f:
        back = list(csv.DictReader(f))
    assert out["full_grid"].endswith(FULL_GRID_FILE) and len(back) == 169
    assert back[0].keys() == set(COLUMNS) | {"filled", "left_model"}
    assert sum(x["filled"] == "true" for x in back) == 169 - out["n_simulated"]
