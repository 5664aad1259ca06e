"""End to end with the real maps harness and reference solver: adaptive maps scored, and `run --quick`."""

import json

import pytest

from rockbench.benchmark.cli import main
from rockbench.benchmark.maps import MapSpec, parse_range, run_map
from rockbench.benchmark.presets import get_preset
from rockbench.benchmark.scoring import score_dirs
from rockbench.engines.registry import availability, names
from rockbench.reference_solver.restitution import Restitution


def _spec(n=13):
    return MapSpec(get_preset("B3M").block(), "sine", Restitution(), parse_range("--w-ratio", f"1:13:{n}", "w_ratio"),
                   parse_range("--a-ratio", f"1:9:{n}", "a_ratio"))


def test_adaptive_reference_map_scores_perfect_against_the_full_one(tmp_path):
    run_map(_spec(), tmp_path / "full", serial=True, plot=False)
    run_map(_spec(), tmp_path / "adaptive", serial=True, adaptive=True, coarse_stride=2, plot=False)
    doc = score_dirs([tmp_path / "adaptive"], against=[tmp_path / "full"])
    (p,) = doc["pairs"]
    assert p["filled_cells"] > 0  # inferred cells are counted, not called invalid
    s = p["scores"]
    assert s["invalid_cells"] == 0 and s["failed_cells"] == 0
    # the adaptive rule only skips cells inside uniform regions
    assert s["agreement"] == 1.0 and s["boundary_max"] == 0.0


@pytest.mark.slow
def test_run_quick_end_to_end(tmp_path, capsys):
    out = tmp_path / "quick"
    assert main(["run", "--quick", "--out", str(out)]) == 0
    stdout = capsys.readouterr().out
    assert (out / "index.html").is_file() and (out / "report.md").is_file()
    assert len(list((out / "maps" / "reference").iterdir())) == 12  # 2 blocks x 2 pulses x 3 restitutions
    assert (out / "img" / "theta_b3m_sine_6_6.1.png").is_file()
    suite = json.loads((out / "suite.json").read_text())
    assert suite["suite_name"] == "quick" and suite["suite"]["grid"]["adaptive"] and len(suite["maps"]) >= 12
    engines = [n for n in names() if n != "reference" and availability(n)["available"]]
    if engines:
        doc = json.loads((out / "score.json").read_text())
        assert {p["engine"] for p in doc["pairs"]} == set(engines)
        assert "engine" in stdout and "agree" in stdout
    else:
        assert "no scores" in stdout
    # a rerun resumes: nothing is computed again and the report is rewritten
    assert main(["run", "--quick", "--out", str(out)]) == 0
