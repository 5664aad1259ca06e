"""score.json records each pair's engine version, and compare names both sides' versions when they
differ."""

from __future__ import annotations

import json

from rockbench.benchmark.cli.main import main
from rockbench.benchmark.engine_info.versions import differences, differences_line


def _set_version(map_dir, version):
    p = map_dir / "run.json"
    run = json.loads(p.read_text())
    run["engine"]["version"] = version
    p.write_text(json.dumps(run))


def _runs(write_map, band, tmp_path, v_base, v_cur):
    base, cur = tmp_path / "base", tmp_path / "cur"
    for root, v in ((base, v_base), (cur, v_cur)):
        write_map(root / "ref", band(12, 10, 6))
        write_map(root / "eng", band(12, 10, 6), engine="mujoco")
        _set_version(root / "eng", v)
    return base, cur


def test_score_records_and_compare_names_the_versions(write_map, band, tmp_path, capsys):
    base, cur = _runs(write_map, band, tmp_path, "3.3.7", "4.0.0")
    assert main(["score", str(base), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert {p["engine_version"] for p in doc["pairs"]} == {"3.3.7"}
    assert main(["compare", str(base), str(cur)]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0] == "engine versions differ: mujoco 3.3.7 (baseline) → 4.0.0 (current)"
    assert main(["compare", str(base), str(cur), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["engine_versions"] == [{"engine": "mujoco", "baseline": "3.3.7", "current": "4.0.0"}]


def test_same_versions_say_nothing(write_map, band, tmp_path, capsys):
    base, cur = _runs(write_map, band, tmp_path, "4.0.0", "4.0.0")
    assert main(["compare", str(base), str(cur)]) == 0
    assert "engine versions" not in capsys.readouterr().out


def test_differences_leave_out_unknown_and_one_sided_engines():
    a = {"pairs": [{"engine": "mujoco", "engine_version": "1"}, {"engine": "exudyn", "engine_version": "2"}]}
    b = {"pairs": [{"engine": "mujoco", "engine_version": "1"}, {"engine": "pybullet", "engine_version": "3"},
                   {"engine": "exudyn"}]}
    assert differences(a, b) == [] and differences_line(a, b) is None
    assert differences({"pairs": []}, a) == []
