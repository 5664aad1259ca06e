"""``rockbench score`` and ``rockbench compare`` end to end on hand-made map directories."""

import json

import numpy as np
import pytest

from rockbench.benchmark.cli.main import main
from rockbench.reference_solver.restitution import Restitution


MOD = Restitution("modified", k=0.8608)


@pytest.fixture
def suite(write_map, band, tmp_path):
    """reference Housner + modified, and an engine one row off the Housner reference."""
    root = tmp_path / "run"
    write_map(root / "ref-h", band(12, 10, 6))
    write_map(root / "ref-m", band(12, 10, 7), restitution=MOD)
    write_map(root / "eng", band(12, 10, 7), engine="mujoco", settings={"settings": "calibrated"}, shuffle_seed=1)
    return root


def run_cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_score_writes_score_json_and_prints_tables(suite, capsys):
    code, out, err = run_cli(capsys, "score", suite)
    assert code == 0, err
    doc = json.loads((suite / "score.json").read_text())
    assert doc["kind"] == "rockbench-score" and doc["metrics_version"]
    assert {m["name"] for m in doc["metrics"]} >= {"agreement", "iou_overturn", "boundary_mean"}
    assert all("definition" in m and "direction" in m for m in doc["metrics"])
    pairs = {p["reference"]["restitution"]: p for p in doc["pairs"]}
    assert set(pairs) == {"housner", "modified(k=0.8608)"}
    h = pairs["housner"]
    assert h["like_for_like"] and h["variant"] == "mujoco[settings=calibrated]"
    assert h["scores"]["agreement"] == pytest.approx(1 - 1 / 12)
    assert h["scores"]["boundary_mean"] == pytest.approx(7.5 / 11)  # one a-step
    # the engine happens to match the modified reference exactly
    assert pairs["modified(k=0.8608)"]["scores"]["agreement"] == 1.0
    assert "mujoco[settings=calibrated]" in out and "agree" in out


def test_score_gate(suite, capsys):
    code, out, err = run_cli(capsys, "score", suite, "--fail-under", "agreement=0.95", "--no-write")
    assert code == 1 and "gate failed" in err and "agreement" in err
    code, *_ = run_cli(capsys, "score", suite, "--fail-under", "agreement=0.9", "--fail-over", "failed_cells=0")
    assert code == 0
    code, out, err = run_cli(capsys, "score", suite, "--fail-under", "boundary_max=0.1")
    assert code == 2 and "--fail-over" in err and "Traceback" not in err
    code, out, err = run_cli(capsys, "score", suite, "--fail-under", "agreemnt=0.9")
    assert code == 2 and "Did you mean agreement" in err


def test_score_json_and_markdown(suite, capsys):
    code, out, _ = run_cli(capsys, "score", suite, "--json", "--no-write")
    assert code == 0 and json.loads(out)["pairs"]
    code, out, _ = run_cli(capsys, "score", suite, "--markdown", "--no-write")
    assert code == 0 and "| engine |" in out and "|---|" in out


def test_score_against(write_map, band, tmp_path, capsys):
    write_map(tmp_path / "a", band(8, 8, 3))
    write_map(tmp_path / "b", band(8, 8, 4))
    code, out, err = run_cli(capsys, "score", tmp_path / "b", "--against", tmp_path / "a", "--no-write", "--json")
    assert code == 0, err
    (p,) = json.loads(out)["pairs"]
    assert p["scores"]["critical_error_max"] == pytest.approx(7.5 / 7)


def test_score_incomparable_and_bad_input(write_map, band, tmp_path, capsys):
    write_map(tmp_path / "r", band(8, 8, 3))
    code, _, err = run_cli(capsys, "score", tmp_path / "r")
    assert code == 5 and "only reference maps" in err
    write_map(tmp_path / "e", band(9, 8, 3), engine="pybullet")  # another grid
    code, _, err = run_cli(capsys, "score", tmp_path / "r", tmp_path / "e")
    assert code == 5 and "different grids" in err
    code, _, err = run_cli(capsys, "score", tmp_path / "nowhere")
    assert code == 2 and "not a directory" in err
    (tmp_path / "empty").mkdir()
    code, _, err = run_cli(capsys, "score", tmp_path / "empty")
    assert code == 2 and "holds no map" in err


