"""``rockbench simulate`` through the command line: the paper's Fig. 17 pair, outputs, bad input."""

from __future__ import annotations

import json
import os

import pytest

from rockbench.benchmark.cli.main import main

FIG17 = ["simulate", "--block", "B3M", "--pulse", "sine", "--w-ratio", "6", "--a-ratio", "6.1",
         "--restitution", "modified"]
KEYS = {"outcome", "n_impacts", "max_abs_theta_rad", "t_overturn_s", "eta", "alpha_rad", "p_rad_s", "omega_rad_s",
        "amplitude_mps2", "engine", "valid", "flags", "w_ratio", "a_ratio", "t_uplift_s", "dt_s", "mode", "impacts"}


def run_json(capsys, args):
    code = main(args + ["--json"])
    out = capsys.readouterr()
    assert code == 0, out.err
    return json.loads(out.out)


@pytest.mark.parametrize("k, outcome", [("0.7595", "overturn"), ("0.8608", "rocking")])
@pytest.mark.parametrize("mode", ["energy", "to-rest"])
def test_fig17_pair(capsys, k, outcome, mode):
    o = run_json(capsys, FIG17 + ["--k", k, "--mode", mode])
    assert o["outcome"] == outcome
    assert KEYS <= set(o)
    assert o["engine"] == "reference" and o["valid"] is True and o["flags"] == [] and o["mode"] == mode
    assert o["w_ratio"] == pytest.approx(6.0) and o["a_ratio"] == pytest.approx(6.1)
    assert (o["t_overturn_s"] is not None) == (outcome == "overturn")
    if outcome == "overturn" or mode == "to-rest":  # energy mode stops a rocking block at the pulse's end
        assert 0.13 < o["impacts"][0]["t_s"] < 0.15


def test_fig17_pictures_reach_the_decisive_impact_on_one_span(capsys, tmp_path, monkeypatch):
    """README's Fig. 17 pair: the rocking run (energy mode stops it at the pulse's end, 0.091 s) is
    drawn integrated on, so both pictures show the impact near 0.14 s over the same span."""
    from rockbench.benchmark.report.plots import trajectories

    drawn = []
    real = trajectories.plot_theta
    monkeypatch.setattr(trajectories, "plot_theta", lambda *a, **kw: drawn.append(real(*a, **kw)) or drawn[-1])
    spans = []
    for k in ("0.8608", "0.7595"):
        o = run_json(capsys, FIG17 + ["--k", k, "--plot", str(tmp_path / f"fig17-{k}.png")])
        spans.append(o["plot_span_s"])
        assert (tmp_path / f"fig17-{k}.png").read_bytes()[:4] == b"\x89PNG"
    assert spans[0] == spans[1] and spans[0] > 0.36     # past the overturn at 0.350 s
    for d in drawn:
        (line,) = d["lines"].values()
        assert line.get_xdata()[-1] > 0.3               # not stopped at the pulse's end
        (marks,) = d["impacts"].values()
        assert 0.14 < marks.get_xdata()[0] < 0.15
        assert d["ax"].get_xlim() == pytest.approx((0.0, spans[0]))
        assert d["ax_pulse"] is not None


def test_text_summary(capsys):
    assert main(FIG17 + ["--k", "0.7595"]) == 0
    out = capsys.readouterr().out
    assert "outcome: overturn" in out and "impact at" in out


def test_history_and_plot_files(capsys, tmp_path):
    h, p = tmp_path / "h.csv", tmp_path / "p.png"
    o = run_json(capsys, FIG17 + ["--k", "0.7595", "--history", str(h), "--plot", str(p)])
    lines = h.read_text().splitlines()
    assert lines[0] == "t_s,theta_rad,theta_dot_rad_s,theta_ddot_rad_s2"
    rows = [list(map(float, r.split(","))) for r in lines[1:]]
    assert len(rows) > 100 and all(len(r) == 4 for r in rows)
    assert all(b[0] > a[0] for a, b in zip(rows, rows[1:]))
    assert abs(rows[-1][1]) > o["alpha_rad"]
    assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(x.name for x in tmp_path.iterdir()) == ["h.csv", "p.png"]  # no temporary files left


