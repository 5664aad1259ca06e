"""The shipped restitution data, the outcomes loader and scoring against a small made-up test set."""

import math

import numpy as np
import pytest

from rockbench.benchmark.blocks.experiments import (SHAKING_TABLE_LIMIT_MPS2, experimental_eta, load_outcomes,
                                                  load_restitution, parse_outcomes, restitution_errors,
                                                  restitution_targets, st_limit_a_ratio)
from rockbench.benchmark.blocks.presets import PRESETS, TABLE_1
from rockbench.benchmark.maps.result import MapResult
from rockbench.benchmark.scoring.experiments import score_outcomes
from rockbench.benchmark.scoring.metrics import OVERTURN, REST, ROCKING
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import G

# η_H and η_M (average k) as the paper's Table 1 prints them, and η_M with the exact k of its section 5
# from eq. (10) (docs/physics.md §5)
PRINTED = {"B3M": (0.7526, 0.8106, 0.8494), "B6M": (0.9294, 0.9472, 0.9515),
           "B3L": (0.7526, 0.8598, 0.8615), "B6L": (0.9294, 0.9617, 0.9626)}


def test_restitution_data_matches_the_paper_and_presets():
    data = load_restitution()
    assert "provenance" in data and "10.1007/s00707-018-2246-8" in data["provenance"]["measured_in"]
    avg = {s["size"]: s["k_average"] for s in data["size_averages"]}
    assert avg == {"M": 0.8608, "L": 0.7306}
    for rec in data["blocks"]:
        name = rec["block"]
        pre = PRESETS[name]
        assert rec["k_exact"] == pre.k_exact and avg[rec["size"]] == pre.k_average
        t = restitution_targets(name)
        eta_h, eta_avg, eta_exact = PRINTED[name]
        # the formula reproduces the printed values, and the file stores them
        assert round(t["housner"], 4) == eta_h == rec["eta_housner"]
        assert round(t["modified_average_k"], 4) == eta_avg == rec["eta_modified_average_k"]
        assert round(t["experiment"], 4) == eta_exact == rec["eta_modified_exact_k"]
        assert experimental_eta(name) == t["experiment"]
    # the experimental data is Table 1's four blocks, and only theirs (not the presets from the measured range)
    assert [rec["block"] for rec in data["blocks"]] == list(TABLE_1) == list(PRINTED)
    with pytest.raises(ConfigError, match="no free-rocking restitution data for block 'B2M'; the data covers Table 1"):
        experimental_eta("B2M")


def test_restitution_errors():
    e = restitution_errors(0.8494, "B3M")
    assert e["experiment_rel_error"] == pytest.approx(0.0, abs=1e-4)
    assert e["housner_rel_error"] == pytest.approx((0.8494 - 0.752577319587629) / 0.752577319587629)
    with pytest.raises(ConfigError, match="B3M"):
        restitution_errors(0.9, "B9X")


GOOD = """# source: made up for this test, not measured
# a second comment line
block,pulse,f_hz,amplitude_mps2,outcome,repetitions,source
B6M,sine,{f1},{a1},O,3,test
B6M,sine,{f2},{a2},R,1,test
B6M,sine,{f3},{a3},T,2,test
B6M,sine,{f4},{a4},O,1,test
B3M,sine,1.0,5.0,O,1,test
B6M,cosine,1.0,5.0,O,1,test
B6M,sine,0.01,5.0,O,4,test
"""


def _b6m_map():
    """A 5×5 map of B6M: rest below a=1.5, rocking for a in [1.5, 3.5), overturn above."""
    w = np.linspace(1.0, 5.0, 5)
    a = np.linspace(1.0, 5.0, 5)
    c = np.full((5, 5), REST)
    c[1:3] = ROCKING
    c[3:] = OVERTURN
    return MapResult.from_outcomes(w, a, c)


def _physical(w, a):
    b = PRESETS["B6M"].block()
    return w * b.p_rad_s / (2 * math.pi), a * G * math.tan(b.alpha_rad)


