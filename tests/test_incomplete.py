"""No silent gaps: an engine map with fewer cells than its grid is refused (exit 2, naming the map, the
cells missing and the command that completes it) unless --allow-incomplete, then scored on what is
there and marked; a metric with nothing to judge is null, never perfect. And bad inputs to compare, report and --pulse."""

import json

import pytest

from test_score_runs import run_cli

N_A, N_W = 10, 8


@pytest.fixture
def run(write_map, band, tmp_path):
    root = tmp_path / "run"
    write_map(root / "ref", band(N_A, N_W, 5))
    write_map(root / "eng", band(N_A, N_W, 6), engine="mujoco", settings={"settings": "calibrated"})
    return root


def _cut_half(d):
    lines = (d / "cells.csv").read_text().splitlines(keepends=True)
    (d / "cells.csv").write_text("".join(lines[: 1 + (len(lines) - 1) // 2]))
    return (len(lines) - 1) - (len(lines) - 1) // 2


def _empty(d):
    (d / "cells.csv").write_bytes(b"")
    return N_A * N_W


def _delete(d):
    (d / "cells.csv").unlink()
    return N_A * N_W


def _count_disagrees(d):
    meta = json.loads((d / "run.json").read_text())
    meta["summary"] = {"n_simulated": N_A * N_W + 7, "complete": True}
    (d / "run.json").write_text(json.dumps(meta))
    return 7


DAMAGE = [_cut_half, _empty, _delete, _count_disagrees]


@pytest.mark.parametrize("damage", DAMAGE, ids=lambda f: f.__name__.strip("_"))
def test_score_refuses_an_incomplete_engine_map(run, damage, capsys):
    missing = damage(run / "eng")
    code, out, err = run_cli(capsys, "score", run)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1
    assert str(run / "eng") in err and f"{missing} of its {N_A * N_W} cells are missing" in err
    assert "rockbench map" in err and "--allow-incomplete" in err
    assert not (run / "score.json").exists()


@pytest.mark.parametrize("damage", DAMAGE, ids=lambda f: f.__name__.strip("_"))
def test_allow_incomplete_scores_what_is_there_and_marks_it(run, damage, capsys):
    missing = damage(run / "eng")
    code, out, _ = run_cli(capsys, "score", run, "--allow-incomplete")
    assert code == 0
    (p,) = json.loads((run / "score.json").read_text())["pairs"]
    assert p["complete"] is False and p["cells_missing"] == missing
    assert "incomplete" in out
    if damage in (_empty, _delete):   # nothing to judge: n/a, never perfect
        assert all(v is None for k, v in p["scores"].items() if k != "failed_cells")
        assert p["scores"]["consistency"] is None and p["scores"]["spurious_invalid"] is None


def test_compare_refuses_a_score_file_of_incomplete_maps(run, capsys, tmp_path):
    assert run_cli(capsys, "score", run, "--out", tmp_path / "base.json")[0] == 0
    _empty(run / "eng")
    assert run_cli(capsys, "score", run, "--allow-incomplete", "--out", tmp_path / "cur.json")[0] == 0
    code, _, err = run_cli(capsys, "compare", tmp_path / "base.json", tmp_path / "cur.json")
    assert code == 2 and "incomplete maps" in err and "--allow-incomplete" in err
    code, out, _ = run_cli(capsys, "compare", tmp_path / "base.json", tmp_path / "cur.json", "--allow-incomplete",
                           "--json")
    res = json.loads(out)
    assert code == 1 and res["regressions"] and not res["improvements"]   # an empty map never "improves"


def test_report_refuses_an_incomplete_engine_map(run, capsys, tmp_path):
    _cut_half(run / "eng")
    code, _, err = run_cli(capsys, "report", run, "--out", tmp_path / "rep", "--no-trajectories")
    assert code == 2 and "incomplete" in err and str(run / "eng") in err
    code, _, _ = run_cli(capsys, "report", run, "--out", tmp_path / "rep", "--no-trajectories", "--allow-incomplete")
    assert code == 0
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "incomplete:" in page


def test_the_report_opens_with_the_verdict(run, capsys, tmp_path):
    assert run_cli(capsys, "report", run, "--out", tmp_path / "rep", "--no-trajectories")[0] == 0
    page = (tmp_path / "rep" / "index.html").read_text()
    assert 'id=\'verdict\'' in page or 'id="verdict"' in page
    assert page.index("verdict'") < page.index("<table")
    md = (tmp_path / "rep" / "report.md").read_text()
    assert md.index("## Verdict") < md.index("| rank")


def test_an_incomplete_reference_map_stays_not_comparable(run, capsys):
    _cut_half(run / "ref")
    code, _, err = run_cli(capsys, "score", run, "--allow-incomplete")
    assert code == 5 and "reference map" in err


# -- edges -------------------------------------------------------------------------------------------

def test_compare_on_a_json_that_is_not_a_score_file_exits_2(tmp_path, capsys):
    (tmp_path / "x.json").write_text('{"a": 1}')
    code, _, err = run_cli(capsys, "compare", tmp_path / "x.json", tmp_path / "x.json")
    assert code == 2 and "is not a rockbench score file" in err and len(err.strip().splitlines()) == 1


def test_compare_on_a_score_file_of_the_old_schema_exits_5(run, capsys, tmp_path):
    assert run_cli(capsys, "score", run)[0] == 0
    old = json.loads((run / "score.json").read_text())
    old["schema_version"], old["metrics_version"] = 1, "2"
    (tmp_path / "old.json").write_text(json.dumps(old))
    code, _, err = run_cli(capsys, "compare", tmp_path / "old.json", run / "score.json")
    assert code == 5 and "score schema 1" in err and "rescore" in err


@pytest.mark.parametrize("command", [["simulate", "--w-ratio", "2", "--a-ratio", "2"],
                                     ["simulate", "--a-ratio", "2"]])
def test_pulse_naming_a_directory_exits_2(tmp_path, capsys, command):
    code, _, err = run_cli(capsys, *command, "--block", "B3M", "--pulse", tmp_path)
    assert code == 2 and "--pulse names a directory" in err
