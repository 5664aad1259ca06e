"""Loud failures: an engine that cannot simulate is stopped early with one line and
exit 3; the installed version against the supported range in `engines` and `check-adapter`.

The engines here are fakes (tests/maps_helpers.py): ``broken`` fails every cell with one error (as
Exudyn 1.9.0 does), ``unstartable`` cannot be set up in a worker. The supported range and the
installed version are monkeypatched (no old engine is installed by a test).
"""

from __future__ import annotations

import json
import os

import pytest

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.engine_info.health import EngineHealth, cannot_simulate_line, common_error
from rockbench.engines import support

SUITE = ("[suite]\nname = 't'\n[grid]\nw_ratio = '1:8:3'\na_ratio = '1:9:3'\n"
         "[cases]\nblocks = ['B3M', 'B6L']\npulses = ['sine']\n[reference]\nrestitutions = ['housner']\n"
         "[engines]\nnames = [{names}]\nown_eta = false\n[grid]\n")


@pytest.fixture
def old_version(monkeypatch):
    """The fake engines as a distribution ``fakedist`` 3.2.0, with ``fakedist>=3.3`` supported."""
    for name in ("broken", "unstartable", "analytic"):
        monkeypatch.setitem(support.DISTRIBUTIONS, name, ("fakedist",))
        monkeypatch.setitem(support.EXTRAS, name, "fake")
    monkeypatch.setattr(support, "_declared", lambda extra: {"fakedist": ">=3.3"} if extra == "fake" else {})
    monkeypatch.setattr(support, "version", lambda d: "3.2.0" if d == "fakedist" else "0")


def _suite(tmp_path, names):
    p = tmp_path / "s.toml"
    p.write_text(SUITE.format(names=", ".join(repr(n) for n in names)).rsplit("[grid]\n", 1)[0])
    return str(p)


def test_common_error_only_when_every_simulated_cell_failed_alike():
    same = [{"flag": "engine-error", "message": "TypeError: x"}] * 3
    assert common_error(same, 3) == "TypeError: x"
    assert common_error(same[:2], 3) is None                      # one cell worked
    assert common_error(same[:2] + [{"flag": "timeout", "message": ""}], 3) is None
    assert common_error([], 0) is None


def test_the_line_names_engine_version_error_and_range(old_version):
    line = cannot_simulate_line("broken", "TypeError: boom", "every one of the 9 simulated cells of its first map")
    assert "'broken' (fakedist 3.2.0)" in line and "TypeError: boom" in line
    assert "fakedist 3.2.0 is outside the supported range fakedist>=3.3" in line
    assert "pip install 'fakedist>=3.3'" in line and "\n" not in line


def test_health_counts_failures_per_engine_and_skips_after_a_broken_map():
    h = EngineHealth()
    h.record_map("good", [{"flag": "timeout", "message": ""}], 10)
    h.record_map("bad", [{"flag": "engine-error", "message": "E: x"}] * 4, 4)
    assert not h.skip("good") and h.skip("bad") and h.skip("bad")
    lines = h.failure_lines()
    assert lines == ["bad: 4 of 4 simulated cells failed (4 × E: x)", "good: 1 of 10 simulated cells failed (1 × timeout)"]
    (line,) = h.broken_lines()
    assert line.startswith("engine 'bad'") and line.endswith("Its other 2 maps were skipped.")


def test_run_stops_a_broken_engine_after_its_first_map_and_exits_3(fake_engines, old_version, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["run", _suite(tmp_path, ["analytic", "broken"]), "--out", str(out), "--jobs", "1", "--no-report"])
    cap = capsys.readouterr()
    assert code == 3, cap.err
    last = cap.err.strip().splitlines()[-1]
    assert last.startswith("rockbench: error: engine 'broken' (fakedist 3.2.0) cannot simulate: every one of the 9")
    assert "unexpected keyword argument 'mass'" in last and "fakedist>=3.3" in last
    assert "Its other map was skipped." in last
    # its first map is kept (and scored: failed cells are its answer), the second never ran
    broken = sorted(p.parent.name for p in (out / "maps").glob("broken*/*/cells.csv"))
    assert len(broken) == 1
    assert len(list((out / "maps").glob("analytic*/*/cells.csv"))) == 2       # the other engine ran in full
    assert (out / "score.json").exists()
    assert "failed cells: analytic: 0 of " in cap.out and "failed cells: broken: 9 of 9 simulated cells" in cap.out


