"""The README stays short and its numbers stay the records': each generated block equals what
tests/measurements/readme_results.py writes from the record verdict-default, and the quick start is the
two commands CI and users run."""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()
sys.path.insert(0, str(ROOT / "tests" / "measurements"))

import readme_results  # noqa: E402
from records import load  # noqa: E402


def _block(name: str) -> str:
    m = re.search(rf"<!-- {name} -->\n(.*?)\n<!-- /{name} -->", README, re.S)
    assert m, f"README lacks its <!-- {name} --> block"
    return m.group(1)


def test_every_generated_block_is_the_records():
    rec = load("verdict-default")
    for name, write in readme_results.BLOCKS.items():
        assert _block(name) == write(rec), f"README's {name} block differs: rerun tests/measurements/readme_results.py"


def test_the_record_is_of_the_default_suite_at_todays_metrics():
    from rockbench.benchmark.scoring.metrics import METRICS_VERSION

    fig = load("verdict-default")["figures"]
    assert str(fig["metrics_version"]) == str(METRICS_VERSION)
    assert fig["suite"] == "default"


def test_the_readme_is_short_and_its_quick_start_is_two_commands():
    assert len(README.splitlines()) <= 160
    start = README.index("## Quick start")
    commands = re.search(r"```bash\n(.*?)```", README[start:], re.S).group(1).strip().splitlines()
    assert len(commands) == 2
    assert commands[0].endswith("rockbench run") and "pytest" in commands[1]
    ci = (ROOT / ".ci" / "run").read_text()
    assert "pytest -q -n 2 --dist loadfile" in ci and commands[1].endswith("pytest -q -n 2 --dist loadfile")


def test_the_readme_names_no_commit_outside_its_generated_blocks():
    text = README
    for name in readme_results.BLOCKS:
        text = text.replace(_block(name), "")
    assert not re.search(r"\b[0-9a-f]{7,40}\b", text), "a commit hash typed into the README"