def test_scoring_a_small_test_set(tmp_path):
    vals = {}
    # O at an overturn cell, R at a rocking cell, T at a rocking cell (wrong), O at a rocking cell (wrong)
    for n, (w, a) in enumerate([(2.0, 4.1), (3.0, 2.0), (4.2, 2.9), (1.0, 3.1)], 1):
        vals[f"f{n}"], vals[f"a{n}"] = _physical(w, a)
    path = tmp_path / "outcomes.csv"
    path.write_text(GOOD.format(**vals))
    pts = load_outcomes(path)
    assert len(pts) == 7 and pts[0].line == 4
    assert pts[0].w_ratio == pytest.approx(2.0) and pts[0].a_ratio == pytest.approx(4.1)
    s = score_outcomes(pts, _b6m_map(), "B6M", "sine")
    assert s["points"] == 5  # the B3M and cosine rows belong to other maps
    assert s["outside"] == 4  # the 0.01 Hz row lies left of the map
    assert s["runs"] == 3 + 1 + 2 + 1
    assert s["accuracy"] == pytest.approx(4 / 7)
    assert s["overturn_accuracy"] == pytest.approx(6 / 7)  # only the last O (in rocking) is wrong
    assert s["confusion"]["O"] == {"rest": 0, "rocking": 1, "overturn": 3, "failed": 0}
    assert s["confusion"]["T"]["rocking"] == 2
    # nothing matches: NaN accuracy, no crash
    assert math.isnan(score_outcomes(pts, _b6m_map(), "B6L", "sine")["accuracy"])


@pytest.mark.parametrize("text, match", [
    ("", "no header"),
    ("block,pulse,f_hz,amplitude_mps2,outcome,source\n", "no data rows"),
    ("block,pulse,f_hz,outcome,source\nB3M,sine,1,O,x\n", "amplitude column"),
    ("block,pulse,f_hz,omega_rad_s,amplitude_mps2,outcome,source\nB3M,sine,1,6,3,O,x\n", "exactly one frequency"),
    ("block,f_hz,amplitude_mps2,outcome,source\nB3M,1,3,O,x\n", "missing column 'pulse'"),
    ("block,pulse,f_hz,amplitude_mps2,outcome,source,colour\nB3M,sine,1,3,O,x,red\n", "unknown column 'colour'"),
    ("block,pulse,f_hz,amplitude_mps2,outcome,source\nB9M,sine,1,3,O,x\n", "block 'B9M' is not one of the experiments'"),
    # a preset outside Table 1 was never on the shaking table
    ("block,pulse,f_hz,amplitude_mps2,outcome,source\nB2M,sine,1,3,O,x\n",
     r"block 'B2M' is not one of the experiments' blocks; use one of B3M, B6M, B3L, B6L \(Table 1\)"),
    ("block,pulse,f_hz,amplitude_mps2,outcome,source\nB3M,square,1,3,O,x\n", "unknown pulse"),
    ("block,pulse,f_hz,amplitude_mps2,outcome,source\nB3M,sine,-1,3,O,x\n", r"f_hz must be a finite number > 0"),
    ("block,pulse,f_hz,amplitude_mps2,outcome,source\nB3M,sine,1,abc,O,x\n", "amplitude_mps2 must be a number"),
    ("block,pulse,f_hz,amplitude_mps2,outcome,source\nB3M,sine,1,3,X,x\n", "outcome must be T"),
    ("block,pulse,f_hz,amplitude_mps2,outcome,repetitions,source\nB3M,sine,1,3,O,0,x\n", "repetitions"),
    ("block,pulse,f_hz,amplitude_mps2,outcome,source\nB3M,sine,1,3,O\n", "5 fields"),
    ("block,pulse,f_hz,amplitude_mps2,outcome,source\nB3M,sine,1,3,O,\n", "empty source"),
])
def test_malformed_files_are_rejected_with_one_line(text, match):
    with pytest.raises(ConfigError, match=match) as e:
        parse_outcomes(text, name="bad.csv")
    assert "\n" not in str(e.value) and str(e.value).startswith("bad.csv")


def test_line_numbers_count_comments(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("# provenance\nblock,pulse,f_hz,amplitude_mps2,outcome,source\nB3M,sine,1,3,O,a\nB3M,sine,1,3,Q,a\n")
    with pytest.raises(ConfigError, match=r"x.csv:4: outcome"):
        load_outcomes(p)
    with pytest.raises(ConfigError, match="does not exist"):
        load_outcomes(tmp_path / "missing.csv")


def test_units_and_st_limit():
    pts = parse_outcomes("block,pulse,period_s,amplitude_g,outcome,source\nB3L,sine,0.5,1.0,R,x\n")
    assert pts[0].omega_rad_s == pytest.approx(4 * math.pi) and pts[0].amplitude_mps2 == pytest.approx(G)
    assert pts[0].repetitions == 1
    b = PRESETS["B6M"].block()
    assert st_limit_a_ratio("B6M") == pytest.approx(SHAKING_TABLE_LIMIT_MPS2 / (G * math.tan(b.alpha_rad)))
