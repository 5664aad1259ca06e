"""One producer of the score: :func:`score_run` makes a typed :class:`Scores`, score.json is its
serialisation, and what the report and the console show is the same whether the scores are the live ones or
read back from score.json."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rockbench.benchmark.report.build import write_report
from rockbench.benchmark.report.console import console_summary
from rockbench.benchmark.scoring.score_runs import compare_scores, load_run_maps, load_score, score_run
from rockbench.benchmark.scoring.scores import SCORE_KIND, Scores, pair_key
from rockbench.benchmark.store.files import json_safe, write_json
from rockbench.reference_solver.restitution import Restitution

_json = st.recursive(st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=5),
                     lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
                     max_leaves=8)


@st.composite
def _documents(draw) -> dict:
    """A score.json document: pairs sorted by key with arbitrary extra fields, a verdict, optional parts."""
    pairs = []
    for n in range(draw(st.integers(0, 6))):
        p = {"variant": draw(st.sampled_from(["a", "b[settings=calibrated]"])), "block": draw(st.sampled_from(["B3M", "B6L"])),
             "pulse": draw(st.sampled_from(["sine", "cosine"])), "restitution": "housner",
             "reference": {"restitution": draw(st.sampled_from(["housner", "0.8"]))}, "scores": {"n": n},
             "extra": draw(_json)}
        pairs.append({"key": pair_key(p), **p})
    pairs.sort(key=lambda p: p["key"])
    doc = {"kind": SCORE_KIND, "schema_version": 2, "metrics_version": "9", "rules_version": "4",
           "created_utc": "2026-01-01T00:00:00Z", "metrics": [{"name": "m"}], "pairs": pairs, "skipped": [],
           "reference_gaps": [{"block": "B3M", "boundary_mean": draw(st.floats(0, 1))}]}
    if draw(st.booleans()):
        doc["experiments"] = [{"variant": "a", "accuracy": 0.5}]
    doc["verdict"] = {"metric": "boundary_mean", "direction": "lower", "unit": "w/a units", "confidence": 0.95,
                      "declared": {}, "fail_distance": 0.3, "mcb": draw(_json), "power": None, "general": None,
                      "equivalence": {"within": []}, "variants": [{"variant": "a", "x": draw(_json)}]}
    for name in ("speed", "pairing", "gate"):
        if draw(st.booleans()):
            doc[name] = {"what": draw(_json)}
    return doc


@settings(max_examples=60, deadline=None)
@given(_documents())
def test_score_json_reads_back_to_the_document_it_was(doc):
    scores = Scores.from_json(doc)
    assert scores.to_json() == doc
    assert Scores.from_json(scores.to_json()) == scores
    # typed: variants → scenarios → pairs, every pair once
    flat = [p.key for v in scores.variants for s in v.scenarios for p in s.pairs
            if (p.variant, p.block, p.pulse) == (v.variant, s.block, s.pulse)]
    assert sorted(flat) == [p["key"] for p in doc["pairs"]]


def test_the_scores_keep_an_older_files_words_and_unknown_fields():
    doc = {"kind": SCORE_KIND, "schema_version": 2, "metrics_version": "8", "created_utc": "t", "metrics": [],
           "pairs": [], "skipped": [], "reference_gaps": [], "verdict": {"variants": [], "text": ["old words"]},
           "later": 1}
    assert Scores.from_json(doc).to_json() == {k: v for k, v in doc.items()} | {"verdict": {
        **{k: None for k in ("metric", "direction", "unit", "confidence", "declared", "fail_distance", "mcb", "power",
                             "general", "equivalence")}, "variants": [], "text": ["old words"]}}


def test_editing_the_document_changes_nothing_in_the_scores():
    doc = {"metrics_version": "9", "pairs": [{"key": "k", "variant": "v", "block": "B", "pulse": "p", "s": [1]}],
           "verdict": {"variants": [{"variant": "v"}]}}
    scores = Scores.from_json(doc)
    out = scores.to_json()
    out["pairs"][0]["s"].append(2)
    out["verdict"]["variants"][0]["variant"] = "w"
    doc["pairs"][0]["s"].append(3)
    assert scores.pairs[0]["s"] == [1] and scores.verdict.variants[0]["variant"] == "v"


@pytest.fixture(scope="module")
def run(write_map, band, tmp_path_factory):
    """A run of two engines and two references on one block, and a speed-free scoring of it."""
    root = tmp_path_factory.mktemp("scores") / "run"
    a = (0.5, 3.5)
    write_map(root / "ref-h", band(20, 16, 10), block="B6L", a=a)
    write_map(root / "ref-m", band(20, 16, 11), block="B6L", restitution=Restitution("modified", k=0.7306), a=a)
    write_map(root / "mj", band(20, 16, 9), engine="mujoco", block="B6L", settings={"settings": "calibrated"}, a=a)
    write_map(root / "pb", band(20, 16, 12), engine="pybullet", block="B6L", a=a)
    maps = load_run_maps([root])
    return root, maps, score_run(maps)


def test_the_report_and_the_console_read_the_same_from_score_json(run, tmp_path):
    root, maps, live = run
    back = Scores.from_json(json.loads(json.dumps(live.to_json())))
    assert json.dumps(back.to_json()) == json.dumps(live.to_json())     # NaN is not equal to itself
    assert console_summary(back) == console_summary(live) and "Verdict" in console_summary(live)
    pages = []
    for name, scores in (("live", live), ("back", back)):
        write_report(maps, scores, tmp_path / name, trajectories=False, log=lambda m: None, run_dirs=[root],
                     created="2026-01-01 00:00 UTC")
        pages.append({f: (tmp_path / name / f).read_text() for f in ("report.md", "index.html", "score.json")})
    assert pages[0] == pages[1]
    assert json.loads(pages[0]["score.json"]) == json.loads(json.dumps(json_safe(live.to_json())))


def test_compare_and_load_score_read_the_written_scores(run, tmp_path):
    _, _, live = run
    write_json(tmp_path / "score.json", live.to_json())
    back = load_score(tmp_path / "score.json")
    assert isinstance(back, Scores) and back.pairs == json_safe(live.pairs)
    res = compare_scores(live, back)
    assert res["status"] == "ok" and res["compared"] == len(live.pairs) > 0
