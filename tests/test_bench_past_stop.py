"""The replay and table of tests/measurements/bench_past_stop.py, on made-up runs (no engine runs)."""

from measurement_scripts import load_script


def _bench():
    return load_script("bench_past_stop")


def test_fixed_segments_count_the_steps_from_each_stop_to_its_segments_end():
    # step 1 ms, segments of 0.1 s (100 steps), pulse 0.3 s; stops at 0.25 s and 0.3 s
    over, total, segments = _bench().past(1e-3, 0.1, 2.0, 1.0, [(0.25, 0.3), (0.3, 0.3)], None)
    assert (over, total, segments) == (50 + 0, 250 + 300, 3 + 3)


def test_segments_at_the_marks_end_at_the_pulses_end_and_shorter_after_it():
    # the same runs, 0.02 s after the pulse: the first stops within a 0.1 s segment that ends at the
    # pulse's end (step 300), the second at it
    over, total, segments = _bench().past(1e-3, 0.1, 2.0, 1.0, [(0.25, 0.3), (0.31, 0.3)], 0.02)
    assert (over, total, segments) == (50 + 10, 250 + 310, 3 + 4)


def test_pooled_and_table_from_rows():
    bench = _bench()
    row = {"engine": "mujoco", "block": "B3M", "dt_s": 1e-4, "runs": 2, "mean_simulated_s": 0.5, "near_segment_s": 0.04,
           "fixed": {"past_pct": 30.0, "segments_per_run": 2.0, "steps_past": 30, "steps_to_stops": 100},
           "marks": {"past_pct": 3.0, "segments_per_run": 8.0, "steps_past": 3, "steps_to_stops": 100},
           "now": {"past_pct": 2.0, "segments_per_run": 9.0, "steps_past": 2, "steps_to_stops": 100}}
    other = {**row, "block": "B8M", "now": {**row["now"], "steps_past": 6, "steps_to_stops": 200}}
    assert bench.pooled([row, other])["mujoco"]["past_pct"] == 100.0 * 8 / 300
    lines = bench.markdown_table({"near_s": 0.05, "rows": [row]}).splitlines()
    assert lines[2] == ("| mujoco | B3M | 0.1 ms | 2 | 0.500 s | 30.0 % (2.0) | 3.0 % (8.0) | at the marks (0.04 s) "
                        "| 2.0 % |")
