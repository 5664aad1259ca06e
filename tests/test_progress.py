"""The engines' progress lines (engines/progress.py): throttled, nested activities named outermost
first, routed to the console's stderr by the command line and never to stdout; the line before a
first Warp kernel compile; a real calibration and the time-step rule saying where they are."""

from __future__ import annotations

import json
import logging

import pytest

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.cli.main import main
from rockbench.benchmark.suites.progress import ConsoleHandler, SuiteConsole, hide_engine_progress, \
    show_engine_progress
from rockbench.engines import progress
from rockbench.engines.calibration import step_rule
from rockbench.engines.contract import CellResult
from rockbench.reference_solver.restitution import housner_eta
from rockbench.engines.calibration.routine import calibrate

B3M = get_preset("B3M").block()


class Clock:
    """A clock the test moves by hand [s]."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


@pytest.fixture
def heard(monkeypatch):
    """The progress lines said during the test (a handler on the logger), the throttle's memory reset."""
    lines: list[str] = []

    class Keep(logging.Handler):
        def emit(self, record):
            lines.append(record.getMessage())

    monkeypatch.setattr(progress, "_last_said", [None])
    h = Keep()
    progress.LOGGER.addHandler(h)
    old = progress.LOGGER.level
    progress.LOGGER.setLevel(logging.INFO)
    yield lines
    progress.LOGGER.removeHandler(h)
    progress.LOGGER.setLevel(old)


def test_lines_are_throttled_and_the_first_waits_for_the_interval(heard, monkeypatch):
    clock = Clock()
    monkeypatch.setattr(progress, "clock", clock)
    monkeypatch.setattr(progress, "INTERVAL_S", 5.0)
    with progress.activity("newton: calibration of B6L"):
        progress.plan(10)
        for t in (1.0, 2.0, 4.9, 5.0, 6.0, 9.9, 10.0, 10.5):
            clock.now = 100.0 + t
            progress.advance()
    assert heard == ["newton: calibration of B6L: 4 of 10 candidates measured (5.0 s so far)",
                     "newton: calibration of B6L: 7 of 10 candidates measured (10.0 s so far)"]


def test_a_short_activity_says_nothing(heard, monkeypatch):
    clock = Clock()
    monkeypatch.setattr(progress, "clock", clock)
    with progress.activity("quick"):
        progress.plan(3)
        for _ in range(3):
            clock.now += 0.5
            progress.advance()
    progress.advance()   # none open: nothing
    assert heard == []


def test_nested_activities_are_named_outermost_first_and_never_count_past_the_plan(heard, monkeypatch):
    clock = Clock()
    monkeypatch.setattr(progress, "clock", clock)
    with progress.activity("mujoco: time-step rule for B3M at η 0.7526"):
        clock.now += 70.0
        with progress.activity("ladder step 4 of 4 (0.1 ms)"):
            with progress.activity("calibration of B3M to η 0.7526 at Δt 0.1 ms"):
                progress.plan(2)
                progress.advance(5)
    assert heard == ["mujoco: time-step rule for B3M at η 0.7526; ladder step 4 of 4 (0.1 ms); calibration of B3M "
                     "to η 0.7526 at Δt 0.1 ms: 2 of 2 candidates measured (1 min 10 s so far)"]
    assert not progress.is_open()


def test_an_announcement_is_not_throttled_and_resets_the_throttle(heard, monkeypatch):
    clock = Clock()
    monkeypatch.setattr(progress, "clock", clock)
    with progress.activity("long"):
        clock.now += 6.0
        progress.announce("compiling")
        progress.advance()            # 0 s after the announcement: held back
        clock.now += 5.0
        progress.advance()
    assert heard == ["compiling", "long: 2 candidates measured (11.0 s so far)"]


def test_the_console_handler_writes_stderr_only_with_one_prefix(capsys):
    handler = show_engine_progress()
    try:
        progress.announce("newton: compiling Warp kernels")
        progress.LOGGER.info("rockbench: already prefixed")
    finally:
        hide_engine_progress(handler)
    progress.announce("not shown: the handler is gone")
    out, err = capsys.readouterr()
    assert out == ""
    assert err.splitlines() == ["rockbench: newton: compiling Warp kernels", "rockbench: already prefixed"]


def test_the_console_handler_goes_through_the_suite_console():
    lines: list[str] = []
    handler = ConsoleHandler(SuiteConsole(3, lines.append))
    progress.LOGGER.addHandler(handler)
    old = progress.LOGGER.level
    progress.LOGGER.setLevel(logging.INFO)
    try:
        progress.announce("two\n\nlines ")
    finally:
        progress.LOGGER.removeHandler(handler)
        progress.LOGGER.setLevel(old)
    assert lines == ["two", "lines"]


