"""The benchmark records in tests/measurements/results/: every file is a valid record, and what cites one finds it."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

from measurement_scripts import load_script

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "tests" / "measurements" / "records.py"
#: ``tests/measurements/results/NAME`` or, within tests/measurements/, ``results/NAME`` (not ``rockbench-results/``)
CITATION = re.compile(r"(?<![\w-])(?:tests/measurements/)?results/([A-Za-z0-9_.{},*-]+)")


def _records():
    return load_script("records")


def test_every_file_in_the_folder_is_a_valid_record():
    r = subprocess.run([sys.executable, str(SCRIPT), "check"], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_checker_names_what_is_wrong():
    records = _records()
    good = json.loads(next((ROOT / "tests" / "measurements" / "results").glob("*.json")).read_text())
    assert records.problems(good, good["name"]) == []
    bad = dict(good, name="run-2026-11-22", commit="HEAD", machine={"cores": 2}, extra=1)
    del bad["versions"]
    text = "; ".join(records.problems(bad, "run-2026-11-22"))
    for word in ("no date", "hex digits", "machine must have", "missing 'versions'", "unknown field 'extra'"):
        assert word in text


def test_written_records_pass_the_check_and_show(tmp_path):
    records = _records()
    path = records.write_record("a-test", "nothing: a test of the writer", "pytest", {"wall_s": 1.5},
                                directory=tmp_path)
    rec = json.loads(path.read_text())
    assert records.check(tmp_path) == []
    assert rec["commit_basis"] == "measured" and rec["machine"]["cores"] >= 1
    assert "wall_s" in records.show(rec)
    (tmp_path / "notes.md").write_text("prose")
    assert records.check(tmp_path) == ["notes.md: not a record (only NAME.json files belong here)"]


def test_every_cited_record_exists():
    """Docs, scripts and tests that name a file of tests/measurements/results/ name one that is there.

    A name without a dot is a placeholder (``NAME``, ``run-<suite>-suite.json`` cut at ``<``)."""
    sources = [ROOT / "README.md", *ROOT.glob("docs/*.md"), *ROOT.glob("tests/measurements/**/*.py"),
               *ROOT.glob("tests/measurements/**/*.md"), *ROOT.glob("tests/*.py"), *ROOT.glob("benchmark/**/*.py")]
    missing = []
    for src in sources:
        for name in CITATION.findall(src.read_text()):
            name = name.rstrip(".,")
            if "." in name and not (ROOT / "tests" / "measurements" / "results" / name).is_file():
                missing.append(f"{src.relative_to(ROOT)}: {name}")
    assert not missing, missing
