"""The engine contract's refactor kept every map identical (issue 45): each engine's yardstick, recorded
before it (tests/measurements/results/yardstick-<engine>.json), recomputed from an empty calibration
cache and compared cell by cell and calibration by calibration (tests/measurements/yardstick.py).

Slow: every calibration, and the time-step rule's, is made afresh (seconds for DART, minutes for
Newton and Genesis, about 25 minutes for MuJoCo Warp on Warp's CPU device).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "measurements"))
import yardstick  # noqa: E402
from records import RESULTS_DIR, load  # noqa: E402

ENGINES = sorted(p.stem.removeprefix("yardstick-").replace("-", "_") for p in RESULTS_DIR.glob("yardstick-*.json"))

pytestmark = [pytest.mark.slow, pytest.mark.engine]


@pytest.mark.parametrize("engine", ENGINES)
def test_the_yardstick_is_unchanged(engine, tmp_path, monkeypatch):
    from rockbench.engines.registry import availability

    if not availability(engine)["available"]:
        pytest.skip(f"{engine} is not installed here")
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path))
    now = yardstick.compute(engine, str(tmp_path))
    diffs, _words, _shape = yardstick.compare(load(yardstick.record_name(engine))["figures"], now)
    assert not diffs, "\n".join(diffs)


def test_a_yardstick_is_recorded_for_every_builtin_engine():
    from rockbench.engines.registry import BUILTIN

    assert set(ENGINES) == set(BUILTIN)
