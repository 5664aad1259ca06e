"""The speed stage: a toy engine whose error and cost are known (``maps_helpers.StepCostAdapter``: its
boundary lies ``shift_per_s``·Δt above the plain one, its cost is ``cpu_per_step_s``/Δt CPU seconds per
simulated second) drawn through the maps, the store's cost columns, the scores' speed section, the
matched-accuracy table, the picture and ``compare``'s cost flag."""

import copy
import csv
import json
import math

import pytest

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.cli.main import main
from rockbench.benchmark.maps.grid import MapSpec, parse_range
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.report.plots.speed import plot_accuracy_cost
from rockbench.benchmark.scoring.score_runs import compare_scores, score_dirs
from rockbench.benchmark.scoring.scores import Scores
from rockbench.benchmark.scoring.speed import band, matched, point
from rockbench.benchmark.scoring.speed_runs import SPEED_FILE
from rockbench.benchmark.store.files import COLUMNS, COST_COLUMNS
from rockbench.benchmark.store.loading import load_map
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.restitution import Restitution

STEPS = (1e-3, 5e-4, 2e-4, 1e-4)
#: the toy's boundary lies SHIFT·Δt above the reference's along a0/(g·tanα): 0.06, 0.03, 0.012, 0.006
SHIFT = 60.0
#: its CPU per step [s]: 3 ms of CPU per simulated second at 1 ms, 30 ms at 0.1 ms
CPU_PER_STEP = 3e-6
BLOCKS = ("B3M", "B6M")
RULE = 5e-4


def _spec(block, dt=None, **settings):
    x, y = parse_range("--w-ratio", "1:8:9", "w_ratio"), parse_range("--a-ratio", "1:12:12", "a_ratio")
    return MapSpec(get_preset(block).block(), "sine", Restitution(), x, y, engine="analytic-step",
                   engine_settings=settings, dt_s=dt)


@pytest.fixture(scope="module")
def stage(tmp_path_factory):
    """The toy's reference (no shift, no cost) and its speed maps at four steps on two blocks, scored."""
    import maps_helpers
    maps_helpers.register_all()
    root = tmp_path_factory.mktemp("speed")
    for block in BLOCKS:
        run_map(_spec(block, shift_per_s=0.0, cpu_per_step_s=0.0), root / "ref" / block, serial=True, adaptive=True,
                coarse_stride=2, locate_depth=4)
        for dt in STEPS:
            run_map(_spec(block, dt, settings="calibrated", shift_per_s=SHIFT, cpu_per_step_s=CPU_PER_STEP),
                    root / "speed" / f"{dt:g}" / block, serial=True, adaptive=True, coarse_stride=2, locate_depth=4,
                    stage={"name": "speed", "step_rule": {"dt_s": RULE}, "device": {"runs_on": "cpu", "note": ""}})
    declared = {"steps_s": list(STEPS), "blocks": list(BLOCKS), "pulses": ["sine"], "matched_distance": 0.015,
                "source": "the test"}
    (root / "speed" / SPEED_FILE).write_text(json.dumps({"declared": declared, "absent": [
        {"engine": "mujoco_warp", "why": "skipped: no CUDA device here"}]}))
    doc = score_dirs([root / "speed"], against=[root / "ref"]).to_json()
    return root, doc


def _row(doc):
    (row,) = doc["speed"]["engines"]
    return row


