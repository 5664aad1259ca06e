"""End to end with the real maps harness and reference solver: adaptive maps scored, and `run --quick`."""

import json
import subprocess
import sys

import pytest

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.maps.grid import MapSpec, parse_range
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.scoring.score_runs import score_dirs
from rockbench.engines.registry import BUILTIN, adapter_class, availability
from rockbench.reference_solver.restitution import Restitution


def _spec(n=13):
    return MapSpec(get_preset("B3M").block(), "sine", Restitution(), parse_range("--w-ratio", f"1:13:{n}", "w_ratio"),
                   parse_range("--a-ratio", f"1:9:{n}", "a_ratio"))


def test_adaptive_reference_map_scores_perfect_against_the_full_one(tmp_path):
    run_map(_spec(), tmp_path / "full", serial=True)
    run_map(_spec(), tmp_path / "adaptive", serial=True, adaptive=True, coarse_stride=2)
    doc = score_dirs([tmp_path / "adaptive"], against=[tmp_path / "full"]).to_json()
    (p,) = doc["pairs"]
    assert p["filled_cells"] > 0  # inferred cells are counted, not called invalid
    s = p["scores"]
    assert s["spurious_invalid"] == 0 and s["failed_cells"] == 0
    # outside the rigid model's domain the adaptive map's simulated cells carry the same flags
    assert p["cells_outside_domain"] > 0 and s["consistency"] == 1.0
    # the adaptive rule only skips cells inside uniform regions
    assert s["agreement"] == 1.0 and s["boundary_max"] == 0.0


def _rockbench(*args):
    # a fresh process: engines other tests register in this one must not join the suite
    return subprocess.run([sys.executable, "-m", "rockbench.benchmark.cli.main", *args], capture_output=True,
                          text=True, timeout=900)


@pytest.mark.slow
def test_run_quick_end_to_end(tmp_path):
    out = tmp_path / "quick"
    r = _rockbench("run", "--quick", "--out", str(out))
    assert r.returncode == 0, r.stderr[-3000:]
    assert (out / "index.html").is_file() and (out / "report.md").is_file()
    # 2 pulses x (B3M: 3 restitutions, B8M: Housner and the average k's η_M, no exact k)
    assert len(list((out / "maps" / "reference").iterdir())) == 10
    assert "note: no modified-exact reference map for B8M" in r.stderr
    # the suite's yardstick: four planted reductions on both blocks and pulses
    assert len(list((out / "maps").glob("reference-planted-eta-factor=*/*"))) == 4 * 2 * 2
    assert (out / "img" / "theta_b3m_sine_6_6.1.png").is_file()
    assert (out / "trajectories" / "theta_b3m_sine_6_6.1.npz").is_file()   # what the report drew it from
    suite = json.loads((out / "suite.json").read_text())
    assert suite["suite_name"] == "quick" and suite["suite"]["grid"]["adaptive"] and len(suite["maps"]) >= 12
    # the engines the suite's "available" picks: installed, not in its `exclude` list (drake), and not
    # left out on this machine by the adapter itself (MuJoCo Warp without a CUDA device)
    left_out = suite["suite"]["engines"].get("exclude", [])
    engines = [n for n in BUILTIN if n != "reference" and n not in left_out and availability(n)["available"]
               and not adapter_class(n).default_suite_exclusion()]
    for n in left_out:
        if n in BUILTIN and availability(n)["available"]:
            assert f"engine {n} left out by the suite" in r.stderr
    doc = json.loads((out / "score.json").read_text())
    assert {p["engine"] for p in doc["pairs"]} == set(engines) | {"reference"}   # the planted variants too
    assert {p["settings"] for p in doc["pairs"] if p["engine"] == "reference"} == {"planted"}
    assert "agree" in r.stdout
    # one pool of workers per engine variant, kept for all its maps: one workers.log each
    for e in (e for e in engines if adapter_class(e).batching != "parallel"):   # in-process: no workers
        variant_dirs = [d for d in (out / "maps").iterdir() if d.name.startswith(e)]
        assert variant_dirs and all((d / "workers.log").is_file() for d in variant_dirs)
        assert not any((m / "workers.log").exists() for d in variant_dirs for m in d.iterdir() if m.is_dir())
    # a console that reads cleanly: one total N, k counting finished maps in order, no blank
    # line, each note once, and no line of Warp's own
    prog = [ln for ln in r.stderr.splitlines() if ln.startswith("rockbench: [")]
    assert [int(ln.split("[")[1].split("/")[0]) for ln in prog] == list(range(1, len(prog) + 1))
    assert {ln.split("/")[1].split("]")[0] for ln in prog} == {str(len(prog))}
    assert all(ln.strip() for ln in r.stderr.splitlines())
    notes = [ln for ln in r.stderr.splitlines() if ln.startswith("rockbench: note:")]
    assert len(notes) == len(set(notes))
    assert not any(ln.startswith("Warp") for ln in r.stderr.splitlines())
    # a rerun resumes: every map is already complete
    r = _rockbench("run", "--quick", "--out", str(out))
    assert r.returncode == 0 and "resuming" in r.stderr, r.stderr[-3000:]


