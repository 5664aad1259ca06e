"""tests/measurements/bench_run_parts.py: one DART cell's parts (nothing timed is tested), and the loop's
functions put back after it."""

import pytest

from measurement_scripts import load_script


def test_dart_parts_line_counts_steps_and_segments_and_restores_the_loop():
    pytest.importorskip("dartpy")
    from rockbench.engines import loop

    stop, trajectory = loop._stop, loop.trajectory
    line = load_script("bench_run_parts").measure("dart", "shipped", "B3M:sine:3:5", runs=2)
    assert "182 steps run, 182 kept; 4 segments" in line and "judge" in line, line
    assert loop._stop is stop and loop.trajectory is trajectory