def test_the_time_step_rule_says_which_step_of_its_ladder_and_its_probe_cells(heard, monkeypatch):
    monkeypatch.setattr(progress, "INTERVAL_S", 0.0)
    monkeypatch.setattr(step_rule, "probe_cases", lambda block, eta: [("sine", 2.0, 1.5), ("sine", 3.0, 2.0)])
    eta = housner_eta(B3M.alpha_rad)

    def calibrate(dt):
        return type("Cal", (), {"eta_measured": eta, "reached": True})()

    def answers(cases):
        return [CellResult(outcome="rocking", valid=True) for _ in cases]

    with progress.activity("fake: time-step rule for B3M"):
        step_rule.converged_step(calibrate, answers, B3M, eta)
    n = len(step_rule.STEP_LADDER_S)
    assert heard[0].startswith(f"fake: time-step rule for B3M; ladder step {n} of {n} "
                               f"({1e3 * step_rule.STEP_LADDER_S[-1]:g} ms); probe cells: 2 of 2 run (")
    assert any(f"ladder step 1 of {n} ({1e3 * step_rule.STEP_LADDER_S[0]:g} ms)" in ln for ln in heard)


@pytest.mark.engine
def test_a_real_calibration_says_how_many_candidates_it_measured(heard, monkeypatch):
    pytest.importorskip("mujoco")
    from rockbench.engines.registry import get_adapter
    monkeypatch.setattr(progress, "INTERVAL_S", 0.0)
    c = calibrate(get_adapter("mujoco"), B3M, housner_eta(B3M.alpha_rad), dt_s=1e-3, use_cache=False)
    head = f"mujoco: calibration of B3M to η {housner_eta(B3M.alpha_rad):.4f} at Δt 1 ms: "
    assert heard and all(ln.startswith(head) and "candidates measured" in ln for ln in heard)
    assert heard[-1].startswith(head + f"{c.evaluations} of {c.evaluations} candidates measured")
    assert any(ln.startswith(head + "1 of ") for ln in heard)      # counted one by one, not only per batch


@pytest.mark.engine
def test_simulate_json_keeps_stdout_to_its_object(tmp_path, monkeypatch, capsys):
    pytest.importorskip("mujoco")
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(progress, "INTERVAL_S", 0.0)
    monkeypatch.setattr(progress, "_last_said", [None])
    rc = main(["simulate", "--engine", "mujoco", "--block", "B3M", "--w-ratio", "3", "--a-ratio", "4", "--dt", "0.001",
               "--json"])
    out, err = capsys.readouterr()
    assert rc in (0, 1)
    assert json.loads(out)["engine"] == "mujoco"
    assert "rockbench: mujoco: calibration of B3M to η" in err and "candidates measured" in err
    assert progress.LOGGER.handlers == []            # the command took its handler away


def test_a_cold_warp_kernel_cache_is_said_once(heard, monkeypatch, tmp_path):
    wp = pytest.importorskip("warp")
    from rockbench.engines.adapters import warp_start
    monkeypatch.setattr(wp.config, "kernel_cache_dir", str(tmp_path))
    monkeypatch.setattr(warp_start, "_said", set())
    assert not warp_start.kernels_cached("newton.")
    warp_start.say_first_compile("newton", "newton.")
    warp_start.say_first_compile("newton", "newton.")
    assert len(heard) == 1
    assert heard[0].startswith("newton: compiling Warp kernels (first run after install or with an empty cache, ")
    assert str(tmp_path) in heard[0]
    (tmp_path / "wp_mujoco_warp._src.smooth_439a86e").mkdir()
    assert warp_start.kernels_cached("mujoco_warp.") and not warp_start.kernels_cached("newton.")
    warp_start.say_first_compile("mujoco_warp", "mujoco_warp.")
    assert len(heard) == 1


def test_a_heartbeat_from_a_long_run_says_where_things_are_without_counting(heard, monkeypatch):
    clock = Clock()
    monkeypatch.setattr(progress, "clock", clock)
    with progress.activity("calibration"):
        progress.plan(4)
        progress.advance()
        for _ in range(3):
            clock.now += 3.0
            progress.tick()
    progress.tick()   # none open: nothing
    assert heard == ["calibration: 1 of 4 candidates measured (6.0 s so far)"]
