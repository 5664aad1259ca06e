"""The command line imports only what the command it runs needs: ``--help`` and
``blocks`` neither numpy nor numba; matplotlib only where a picture is drawn, and never pyplot
for a map's picture. What is checked is what gets imported, not how long it takes."""

import json
import subprocess
import sys

import pytest

from rockbench.benchmark.cli.main import COMMANDS, build_parser, command_of, main


def _loaded_after(argv: list[str], *, cwd=None) -> set:
    code = ("import sys, json; from rockbench.benchmark.cli.main import main; "
            f"rc = main({argv!r}); "
            "print(json.dumps({'rc': rc, 'mods': sorted(m for m in sys.modules if m.split('.')[0] in "
            "('numpy', 'numba', 'matplotlib', 'scipy', 'dask', 'tqdm'))}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=cwd)
    doc = json.loads(out.stdout.strip().splitlines()[-1])
    assert doc["rc"] == 0, out.stderr
    return {m.split(".")[0] for m in doc["mods"]} | ({"matplotlib.pyplot"} if "matplotlib.pyplot" in doc["mods"]
                                                     else set())


@pytest.mark.parametrize("argv", [["--help"], ["blocks"], ["blocks", "--json"]])
def test_help_and_blocks_import_no_numerics(argv):
    if argv == ["--help"]:
        # argparse's --help exits through SystemExit(0): run it through the console entry instead
        out = subprocess.run([sys.executable, "-c", "import sys; from rockbench.benchmark.cli.main import main; "
                              "\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
                              "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'numba', "
                              "'matplotlib')))"], capture_output=True, text=True, check=True)
        assert out.stdout.strip().splitlines()[-1] == "[]"
        assert "simulate" in out.stdout and "check-adapter" in out.stdout
        return
    assert _loaded_after(argv) == set()


def test_map_without_picture_imports_no_matplotlib(tmp_path):
    mods = _loaded_after(["map", "--block", "B3M", "--w-ratio", "1:5:4", "--a-ratio", "1:5:4", "--out",
                          str(tmp_path / "m"), "--no-plot", "--json"])
    assert "matplotlib" not in mods and "numba" in mods


def test_map_picture_without_pyplot(tmp_path):
    mods = _loaded_after(["map", "--block", "B3M", "--w-ratio", "1:5:4", "--a-ratio", "1:5:4", "--out",
                          str(tmp_path / "m"), "--json"])
    # drawn by the forked helper (two cores or more: this process never loads matplotlib) or here
    assert "matplotlib.pyplot" not in mods
    assert (tmp_path / "m" / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


_DRAW = """
import sys, numpy as np
from rockbench.benchmark.maps.grid import MapSpec, make_axis
from rockbench.benchmark.maps.result import empty_result
from rockbench.benchmark.report.plots.picture import MapPicture
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.reference_solver.restitution import Restitution
s = MapSpec(get_preset("B3M").block(), "sine", Restitution(), make_axis("--w-ratio", "w_ratio", 1, 8, 30),
            make_axis("--a-ratio", "a_ratio", 1, 8, 20))
r = empty_result(s)
i, j = np.indices(s.shape)
r.outcome[:] = np.where(i > j, 2, np.where(i > 3, 1, 0))
r.outcome[5, 5] = -1
r.simulated[:] = True
helper = sys.argv[1] == "helper"
pic = MapPicture(helper=helper)
assert (pic.pid is not None) == helper
assert "matplotlib" not in sys.modules
pic.draw(r, sys.argv[2])
print(sorted(m for m in sys.modules if m.startswith("matplotlib.pyplot")), "matplotlib" in sys.modules)
"""


@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="the helper is forked")
def test_picture_by_helper_equals_picture_drawn_here(tmp_path):
    out = {}
    for how in ("helper", "here"):
        r = subprocess.run([sys.executable, "-c", _DRAW, how, str(tmp_path / how)], capture_output=True,
                           text=True, check=True)
        out[how] = r.stdout.split()
    assert out["helper"] == ["[]", "False"]        # the helper drew it: this process loaded no matplotlib
    assert out["here"] == ["[]", "True"]           # drawn here: matplotlib, but not pyplot
    assert (tmp_path / "helper.png").read_bytes() == (tmp_path / "here.png").read_bytes()


def test_help_lines_are_the_commands_own():
    """The stubs ``--help`` shows say what each command's own parser says."""
    parser = build_parser("*")
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    own = {a.dest: a.help for a in sub._choices_actions}
    assert own == COMMANDS


def test_command_of():
    assert command_of(["--debug", "map", "--out", "x"]) == "map"
    assert command_of(["--version"]) is None
    assert command_of([]) is None


def test_unknown_command_is_usage_error(capsys):
    assert main(["mapp"]) == 2
    assert "invalid choice" in capsys.readouterr().err
