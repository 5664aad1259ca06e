"""Fixtures shared by the tests.

``fake_engines``
    registers the small test adapters of ``tests/maps_helpers.py`` (the analytic map and engines that
    misbehave on purpose) and gives that module. They stay in a module of their own because worker
    processes import them by name (``"maps_helpers:AnalyticAdapter"``).
``analytic_truth``
    the analytic adapters' known outcome grid of a MapSpec.
``write_map``, ``band``
    a map directory written by hand in the store's own layout (run.json + cells.csv), and a simple
    outcome grid for it (``tests/mapdirs.py``, which ``tests/measurements/bench_scores.py`` uses too).

``fake_engines`` registers again for every test that asks (as the per-file fixtures did before); the
other three hold no state and are session-wide, so module-scoped fixtures may use them.
"""

import pytest

import maps_helpers
import mapdirs


@pytest.fixture
def fake_engines():
    maps_helpers.register_all()
    return maps_helpers


@pytest.fixture(scope="session")
def analytic_truth():
    return lambda spec: maps_helpers.analytic_grid(spec.w_ratios(), spec.a_ratios())


@pytest.fixture(scope="session")
def write_map():
    return mapdirs.write_map


@pytest.fixture(scope="session")
def band():
    return mapdirs.band

