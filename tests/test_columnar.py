"""The columnar path of reference maps: arrays from the grid to cells.csv, with the same
results and the same text, cell for cell, as the per-cell path (Case and CellResult objects, rows
formatted one by one)."""

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from rockbench.benchmark.store import columnar

from rockbench.benchmark import sweep as maps
from rockbench.benchmark.store.columnar import format_rows, repr_floats
from rockbench.benchmark.maps.executors import ProcessExecutor, make_executor, worker_init
from rockbench.benchmark.maps.grid import MapSpec, make_axis
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.store.loading import load_map
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.adapters.reference import ReferenceAdapter
from rockbench.reference_solver.model import Block
from rockbench.reference_solver.restitution import Restitution
from rockbench.reference_solver.validity import contact_flag_bits, contact_flags

EDGES = [0.0, -0.0, 1.0, -1.0, 0.1, 0.2, 0.3, 1 / 3, 2 / 3, 0.5, 0.25, 0.125, 1.5, 2.5, 9.5, 1e16, 1e15, 1e-5, 1e-4,
         0.0001234, 9999999999999998.0, 123456789012345678.0, 1e22, 1e23, 5e-324, 1.5e-323, 2.2250738585072014e-308,
         2.225073858507201e-308, 1.7976931348623157e308, float(2**53), float(2**53 + 2), 4.35, 0.3 * 3, 100.0,
         123.456, 1e-7, 1e300, 1e-300, math.nan, -math.nan, math.inf, -math.inf, 35757.405004333814]


def test_floats_are_written_as_repr_writes_them():
    rng = np.random.default_rng(16)
    x = np.concatenate([EDGES, rng.random(100_000), rng.standard_normal(50_000) * 1e-4,
                        10 ** rng.uniform(-320, 308, 100_000),
                        rng.integers(0, 2**64, 100_000, dtype=np.uint64).view(np.float64),   # any bit pattern
                        np.ldexp(1.0, np.arange(-1074, 1024)), [float(f"1e{k}") for k in range(-323, 309)],
                        np.arange(0, 5000) / 8.0, np.arange(1, 5000) / 1000.0])
    assert repr_floats(x) == [repr(v) for v in x.tolist()]


def test_contact_flag_bits_is_the_one_rule():
    n = np.array([-1.0, 1.0, -1.0, 0.0, -0.0, math.nan, 0.3, 2.0])
    f = np.array([11.0, 11.0, 1.0, 10.0, 0.0, math.nan, math.inf, 10.000001])
    bits = contact_flag_bits(n, f, 10.0)
    names = ("lift-required", "slip-required")
    assert [[x for k, x in enumerate(names) if b >> k & 1] for b in bits] == \
        [contact_flags(a, b, 10.0) for a, b in zip(n, f)]


def _spec(n, block="B3M", pulse="sine", rest=None, w=(0.5, 10.0), a=(0.5, 10.0)):
    b = get_preset(block).block() if isinstance(block, str) else block
    return MapSpec(b, pulse, rest or Restitution("modified", k=0.8608), make_axis("--w-ratio", "w_ratio", *w, n),
                   make_axis("--a-ratio", "a_ratio", *a, n))


def _rows(d):
    """cells.csv by cell, every column but the times (wall_s, and the cost: the per-cell path measures the
    CPU time of its calls, the columnar path has none)."""
    with open(Path(d) / "cells.csv", newline="") as f:
        out = {}
        for r in csv.DictReader(f):
            for c in ("wall_s", "cpu_s", "simulated_s"):
                r.pop(c)
            out[(int(r["i"]), int(r["j"]))] = r
    return out


def _lines(d):
    """cells.csv's lines by cell with the times (wall_s, cpu_s, simulated_s) cut out (the text, not its parse)."""
    text = (Path(d) / "cells.csv").read_text().splitlines()
    out = {}
    for line in text[1:]:
        f = line.split(",")
        assert len(f) == 26
        out[(int(f[-2]), int(f[-1]))] = f[:17] + f[20:]
    return out


def _per_cell_path(monkeypatch):
    monkeypatch.setattr(maps, "_grid_runner", lambda executor, spec: None)


@pytest.mark.parametrize("compiled", [False, True])
@pytest.mark.parametrize("adaptive", [False, True])
def test_columnar_cells_csv_equals_per_cell_path(tmp_path, monkeypatch, adaptive, compiled):
    # B3M under strong sine waves: rest, rocking and overturn, lift-required and slip-required cells;
    # chunks this small are written by Python's repr unless the compiled writer is asked for
    if compiled:
        monkeypatch.setattr(columnar, "COMPILED_MIN_ROWS", 0)
    s = _spec(36)
    a = run_map(s, tmp_path / "columnar", serial=True, adaptive=adaptive)
    with monkeypatch.context() as m:
        _per_cell_path(m)
        b = run_map(s, tmp_path / "per-cell", serial=True, adaptive=adaptive)
    ra, rb = _rows(tmp_path / "columnar"), _rows(tmp_path / "per-cell")
    assert ra == rb
    assert _lines(tmp_path / "columnar") == _lines(tmp_path / "per-cell")
    flags = {r["flags"] for r in ra.values()}
    assert {"", "lift-required", "slip-required", "lift-required;slip-required"} <= flags
    assert {r["outcome"] for r in ra.values()} == {"rest", "rocking", "overturn"}
    for f in ("outcome", "simulated", "n_impacts", "max_abs_theta_rad", "valid", "left_model"):
        assert np.array_equal(getattr(a, f), getattr(b, f), equal_nan=True), f
    back = load_map(tmp_path / "columnar")
    for f in ("outcome", "n_impacts", "max_abs_theta_rad", "valid", "left_model"):
        assert np.array_equal(getattr(back, f), getattr(a, f), equal_nan=True), f


