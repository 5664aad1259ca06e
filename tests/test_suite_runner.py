"""Suite files of `rockbench run`: the shipped ones parse, bad ones are refused with one line."""

import json
from pathlib import Path

import pytest

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.suites.model import load_suite, restitution_for, suite_path
from rockbench.benchmark.suites.plan import plan
from rockbench.benchmark.suites.runner import run_suite
from rockbench.reference_solver.errors import ConfigError


def test_shipped_suites_parse_and_plan():
    d = load_suite(suite_path(None, quick=False))
    q = load_suite(suite_path(None, quick=True))
    assert d.name == "default" and q.name == "quick"
    # eight problems: four slendernesses of the medium size × two pulses
    assert d.cases.blocks == ["B2M", "B3M", "B6M", "B8M"] and d.cases.pulses == ["sine", "cosine"]
    assert q.cases.blocks == ["B3M", "B8M"]  # one Table 1 block, one from the measured range
    assert not [j for j in plan(q, ["mujoco", "exudyn"]) if j.settings.get("calibrate_on")]   # the default suite's
    jobs = plan(d, ["mujoco", "pybullet"])
    refs = [j for j in jobs if j.engine == "reference" and not j.settings]
    # blocks × pulses × (Housner, modified average k) + Table 1's B3M and B6M × pulses × modified exact k
    assert len(refs) == 4 * 2 * 2 + 2 * 2
    planted = [j for j in jobs if j.engine == "reference" and j.settings]
    assert len(planted) == 4 * 4 * 2   # four reductions δ × four blocks × two pulses
    assert sorted({j.settings["planted_eta_factor"] for j in planted}) == [0.98, 0.99, 0.995, 1.0]
    assert {j.restitution.label for j in planted} == {"housner"} and {j.dt_s for j in planted} == {d.reference.dt_s}
    # engines × (2 variants on the four blocks + the held-out check on B2M and B8M) × pulses, and MuJoCo's
    # engine-planted variants: four δ × four blocks × two pulses
    engine_jobs = [j for j in jobs if j.engine != "reference"]
    engine_planted = [j for j in engine_jobs if j.settings.get("planted_eta_factor")]
    assert len(engine_planted) == 4 * 4 * 2 and {j.engine for j in engine_planted} == {"mujoco"}
    assert sorted({j.settings["planted_eta_factor"] for j in engine_planted}) == [0.98, 0.99, 1.01, 1.02]
    assert len(engine_jobs) - len(engine_planted) == 2 * (2 * 4 + 2) * 2
    assert {j.block for j in engine_jobs if not j.settings.get("calibrate_on")} == {"B2M", "B3M", "B6M", "B8M"}
    held = [j for j in jobs if j.settings.get("calibrate_on")]
    assert {j.block for j in held} == {"B2M", "B8M"} and {j.settings["calibrate_on"] for j in held} == {"neighbour"}
    assert len({j.subdir for j in jobs}) == len(jobs)
    assert {j.restitution.label for j in refs if j.block == "B3M"} == {"housner", "modified(k=0.8608)",
                                                                        "modified(k=0.7595)"}
    assert {j.restitution.label for j in refs if j.block == "B2M"} == {"housner", "modified(k=0.8608)"}
    assert {j.settings["settings"] for j in jobs if j.engine == "mujoco"} == {"calibrated", "shipped"}


def test_newton_suite_has_one_variant_per_solver():
    """`rockbench run newton`: each of Newton's solvers a variant of its own, named in the map folder
    and in the variant's words."""
    from rockbench.benchmark.scoring.labels import variant_label
    s = load_suite(suite_path("newton", False))
    jobs = [j for j in plan(s, ["newton"]) if j.engine == "newton"]
    solvers = {j.settings["solver"] for j in jobs}
    assert solvers == {"xpbd", "semi_implicit", "featherstone", "vbd"}
    assert len(jobs) == 4 * 2 * 2 and len({j.subdir for j in jobs}) == len(jobs)
    assert {variant_label("newton", j.settings, restitution="housner").split(", ")[-1] for j in jobs} == \
        {"XPBD solver", "semi-implicit solver", "Featherstone solver", "VBD solver"}


