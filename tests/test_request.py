"""One case request for the command line and the notebook API: the same words give the same case."""

import pytest

from rockbench.benchmark.api import request_of
from rockbench.benchmark.cli.main import build_parser
from rockbench.benchmark.request import CaseRequest
from rockbench.reference_solver.errors import ConfigError


def _cli(*argv):
    return CaseRequest.from_args(build_parser("simulate").parse_args(["simulate", *argv]))


def test_the_command_line_and_the_api_ask_for_the_same_case():
    cli = _cli("--block", "B3M", "--w-ratio", "6", "--a-ratio", "6.1", "--restitution", "modified", "--k", "0.7595",
               "--engine", "mujoco", "--settings", "shipped", "--set", "contact=distributed")
    api = request_of("B3M", w_ratio=6, a_ratio=6.1, restitution="modified", k=0.7595, engine="mujoco",
                   settings="shipped", contact="distributed")
    (c1, p1), (c2, p2) = cli.case(), api.case()
    assert p1 is p2 and c1.block == c2.block and c1.restitution == c2.restitution and c1.eta == c2.eta
    assert (c1.pulse.kind, c1.pulse.amplitude_mps2, c1.pulse.omega_rad_s) == \
        (c2.pulse.kind, c2.pulse.amplitude_mps2, c2.pulse.omega_rad_s)
    assert cli.engine_settings() == api.engine_settings() == {"settings": "shipped", "contact": "distributed"}


def test_a_map_spec_from_the_request():
    from rockbench.benchmark.maps.grid import make_axis
    spec = request_of("B6L", restitution="housner").map_spec(
        "cosine", lambda: (make_axis("--w-ratio", "w_ratio", 1, 4, 4), make_axis("--a-ratio", "a_ratio", 1, 3, 3)))
    assert spec.block.name == "B6L" and spec.pulse == "cosine" and spec.shape == (3, 4) and spec.engine == "reference"


@pytest.mark.parametrize("kw, words", [
    ({"w_ratio": 6}, "no amplitude given"),
    ({"w_ratio": 6, "omega": 3, "a_ratio": 2}, "the frequency is given twice"),
    ({"w_ratio": 6, "a_ratio": 2, "width": 0.05}, "give either --block or --width/--height"),
])
def test_one_rule_one_message(kw, words):
    with pytest.raises(ConfigError, match=words):
        request_of("B3M", **kw).case()
