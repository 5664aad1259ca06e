"""The Python API for notebooks: `import rockbench.benchmark`, simulate, stability_map, load_run, python -m rockbench."""

import subprocess
import sys

import numpy as np
import pytest

import rockbench.benchmark as rb
from rockbench.reference_solver.errors import ConfigError

pd = pytest.importorskip("pandas")
xr = pytest.importorskip("xarray")


def test_version_and_a_cheap_import():
    assert rb.__version__ and rb.__version__[0].isdigit()
    code = "import sys, rockbench.benchmark as rb; print(rb.__version__); print('numba' in sys.modules, 'numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out[0] == rb.__version__ and out[1:] == ["False", "False"]   # the solver loads on first use
    # the three floors stay where they were
    import importlib
    for m in ("rockbench.benchmark.cli.main", "rockbench.engines.registry", "rockbench.reference_solver.solver"):
        importlib.import_module(m)


def test_python_dash_m_is_the_cli():
    r = subprocess.run([sys.executable, "-m", "rockbench.benchmark", "blocks", "--json"], capture_output=True, text=True)
    assert r.returncode == 0 and '"B3M"' in r.stdout
    r = subprocess.run([sys.executable, "-m", "rockbench.benchmark", "--version"], capture_output=True, text=True)
    assert r.stdout.strip() == rb.__version__
    r = subprocess.run([sys.executable, "-m", "rockbench.benchmark", "simulate", "--block", "B3M"], capture_output=True,
                       text=True)
    assert r.returncode == 2 and "amplitude" in r.stderr


def test_simulate_gives_the_history_as_arrays():
    sim = rb.simulate("B3M", w_ratio=6, a_ratio=6.1, restitution="modified", k=0.7595)
    assert sim.outcome == "overturn" and sim.valid and sim.n_impacts == 1
    assert isinstance(sim.t_s, np.ndarray) and sim.t_s.shape == sim.theta_rad.shape == sim.theta_dot_rad_s.shape
    assert sim.impacts_s == pytest.approx([0.1465], abs=1e-3)
    assert sim.w_ratio == pytest.approx(6.0) and sim.a_ratio == pytest.approx(6.1)
    assert sim.eta == pytest.approx(0.8494, abs=1e-4) and sim.min_normal_mg > 0
    df = sim.to_dataframe()
    assert list(df.columns) == ["t_s", "theta_rad", "theta_dot_rad_s"] and len(df) == sim.t_s.size


def test_simulate_plot_runs_past_the_pulse_to_the_decisive_impact():
    sims = [rb.simulate("B3M", w_ratio=6, a_ratio=6.1, restitution="modified", k=k) for k in (0.8608, 0.7595)]
    assert [s.outcome for s in sims] == ["rocking", "overturn"]
    assert sims[0].t_s[-1] == pytest.approx(sims[0].t_pulse_end_s, abs=2e-3)   # the energy decision stops early
    drawn = [s.plot() for s in sims]
    # both pictures span the same time and show the impact just before 0.15 s
    assert drawn[0]["ax"].get_xlim() == pytest.approx(drawn[1]["ax"].get_xlim())
    for d in drawn:
        (line,) = d["lines"].values()
        assert line.get_xdata()[-1] > 0.3
        (marks,) = d["impacts"].values()
        assert marks.get_xdata()[0] == pytest.approx(0.1465, abs=1e-3)


def test_simulate_names_keywords_in_its_errors():
    with pytest.raises(ConfigError, match="a_ratio="):
        rb.simulate("B3M", w_ratio=6)
    with pytest.raises(ConfigError, match="w_ratio="):
        rb.simulate("B3M", w_ratio=6, omega=3, a_ratio=2)
    with pytest.raises(ConfigError, match="no setting .bogus_setting"):
        rb.simulate("B3M", w_ratio=6, a_ratio=2, bogus_setting=1)


def test_stability_map_as_a_dataset_and_a_tidy_frame():
    ds = rb.stability_map("B3M", w_ratio=(1, 12, 12), a_ratio=(1, 10, 10))
    assert isinstance(ds, xr.Dataset) and dict(ds.sizes) == {"a_ratio": 10, "w_ratio": 12}
    assert ds.w_ratio.values[[0, -1]] == pytest.approx([1, 12]) and ds.a_ratio.attrs["long_name"] == "a₀/(g·tanα)"
    assert set(np.unique(ds.outcome.values)) <= {"rest", "rocking", "overturn"}
    assert ds.outcome_code.attrs["flag_meanings"] == "missing failed rest rocking overturn"
    assert ds.attrs["engine"] == "reference" and ds.attrs["block"] == "B3M" and not ds.filled.any()
    # the reference's own domain is in it: lift-/slip-required cells are not valid and left the model
    assert bool((~ds.valid == ds.left_model).all())
    df = rb.stability_map("B3M", w_ratio=(1, 12, 12), a_ratio=(1, 10, 10), output="dataframe")
    assert len(df) == 120 and isinstance(df.outcome.dtype, pd.CategoricalDtype)
    assert list(df.outcome.cat.categories) == ["rest", "rocking", "overturn", "failed", "missing"]
    assert (df.outcome.astype(str).to_numpy().reshape(10, 12) == ds.outcome.values).all()
    with pytest.raises(ConfigError, match="output"):
        rb.stability_map("B3M", output="csv")


def test_load_run_reads_maps_and_scores(write_map, band, tmp_path):
    from rockbench.benchmark.cli.main import main
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
    a = (0.5, 1.5)   # a step of 0.2: one row off is within the declared fail distance (0.3)
    write_map(tmp_path / "run" / "ref", band(6, 7, 3), block="B3M", a=a)
    write_map(tmp_path / "run" / "eng", band(6, 7, 4), engine="mujoco", block="B3M", settings={"settings": "shipped"},
              a=a)
    assert main(["score", str(tmp_path / "run"), "--no-write", "--json"]) == 0
    assert main(["score", str(tmp_path / "run"), "--out", str(tmp_path / "run" / "score.json")]) == 0
    run = rb.load_run(tmp_path / "run")
    assert sorted(m.variant for m in run.maps) == ["mujoco[settings=shipped]", "reference"]
    cells = run.cells()
    assert len(cells) == 84 and set(cells.variant.cat.categories) == {"mujoco[settings=shipped]", "reference"}
    s = run.summary()
    assert list(s.index) == ["mujoco[settings=shipped]"] and s.loc["mujoco[settings=shipped]", "agreement"] < 1
    assert set(run.scores().columns) >= {"variant", "agreement", "consistency", "spurious_invalid"}
    assert "rigid model" in run.metrics()["consistency"]
    v = run.verdict()
    assert list(v.index) == ["mujoco[settings=shipped]"] and v.loc["mujoco[settings=shipped]", "rank"] == 1
    assert v.loc["mujoco[settings=shipped]", "ci95_lo"] <= v.loc["mujoco[settings=shipped]", "value"]
    assert v.loc["mujoco[settings=shipped]", "settings"] == "as-shipped"
    assert v.loc["mujoco[settings=shipped]", "group"] == "as-shipped"
    # score.json holds the numbers; the verdict's words are written from them
    assert run.verdict_text(short=True) and run.verdict_text()[-1].startswith("Measure:")
    assert "text" not in run.score.to_json()["verdict"]