def test_restitution_tokens():
    assert restitution_for("modified-exact", "B6L").k == 0.7214
    assert restitution_for("modified:0.5", "B6L").k == 0.5
    assert restitution_for("0.9", "B6L").value == 0.9
    with pytest.raises(ConfigError, match="not one of"):
        restitution_for("bouncy", "B3M")


@pytest.mark.parametrize("text, match", [
    ("[grid]\nw_ratio = '1:2:3'\na_ratio = '1:2:3'\n[colours]\nx = 1\n", "unknown table"),
    ("[grid]\nw_ratio = '1:2:3'\na_ratio = '1:2:3'\nzoom = 2\n", "unknown key grid.zoom"),
    ("[grid]\nw_ratio = 5\na_ratio = '1:2:3'\n", "grid.w_ratio must be a string"),
    ("[grid]\nw_ratio = '1:2:3'\na_ratio = '1:2:3'\n[cases]\nblocks = ['B9X']\n", "unknown block"),
    ("[grid]\nw_ratio = '1:2:3'\na_ratio = '1:2:3'\n[cases]\npulses = ['square']\n", "cases.pulses"),
    ("[grid]\nw_ratio = '1:2:3'\na_ratio = '1:2:3'\n[engines]\nnames = 3\n", "engines.names"),
    ("[grid\n", "not valid TOML"),
    ("[grid]\nw_ratio = '1:16:11'\na_ratio = '1:12:9'\n[reference]\ndt_s = true\n",
     "reference.dt_s must be a number of seconds > 0, got True."),
])
def test_bad_suites(tmp_path, text, match):
    p = tmp_path / "s.toml"
    p.write_text(text)
    with pytest.raises(ConfigError, match=match):
        load_suite(p)


@pytest.mark.parametrize("text, line", [
    ("[grid]\nw_ratio = 5\na_ratio = '1:2:3'\n", "suite s.toml: grid.w_ratio must be a string LO:HI:N, got 5."),
    ("[grid]\nw_ratio = '1:16:11'\na_ratio = '1:12:9'\n[engines]\nvariants = [{}, {restitution = 'nope'}]\n",
     "suite s.toml: engines.variants[1].restitution: restitution 'nope' is not one of housner, modified-average, "
     "modified-exact, modified:K or a number in (0, 1]."),
    ("[grid]\nw_ratio = '1:16:11'\na_ratio = '1:12:9'\ncoarse_stride = 0\n",
     "suite s.toml: grid.coarse_stride must be a whole number >= 1, got 0."),
    ("[grid]\nw_ratio = '1:16:11'\na_ratio = '1:12:9'\nlocate_depth = 13\n",
     "suite s.toml: grid.locate_depth must be a whole number from 0 to 12 (rounds of bisection of each boundary "
     "edge), got 13."),
    ("[grid]\nw_ratio = '16:1:5'\na_ratio = '1:2:3'\n",
     "suite s.toml: grid.w_ratio range is reversed (16 > 1); give LO:HI:N with LO < HI."),
])
def test_a_bad_suite_is_one_line_in_the_words_of_its_key(tmp_path, text, line):
    """The typed model (pydantic) words each problem as the suite's own rule does, nothing of pydantic's."""
    p = tmp_path / "s.toml"
    p.write_text(text)
    with pytest.raises(ConfigError) as e:
        load_suite(p)
    assert str(e.value) == line