def test_custom_block_and_other_ways_to_give_the_case(capsys, tmp_path):
    o = run_json(capsys, ["simulate", "--width", "0.045", "--height", "0.10125", "--period", "0.2",
                          "--amplitude-g", "0.8", "--restitution", "0.9", "--pulse", "cosine", "--linearized"])
    assert o["omega_rad_s"] == pytest.approx(2 * 3.141592653589793 / 0.2)
    assert o["amplitude_mps2"] == pytest.approx(0.8 * 9.81) and o["eta"] == 0.9
    rec = tmp_path / "rec.csv"
    rec.write_text("t_s,accel_mps2\n0,0\n0.05,8\n0.1,-8\n0.15,0\n")
    o = run_json(capsys, ["simulate", "--block", "B6M", "--pulse", str(rec), "--amplitude", "6"])
    assert o["omega_rad_s"] is None and o["amplitude_mps2"] == pytest.approx(6.0)
    assert o["outcome"] in ("rest", "rocking", "overturn")


P = ["--w-ratio", "6", "--a-ratio", "6.1"]
BAD = [
    (["--width", "-0.045", "--height", "0.1"] + P, "--width"),
    (["--width", "nan", "--height", "0.1"] + P, "--width"),
    (["--width", "0.045", "--height", "0"] + P, "--height"),
    (["--width", "0.045", "--height", "0.1", "--density", "0"] + P, "--density"),
    (["--width", "0.045", "--height", "0.1", "--depth", "inf"] + P, "--depth"),
    (["--block", "B3M", "--w-ratio", "0", "--a-ratio", "6"], "--w-ratio"),
    (["--block", "B3M", "--omega", "-3", "--a-ratio", "6"], "--omega"),
    (["--block", "B3M", "--period", "nan", "--a-ratio", "6"], "--period"),
    (["--block", "B3M", "--w-ratio", "6", "--a-ratio", "0"], "--a-ratio"),
    (["--block", "B3M", "--w-ratio", "6", "--amplitude", "-2"], "--amplitude"),
    (["--block", "B3M", "--w-ratio", "6", "--amplitude-g", "inf"], "--amplitude-g"),
    (["--block", "B3M", "--dt", "0"] + P, "--dt"),
    (["--block", "B3M", "--dt", "-1e-3"] + P, "--dt"),
    (["--block", "B3M", "--dt", "nan"] + P, "--dt"),
    (["--block", "B3M", "--dt", "0.02"] + P, "too coarse"),
    (["--block", "B3M", "--restitution", "modified", "--k", "1.5"] + P, "--k"),
    (["--block", "B3M", "--restitution", "modified", "--k", "-0.1"] + P, "--k"),
    (["--block", "B3M", "--restitution", "0"] + P, "(0, 1]"),
    (["--block", "B3M", "--restitution", "1.2"] + P, "(0, 1]"),
    (["--block", "B3X"] + P, "Did you mean B3M"),
    (["--block", "B3M", "--omega", "60"] + P, "frequency is given twice"),
    (["--block", "B3M", "--amplitude", "30"] + P, "amplitude is given twice"),
    (["--block", "B3M", "--w-ratio", "6", "--period", "0.1", "--a-ratio", "6"], "frequency is given twice"),
    (["--block", "B3M", "--a-ratio", "6"], "no frequency"),
    (["--block", "B3M", "--w-ratio", "6"], "no amplitude"),
    (["--block", "B3M", "--mode", "forever"] + P, "--mode"),
]


@pytest.mark.parametrize("extra, needle", BAD)
def test_bad_input_exits_2_with_one_line(capsys, tmp_path, extra, needle):
    _assert_bad(capsys, tmp_path, ["simulate"] + extra, needle)


