"""What an installed rockbench shows about itself: help texts that point at nothing a user lacks,
a shipped suite on request, and the metric definitions in `score --help`."""

import re
import tomllib

import pytest

from rockbench.benchmark.cli.main import COMMANDS, build_parser, main
from rockbench.benchmark.scoring.metrics import METRICS

#: paths that exist only in a clone of the repository (or not even there); report.md is an output
ONLY_IN_A_CLONE = re.compile(r"docs/|shared/|benchmark/suites|tests/measurements/|\b(?!report\.md)\w+\.md\b")


def _help(argv, capsys):
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(argv)
    assert e.value.code == 0
    return capsys.readouterr().out


@pytest.mark.parametrize("command", [None] + list(COMMANDS))
def test_help_points_at_nothing_a_user_does_not_have(command, capsys):
    text = _help([command, "--help"] if command else ["--help"], capsys)
    assert not ONLY_IN_A_CLONE.search(text), ONLY_IN_A_CLONE.search(text).group(0)


def test_score_help_defines_every_metric(capsys):
    text = " ".join(_help(["score", "--help"], capsys).split())
    for m in METRICS.values():
        assert " ".join(m.definition.split()) in text, m.name


@pytest.mark.parametrize("name", ["default", "quick"])
def test_run_shows_a_shipped_suite(name, capsys):
    assert main(["run", "--show-suite", name]) == 0
    suite = tomllib.loads(capsys.readouterr().out)
    assert suite["suite"]["name"] == name and "grid" in suite and "engines" in suite


def test_run_show_suite_refuses_what_is_not_shipped(capsys):
    assert main(["run", "--show-suite", "nope"]) == 2
    assert "default, quick" in capsys.readouterr().err
    assert main(["run", "--show-suite", "quick", "--quick"]) == 2