def test_run_cli_usage(tmp_path, capsys):
    assert main(["run", "--plan", "--quick", "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "maps/reference/B3M-sine-housner" in out and not (tmp_path / "o").exists()
    assert main(["run", str(tmp_path / "missing.toml")]) == 2
    assert main(["run", "nosuchsuite"]) == 2
    assert main(["run", "default", "--quick"]) == 2
    assert main(["run", "--quick", "--jobs", "0"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 4


def test_each_variant_keeps_one_pool_and_stops_it_after_its_last_map(fake_engines, tmp_path, monkeypatch):
    from rockbench.benchmark.maps import executors
    from rockbench.benchmark.suites.runner import run_suite

    fake_engines.register_all()
    (tmp_path / "s.toml").write_text(
        "[suite]\nname = 't'\n[grid]\nw_ratio = '1:8:5'\na_ratio = '1:9:5'\n"
        "[cases]\nblocks = ['B3M', 'B6L']\npulses = ['sine']\n[reference]\nrestitutions = ['housner']\n"
        "[engines]\nnames = ['analytic']\nvariants = [{ sleep_s = 0.0 }, { sleep_s = 1e-4 }]\nown_eta = false\n")
    logs = []
    real = executors.make_executor

    def spy(engine, settings, **kw):
        ex = real(engine, settings, **kw)
        if engine != "reference":
            name = f"{engine} {settings['sleep_s']}"
            logs.append(f"open {name}")
            close = ex.close
            ex.close = lambda: (logs.append(f"close {name}"), close())
        return ex

    monkeypatch.setattr(executors, "make_executor", spy)
    res = run_suite(load_suite(tmp_path / "s.toml"), tmp_path / "out", jobs=1, report=False, log=logs.append)
    assert len(res["maps"]) == 2 + 2 * 2           # reference, and the two variants' two maps each
    seen = [m.split(" → ")[0].split(" B")[0] if m.startswith("[") else m for m in logs
            if m.startswith(("[", "open", "close"))]
    # the reference maps are computed by their own thread, beside the engine maps
    # [k/6]: k counts finished maps, in order whichever thread finished them
    assert [int(m[1:m.index("/")]) for m in seen if m.startswith("[")] == [1, 2, 3, 4, 5, 6]
    assert sum(m.endswith("reference") for m in seen) == 2
    assert [m.split("] ")[-1] for m in seen if not m.endswith("reference")] == [
        "open analytic 0.0", "analytic", "analytic", "close analytic 0.0",
        "open analytic 0.0001", "analytic", "analytic", "close analytic 0.0001"]


# -- the whole suite is checked before the first map, and --plan fails the same way -------------

GRID = "[grid]\nw_ratio = '1:16:11'\na_ratio = '1:12:9'\n[cases]\nblocks = ['B3M']\npulses = ['sine']\n"


@pytest.mark.parametrize("extra, needle", [
    ("[report]\ncases = ['nonsense']\n", "report.cases"),
    ("[report]\ncases = ['B9X:sine:6:6.1']\n", "report.cases"),
    ("[report]\ncases = ['B3M:sine:6:-1']\n", "report.cases"),
    ("[report]\nexperiments = 'no-such-file.csv'\n", "report.experiments"),
    ("[run]\ncell_timeout_s = true\n", "run.cell_timeout_s"),
    ("[engines]\nnames = ['analytic']\nvariants = [{ foo = 1 }]\n", "engines.variants[0]"),
    ("[engines]\nnames = ['mujoco']\nvariants = [{ friction = -1 }]\n", "engines.variants[0]"),
    ("[reference]\nrestitutions = []\n", "reference.restitutions is empty"),
    ("[reference]\nrestitutions = ['1.5']\n", "reference.restitutions"),
    ("[engines]\nvariants = []\n", "engines.variants"),
    ("[grid]\nadaptive = 'yes'\n", None),
])
def test_bad_suite_fails_before_the_first_map_and_in_plan(fake_engines, tmp_path, capsys, extra, needle):
    fake_engines.register_all()
    text = GRID + extra if not extra.startswith("[grid]") else GRID.replace("[cases]", extra.split("\n", 1)[1] + "[cases]")
    p = tmp_path / "s.toml"
    p.write_text(text)
    for args in (["run", str(p), "--plan"], ["run", str(p), "--out", str(tmp_path / "out")]):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "s.toml" in err and "--case" not in err, err
        assert needle is None or needle in err, err
    assert not (tmp_path / "out").exists()     # nothing computed, nothing written


@pytest.mark.parametrize("grid, needle", [("'1:16'", "LO:HI:N"), ("'16:1:5'", "reversed"),
                                          ("'1:16:100000'", "cells")])
def test_bad_suite_grids(tmp_path, capsys, grid, needle):
    p = tmp_path / "s.toml"
    p.write_text(f"[grid]\nw_ratio = {grid}\na_ratio = '1:12:100000'\n")
    assert main(["run", str(p), "--plan"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err and "grid" in err, err


@pytest.mark.parametrize("key", ["pulses", "blocks"])
def test_empty_case_lists(tmp_path, capsys, key):
    p = tmp_path / "s.toml"
    p.write_text(GRID.replace(f"{key} = ", f"{key} = [] #"))
    assert main(["run", str(p), "--plan"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"cases.{key} is empty" in err and err.count("s.toml") == 1, err


def test_a_folder_is_never_a_suite_file(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "quick").mkdir()          # e.g. the output of an earlier `run --quick --out quick`
    (tmp_path / "default").mkdir()
    assert suite_path("quick", False).name == "quick.toml" and "suites" in str(suite_path("quick", False))
    assert suite_path(None, True).name == "quick.toml"
    assert main(["run", "--quick", "--out", "quick", "--plan"]) == 0
    assert main(["run", "default", "--plan"]) == 0
    capsys.readouterr()
    (tmp_path / "d.toml").mkdir()
    assert main(["run", "d.toml", "--plan"]) == 2
    assert "is a folder" in capsys.readouterr().err
    (tmp_path / "mysuite").write_text(GRID)
    assert main(["run", "mysuite", "--plan"]) == 2        # a bare name is a shipped suite's
    assert "./mysuite" in capsys.readouterr().err
    assert main(["run", "./mysuite", "--plan"]) == 0


def test_run_engines_option(fake_engines, tmp_path, capsys):
    fake_engines.register_all()
    p = tmp_path / "s.toml"
    p.write_text(GRID + "[engines]\nvariants = [{ sleep_s = 0.0 }]\n")
    assert main(["run", str(p), "--plan", "--engines", "analytic"]) == 0
    out = capsys.readouterr().out
    assert "maps/analytic-sleep-s=0.0/B3M-sine-housner" in out and "maps/reference/B3M-sine-housner" in out
    assert "raising" not in out and "mujoco" not in out
    assert main(["run", str(p), "--plan", "--engines", "analytc"]) == 2
    assert "Did you mean 'analytic'" in capsys.readouterr().err
    assert main(["run", str(p), "--plan", "--engines", ""]) == 2
    capsys.readouterr()
    res = run_suite(load_suite(p), tmp_path / "out", jobs=1, report=False, engines=["analytic"], log=lambda m: None)
    assert {m["label"].split()[0] for m in res["maps"]} == {"reference", "analytic"}


def _rows(d):
    import csv
    with open(d / "cells.csv", newline="") as f:
        # every column but the times (wall_s and the cost, cpu_s and simulated_s: a time too, here its CPU's)
        return {(r["i"], r["j"]): {k: v for k, v in r.items() if k not in ("wall_s", "cpu_s")} for r in csv.DictReader(f)}


def test_lanes_and_helpers_give_what_one_worker_gives(fake_engines, tmp_path):
    """Engine maps on two lanes at once and the η measured by two helpers: the same maps, cell for
    cell, and the same calibration.json as one worker doing everything in turn; each η measured once,
    and not again on a rerun."""
    from rockbench.benchmark.suites.runner import run_suite

    fake_engines.register_all()
    log = tmp_path / "measured.txt"
    (tmp_path / "s.toml").write_text(
        "[suite]\nname = 't'\n[grid]\nw_ratio = '1:8:9'\na_ratio = '1:9:9'\nadaptive = true\ncoarse_stride = 2\n"
        "[cases]\nblocks = ['B3M', 'B6L']\npulses = ['sine', 'cosine']\n[reference]\nrestitutions = ['housner']\n"
        "[engines]\nnames = ['analytic-eta']\nvariants = [{ sleep_s = 0.0, work_s = 0.2, log_path = '%s' }, "
        "{ sleep_s = 1e-4, work_s = 0.2, log_path = '%s' }]\nown_eta = true\n" % (log, log))
    suite = load_suite(tmp_path / "s.toml")
    said = []
    one = run_suite(suite, tmp_path / "one", jobs=1, report=False, log=lambda m: None)
    two = run_suite(suite, tmp_path / "two", jobs=2, report=False, log=said.append)
    # [k/N]: N planned before the first map, own-η reference maps included; k in order
    prog = [m for m in said if m.startswith("[")]
    assert [m.split("]")[0] for m in prog] == [f"[{k}/20" for k in range(1, 21)]
    assert [m["label"] for m in one["maps"]] == [m["label"] for m in two["maps"]]
    assert len(one["maps"]) == 4 + 2 * 4 + 2 * 2 * 2    # reference, engine maps, own-η reference maps
    for m1, m2 in zip(one["maps"], two["maps"]):
        d1, d2 = Path(m1["dir"]), Path(m2["dir"])
        assert d1.relative_to(tmp_path / "one") == d2.relative_to(tmp_path / "two")
        assert _rows(d1) == _rows(d2), d1.name
    cal1 = json.loads((tmp_path / "one" / "calibration.json").read_text())
    cal2 = json.loads((tmp_path / "two" / "calibration.json").read_text())
    assert cal1 == cal2 and len(cal1["measurements"]) == 4
    lines = log.read_text().splitlines()
    assert len(lines) == 2 * 4                          # each variant × block once per run
    run_suite(suite, tmp_path / "two", jobs=2, report=False, log=lambda m: None)
    assert len(log.read_text().splitlines()) == 8       # the rerun reuses calibration.json


def test_a_lane_whose_workers_cannot_start_stops_that_engine_and_the_suite_goes_on(fake_engines, tmp_path,
                                                                                  monkeypatch):
    """Workers that cannot start their engine stop that engine (its other maps are skipped,
    one line says why, `run` exits 3), whichever lane meets them first; nothing hangs, and the
    reference maps and the scores still come out."""
    import os

    from rockbench.benchmark.maps import executors
    from rockbench.benchmark.suites.runner import run_suite

    fake_engines.register_all()
    monkeypatch.setenv("RB_TEST_PARENT_PID", str(os.getpid()))
    monkeypatch.setattr(executors.ProcessExecutor, "START_TIMEOUT_S", 1.0)
    (tmp_path / "s.toml").write_text(
        "[suite]\nname = 't'\n[grid]\nw_ratio = '1:8:5'\na_ratio = '1:9:5'\n"
        "[cases]\nblocks = ['B3M', 'B6L']\npulses = ['sine', 'cosine']\n[reference]\nrestitutions = ['housner']\n"
        "[engines]\nnames = ['hanging-start']\nown_eta = false\n")
    res = run_suite(load_suite(tmp_path / "s.toml"), tmp_path / "out", jobs=2, report=False, log=lambda m: None)
    (line,) = res["cannot_simulate"]
    assert "engine 'hanging-start' cannot simulate: starting it failed with" in line and "keep dying at start" in line
    assert len(res["maps"]) == 4                     # the four reference maps; no engine map was recorded


def test_engines_include_takes_an_engine_that_leaves_every_available_suite(tmp_path, monkeypatch):
    """engines.include: an engine whose default_suite_exclusion leaves "available" suites (MuJoCo Warp
    without a CUDA device)
    takes part anyway; a name rockbench does not know, or include beside a list of names, is one line."""
    from rockbench.engines.adapters.pybullet import PybulletAdapter
    from rockbench.benchmark.suites.plan import engine_names
    monkeypatch.setattr(PybulletAdapter, "default_suite_exclusion", classmethod(lambda cls: "slow here (test)"))
    p = tmp_path / "s.toml"
    p.write_text(GRID)
    picked, notes = engine_names(load_suite(p))
    assert "pybullet" not in picked and any("pybullet skipped: slow here (test)" in n for n in notes)
    p.write_text(GRID + '[engines]\ninclude = ["pybullet"]\n')
    picked, notes = engine_names(load_suite(p))
    assert "pybullet" in picked and not any("pybullet" in n for n in notes)
    p.write_text(GRID + '[engines]\ninclude = ["pybulet"]\n')
    with pytest.raises(ConfigError, match="engines.include names engine 'pybulet'"):
        engine_names(load_suite(p))
    for extra, needle in (('names = ["mujoco"]\ninclude = ["pybullet"]\n', "engines.include goes with names"),
                          ('include = ["pybullet"]\nexclude = ["pybullet"]\n', "in both engines.exclude and")):
        p.write_text(GRID + "[engines]\n" + extra)
        with pytest.raises(ConfigError, match=needle):
            load_suite(p)


def _engines_section(text: str) -> str:
    return text[text.index("[engines]"):text.index("[run]")]


@pytest.mark.parametrize("name", ["default", "quick"])
def test_a_shipped_suite_leaves_an_engine_out_only_by_name_and_says_why(name):
    """The default and quick suites take every available engine; one left out for time is
    named in the suite's own engines.exclude, and the comment beside it gives the reason (the
    measured cost), so the report's note and the file both say it, never the adapter alone."""
    path = suite_path(name, False)
    section = _engines_section(path.read_text())
    comment = " ".join(line for line in section.splitlines() if line.lstrip().startswith("#"))
    suite = load_suite(path)
    assert suite.engines.names == "available"
    for engine in suite.engines.exclude:
        assert engine in comment.lower(), f"{name}.toml leaves {engine} out without saying why"


def test_only_mujoco_warp_leaves_suites_of_every_engine_by_itself():
    """An adapter's own default_suite_exclusion is for what depends on the machine (MuJoCo
    Warp without a CUDA device); Newton's blanket rule on a CPU is gone, and whether an engine's cost
    fits a suite's budget is the suite file's to say."""
    from rockbench.engines.contract import EngineAdapter
    from rockbench.engines.registry import BUILTIN, adapter_class
    own = {n for n in BUILTIN if n != "reference"
           and adapter_class(n).default_suite_exclusion.__func__ is not EngineAdapter.default_suite_exclusion.__func__}
    assert own == {"mujoco_warp"}


# -- what a suite declares for its verdict ------------------------------------------------------------------

def test_the_code_defaults_are_the_default_suites_declarations():
    """`rockbench score` of a folder without a suite uses the code's declarations: those of the default
    suite, every shipped suite declares the same."""
    from rockbench.benchmark.scoring.declared import DEFAULTS
    for name in ("default", "quick", "full", "newton"):
        s = load_suite(suite_path(name, False))
        assert s.verdict == DEFAULTS and s.verdict.source == f"the suite {name!r}"


@pytest.mark.parametrize("table, line", [
    ("fail_distance = 0", "suite s.toml: verdict.fail_distance must be \"largest-restitution-gap\" or a number > 0 "
                          "in the normalised plane, got 0."),
    ("fail_distance = 'far'", "suite s.toml: verdict.fail_distance must be \"largest-restitution-gap\" or a number > 0 "
                              "in the normalised plane, got 'far'."),
    ("equivalence_margin = 'restitution'",
     "suite s.toml: verdict.equivalence_margin must be \"restitution-gap\" or a number > 0, got 'restitution'."),
    ("held_out_margin = -0.05",
     "suite s.toml: verdict.held_out_margin must be \"half-restitution-gap\" or a number > 0 in the normalised "
     "plane, got -0.05."),
    ("general_range_h_over_b = [6.0, 1.5]",
     "suite s.toml: verdict.general_range_h_over_b must be [lo, hi], two slendernesses h/b with 0 < lo < hi, "
     "got [6.0, 1.5]."),
    ("confidence = 0.9", "suite s.toml: unknown key verdict.confidence; [verdict] takes equivalence_margin, "
                         "fail_distance, general_range_h_over_b, held_out_margin."),
])
def test_a_bad_verdict_table_is_one_line(tmp_path, capsys, table, line):
    p = tmp_path / "s.toml"
    p.write_text(GRID + "[verdict]\n" + table + "\n")
    with pytest.raises(ConfigError) as e:
        load_suite(p)
    assert str(e.value) == line
    assert main(["run", str(p), "--plan", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.strip() == f"rockbench: error: {line}" and not (tmp_path / "o").exists()


def test_a_run_records_its_declarations_and_a_rescore_reads_them(fake_engines, tmp_path, capsys):
    """The suite's [verdict] reaches score.json as ``declared``, suite.json records it, and `rockbench
    score` of the run folder reads it back; the code's defaults fill what the table leaves out."""
    fake_engines.register_all()
    (tmp_path / "s.toml").write_text(
        "[suite]\nname = 't'\n[grid]\nw_ratio = '1:8:5'\na_ratio = '1:9:5'\n"
        "[cases]\nblocks = ['B3M']\npulses = ['sine']\n[reference]\nrestitutions = ['housner']\n"
        "[engines]\nnames = ['analytic']\nown_eta = false\n[verdict]\nfail_distance = 5.0\nheld_out_margin = 0.1\n")
    res = run_suite(load_suite(tmp_path / "s.toml"), tmp_path / "out", jobs=1, report=False, log=lambda m: None)
    declared = res["score"].verdict.declared
    assert declared["fail_distance"] == 5.0 and declared["held_out_margin"] == 0.1
    assert declared["equivalence_margin"] == "restitution-gap" and declared["source"] == "the suite 't'"
    recorded = json.loads((tmp_path / "out" / "suite.json").read_text())["verdict_declared"]
    assert recorded["fail_distance"] == 5.0
    assert main(["score", str(tmp_path / "out"), "--no-write", "--json"]) == 0
    out, err = capsys.readouterr()
    again = json.loads(out)["verdict"]["declared"]
    assert again["fail_distance"] == 5.0 and "its run's suite.json" in again["source"]
    assert "code's defaults" not in err


def test_a_block_without_a_measured_k_skips_the_exact_k_reference_with_a_note(tmp_path, capsys):
    """B2M (not in Table 1) has no exact k: its modified-exact reference map is skipped, and the plan (and the
    run, and its report) say so in one note; an engine variant calibrated to it there is refused in one line."""
    p = tmp_path / "s.toml"
    p.write_text("[grid]\nw_ratio = '1:16:5'\na_ratio = '1:12:5'\n[cases]\nblocks = ['B2M', 'B3M']\npulses = ['sine']\n"
                 "[reference]\nrestitutions = ['housner', 'modified-exact']\n[engines]\nnames = []\n")
    s = load_suite(p)
    refs = [(j.block, j.restitution.label) for j in plan(s, []) if j.engine == "reference"]
    assert refs == [("B2M", "housner"), ("B3M", "housner"), ("B3M", "modified(k=0.7595)")]
    assert main(["run", str(p), "--plan", "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    assert ("rockbench: no modified-exact reference map for B2M: it is not in Table 1 (paper's measured range) and "
            "has no measured k (only Table 1's B3M, B6M, B3L, B6L have one)") in err
    p.write_text(p.read_text().replace("names = []", "names = []\nvariants = [{ restitution = 'modified-exact' }]"))
    with pytest.raises(ConfigError) as e:
        load_suite(p)
    assert str(e.value) == ("suite s.toml: engines.variants[0].restitution: restitution 'modified-exact' is not defined "
                            "for block B2M, which is not in Table 1 (paper's measured range) and has no measured k; map "
                            "it with another restitution, or keep the variant to Table 1's blocks (B3M, B6M, B3L, B6L) "
                            "with its blocks key.")
    p.write_text(p.read_text().replace("{ restitution = 'modified-exact' }",
                                       "{ restitution = 'modified-exact', blocks = ['B3M'] }"))
    assert [j.block for j in plan(load_suite(p), ["mujoco"]) if j.engine == "mujoco"] == ["B3M"]