def test_score_with_experiments(suite, tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("block,pulse,f_hz,amplitude_mps2,outcome,source\nB6M,sine,1,2,Z,me\n")
    code, out, err = run_cli(capsys, "score", suite, "--experiments", bad)
    assert code == 2 and "bad.csv:2" in err and len(err.strip().splitlines()) == 1
    assert not (suite / "score.json").exists()  # nothing half-written
    good = tmp_path / "good.csv"
    # B6M: p = 8.423 rad/s; w_ratio 5 -> 6.70 Hz; a_ratio 7.5 (overturn everywhere) -> 7.5*9.81*tan(alpha)
    good.write_text("block,pulse,f_hz,amplitude_mps2,outcome,source\nB6M,sine,6.7,16.3,O,me\n")
    code, out, err = run_cli(capsys, "score", suite, "--experiments", good, "--json")
    assert code == 0, err
    ex = json.loads(out)["experiments"]
    assert len(ex) == 3 and all(e["accuracy"] == 1.0 and e["runs"] == 1 for e in ex)


def test_compare_identical_and_worsened(write_map, band, tmp_path, capsys):
    base, cur = tmp_path / "base", tmp_path / "cur"
    for root in (base, cur):
        write_map(root / "ref", band(12, 10, 6))
    write_map(base / "eng", band(12, 10, 6), engine="exudyn")
    same = band(12, 10, 6)
    write_map(cur / "eng", same, engine="exudyn")
    code, out, err = run_cli(capsys, "compare", base, cur)
    assert code == 0, err + out
    worse = band(12, 10, 6)
    worse[6, 3:6] = 1  # the engine stops overturning in three cells
    write_map(cur / "eng", worse, engine="exudyn")
    code, out, err = run_cli(capsys, "compare", base, cur)
    assert code == 1 and "REGRESSION" in out and "agreement" in out
    code, out, _ = run_cli(capsys, "compare", base, cur, "--json")
    res = json.loads(out)
    assert code == 1 and res["status"] == "regression"
    assert {r["metric"] for r in res["regressions"]} >= {"agreement", "iou_overturn"}
    # a generous tolerance accepts it
    code, out, _ = run_cli(capsys, "compare", base, cur, "--tolerance", "10")
    assert code == 0
    code, out, _ = run_cli(capsys, "compare", base, cur, "--markdown")
    assert code == 1 and "| REGRESSION |" in out
    # compare reads score.json files too; and the other way round is an improvement
    assert run_cli(capsys, "score", base)[0] == 0 and run_cli(capsys, "score", cur)[0] == 0
    code, out, _ = run_cli(capsys, "compare", cur / "score.json", base / "score.json", "--json")
    assert code == 0 and json.loads(out)["improvements"]


def test_compare_incomparable(write_map, band, tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    write_map(a / "ref", band(8, 8, 3))
    write_map(a / "eng", band(8, 8, 3), engine="mujoco")
    write_map(b / "ref", band(8, 8, 3), block="B3M")
    write_map(b / "eng", band(8, 8, 3), engine="mujoco", block="B3M")
    code, _, err = run_cli(capsys, "compare", a, b)
    assert code == 5 and "no scored pair" in err
    c = tmp_path / "c"
    write_map(c / "ref", band(8, 9, 3))
    write_map(c / "eng", band(8, 9, 3), engine="mujoco")
    code, _, err = run_cli(capsys, "compare", a, c)
    assert code == 5 and "other grids" in err
    s = tmp_path / "s.json"
    s.write_text(json.dumps({"kind": "rockbench-score", "schema_version": 99, "pairs": []}))
    code, _, err = run_cli(capsys, "compare", s, a)
    assert code == 5 and "schema" in err
    code, _, err = run_cli(capsys, "compare", a, tmp_path / "missing.json")
    assert code == 2
    code, _, err = run_cli(capsys, "compare", a, a, "--tolerance", "agreement=x")
    assert code == 2


def test_missing_pair_is_a_regression(write_map, band, tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    for root in (a, b):
        write_map(root / "ref", band(8, 8, 3))
        write_map(root / "eng", band(8, 8, 3), engine="mujoco")
    write_map(a / "eng2", band(8, 8, 3), engine="pybullet")
    code, out, _ = run_cli(capsys, "compare", a, b)
    assert code == 1 and "MISSING" in out and "pybullet" in out


def test_own_eta_reference_is_marked(write_map, band, tmp_path, capsys):
    """(d): a reference map with the engine's own measured η is recognised from calibration.json."""
    root = tmp_path / "run"
    write_map(root / "maps" / "ref-h", band(8, 8, 3))
    write_map(root / "maps" / "ref-own", band(8, 8, 4), restitution=Restitution("constant", value=0.9712))
    write_map(root / "maps" / "eng", band(8, 8, 4), engine="mujoco", settings={"settings": "shipped"})
    (root / "calibration.json").write_text(json.dumps({"kind": "rockbench-calibration", "measurements": [
        {"variant": "mujoco[settings=shipped]", "block": "B6M", "eta_measured": 0.97121}]}))
    code, out, err = run_cli(capsys, "score", root, "--json", "--no-write")
    assert code == 0, err
    kinds = {p["reference"]["restitution"]: p["reference"]["kind"] for p in json.loads(out)["pairs"]}
    assert kinds == {"housner": "same-law", "0.9712": "own-eta"}
    code, out, _ = run_cli(capsys, "score", root, "--no-write")
    assert "0.9712 (own η)" in out


def test_own_eta_jobs():
    from rockbench.benchmark.suites.model import load_suite, suite_path
    from rockbench.benchmark.suites.plan import own_eta_jobs
    s = load_suite(suite_path("default", False))
    assert s.engines.own_eta
    jobs = own_eta_jobs(s, [{"variant": "a", "block": "B3M", "eta_measured": 0.91234},
                            {"variant": "b", "block": "B3M", "eta_measured": 0.91231},  # same to 4 decimals
                            {"variant": "c", "block": "B6L", "eta_measured": None}])
    assert [j.subdir for j in jobs] == ["maps/reference/B3M-sine-own-eta-0.9123",
                                        "maps/reference/B3M-cosine-own-eta-0.9123"]
    assert jobs[0].restitution.value == 0.9123


def test_cells_csv_from_another_tool_is_read_by_its_cli_columns(write_map, band, tmp_path, capsys):
    """A map directory without the store's run.json: cells.csv with only the required columns of docs/cli.md."""
    write_map(tmp_path / "ref", band(4, 3, 2))
    d = tmp_path / "foreign"
    d.mkdir()
    rows = ["engine,block,pulse,restitution,eta,w_ratio,a_ratio,omega_rad_s,amplitude_mps2,outcome,n_impacts,"
            "max_abs_theta_rad,valid,flags"]
    for i, a in enumerate(np.linspace(0.5, 8.0, 4)):
        for w in np.linspace(1.0, 10.0, 3):
            out = "overturn" if i >= 1 else "rocking"
            rows.append(f"myengine,B6M,sine,housner,0.93,{float(w)!r},{float(a)!r},1,1,{out},1,0.1,true,")
    (d / "cells.csv").write_text("\n".join(rows) + "\n")
    code, out, err = run_cli(capsys, "score", d, "--against", tmp_path / "ref", "--json", "--no-write")
    assert code == 0, err
    (p,) = json.loads(out)["pairs"]
    assert p["variant"] == "myengine" and p["scores"]["critical_error_max"] == pytest.approx(2.5)
    (d / "cells.csv").write_text("engine,block\nx,y\n")
    code, _, err = run_cli(capsys, "score", d, "--against", tmp_path / "ref")
    assert code == 5 and "lacks the column" in err


@pytest.mark.parametrize("old_version", ["1", "3", "4", "5", "6"])
def test_compare_refuses_older_metrics_versions(write_map, band, tmp_path, capsys, old_version):
    """A score file whose verdict is older than version 7's (classes compared with their best,
    declarations, power) is refused in one line that says to re-score: exit 5."""
    a = tmp_path / "a"
    write_map(a / "ref", band(8, 8, 3))
    write_map(a / "eng", band(8, 8, 3), engine="mujoco")
    assert run_cli(capsys, "score", a)[0] == 0
    old = json.loads((a / "score.json").read_text())
    old["metrics_version"] = old_version
    (tmp_path / "old.json").write_text(json.dumps(old))
    code, _, err = run_cli(capsys, "compare", tmp_path / "old.json", a / "score.json")
    assert code == 5 and f"holds metrics version {old_version}" in err and "rockbench score RUN_DIR" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    # a score file of this version compares (the report never reads a score file: it scores the maps)
    code, _, err = run_cli(capsys, "compare", a / "score.json", a / "score.json")
    assert code == 0, err


def test_scoring_half_a_reference_map_exits_5(write_map, band, tmp_path, capsys):
    """A reference map with 20 of its 36 rows (an unfinished run) is refused, never scored."""
    root = tmp_path / "run"
    write_map(root / "ref", band(36, 6, 20))
    write_map(root / "eng", band(36, 6, 20), engine="mujoco")
    cells = root / "ref" / "cells.csv"
    lines = cells.read_text().splitlines(keepends=True)
    cells.write_text("".join(lines[: 1 + 20 * 6]))
    code, _, err = run_cli(capsys, "score", root, "--no-write")
    assert code == 5 and "incomplete" in err and "96 of its 216 cells are missing" in err
    # a header-only cells.csv is refused the same way (it scored IoU 1.0 before)
    cells.write_text(lines[0])
    code, _, err = run_cli(capsys, "score", root, "--no-write")
    assert code == 5 and "216 of its 216 cells are missing" in err


def test_score_json_records_the_domain_per_pair(write_map, band, tmp_path, capsys):
    root = tmp_path / "run"
    lift = np.zeros((10, 8), bool)
    lift[7:, :3] = True                      # the reference needs the table to pull the block here
    write_map(root / "ref", band(10, 8, 5), invalid=lift)
    write_map(root / "eng", band(10, 8, 5), engine="mujoco", invalid=lift)   # the engine flags slip there
    assert run_cli(capsys, "score", root)[0] == 0
    (p,) = json.loads((root / "score.json").read_text())["pairs"]
    assert p["cells_in_domain"] == 80 - 9 and p["cells_outside_domain"] == 9
    assert p["scores"]["consistency"] == 1.0 and p["scores"]["spurious_invalid"] == 0
    assert p["scores"]["agreement"] == 1.0


# -- pairing within a run, tolerances in cells, well-formed Markdown -------------------------------

def _md_rows(text):
    """The cells of each row of every Markdown table in ``text`` (``\\|`` is a pipe inside a cell)."""
    import re
    rows = []
    for line in text.splitlines():
        if line.startswith("|"):
            cells = re.split(r"(?<!\\)\|", line.strip())[1:-1]
            rows.append(cells)
    return rows


def test_compare_markdown_tables_are_well_formed_and_always_there(write_map, band, tmp_path, capsys):
    base, cur = tmp_path / "base", tmp_path / "cur"
    for root in (base, cur):
        write_map(root / "ref", band(12, 10, 6))
    write_map(base / "eng", band(12, 10, 6), engine="exudyn")
    write_map(cur / "eng", band(12, 10, 6), engine="exudyn")
    code, out, _ = run_cli(capsys, "compare", base, cur, "--markdown")
    assert code == 0
    rows = _md_rows(out)
    assert len(rows) == 3 and rows[1][0].strip() == "---"          # header, rule, one "ok" row
    assert all(len(r) == 7 for r in rows)
    worse = band(12, 10, 6)
    worse[6, 2:8] = 1
    write_map(cur / "eng", worse, engine="exudyn")
    code, out, _ = run_cli(capsys, "compare", base, cur, "--markdown")
    assert code == 1
    rows = _md_rows(out)
    assert len(rows) > 3 and all(len(r) == 7 for r in rows), out
    assert any("exudyn \\| B6M \\| sine" in r[1] for r in rows)


def test_runs_given_together_are_paired_within_each_run(write_map, band, tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    write_map(a / "ref", band(12, 10, 6))
    write_map(a / "eng", band(12, 10, 6), engine="mujoco")           # perfect against its own reference
    write_map(b / "ref", band(12, 10, 3))
    write_map(b / "eng", band(12, 10, 3), engine="mujoco", invalid=np.ones((12, 10), bool))
    code, out, err = run_cli(capsys, "score", a, b, "--json", "--no-write")
    assert code == 0, err
    doc = json.loads(out)
    assert len(doc["pairs"]) == 2 and doc["pairing"]["rule"] == "within each run"
    for p in doc["pairs"]:
        assert p["run"] == p["reference"]["run"] and not p["across_runs"]
        assert p["scores"]["agreement"] == 1.0
    assert sorted(p["invalid_cells"] for p in doc["pairs"]) == [0, 120]   # not summed twice
    assert "across runs" not in err


def test_a_run_without_its_reference_is_paired_across_runs_and_says_so(write_map, band, tmp_path, capsys):
    refs, engs = tmp_path / "refs", tmp_path / "engs"
    write_map(refs / "ref", band(12, 10, 6))
    write_map(engs / "eng", band(12, 10, 6), engine="mujoco")
    code, out, err = run_cli(capsys, "score", refs, engs, "--json", "--no-write")
    assert code == 0, err
    (p,) = json.loads(out)["pairs"]
    assert p["across_runs"] and "paired across runs" in err and str(refs) in err


def test_compare_refuses_a_document_holding_a_pair_twice(write_map, band, tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    for root in (a, b):
        write_map(root / "ref", band(8, 8, 3))
        write_map(root / "eng", band(8, 8, 3), engine="mujoco")
    assert run_cli(capsys, "score", a, b, "--out", tmp_path / "both.json")[0] == 0
    code, _, err = run_cli(capsys, "compare", tmp_path / "both.json", a)
    assert code == 5 and "twice" in err


def test_tolerances_are_stated_in_cells(write_map, band, tmp_path, capsys):
    """On a 9 × 11 grid one flipped cell moves agreement by 1/99 > 0.005: not a regression by default;
    a shifted boundary is."""
    base, cur = tmp_path / "base", tmp_path / "cur"
    for root in (base, cur):
        write_map(root / "ref", band(9, 11, 4))
    write_map(base / "eng", band(9, 11, 4), engine="mujoco")
    one = band(9, 11, 4)
    one[4, 5] = 1
    write_map(cur / "eng", one, engine="mujoco")
    code, out, _ = run_cli(capsys, "compare", base, cur, "--json")
    res = json.loads(out)
    assert code == 0 and res["status"] == "ok", res["regressions"]
    assert run_cli(capsys, "compare", base, cur, "--tolerance", "0.005")[0] == 1     # the old absolute rule
    assert run_cli(capsys, "compare", base, cur, "--tolerance", "agreement=0.5cells")[0] == 1
    shifted = band(9, 11, 5)                                  # the boundary one row up: 11 cells
    write_map(cur / "eng", shifted, engine="mujoco")
    code, out, _ = run_cli(capsys, "compare", base, cur, "--json")
    res = json.loads(out)
    assert code == 1 and "agreement" in {r["metric"] for r in res["regressions"]}
    row = next(r for r in res["regressions"] if r["metric"] == "agreement")
    assert row["tolerance"] == pytest.approx(2 / 99)
    assert run_cli(capsys, "compare", base, cur, "--tolerance", "12cells")[0] == 0
    assert run_cli(capsys, "compare", base, cur, "--tolerance", "xcells")[0] == 2