def test_columnar_map_quotes_names_and_takes_friction(tmp_path, monkeypatch):
    """A custom block whose name needs csv quoting, a cosine pulse, another friction setting."""
    blk = Block(0.05, 0.2, name='odd, "block"')
    s = MapSpec(blk, "cosine", Restitution("constant", value=0.9), make_axis("--w-ratio", "w_ratio", 1, 8, 12),
                make_axis("--a-ratio", "a_ratio", 0.5, 8, 10), engine_settings={"friction": 2.0})
    run_map(s, tmp_path / "c", serial=True)
    with monkeypatch.context() as m:
        _per_cell_path(m)
        run_map(s, tmp_path / "p", serial=True)
    ra = _rows(tmp_path / "c")
    assert ra == _rows(tmp_path / "p")
    assert {r["block"] for r in ra.values()} == {'odd, "block"'}
    assert any(r["flags"] == "slip-required" for r in ra.values())


def test_reference_in_worker_processes_equals_columnar(tmp_path):
    s = _spec(16, pulse="cosine")
    run_map(s, tmp_path / "c", serial=True)
    ex = ProcessExecutor(worker_init("reference", {}), jobs=2)
    try:
        run_map(s, tmp_path / "p", executor=ex)
    finally:
        ex.close()
    assert _rows(tmp_path / "c") == _rows(tmp_path / "p")


def test_resume_after_partial_columnar_map(tmp_path, monkeypatch):
    """A map killed after some chunks resumes with the rest: same rows as one run, none twice."""
    s = _spec(30)
    monkeypatch.setattr(maps, "COLUMNAR_CHUNK", 100)
    calls = []
    real = ReferenceAdapter.solve_grid

    def dying(self, *a, **k):
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return real(self, *a, **k)

    with monkeypatch.context() as m:
        m.setattr(ReferenceAdapter, "solve_grid", dying)
        with pytest.raises(KeyboardInterrupt):
            run_map(s, tmp_path / "m", serial=True)
    assert len(_rows(tmp_path / "m")) == 300
    r = run_map(s, tmp_path / "m", serial=True)
    assert r.n_resumed == 300 and r.complete
    run_map(s, tmp_path / "one", serial=True)
    lines = (tmp_path / "m" / "cells.csv").read_text().splitlines()
    assert len(lines) == 1 + 900 and _rows(tmp_path / "m") == _rows(tmp_path / "one")


def test_jobs_are_threads_for_the_reference():
    ex = make_executor("reference", {}, jobs=1)
    assert ex.describe() == {"kind": "in-process batch (the adapter's parallel batching)", "jobs": 1, "threads": 1}
    import numba
    before = numba.get_num_threads()
    with ex.threads():
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == before


def test_format_rows_refuses_failed_cells():
    with pytest.raises(ValueError):
        format_rows("a,b,c,d,e,", [["1.0"]] * 4, np.array([0]), np.array([0]), np.array([-1]), np.array([0]),
                    np.array([0]), [""], np.array([0.0]), np.array([0.0]), np.array([0.0]), np.array([0.0]),
                    np.array([0.0]), "0.0")


def test_small_chunks_are_written_by_python_with_the_same_text(monkeypatch):
    """Below COMPILED_MIN_ROWS rows, format_rows uses repr; both writers give the same bytes on every
    kind of double (the edge cases, random bit patterns), NaN uplift times, every outcome and flag."""
    rng = np.random.default_rng(8)
    n = 3000
    pool = np.concatenate([EDGES, rng.integers(0, 2**64, 2000, dtype=np.uint64).view(np.float64), rng.random(500)])
    floats = [rng.choice(pool, n) for _ in range(5)]
    floats[2][rng.random(n) < 0.3] = math.nan          # t_uplift: never lifted
    axes = [[repr(float(v)) for v in rng.random(7)] for _ in range(4)]
    args = ('"my, block",b,c,d,e,', axes, rng.integers(0, 7, n), rng.integers(0, 7, n), rng.integers(0, 3, n),
            rng.integers(0, 1000, n), rng.integers(0, 4, n), ["", "lift-required", "slip-required",
                                                               "lift-required;slip-required"], *floats, "0.25")
    assert n < columnar.COMPILED_MIN_ROWS
    py = format_rows(*args)
    monkeypatch.setattr(columnar, "COMPILED_MIN_ROWS", 0)
    assert format_rows(*args) == py
    assert py.count(b"\n") == n