TINY_SUITE = """
[grid]
w_ratio = "1:16:7"
a_ratio = "1:12:7"
adaptive = true
coarse_stride = 2
[cases]
blocks = ["B2M", "B3M"]
pulses = ["sine"]
[reference]
restitutions = ["housner", "modified-average", "modified-exact"]
[engines]
names = ["mujoco"]
variants = [{ settings = "calibrated", blocks = ["B3M"] },
            { settings = "calibrated", calibrate_on = "neighbour", blocks = ["B2M"] }]
own_eta = true
[power]
eta_reductions = [0.0, 0.02]
[report]
cases = []
"""


@pytest.mark.slow
@pytest.mark.engine
def test_run_a_tiny_suite_with_a_held_out_transfer_and_planted_variants(tmp_path):
    """One engine calibrated on B3M (h/b 2.25) and mapped on B2M (h/b 1.5), where Housner's η is 0.5385 and
    not 0.7526: the calibration is B3M's own (its target, contact settings and step), applied to B2M; the
    planted variants map the in-sample block; B2M has no exact-k reference, and the run says so."""
    pytest.importorskip("mujoco")
    (tmp_path / "tiny.toml").write_text(TINY_SUITE)
    out = tmp_path / "out"
    r = _rockbench("run", str(tmp_path / "tiny.toml"), "--out", str(out))
    assert r.returncode == 0, r.stderr[-3000:]
    assert "note: no modified-exact reference map for B2M: it is not in Table 1" in r.stderr
    refs = sorted(d.name for d in (out / "maps" / "reference").iterdir())
    assert [d for d in refs if "own-eta" not in d] == ["B2M-sine-housner", "B2M-sine-modified-k=0.8608",
                                                        "B3M-sine-housner", "B3M-sine-modified-k=0.7595",
                                                        "B3M-sine-modified-k=0.8608"]
    planted = sorted(p.relative_to(out / "maps").as_posix() for p in (out / "maps").glob("reference-planted*/*"))
    assert planted == ["reference-planted-eta-factor=0.98/B3M-sine-housner",
                       "reference-planted-eta-factor=1.0/B3M-sine-housner"]
    held = json.loads((out / "maps" / "mujoco-calibrate-on=neighbour-settings=calibrated" / "B2M-sine-housner"
                       / "run.json").read_text())
    own = json.loads((out / "maps" / "mujoco-settings=calibrated" / "B3M-sine-housner" / "run.json").read_text())
    hs, os_ = held["engine"]["resolved_settings"], own["engine"]["resolved_settings"]
    assert hs["calibration"]["calibrated_on"] == "B3M"
    assert hs["calibration"]["eta_target"] == pytest.approx(0.752577319587629)   # B3M's η_H, not B2M's 0.5385
    assert held["spec"]["eta"] == pytest.approx(1 - 6 / 13)                      # the map itself asks for B2M's
    same = {k: v for k, v in os_.items() if k not in ("calibration", "calibrate_on")}   # the setting itself differs
    assert {k: hs.get(k) for k in same} == same    # B3M's contact settings and step, applied to B2M
    doc = json.loads((out / "score.json").read_text())
    pairs = {(p["variant"], p["block"]): p for p in doc["pairs"] if p["like_for_like"]}
    h = pairs[("mujoco[calibrate_on=neighbour,settings=calibrated]", "B2M")]
    assert h["held_out"] and h["calibrated_on"] == "B3M" and h["slenderness"] == 1.5
    p0 = pairs[("reference[planted_eta_factor=1.0]", "B3M")]
    assert p0["settings"] == "planted" and p0["scores"]["boundary_mean"] == 0.0
    assert pairs[("reference[planted_eta_factor=0.98]", "B3M")]["settings"] == "planted"
    rows = {v["variant"]: v for v in doc["verdict"]["variants"]}
    assert rows["mujoco[calibrate_on=neighbour,settings=calibrated]"]["held_out"]["scenarios"] == 1
    assert rows["reference[planted_eta_factor=0.98]"]["rank"] is None
    assert (out / "index.html").is_file()
    assert "> no modified-exact reference map for B2M: it is not in Table 1" in (out / "report.md").read_text()
