"""The table and record of tests/measurements/bench_step_accuracy.py, on a made-up record (no engine runs)."""

import json
import math

from measurement_scripts import load_script


def _bench():
    return load_script("bench_step_accuracy")


def _row(engine, variant, dt_s, **kw):
    base = {"engine": engine, "variant": variant, "dt_s": dt_s, "eta": 0.75, "reached": True,
            "boundary_mean": 0.1, "invalid_cells": 0, "cell_wall_s_mean": 0.012, "simulated_cells": 200}
    return {**base, **kw}


RECORD = {"rows": [_row("mujoco", "as shipped", 2e-3, eta=None, boundary_mean=15.5),
                   _row("mujoco", "calibrated", 1e-4, boundary_mean=0.05, invalid_in_domain=2, map_cpu_s=3.0),
                   _row("mujoco", "calibrated", 1e-3, reached=False, boundary_mean=0.4),
                   _row("exudyn", "calibrated", 2e-3, error="ConfigError: --dt 0.002 s is too coarse\nmore")],
          "rule_steps": [{"engine": "mujoco", "dt_s": 1e-4, "converged": False}]}


def test_table_orders_rows_and_marks_the_rule_step_and_failures():
    lines = _bench().markdown_table(RECORD).splitlines()
    body = lines[2:]
    assert len(body) == 4
    # engines in the record's order; calibrated coarsest first, then as shipped
    assert body[0].startswith("| mujoco | 1 ms | 0.7500 (not reached) | 0.400 | 0 | 12.0 | – | 200 |")
    assert body[1] == ("| mujoco | 0.1 ms (rule: no coarser step agrees) | 0.7500 | 0.050 | 0 (2) | 12.0 | 15.0 "
                       "| 200 |")
    assert body[2].startswith("| mujoco | as shipped, 2 ms | – | 15.500 |")
    rec = {**RECORD, "rule_steps": [{"engine": "mujoco", "dt_s": 1e-3, "converged": True}]}
    assert "| mujoco | 1 ms (rule) |" in _bench().markdown_table(rec)
    assert "not run: ConfigError: --dt 0.002 s is too coarse |" in body[3] and "more" not in body[3]


def test_record_is_strict_json_and_keeps_other_engines_rows():
    b = _bench()
    old = {"rows": RECORD["rows"], "rule_steps": RECORD["rule_steps"],
           "versions": {"mujoco": "4"}, "runs": [{"engines": ["mujoco"]}]}
    new = {"rows": [_row("exudyn", "calibrated", 1e-4, eta=math.nan)], "rule_steps": [],
           "versions": {"exudyn": "1"}, "runs": [{"engines": ["exudyn"]}]}
    merged = b._json_safe(b._merged(old, new, ["exudyn"]))
    assert [r["engine"] for r in merged["rows"]] == ["mujoco"] * 3 + ["exudyn"]
    assert merged["rows"][-1]["eta"] is None and merged["versions"] == {"mujoco": "4", "exudyn": "1"}
    assert len(merged["runs"]) == 2 and len(merged["rule_steps"]) == 1
    json.dumps(merged, allow_nan=False)