def _assert_bad(capsys, tmp_path, args, needle):
    h, p = tmp_path / "h.csv", tmp_path / "p.png"
    code = main(args + ["--history", str(h), "--plot", str(p)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert needle in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    # nothing written: only the record file the test itself made may be there
    assert [x.name for x in tmp_path.iterdir() if x.name != "rec.csv"] == []


@pytest.mark.parametrize("content, needle", [
    (None, "cannot read"),
    ("", "empty"),
    ("t_s,accel_mps2\n0,abc\n", "not two numbers"),
    ("t_s,accel_mps2\n0,1\n0.2,2\n0.1,3\n", "increase strictly"),
])
def test_bad_record_files(capsys, tmp_path, content, needle):
    rec = tmp_path / "rec.csv"
    if content is not None:
        rec.write_text(content)
    _assert_bad(capsys, tmp_path, ["simulate", "--block", "B3M", "--pulse", str(rec)], needle)


def test_record_with_too_coarse_dt(capsys, tmp_path):
    rec = tmp_path / "rec.csv"
    rec.write_text("0,0\n0.01,5\n0.02,0\n")
    _assert_bad(capsys, tmp_path, ["simulate", "--block", "B3M", "--pulse", str(rec), "--dt", "0.05"], "too coarse")


def test_bad_output_paths(capsys, tmp_path):
    code = main(FIG17 + ["--k", "0.7", "--plot", str(tmp_path / "x.jpg")])
    assert code == 2 and "--plot" in capsys.readouterr().err
    code = main(FIG17 + ["--k", "0.7", "--history", str(tmp_path / "nope" / "h.csv")])
    assert code == 2 and "does not exist" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_unknown_engine_suggests(capsys):
    code = main(FIG17 + ["--k", "0.7", "--engine", "refrence"])
    err = capsys.readouterr().err
    assert code == 2 and "Did you mean 'reference'" in err


def test_mode_for_other_engines_is_refused(capsys):
    code = main(FIG17 + ["--k", "0.7", "--engine", "mujoco", "--mode", "energy"])
    assert code == 2 and "reference engine only" in capsys.readouterr().err


def test_subprocess_entry_point(tmp_path):
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "rockbench.benchmark.cli.main"] + FIG17 + ["--k", "1.5"],
                       capture_output=True, text=True, env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--k" in r.stderr and r.stdout == ""


# -- failures, refusals and one-source numbers -----------------------------------------------------

def test_a_failed_simulation_exits_1(fake_engines, capsys):
    fake_engines.register_all()
    args = ["simulate", "--engine", "raising", "--set", "bad_above=0", "--block", "B3M", "--w-ratio", "6",
            "--a-ratio", "6.1"]
    assert main(args) == 1
    out = capsys.readouterr().out
    assert "FAILED: RuntimeError: engine exploded" in out
    assert main(args + ["--json"]) == 1
    o = json.loads(capsys.readouterr().out)
    assert o["outcome"] is None and o["flags"] == ["engine-error"] and not o["valid"]


@pytest.mark.parametrize("extra, needle", [
    (["--dt", "1e-15"], "steps"),
    (["--width", "1e9", "--height", "1e-9"], "lies flat"),
    (["--width", "0.3", "--height", "0.1"], "Housner's law gives η"),
    (["--width", "1e-300", "--height", "1e-300"], "mass"),
])
def test_impossible_cases_are_refused_up_front(capsys, tmp_path, extra, needle):
    base = ["simulate", "--w-ratio", "6", "--a-ratio", "6.1"] + (["--block", "B3M"] if "--width" not in extra else [])
    _assert_bad(capsys, tmp_path, base + extra, needle)


def test_a_record_that_cannot_finish_is_refused(capsys, tmp_path):
    rec = tmp_path / "rec.csv"
    rec.write_text("t_s,accel_mps2\n0,0\n1e6,1\n")
    _assert_bad(capsys, tmp_path, ["simulate", "--block", "B3M", "--pulse", str(rec)], "1e+09 steps")


def test_text_output_takes_each_number_from_the_json(capsys):
    """Counts and times in the text are the JSON's fields, each from one source."""
    args = ["simulate", "--block", "B3M", "--w-ratio", "6", "--a-ratio", "1.5", "--mode", "to-rest"]
    o = run_json(capsys, list(args))
    assert main(args) == 0
    text = capsys.readouterr().out
    assert len(o["impacts"]) > 10 and len(o["impacts"]) != o["n_impacts"]   # two quantities, two names
    assert f"{o['n_impacts']} impact(s) up to the decision" in text
    assert f"off the base at {o['t_uplift_s']:.4f} s" in text
    assert f"event record: {len(o['impacts'])} impact(s)" in text
    assert f"the first at {o['uplifts_s'][0]:.5f} s" in text
    assert f"... {len(o['impacts']) - 10} more" in text
    assert text.count("  impact at ") == 10