def test_run_goes_on_when_an_engine_cannot_start(fake_engines, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("RB_TEST_PARENT_PID", str(os.getpid()))
    out = tmp_path / "out"
    code = main(["run", _suite(tmp_path, ["analytic", "unstartable"]), "--out", str(out), "--jobs", "1",
                 "--no-report"])
    cap = capsys.readouterr()
    assert code == 3, cap.err
    last = cap.err.strip().splitlines()[-1]
    assert "engine 'unstartable' cannot simulate: starting it failed with" in last
    assert "could not load its solver" in last
    assert len(list((out / "maps").glob("analytic*/*/cells.csv"))) == 2
    assert (out / "score.json").exists()


def test_map_where_every_cell_failed_alike_exits_3_after_writing_it(fake_engines, old_version, tmp_path, capsys):
    out = tmp_path / "m"
    code = main(["map", "--engine", "broken", "--block", "B3M", "--w-ratio", "1:8:4", "--a-ratio", "1:9:4",
                 "--out", str(out), "--jobs", "1", "--no-plot", "--json"])
    cap = capsys.readouterr()
    assert code == 3
    assert json.loads(cap.out)["counts"]["failed"] == 16          # the map is written and summarised
    assert cap.err.count("\n") == 1 and "every one of the 16 simulated cells of the map" in cap.err
    assert (out / "cells.csv").exists()


def test_map_with_some_failed_cells_still_exits_0(fake_engines, tmp_path, capsys):
    code = main(["map", "--engine", "raising", "--set", "bad_above=4", "--block", "B3M", "--w-ratio", "1:8:4",
                 "--a-ratio", "1:9:4", "--out", str(tmp_path / "m"), "--jobs", "1", "--no-plot"])
    assert code == 0, capsys.readouterr().err


def test_engines_and_check_adapter_say_when_the_version_is_outside_the_range(fake_engines, old_version, capsys):
    assert main(["engines", "--json"]) == 0
    rows = {r["engine"]: r for r in json.loads(capsys.readouterr().out)}
    assert rows["analytic"]["supported"] == "fakedist>=3.3"
    assert rows["analytic"]["outside_range"] == "fakedist 3.2.0 is outside the supported range fakedist>=3.3"
    assert rows["reference"]["outside_range"] is None
    assert main(["engines"]) == 0
    line = next(s for s in capsys.readouterr().out.splitlines() if s.startswith("analytic "))
    assert "fakedist>=3.3" in line and "outside the supported range" in line
    main(["check-adapter", "analytic"])
    err = capsys.readouterr().err
    assert "warning: fakedist 3.2.0 is outside the supported range fakedist>=3.3" in err


def test_the_ranges_come_from_the_installed_metadata():
    """The one place: pyproject's extras, as the install recorded them."""
    from importlib.metadata import PackageNotFoundError, requires
    try:
        reqs = requires("rockbench") or []
    except PackageNotFoundError:
        pytest.skip("rockbench is not installed")
    mujoco = next(r for r in reqs if r.startswith("mujoco>=") and 'extra == "mujoco"' in r)
    assert support.supported_range("mujoco") == mujoco.split(";")[0].strip()
    assert support.supported_range("reference") == ""


def test_calibrate_refuses_an_engine_outside_its_range_with_exit_3(fake_engines, old_version, capsys):
    assert main(["calibrate", "--engine", "broken", "--block", "B3M"]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "calibrating it failed with TypeError" in err and "fakedist>=3.3" in err


def test_calibrate_error_inside_the_range_stays_a_bug(fake_engines, capsys):
    assert main(["calibrate", "--engine", "broken", "--block", "B3M"]) == 70


def test_a_plugin_declares_its_range_on_its_class_and_every_command_reads_it(fake_engines, capsys):
    """An engine rockbench does not ship declares ``SUPPORTED_VERSIONS`` on its adapter class: the range
    and the installed version outside it are said as for a built-in engine (`engines`, `check-adapter`,
    the cannot-simulate line)."""
    from importlib.metadata import version

    from maps_helpers import AnalyticAdapter
    from rockbench.engines import registry

    class RangedAnalytic(AnalyticAdapter):
        name = "ranged-analytic"
        SUPPORTED_VERSIONS = {"numpy": "<1"}   # the installed NumPy is outside it

    registry.register("ranged-analytic", RangedAnalytic)
    try:
        outside = f"numpy {version('numpy')} is outside the supported range numpy<1"
        assert main(["engines", "--json"]) == 0
        row = {r["engine"]: r for r in json.loads(capsys.readouterr().out)}["ranged-analytic"]
        assert row["supported"] == "numpy<1" and row["outside_range"] == outside
        assert main(["check-adapter", "ranged-analytic"]) == 0
        assert f"warning: {outside}; pip install 'numpy<1' for a supported one." in capsys.readouterr().err
        line = cannot_simulate_line("ranged-analytic", "TypeError: boom", "starting it")
        assert f"'ranged-analytic' (numpy {version('numpy')})" in line and outside in line
        assert "install a supported version (pip install 'numpy<1')" in line
    finally:
        registry.unregister("ranged-analytic")
    assert support.supported_range("ranged-analytic") == ""   # by name alone, nothing is known
