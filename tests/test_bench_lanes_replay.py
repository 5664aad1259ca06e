"""tests/measurements/bench_lanes_replay.py's replay of a cluster run's tasks (bench_suite_cluster.py's record):
the calibrations first, the maps after the last calibration, each task to the core that frees first."""

import json

from measurement_scripts import load_script

replay = load_script("bench_lanes_replay")
CAL = replay.CALIBRATION


def test_maps_wait_for_the_last_calibration():
    tasks = [(CAL, 4.0), (CAL, 2.0), ("map_task", 3.0), ("map_task", 1.0)]
    assert replay.replay_cluster(tasks, 1) == 10.0       # one core: the tasks one after another
    assert replay.replay_cluster(tasks, 2) == 7.0        # calibrations end at 4 s; maps 4 + 3 and 4 + 1
    assert replay.replay_cluster(tasks, 8) == 7.0
    assert replay.replay_cluster([("map_task", 3.0), ("map_task", 1.0)], 2) == 3.0   # no calibration: no wait


def test_a_record_gives_its_tasks_in_order_and_the_time_outside_them(tmp_path):
    stream = [[CAL, 1.5, 5.5, 0], ["map_task", 6.0, 9.0, 0]]
    runs = [{"run": "local lanes", "wall_s": 30.0},
            {"run": "cluster, 1 worker", "wall_s": 12.0, "tasks": {"stream": stream}}]
    record = tmp_path / "r.json"
    record.write_text(json.dumps({"figures": {"runs": runs}}))
    run, tasks, outside_s = replay.cluster_tasks(record)
    assert run["wall_s"] == 12.0 and tasks == [(CAL, 4.0), ("map_task", 3.0)]
    assert outside_s == 1.5 + (12.0 - 9.0)   # no CPU recorded: wall before the first task and after the last


def test_a_record_with_each_tasks_cpu_costs_it(tmp_path):
    stream = [[CAL, 1.5, 5.5, 0, 2.5], ["map_task", 6.0, 9.0, 0, 1.25]]
    runs = [{"run": "cluster, 1 worker", "wall_s": 12.0, "client_cpu_s": 0.75, "tasks": {"stream": stream}}]
    record = tmp_path / "r.json"
    record.write_text(json.dumps({"figures": {"runs": runs}}))
    _, tasks, outside_s = replay.cluster_tasks(record)
    assert tasks == [(CAL, 2.5), ("map_task", 1.25)] and outside_s == 0.75
