"""The report: files, tables, pictures, and a real headless browser opening index.html."""

import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from rockbench.benchmark.cli import main
from rockbench.benchmark.plots.boundaries import boundary_segments, plot_boundaries
from rockbench.benchmark.plots.trajectories import plot_theta
from rockbench.benchmark.report import build_report
from rockbench.benchmark.scores import LabelMap
from rockbench.reference_solver.restitution import Restitution

from mapdirs import band, write_map


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("report")
    root = tmp / "run"
    ref = band(20, 16, 10)
    ref[5, 3:6] = 2  # a tongue
    write_map(root / "ref-h", ref, block="B6L")
    write_map(root / "ref-m", band(20, 16, 11), block="B6L", restitution=Restitution("modified", k=0.7306))
    write_map(root / "mj", band(20, 16, 9), engine="mujoco", block="B6L", settings={"settings": "calibrated"})
    write_map(root / "pb", band(20, 16, 12), engine="pybullet", block="B6L")
    write_map(root / "ref-c", band(20, 16, 8), block="B6L", pulse="cosine")
    exp = tmp / "exp.csv"
    exp.write_text("# made up for the test\nblock,pulse,f_hz,amplitude_mps2,outcome,repetitions,source\n"
                   "B6L,sine,5.0,8.0,O,3,test\nB6L,sine,5.0,1.0,R,1,test\n")
    from rockbench.benchmark.experiments import load_outcomes
    out = tmp / "out"
    res = build_report([root], out, experiments=load_outcomes(exp), trajectories=False, log=lambda m: None)
    return out, res


def test_report_files_and_tables(report):
    out, res = report
    for name in ("index.html", "report.md", "score.json"):
        assert (out / name).is_file()
    imgs = sorted(p.name for p in (out / "img").iterdir())
    assert imgs == ["speed_accuracy.png", "stability_b6l_cosine.png", "stability_b6l_sine.png"]
    md = (out / "report.md").read_text()
    assert "## Summary" in md and "| engine | pairs |" in md
    # best values in bold: mujoco is one row off, pybullet two rows off the Housner reference
    row = next(ln for ln in md.splitlines() if ln.startswith("| mujoco[settings=calibrated] | 1 |"))
    assert "**" in row
    for img in imgs:
        assert f"(img/{img})" in md
    assert "## Experiments" in md and "## Versions and settings" in md
    page = (out / "index.html").read_text()
    assert page.count("data:image/png;base64,") == 3 and "<b>" in page
    doc = json.loads((out / "score.json").read_text())
    assert len(doc["pairs"]) == 4 and doc["experiments"]


def _chromium():
    return shutil.which("chromium") or shutil.which("chromium-browser")


FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def test_index_html_renders_in_headless_chromium(report, tmp_path):
    exe = _chromium()
    if exe is None:
        pytest.skip("chromium is not installed (Debian: apt-get install -y chromium; .ci/run installs it)")
    out, _ = report
    url = (out / "index.html").resolve().as_uri()
    prof = tmp_path / "profile"
    dom = subprocess.run([exe, *FLAGS, f"--user-data-dir={prof}", "--dump-dom", url], capture_output=True,
                         text=True, timeout=120)
    assert dom.returncode == 0, dom.stderr[-2000:]
    body = re.search(r"<body[^>]*>", dom.stdout).group(0)
    # the page's own check ran after load: every picture decoded
    assert 'data-images="3"' in body and 'data-images-ok="yes"' in body, body
    shot = tmp_path / "shot.png"
    r = subprocess.run([exe, *FLAGS, f"--user-data-dir={prof}", f"--screenshot={shot}", "--window-size=1200,2000",
                        url], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and shot.is_file(), r.stderr[-2000:]
    import matplotlib.image as mpimg
    px = mpimg.imread(shot)
    assert px.shape[0] >= 1000 and px.std() > 0.05  # not a blank page


def test_boundary_segments_trace_the_cell_edges():
    c = np.zeros((3, 3), int)
    c[2, 1] = 2
    m = LabelMap([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], c)
    segs = boundary_segments(m)
    # the cell (2, 1) touches the top of the grid: its lower edge and two side edges are drawn
    assert segs.shape == (3, 2, 2)
    assert [[1.5, 2.5], [2.5, 2.5]] in segs.tolist()
    assert [[1.5, 2.5], [1.5, 3.5]] in segs.tolist() and [[2.5, 2.5], [2.5, 3.5]] in segs.tolist()


def test_plots_return_what_they_drew():
    import matplotlib
    matplotlib.use("Agg")
    m = LabelMap(np.arange(4.0), np.arange(4.0), band(4, 4, 2))
    r = plot_boundaries([("housner", m)], [("e", m)], points=[(1.0, 1.0, "R", 2)], st_limit_a_ratio=3.0)
    assert set(r["lines"]) == {"reference housner", "e", "experiment R", "ST limit"}
    t = np.linspace(0, 1, 50)
    r = plot_theta([("reference x", t, 0.1 * np.sin(t)), ("mujoco", t, 0.1 * np.cos(t))], alpha_rad=0.2,
                   t_pulse_end_s=0.5)
    assert set(r["lines"]) == {"reference x", "mujoco"}
    np.testing.assert_allclose(r["lines"]["mujoco"].get_ydata(), 0.5 * np.cos(t))


def test_speed_accuracy_names_every_variant_in_its_legend():
    import matplotlib
    matplotlib.use("Agg")
    from rockbench.benchmark.plots.speed import plot_speed_accuracy
    rows = [{"variant": "a", "ms_per_cell": 10.0, "agreement": 0.9},
            {"variant": "a[x=1]", "ms_per_cell": 10.5, "agreement": 0.9},
            {"variant": "b", "ms_per_cell": None, "agreement": 0.5}]
    r = plot_speed_accuracy(rows)
    assert set(r["points"]) == {"a", "a[x=1]"}
    assert [t.get_text() for t in r["ax"].get_legend().get_texts()] == ["a", "a[x=1]"]


def test_own_eta_references_are_drawn_in_their_engines_colour():
    import matplotlib
    from matplotlib.colors import to_rgba
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    m = LabelMap(np.arange(4.0), np.arange(4.0), band(4, 4, 2))
    refs = [(f"r{k}", m) for k in range(4)]
    r = plot_boundaries(refs, [("e0", m), ("e1", m)], own_eta=[("own e1", m, 1)])
    lines = r["lines"]
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    assert np.allclose(lines["own e1"].get_colors()[0], to_rgba(colours[1]))
    ls = lines["own e1"].get_linestyles()[0]
    assert ls[1] is not None and ls not in [lines[f"reference r{k}"].get_linestyles()[0] for k in range(4)]


def test_report_pairs_each_own_eta_reference_with_its_engine():
    from rockbench.benchmark.report import _split_own_eta_refs
    from rockbench.benchmark.scoring import MapEntry
    m = LabelMap(np.arange(4.0), np.arange(4.0), band(4, 4, 2))

    def entry(engine, variant, restitution, eta):
        return MapEntry(path=f"/x/{variant}-{restitution}", label_map=m, engine=engine, variant=variant,
                        block="B3M", pulse="sine", restitution=restitution, eta=eta)

    refs = [entry("reference", "reference", "housner", 0.7526), entry("reference", "reference", "0.7493", 0.7493),
            entry("reference", "reference", "0.9", 0.9)]
    engines = [entry("a", "a", "housner", 0.7526), entry("b", "b[x=1]", "housner", 0.7526),
               entry("c", "c", "housner", 0.7526)]
    own = {("b[x=1]", "B3M"): 0.74931, ("c", "B3M"): 0.74929, ("a", "B6M"): 0.7493}
    std, paired = _split_own_eta_refs(refs, engines, own)
    # the housner map and a constant η nobody measured stay standard references
    assert [r.restitution for r in std] == ["housner", "0.9"]
    assert [(label, k) for label, _, k in paired] == [("reference at own η of b[x=1], c (η = 0.7493)", 1)]


def test_report_cli_bad_input(tmp_path, capsys):
    write_map(tmp_path / "r", band(5, 5, 2))
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["report", str(tmp_path / "r"), "--out", str(f), "--no-trajectories"]) == 2
    assert main(["report", str(tmp_path / "r"), "--out", str(tmp_path / "o"), "--case", "B3M:sine:6"]) == 2
    err = capsys.readouterr().err
    assert "BLOCK:PULSE:W_RATIO:A_RATIO" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_report_draws_fig17_with_the_reference(tmp_path):
    """θ(t) of the paper's Fig. 17 case with the real reference solver (both k of B3M)."""
    write_map(tmp_path / "run" / "ref", band(6, 6, 3), block="B3M")
    write_map(tmp_path / "run" / "eng", band(6, 6, 2), engine="nosuchengine", block="B3M")
    res = build_report([tmp_path / "run"], tmp_path / "out", log=lambda m: None)
    assert (tmp_path / "out" / "img" / "theta_b3m_sine_6_6.1.png").is_file()
    # the reference curves were drawn; the unknown engine is a note, not a failure
    assert not any(n.startswith("θ(t) reference") for n in res["notes"]), res["notes"]
    assert any("nosuchengine" in n for n in res["notes"])
    assert "theta_b3m_sine_6_6.1.png" in (tmp_path / "out" / "report.md").read_text()
