"""tests/measurements/bench_native_floor.py: its table on a made-up record, and one engine's product and
native loop giving the same θ history (DART as shipped, one overturning cell; nothing timed is tested)."""

import pytest

from measurement_scripts import load_script


def _bench():
    return load_script("bench_native_floor")


def _row(engine, cell, sim_s, product, native, **kw):
    return {"engine": engine, "settings": "calibrated", "cell": cell, "dt_s": 1e-4, "simulated_s": sim_s,
            "product_cpu_s_per_sim_s": product, "native_cpu_s_per_sim_s": native, "ratio": product / native, **kw}


def test_table_sums_cells_by_simulated_time_and_leaves_out_failed_loops():
    """Figures of each engine and settings are totals over its cells; a step per block where they differ."""
    rows = [_row("mujoco", "B3M:sine:3:5", 1.0, 0.2, 0.1, batch_worlds=8, product_batched_cpu_s_per_sim_s=0.1),
            _row("mujoco", "B8M:sine:3:1.5", 3.0, 0.4, 0.4, batch_worlds=8, product_batched_cpu_s_per_sim_s=0.2),
            _row("dart", "B3M:sine:3:5", 1.0, 0.3, 0.2),
            {"engine": "drake", "settings": "calibrated", "cell": "B3M:sine:3:5", "native_error": "KeyError: 'th'"}]
    lines = _bench().markdown_table({"rows": rows}).splitlines()
    assert len(lines) == 4
    # mujoco: product (0.2 + 1.2)/4 = 0.35, native (0.1 + 1.2)/4 = 0.325, batched (0.1 + 0.6)/4 = 0.175
    assert lines[2] == "| mujoco | calibrated | 0.1 ms | 0.35 | 0.325 | 1.08 (2.00) | 0.175 (8 worlds) | 0.54 |"
    assert lines[3] == "| dart | calibrated | 0.1 ms | 0.3 | 0.2 | 1.50 (1.50) | – (one world at a time) | – |"
    rows[1]["dt_s"] = 1e-3
    assert "| 0.1 ms (B3M), 1 ms (B8M) |" in _bench().markdown_table({"rows": rows})


def test_parts_table_gives_the_rest_of_run_many():
    rows = [_row("dart", "B3M:sine:3:5", 1.0, 0.3, 0.2, product_cpu_s=[0.006, 0.005], native_cpu_s=[0.002],
                 product_parts={"posed_cpu_s": 0.001, "loop_cpu_s": 0.003})]
    lines = _bench().parts_table({"rows": rows}).splitlines()
    assert lines[2] == "| dart | calibrated | 5.00 | 1.00 | 3.00 | 1.00 | 2.00 |"


def test_a_bad_cell_is_one_line_and_exit_2(capsys):
    with pytest.raises(SystemExit) as e:
        _bench().main(["--cells", "B3M:sine:3"])
    assert e.value.code == 2 and "bad cell 'B3M:sine:3'" in capsys.readouterr().err


def test_warmup_calls_are_untimed():
    """``warmup`` calls run before the timed ones and are not among the times."""
    calls = []
    times, out = _bench().cpu_times(lambda given: calls.append(given) or len(calls), 2, lambda: "x", warmup=3)
    assert calls == ["x"] * 5 and len(times) == 2 and out == 5


def test_a_negative_warmup_is_one_line_and_exit_2(capsys):
    with pytest.raises(SystemExit) as e:
        _bench().main(["--warmup", "-1"])
    assert e.value.code == 2 and "--warmup at least 0" in capsys.readouterr().err


def test_dart_product_and_native_loop_agree():
    pytest.importorskip("dartpy")
    b = _bench()
    row = b.measure_cell("dart", "shipped", "B3M:sine:3:5", repeats=1)
    assert "native_error" not in row and row["outcome"] == "overturn"
    assert b.agrees(row, 1e-9), row


def test_worlds_table_totals_cells_and_compares_with_the_native_loop_alone():
    """A world's cost at each number of worlds, over the native loop's one world; the largest |Δθ| from alone."""
    def worlds(native_1, native_4, product_4=None, alone=0.0):
        four = {"worlds": 4, "native_cpu_s_per_sim_s": native_4, "theta_diff_from_alone_rad": alone}
        if product_4 is not None:
            four["product_cpu_s_per_sim_s"] = product_4
        return [{"worlds": 1, "product_cpu_s_per_sim_s": 2 * native_1, "native_cpu_s_per_sim_s": native_1,
                 "theta_diff_from_alone_rad": 0.0}, four]
    rows = [_row("drake", "B3M:sine:3:5", 1.0, 0.2, 0.1, worlds=worlds(0.1, 0.05, 0.06, 1e-15)),
            _row("drake", "B8M:sine:3:1.5", 3.0, 0.4, 0.3, worlds=worlds(0.3, 0.1, 0.12)),
            _row("dart", "B3M:sine:3:5", 1.0, 0.3, 0.2, worlds=worlds(0.2, 0.3, alone=1e-9))]
    lines = _bench().worlds_table({"rows": rows}).splitlines()
    # drake one world: native (0.1 + 0.9)/4 = 0.25, product 0.5; four: native (0.05 + 0.3)/4, product (0.06 + 0.36)/4
    assert lines[2] == "| drake | calibrated | 1 | 0.5 | 0.25 | 2.00 | 1.00 | 0 |"
    assert lines[3] == "| drake | calibrated | 4 | 0.105 | 0.0875 | 0.42 | 0.35 | 1e-15 |"
    assert lines[5] == "| dart | calibrated | 4 | one world a batch | 0.3 | – | 1.50 | 1e-09 |"


def test_physx_loop_of_many_worlds_agrees_with_the_product_and_with_one_world():
    """PhysX's worlds at the origin, each on its own table: one world the product's θ bit for bit; as shipped
    (TGS, float32) a world beside others within 1e-6 rad of itself alone (measured: up to 8e-7 over the
    script's cells; PGS, calibrated: 0)."""
    pytest.importorskip("sapien")
    row = _bench().measure_cell("physx", "shipped", "B3M:sine:3:5", repeats=1, ks=(1, 3))
    assert _bench().agrees(row, 1e-9), row
    assert row["worlds"][0]["theta_diff_from_alone_rad"] == 0.0 and row["worlds"][1]["theta_diff_from_alone_rad"] <= 1e-6
    assert row["worlds"][0]["theta_diff_from_product_rad"] == 0.0
