"""The map stage's located boundary: on a map of known boundaries, stored and resumed mid-bisection,
loaded back, of the schema before it, and the reference solver's crossings against independent root
finds."""

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.maps import locating
from rockbench.benchmark.maps.bisection import ALONG_A, ALONG_W
from rockbench.benchmark.maps.boundary import midpoint_boundary
from rockbench.benchmark.maps.grid import MapSpec, make_axis
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.scoring.metrics import critical_amplitude
from rockbench.benchmark.store.files import SAMPLE_COLUMNS, read_samples
from rockbench.benchmark.store.loading import load_entry, load_map
from rockbench.benchmark.errors import IncomparableError
from rockbench.reference_solver.model import G
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution, modified_eta
from rockbench.reference_solver.solver import solve_batch

from ivp_baseline import critical_amplitude as event_critical_amplitude, solve_events


def analytic_spec(n=12):
    return MapSpec(get_preset("B6M").block(), "sine", Restitution(), make_axis("--w-ratio", "w_ratio", 0.5, 8.0, n),
                   make_axis("--a-ratio", "a_ratio", 0.5, 9.0, n), engine="analytic")


@pytest.mark.usefixtures("fake_engines")
def test_analytic_map_crossings_lie_on_its_known_lines(tmp_path):
    """The analytic map overturns above a = 1 + 0.8 w (tests/maps_helpers.py) but in a rocking band 0.05
    about a = 2.5 + 0.8 w, and in a strip 0.06 about a = 1.5 for w < 6: every located crossing lies on
    one of those lines to the tolerance."""
    depth = 6
    r = run_map(analytic_spec(), tmp_path / "m", serial=True, locate_depth=depth)
    b = r.located
    assert b.depth == depth and b.n_crossings > 20 and b.n_samples > 0
    s = r.spec
    dw, da = s.w_ratio_axis[1] - s.w_ratio_axis[0], s.a_ratio_axis[1] - s.a_ratio_axis[0]
    w, a = b.points.T
    # the tolerance along each crossing's own direction, and what it means across the slanted line
    tol = np.where(b.axis == ALONG_W, 0.8 * dw, da) * 0.5 / 2 ** depth + 1e-9
    off = np.min(np.abs(np.stack([a - (1 + 0.8 * w), np.abs(a - (2.5 + 0.8 * w)) - 0.05,
                                  np.where(w < 6, np.abs(a - 1.5) - 0.06, np.inf)])), axis=0)
    assert np.all(off <= tol), b.points[off > tol]


def _sample_keys(d):
    rows, _ = read_samples(d / "bisection.csv")
    return rows


