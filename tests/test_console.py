"""A console that reads cleanly: progress in order with a fixed total, no blank lines,
no Warp line on a machine without a CUDA driver, ``rockbench engines`` in aligned columns."""

from __future__ import annotations

import subprocess
import sys
import threading

import pytest

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.suites.progress import SuiteConsole


def test_progress_counts_finished_maps_in_order_with_a_fixed_total():
    lines = []
    con = SuiteConsole(12, lines.append)

    def finish(n):
        for k in range(n):
            con.finished(f"map {k}", f"out/{k}", 0.5)

    threads = [threading.Thread(target=finish, args=(4,)) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    con.not_needed(2, "shared")
    con.not_needed(0, "nothing")
    finish(2)
    counts = [int(ln[1:ln.index("/")]) for ln in lines]
    assert counts == sorted(counts) and counts[-1] == 12 and len(set(counts)) == len(counts)
    assert all(ln.split("]")[0].endswith("/12") for ln in lines)
    assert "[10/12] 2 planned map(s) not needed: shared" in lines


def test_console_writes_no_blank_line():
    lines = []
    con = SuiteConsole(1, lines.append)
    con.line("\n\nfirst  \n\n  \nsecond\n")
    assert lines == ["first", "second"]


def test_own_eta_maps_are_planned_up_front():
    from rockbench.benchmark.suites.preparation import Preparation, _Task
    prep = object.__new__(Preparation)
    prep.own_eta = True
    prep.tasks = [_Task("mujoco", {}, "B3M", True, None), _Task("mujoco", {}, "B6L", False, None),
                  _Task("pybullet", {"restitution": "modified"}, "B3M", True, None),
                  _Task("dart", {}, "B3M", False, None, (1e-3, 5e-4), speed_only=True)]
    # a variant with its own restitution has no own-η map, nor has a task of the speed stage alone
    assert prep.own_eta_slots() == 2
    prep.own_eta = False
    assert prep.own_eta_slots() == 0


def test_engines_table_is_aligned(capsys):
    assert main(["engines"]) == 0
    lines = capsys.readouterr().out.splitlines()
    head = lines[0]
    starts = [head.index(w) for w in ("available", "version", "note")]
    for ln in lines[1:]:
        assert ln == ln.rstrip()
        for s in starts[:2]:
            assert ln[s - 2:s] == "  " and ln[s] != " ", ln   # every row's column starts under its title
        assert len(ln) <= starts[2] or ln[starts[2] - 2:starts[2]] == "  "


def test_warp_is_not_started_without_a_cuda_driver_by_the_default_suite():
    pytest.importorskip("mujoco_warp")
    from rockbench.engines.adapters.mujoco_warp import cuda_driver_present
    if cuda_driver_present():
        pytest.skip("a CUDA driver is present: Warp has nothing to warn about")
    code = ("from rockbench.benchmark.suites.model import load_suite, suite_path\n"
            "from rockbench.benchmark.suites.plan import engine_names\n"
            "import sys\n"
            "engines, notes = engine_names(load_suite(suite_path(None, True)))\n"
            "assert 'mujoco_warp' not in engines, engines\n"
            "assert 'warp' not in sys.modules or sys.modules['warp'].config.kernel_cache_dir is None\n"
            "print(notes)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "Warp" not in r.stderr and "warning" not in r.stderr.lower(), r.stderr
    assert "no CUDA device here" in r.stdout


def test_warp_asked_for_on_the_cpu_says_so_in_one_line_of_its_own():
    pytest.importorskip("mujoco_warp")
    from rockbench.engines.adapters.mujoco_warp import CPU_LINE, cuda_driver_present
    if cuda_driver_present():
        pytest.skip("a CUDA driver is present")
    code = ("import os\nos.environ.pop('ROCKBENCH_DEVICE_NOTED', None)\n"
            "from rockbench.engines.adapters.mujoco_warp import _warp\n_warp()\n_warp()\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stderr.splitlines() == [CPU_LINE]


def test_device_notes_are_said_once_before_the_maps(monkeypatch):
    import os

    from rockbench.benchmark.suites.progress import say_device_notes
    from rockbench.engines import registry
    from rockbench.engines.contract import DEVICE_NOTED_ENV

    class Gpu:
        @classmethod
        def device_note(cls):
            return "CPU only (slow): no CUDA device here"

    class Cpu:
        @classmethod
        def device_note(cls):
            return ""

    monkeypatch.delenv(DEVICE_NOTED_ENV, raising=False)
    monkeypatch.setattr(registry, "adapter_class", lambda n: {"gpu": Gpu, "cpu": Cpu}[n])
    lines = []
    say_device_notes(["cpu", "gpu"], SuiteConsole(1, lines.append))
    assert lines == ["gpu: CPU only (slow): no CUDA device here"] and os.environ[DEVICE_NOTED_ENV] == "1"


def test_console_lines_from_many_threads_stay_whole(capsys):
    """The map lanes, the reference thread and the engines' progress records print from different threads:
    every line comes out whole, none joined to another or blank (a blank line was seen once under load)."""
    import threading

    from rockbench.benchmark.suites.progress import console_line

    def burst(k):
        for i in range(300):
            console_line(f"thread {k} line {i}")

    threads = [threading.Thread(target=burst, args=(k,)) for k in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 8 * 300
    assert all(ln.startswith("rockbench: thread ") and ln.count("rockbench:") == 1 for ln in lines)