def test_cells_carry_their_cost(stage):
    root, _ = stage
    d = root / "speed" / "0.0001" / "B3M"
    with open(d / "cells.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == COLUMNS and set(COST_COLUMNS) <= set(rows[0])
    spec = _spec("B3M")
    for r in rows:
        w = float(r["w_ratio"])
        wave = 2 * math.pi / (w * spec.block.p_rad_s)
        assert float(r["simulated_s"]) == pytest.approx(1.5 * wave)      # the toy simulates 1.5 waves
        assert float(r["cpu_s"]) >= CPU_PER_STEP * 1.5 * wave / 1e-4 * 0.99   # and burns at least this
    run = json.loads((d / "run.json").read_text())
    assert run["schema_version"] == 5 and run["options"]["stage"]["name"] == "speed"
    assert {"cpu_model", "cpu_count", "cores_usable"} <= set(run["machine"])


def test_distance_shrinks_and_cost_grows_as_constructed(stage):
    _, doc = stage
    pts = {p["dt_s"]: p for p in _row(doc)["points"]}
    assert sorted(pts) == sorted(STEPS)
    for dt, p in pts.items():
        assert p["scenarios"] == 2 and p["complete"] and p["costed"] == p["simulations"] > 0
        # across the line a = 1 + 0.8·ω/p a vertical shift s is 0.781·s; the boundaries are located to
        # a sixteenth of a cell (0.0625 in a0/(g·tanα)), so a shift below that may not show
        s = SHIFT * dt
        assert p["value"] <= 0.781 * s + 0.01
        if s > 0.03:
            assert p["value"] >= 0.6 * 0.781 * s
    values = [pts[dt]["value"] for dt in STEPS]
    costs = [pts[dt]["cost"] for dt in STEPS]
    assert values == sorted(values, reverse=True) and values[0] > values[-1]
    assert costs == sorted(costs) and costs[-1] / costs[0] > 4   # 10 times the burn, plus Python's own per cell
    for dt in STEPS:   # the burn alone: cpu_per_step / Δt CPU seconds per simulated second
        assert pts[dt]["cost"] >= 0.99 * CPU_PER_STEP / dt


def test_matched_accuracy_picks_the_cheapest_step_that_reaches_it(stage):
    _, doc = stage
    row = _row(doc)
    pts = {p["dt_s"]: p for p in row["points"]}
    m, mdd = row["matched"], row["mdd"]["value"]
    finest = pts[1e-4]
    assert m["finest"]["dt_s"] == 1e-4
    within = [dt for dt in STEPS if pts[dt]["value"] <= finest["value"] + mdd]
    assert m["within_mdd"]["dt_s"] == max(within)   # costs grow as the step shrinks: the coarsest is the cheapest
    # as constructed: 0.5 ms lies 0.781 × 0.03 = 0.023 from the reference and 1 ms 0.047; the detectable
    # difference rests on the maps' measured location error (their bisection brackets, metrics 8), which on
    # this coarse toy grid is a few hundredths: 0.5 ms is within it, 1 ms where the error reaches it
    assert 0.02 < mdd < 0.1
    expected = 1e-3 if pts[1e-3]["value"] <= finest["value"] + mdd else 5e-4
    assert m["within_mdd"]["dt_s"] == expected
    assert m["within_mdd"]["speedup_vs_finest"] == pytest.approx(finest["cost"] / pts[expected]["cost"])
    # (b): within the declared 0.015 (speed.json): 0.2 ms (0.781 × 0.012) and 0.1 ms; 0.2 ms is cheaper
    assert m["within_distance"]["dt_s"] == 2e-4
    assert doc["speed"]["declared"]["matched_distance"] == 0.015
    # the rule's record: every block chose 0.5 ms, so its point is that step's
    assert row["rule"]["on_curve"] == RULE and row["rule"]["value"] == pytest.approx(pts[RULE]["value"])
    assert doc["speed"]["absent"][0]["engine"] == "mujoco_warp"


def test_not_reached():
    items = {("B3M", "sine"): {"block": "B3M", "pulse": "sine", "scores": {"boundary_mean": 0.2},
                               "cells": {"w_step": 0.3, "a_step": 0.22, "locate_depth": 5}, "slenderness": 2.25}}
    cost = {"simulations": 10, "costed": 10, "cpu_s": 1.0, "wall_s": 2.0, "simulated_s": 10.0}
    pts = [point(dt, [items[("B3M", "sine")]], [cost], False) for dt in (1e-3, 1e-4)]
    m = matched(pts, None, 0.1)
    assert m["within_distance"] is None and m["within_mdd"]["dt_s"] == 1e-3
    assert matched([], None, 0.1) == {"finest": None, "within_mdd": None, "within_distance": None}


def test_the_verdicts_detectable_difference_sets_criterion_a_where_the_run_has_one(stage):
    """A run with calibrated variants in its verdict: criterion (a) and the band take the verdict's detectable
    difference; a run of the stage alone (the fixture) takes the stage's own, and says so."""
    _, doc = stage
    row = _row(doc)
    assert doc["speed"]["verdict_mdd"] is None and row["band"] == {"value": row["mdd"]["value"], "source": "stage"}
    assert band(0.2, row["mdd"]) == {"value": 0.2, "source": "verdict"} and band(None, None) is None
    items = [{"block": "B3M", "pulse": "sine", "scores": {"boundary_mean": v}, "slenderness": 2.25,
              "cells": {"w_step": 0.3, "a_step": 0.22, "locate_depth": 5}} for v in (0.30, 0.12, 0.10)]
    cost = {"simulations": 10, "costed": 10, "cpu_s": 1.0, "wall_s": 2.0, "simulated_s": 10.0}
    pts = [point(dt, [it], [{**cost, "cpu_s": 1e-3 / dt}], False) for dt, it in zip((1e-3, 5e-4, 1e-4), items)]
    assert matched(pts, band(0.05, None), 0.5)["within_mdd"]["dt_s"] == 5e-4    # 0.12 within 0.10 + 0.05
    assert matched(pts, band(0.25, None), 0.5)["within_mdd"]["dt_s"] == 1e-3    # 0.30 within 0.10 + 0.25


def test_a_rule_step_outside_the_stage_is_said(stage):
    """The rule chose a step the stage did not map (MuJoCo's 0.1 ms against a stage of 1–0.2 ms): the row
    says which, with no point to circle."""
    from rockbench.benchmark.scoring.speed import rule_point
    from rockbench.benchmark.report.speed_words import matched_table
    _, doc = stage
    r = rule_point([], {"B3M": 5e-5, "B6M": 5e-4}, {("B6M", 5e-4): []}, {}, False)
    assert r["outside"] and r["value"] is None and r["steps_s"] == [5e-4, 5e-5]
    speed = copy.deepcopy(doc["speed"])
    speed["engines"][0]["rule"] = r
    _, body = matched_table(speed)
    assert body[0][-1] == "0.5 ms (B6M); 0.05 ms (B3M): not among the steps mapped on every problem"
    assert not plot_accuracy_cost(speed)["rule"]   # nothing to circle


def test_a_step_not_mapped_on_every_problem_is_no_point_and_is_said(stage, tmp_path):
    """A stage stopped midway (Newton's 0.1 ms maps in docs/speed.md): a declared step with no map, or with
    maps on some of the stage's blocks only, is no point of the curve (its mean would be over other
    problems); the row lists it, the table says it beside the finest step, and the finest is the finest
    step mapped on every problem."""
    import shutil
    from rockbench.benchmark.report.speed_words import matched_table
    root, doc = stage
    assert _row(doc)["unmapped"] == []
    cut = tmp_path / "speed"
    shutil.copytree(root / "speed", cut)
    shutil.rmtree(cut / f"{1e-4:g}")                     # 0.1 ms: no map
    shutil.rmtree(cut / f"{2e-4:g}" / BLOCKS[0])         # 0.2 ms: one block of two
    row = _row(score_dirs([cut], against=[root / "ref"]).to_json())
    assert [p["dt_s"] for p in row["points"]] == [1e-3, 5e-4]
    assert row["unmapped"] == [{"dt_s": 2e-4, "blocks": [BLOCKS[1]]}, {"dt_s": 1e-4, "blocks": []}]
    assert row["matched"]["finest"]["dt_s"] == 5e-4
    _, body = matched_table({"engines": [row], "declared": {"matched_distance": 0.015}})
    assert body[0][2].endswith(f"; not mapped: 0.2 ms (only {BLOCKS[1]}), 0.1 ms")


def test_a_finest_step_that_is_also_the_cheapest_match_says_so(stage):
    """Criterion (a) met only by the finest step itself (Exudyn in the stage measured in docs/speed.md): the
    row says so, not "1× cheaper"."""
    from rockbench.benchmark.report.speed_words import matched_table
    _, doc = stage
    speed = copy.deepcopy(doc["speed"])
    m = speed["engines"][0]["matched"]
    m["within_mdd"] = dict(m["finest"], speedup_vs_finest=1.0)
    _, body = matched_table(speed)
    assert body[0][4].endswith("(the finest itself)")


def test_speed_maps_stay_out_of_the_verdict(stage):
    _, doc = stage
    assert doc["pairs"] == [] and doc["verdict"]["variants"] == []


def _section(n_engines=8, spread=1.0):
    """A speed section of ``n_engines`` engines whose curves lie close together (labels must give way)."""
    rows = []
    for k in range(n_engines):
        pts = [{"dt_s": dt, "value": 0.05 + 0.01 * k * spread + 30 * dt, "cost": (0.001 / dt) * (1 + 0.05 * k),
                "se": 0.003} for dt in STEPS]
        rows.append({"engine": f"e{k}", "label": f"Engine number {k} 1.2", "device": {"runs_on": "cpu", "note": ""},
                     "points": pts, "band": {"value": 0.01, "source": "stage"},
                     "matched": {"finest": {"dt_s": 1e-4, "value": pts[-1]["value"], "cost": pts[-1]["cost"]}},
                     "rule": {"per_block": {"B3M": 5e-4}, "on_curve": 5e-4, "value": pts[1]["value"],
                              "cost": pts[1]["cost"]}})
    return {"engines": rows, "declared": {"matched_distance": 0.037, "steps_s": list(STEPS)}, "absent": []}


@pytest.mark.parametrize("n, spread", [(1, 1.0), (4, 1.0), (8, 0.2), (8, 3.0)])
def test_picture_labels_never_overlap_or_leave_the_figure(tmp_path, n, spread):
    from rockbench.benchmark.report.plots.output import save_formats
    drawn = plot_accuracy_cost(_section(n, spread))
    fig = drawn["figure"]
    save_formats(fig, tmp_path / "speed", ("png", "svg", "pdf"))   # vector and 300 dpi, as every figure
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    words = [t.get_window_extent(renderer) for t in drawn["labels"]]
    legend = drawn["legend"].get_window_extent(renderer)
    boxes = words + [legend] + [t.get_window_extent(renderer) for t in drawn["legend"].get_texts()]
    for b in boxes:
        assert page.x0 - 0.5 <= b.x0 and b.x1 <= page.x1 + 0.5 and page.y0 - 0.5 <= b.y0 and b.y1 <= page.y1 + 0.5
    curves = [ln.get_transform().transform_path(ln.get_path()) for ln in drawn["curves"].values()]
    for i, a in enumerate(words):
        assert not a.overlaps(legend)
        assert not any(c.intersects_bbox(a, filled=False) for c in curves)   # no curve runs through the words
        for b in words[i + 1:]:
            assert not a.overlaps(b)
    texts = drawn["legend"].get_texts()
    for i, a in enumerate(texts):
        for b in texts[i + 1:]:
            assert not a.get_window_extent(renderer).overlaps(b.get_window_extent(renderer))
    assert len(drawn["curves"]) == n and len(drawn["rule"]) == n and len(drawn["bands"]) == n
    assert drawn["labels"]                  # the step is written where it fits
    assert (tmp_path / "speed.svg").read_text().count("<text") > 0   # text stays text in the vector file


def _doc_with(doc, factor=1.0, machine=None):
    d = copy.deepcopy(doc)
    for r in d["speed"]["engines"]:
        for key in ("within_mdd", "within_distance", "finest"):
            if r["matched"].get(key):
                r["matched"][key]["cost"] *= factor
    if machine:
        d["speed"]["machine"] = {**(d["speed"]["machine"] or {}), **machine}
    return d


def _compare(base: dict, cur: dict) -> dict:
    """:func:`compare_scores` of two score.json documents."""
    return compare_scores(Scores.from_json(base), Scores.from_json(cur))


def test_compare_flags_a_cost_rise_on_like_machines_only(stage, tmp_path, capsys):
    _, doc = stage
    assert doc["speed"]["machine"] is not None
    same = _compare(doc, _doc_with(doc, 1.4))
    assert same["status"] == "ok" and not same["speed"]["flags"]
    risen = _compare(doc, _doc_with(doc, 1.6))
    assert risen["status"] == "regression" and {r["criterion"] for r in risen["speed"]["flags"]} == \
        {"within_mdd", "within_distance"}
    elsewhere = _compare(doc, _doc_with(doc, 3.0, {"cpu_model": "another CPU"}))
    assert elsewhere["status"] == "ok" and "costs not compared" in elsewhere["speed"]["notes"][0]
    gone = _doc_with(doc)
    gone["speed"]["engines"][0]["matched"]["within_distance"] = None
    assert _compare(doc, gone)["speed"]["flags"][0]["why"] == "no longer reached"
    # the command: exit 1 on the flag, --cost-factor moves it
    for name, d in (("base", doc), ("cur", _doc_with(doc, 1.6))):
        (tmp_path / f"{name}.json").write_text(json.dumps(d, default=str))
    args = ["compare", str(tmp_path / "base.json"), str(tmp_path / "cur.json")]
    assert main(args) == 1
    assert "COST" in capsys.readouterr().out
    assert main(args + ["--cost-factor", "2"]) == 0
    assert main(args + ["--cost-factor", "0.5"]) == 2
    assert "--cost-factor must be a number >= 1" in capsys.readouterr().err


def test_a_schema_4_map_is_read_and_resumed_with_the_cost_columns(tmp_path, fake_engines):
    spec = _spec("B3M", 1e-3, settings="calibrated", cpu_per_step_s=0.0)
    d = tmp_path / "m"
    run_map(spec, d, serial=True, adaptive=True, coarse_stride=2, locate_depth=2)
    before = load_map(d)
    for name in ("cells.csv", "bisection.csv"):   # what schema 4 wrote: no cost columns
        with open(d / name, newline="") as f:
            rows = list(csv.reader(f))
        keep = [k for k, c in enumerate(rows[0]) if c not in COST_COLUMNS]
        with open(d / name, "w", newline="") as f:
            csv.writer(f, lineterminator="\n").writerows([[r[k] for k in keep] for r in rows])
    run = json.loads((d / "run.json").read_text())
    run["schema_version"] = 4
    (d / "run.json").write_text(json.dumps(run))
    old = load_map(d)
    assert (old.outcome == before.outcome).all()
    run_map(spec, d, serial=True, adaptive=True, coarse_stride=2, locate_depth=2)   # resumes: nothing to compute
    with open(d / "cells.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == COLUMNS and all(r["cpu_s"] == "" for r in rows)
    assert json.loads((d / "run.json").read_text())["schema_version"] == 5
    assert (load_map(d).outcome == before.outcome).all()


# -- the suite's [speed] table ------------------------------------------------------------------------------

GRID = "[grid]\nw_ratio = '1:8:9'\na_ratio = '1:12:9'\nadaptive = true\n"


@pytest.mark.parametrize("text, line", [
    (GRID + "[speed]\nsteps_s = [0.001]\n", "speed.steps_s must list at least two time steps"),
    (GRID + "[speed]\nsteps_s = [0.001, 0.001]\n", "speed.steps_s lists 0.001 s twice"),
    (GRID + "[speed]\nsteps_s = [0.001, -1]\n", "speed.steps_s must be a number of seconds > 0, got -1."),
    (GRID + "[cases]\nblocks = ['B3M']\n[speed]\nblocks = ['B6M']\n", "speed.blocks names B6M, which is not in "
     "cases.blocks (B3M); the speed stage is scored against the suite's reference maps."),
    (GRID.replace("1:8:9", "1:16:9") + "[cases]\nblocks = ['B2M']\n[speed]\nsteps_s = [0.002, 0.001]\n",
     "speed.steps_s 0.002 s on the grid (B2M sine): --dt 0.002 s is too coarse"),
    (GRID + "[engines]\nvariants = []\n", "engines.variants is empty; list at least one variant, or add a [speed] "
     "table"),
    (GRID + "[speed]\nmatched_distance = 0\n", "speed.matched_distance must be a number > 0"),
    (GRID + "[speed]\nzoom = 1\n", "unknown key speed.zoom"),
    (GRID + "[speed]\nlocate_depth = -1\n", "speed.locate_depth must be a whole number from 0 to"),
])
def test_bad_speed_tables(tmp_path, text, line):
    p = tmp_path / "s.toml"
    p.write_text(text)
    from rockbench.benchmark.suites.model import load_suite
    with pytest.raises(ConfigError, match=line.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")
                       .replace("]", r"\]").replace(".", r"\.")):
        load_suite(p)


def test_speed_table_defaults_and_the_shipped_suites():
    from rockbench.benchmark.suites.model import load_suite, suite_path
    from rockbench.benchmark.suites.plan import plan, speed_depth
    from rockbench.engines.calibration.step_rule import STEP_LADDER_S
    speed, full = load_suite(suite_path("speed", False)), load_suite(suite_path("full", False))
    for s in (speed, full):
        assert s.speed.steps_s == list(STEP_LADDER_S)     # the time-step rule's ladder: its choice is on the curve
        assert s.speed.blocks == ["B2M", "B3M", "B6M", "B8M"] and s.speed.pulses == ["sine"]
        assert s.speed.locate_depth == speed_depth(s) == 4   # its own depth (docs/speed.md, "The grid and the depth")
    assert full.grid.locate_depth == 5                        # the full suite's own maps keep the grid's
    jobs = [j for j in plan(speed, ["mujoco", "dart"]) if j.stage == "speed"]
    assert len(jobs) == 2 * 4 * 4 and all(j.subdir.startswith("maps/speed/") for j in jobs)
    assert not [j for j in plan(speed, ["mujoco"]) if j.engine != "reference" and j.stage is None]
    assert load_suite(suite_path("default", False)).speed is None


def test_defaults_take_one_block_per_slenderness(tmp_path):
    from rockbench.benchmark.suites.model import load_suite
    p = tmp_path / "s.toml"
    p.write_text("[grid]\nw_ratio = '1:8:9'\na_ratio = '1:12:9'\n[cases]\nblocks = ['B3M', 'B3L', 'B6L', 'B6M']\n"
                 "pulses = ['cosine', 'sine']\n[speed]\n")
    s = load_suite(p)
    assert s.speed.blocks == ["B3M", "B6L"] and s.speed.pulses == ["cosine"]
    from rockbench.benchmark.suites.plan import speed_depth
    assert s.speed.locate_depth is None and speed_depth(s) == s.grid.locate_depth   # the grid's where left out


def test_plan_prints_what_the_stage_costs(capsys, tmp_path):
    assert main(["run", "speed", "--plan", "--engines", "mujoco", "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    assert "speed stage: 1 engine(s) × 4 steps (1, 0.5, 0.2, 0.1 ms) × 4 block(s)" in err
    assert "speed stage, mujoco: 16 maps of 1296 cells" in err and "bisection samples to depth 4" in err


def test_a_suite_of_the_speed_stage_alone_runs_scores_and_reports(fake_engines, tmp_path):
    """`rockbench run` of a suite with a [speed] table and no variant: the stage's maps under maps/speed/, each
    recording its stage, speed.json, score.json's speed section (no pair in the verdict), the report's curves
    and table, and a rerun that computes nothing."""
    from rockbench.benchmark.suites.model import load_suite
    from rockbench.benchmark.suites.runner import run_suite

    fake_engines.register_all()
    p = tmp_path / "s.toml"
    p.write_text("[suite]\nname = 'sp'\n[grid]\nw_ratio = '1:8:9'\na_ratio = '1:12:9'\nadaptive = true\n"
                 "coarse_stride = 2\nlocate_depth = 3\n[cases]\nblocks = ['B3M']\npulses = ['sine']\n"
                 "[reference]\nrestitutions = ['housner']\n[engines]\nnames = ['analytic-step']\nvariants = []\n"
                 "[speed]\nsteps_s = [0.001, 0.0005]\nlocate_depth = 2\n[report]\ncases = []\n")
    said = []
    res = run_suite(load_suite(p), tmp_path / "out", jobs=1, log=said.append)
    out = tmp_path / "out"
    maps = sorted(d.parent.relative_to(out).as_posix() for d in (out / "maps" / "speed").glob("*/*/run.json"))
    assert maps == ["maps/speed/analytic-step-settings=calibrated-dt=0.0005/B3M-sine-housner",
                    "maps/speed/analytic-step-settings=calibrated-dt=0.001/B3M-sine-housner"]
    stage = json.loads((out / maps[0] / "run.json").read_text())["options"]["stage"]
    assert stage["name"] == "speed" and stage["device"]["runs_on"] == "cpu" and stage["step_rule"] is None
    # the stage's maps are bisected to the stage's depth, the reference to the grid's
    assert json.loads((out / maps[0] / "run.json").read_text())["options"]["locate_depth"] == 2
    assert json.loads((out / "maps" / "reference" / "B3M-sine-housner" / "run.json").read_text())["options"][
        "locate_depth"] == 3
    record = json.loads((out / SPEED_FILE).read_text())
    assert record["declared"]["steps_s"] == [0.001, 0.0005] and record["declared"]["blocks"] == ["B3M"]
    assert record["declared"]["locate_depth"] == 2
    assert {a["engine"] for a in record["absent"]} == {"mujoco_warp", "newton", "genesis"}
    doc = json.loads((out / "score.json").read_text())
    assert doc["pairs"] == [] and [p["dt_s"] for p in doc["speed"]["engines"][0]["points"]] == [0.001, 0.0005]
    assert all(p["cost"] > 0 for p in doc["speed"]["engines"][0]["points"])
    md = (out / "report.md").read_text()
    assert "Cost at matched accuracy" in md and "img/speed_accuracy.png" in md and (out / "img" / "speed_accuracy.png").is_file()
    assert "not in the verdict" in md
    # the stage alone has no verdict: its report says so once, and draws no empty verdict, summary or graphs
    assert "the accuracy–cost stage alone" in md and "## Verdict" not in md and "## Summary" not in md
    assert "## Stability graphs" not in md and "_none_" not in md
    page = (out / "index.html").read_text()
    assert "id='verdict'" not in page and "id='summary'" not in page and "id='speed'" in page
    assert page.rstrip().endswith("</html>") and "Versions and settings" in page
    assert len(res["maps"]) == 3   # the reference and the two speed maps
    again = run_suite(load_suite(p), out, jobs=1, log=lambda m: None, report=False)
    assert json.loads((out / "score.json").read_text())["speed"]["engines"][0]["points"][0]["simulations"] == \
        doc["speed"]["engines"][0]["points"][0]["simulations"]
    assert again["score"].speed is not None


def test_the_device_column_is_the_adapters_device_note(stage):
    """The table's "runs on": the adapter's device note where it gives one ("CPU only (...)": said once),
    else "CPU"."""
    from rockbench.benchmark.report.speed_words import matched_table
    _, doc = stage
    speed = copy.deepcopy(doc["speed"])
    assert matched_table(speed)[1][0][1] == "CPU"
    speed["engines"][0]["device"] = {"runs_on": "cpu", "note": "CPU only (Genesis's CPU backend)"}
    assert matched_table(speed)[1][0][1] == "CPU only (Genesis's CPU backend)"