@pytest.mark.usefixtures("fake_engines")
def test_resume_mid_bisection_computes_no_sample_twice(tmp_path, monkeypatch):
    spec = analytic_spec()
    whole = run_map(spec, tmp_path / "whole", serial=True, locate_depth=6)
    real = locating._run_samples
    calls = []

    def interrupted(sweep, keys):
        if len(calls) == 3:
            raise KeyboardInterrupt("stopped in round 4")
        calls.append(len(keys))
        return real(sweep, keys)

    monkeypatch.setattr(locating, "_run_samples", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_map(spec, tmp_path / "m", serial=True, locate_depth=6)
    stored = _sample_keys(tmp_path / "m")
    assert len(stored) == sum(calls) and not (tmp_path / "m" / "boundary.csv").exists()
    # a kill in mid-write leaves half a row: cut off, that sample computed again
    with open(tmp_path / "m" / "bisection.csv", "a") as f:
        f.write("analytic,analytic,B6M,sine,housner,0.9")
    again = []

    def counted(sweep, keys):
        again.append(len(keys))
        return real(sweep, keys)

    monkeypatch.setattr(locating, "_run_samples", counted)
    r = run_map(spec, tmp_path / "m", serial=True, locate_depth=6)
    rows = _sample_keys(tmp_path / "m")
    text = (tmp_path / "m" / "bisection.csv").read_text().splitlines()
    assert len(text) - 1 == len(rows) == whole.located.n_samples       # every sample stored once
    assert sum(again) == whole.located.n_samples - len(stored)           # none computed twice
    for name in ("points", "t", "flags", "edges"):
        np.testing.assert_array_equal(getattr(r.located, name), getattr(whole.located, name))
    assert (tmp_path / "m" / "boundary.csv").read_bytes() == (tmp_path / "whole" / "boundary.csv").read_bytes()


@pytest.mark.usefixtures("fake_engines")
def test_load_map_round_trip(tmp_path):
    r = run_map(analytic_spec(), tmp_path / "m", serial=True, adaptive=True, coarse_stride=3, locate_depth=5)
    back = load_map(tmp_path / "m")
    for name in ("points", "t", "band", "cell_a", "cell_b", "edges", "flags"):
        np.testing.assert_array_equal(getattr(back.located, name), getattr(r.located, name))
    np.testing.assert_array_equal(back.located.chords(), r.located.chords())
    assert back.located.summary() == r.located.summary()
    assert load_entry(tmp_path / "m").map.located.summary() == r.located.summary()
    meta = json.loads((tmp_path / "m" / "run.json").read_text())
    assert meta["options"]["locate_depth"] == 5 and meta["summary"]["locate_depth"] == 5
    assert meta["summary"]["bisection_samples"] == r.located.n_samples
    header = (tmp_path / "m" / "bisection.csv").read_text().splitlines()[0].split(",")
    assert header == SAMPLE_COLUMNS
    lines = (tmp_path / "m" / "boundary.csv").read_text().splitlines()
    assert lines[0] == "w_ratio,a_ratio,i,j,axis,t,kind,flag" and len(lines) == 1 + r.located.n_crossings


@pytest.mark.usefixtures("fake_engines")
def test_a_map_of_schema_3_loads_at_depth_0_and_is_not_resumed(tmp_path):
    d = tmp_path / "m"
    r = run_map(analytic_spec(), d, serial=True, locate_depth=0)
    meta = json.loads((d / "run.json").read_text())
    meta["schema_version"] = 3
    del meta["options"]["locate_depth"]
    (d / "run.json").write_text(json.dumps(meta))
    (d / "boundary.csv").unlink()
    back = load_map(d)
    mid = midpoint_boundary(r.outcome, r.w_ratio, r.a_ratio, r.n_impacts)
    assert back.located.depth == 0
    np.testing.assert_array_equal(back.located.points, mid.points)
    with pytest.raises(IncomparableError, match="schema 3.*does not resume.*delete it"):
        run_map(analytic_spec(), d, serial=True)


def test_reference_crossings_agree_with_a_root_find(tmp_path):
    """The reference map's crossings on edges along a₀ against scipy's brentq on the solver's own
    overturn-or-not at each edge's frequency, to the declared tolerance."""
    block = get_preset("B3M").block()
    depth = 7
    spec = MapSpec(block, "sine", Restitution(), make_axis("w", "w_ratio", 2.0, 8.0, 7),
                   make_axis("a", "a_ratio", 1.0, 9.0, 9))
    b = run_map(spec, tmp_path / "ref", serial=True, locate_depth=depth).located
    scale = G * math.tan(block.alpha_rad)
    eta = spec.eta
    da = spec.a_ratio_axis[1] - spec.a_ratio_axis[0]
    checked = 0
    for k in np.nonzero((b.axis == ALONG_A) & ~b.band)[0]:
        i, j = b.cell_a[k]
        w = spec.omega_axis[j]

        def f(a_ratio):
            out = solve_batch(block.alpha_rad, block.p_rad_s, eta, "sine", np.array([w]),
                              np.array([a_ratio * scale])).outcome[0]
            return 1.0 if out == 2 else -1.0

        lo, hi = spec.a_ratio_axis[i], spec.a_ratio_axis[i + 1]
        root = brentq(f, lo, hi, xtol=1e-6)
        assert abs(b.points[k, 1] - root) <= 0.5 * da / 2 ** depth + 1e-6, (i, j, b.points[k], root)
        checked += 1
    assert checked >= 5


def test_critical_amplitude_agrees_with_the_event_driven_solution(tmp_path):
    """The located critical amplitude of one column against tests/ivp_baseline.py's independent
    event-driven solver (which agrees with the Newmark solver to 0.5 %)."""
    block = get_preset("B3M").block()
    depth = 8
    spec = MapSpec(block, "sine", Restitution.parse("modified", k=0.8608), make_axis("w", "w_ratio", 1.5, 2.5, 3),
                   make_axis("a", "a_ratio", 1.0, 9.0, 9))
    run_map(spec, tmp_path / "ref", serial=True, locate_depth=depth)
    m = load_entry(tmp_path / "ref").map
    a_loc = critical_amplitude(m)[1]                      # the column at ω/p = 2
    scale = G * math.tan(block.alpha_rad)
    w = 2.0 * block.p_rad_s
    eta = modified_eta(block.alpha_rad, 0.8608)
    a_e = event_critical_amplitude(lambda a: solve_events(block.alpha_rad, block.p_rad_s, eta,
                                                          make_pulse("sine", a, w))["outcome"],
                                   0.9 * (a_loc - 1.0) * scale, 1.1 * (a_loc + 1.0) * scale) / scale
    assert a_loc == pytest.approx(a_e, abs=0.5 / 2 ** depth + 5e-3 * a_e)


@pytest.mark.usefixtures("fake_engines")
def test_a_damaged_sample_row_is_named(tmp_path):
    from rockbench.reference_solver.errors import ConfigError

    d = tmp_path / "m"
    run_map(analytic_spec(), d, serial=True, locate_depth=3)
    lines = (d / "bisection.csv").read_text().splitlines(keepends=True)
    lines[2] = lines[2].rsplit(",", 1)[0] + ",1.5\n"       # t outside (0, 1)
    (d / "bisection.csv").write_text("".join(lines))
    with pytest.raises(ConfigError, match=r"bisection.csv' line 3: t '1.5' is not a number between 0 and 1"):
        load_map(d)
