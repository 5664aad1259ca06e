"""Table pulses: ü, u̇, u consistent and exact (docs/physics.md §4; the paper's eq. (12) is misprinted)."""

import math

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.pulses import (CosinePulse, HalfSinePulse, RecordPulse, SinePulse, make_pulse)


def _integrals_match(pulse, t_end):
    t = np.linspace(0.0, t_end, 200_001)
    a = pulse.accel(t)
    v = cumulative_trapezoid(a, t, initial=0.0)
    u = cumulative_trapezoid(pulse.vel(t), t, initial=0.0)
    # the trapezoid smears a jump of ü at the pulse's end over one sample: tolerance ~ a0·Δt
    tol = 2 * (t[1] - t[0]) * max(1.0, np.abs(a).max())
    np.testing.assert_allclose(pulse.vel(t), v, atol=tol)
    np.testing.assert_allclose(pulse.disp(t), u, atol=tol)


@pytest.mark.parametrize("cls", [SinePulse, CosinePulse, HalfSinePulse])
def test_velocity_and_displacement_are_integrals(cls):
    p = cls(7.3, 13.0)
    _integrals_match(p, 1.5 * p.duration_s + 0.2)


def test_sine_closed_forms_and_end_state():
    a0, w = 5.0, 20.0
    p = SinePulse(a0, w)
    T = 2 * math.pi / w
    assert p.duration_s == pytest.approx(T)
    assert p.vel(T) == pytest.approx(0.0, abs=1e-12)
    assert p.disp(T) == pytest.approx(2 * math.pi * a0 / w**2)   # not eq. (12) as printed
    assert p.disp(T + 1.0) == pytest.approx(2 * math.pi * a0 / w**2)
    assert p.accel(T + 1e-9) == 0.0


def test_cosine_end_state_back_to_zero():
    p = CosinePulse(4.0, 10.0)
    T = p.duration_s
    assert p.accel(0.0) == 4.0
    assert p.vel(T) == pytest.approx(0.0, abs=1e-12)
    assert p.disp(T) == pytest.approx(0.0, abs=1e-12)


def test_half_sine_is_a_velocity_pulse():
    a0, w = 3.0, 8.0
    p = HalfSinePulse(a0, w)
    assert p.duration_s == pytest.approx(math.pi / w)
    assert p.vel(10.0) == pytest.approx(2 * a0 / w)


def test_record_reproduces_a_sampled_sine():
    a0, w = 6.0, 15.0
    s = SinePulse(a0, w)
    t = np.linspace(0, s.duration_s, 4001)
    r = RecordPulse(t, s.accel(t))
    tt = np.linspace(0, s.duration_s * 1.2, 777)
    np.testing.assert_allclose(r.accel(tt), s.accel(tt), atol=1e-4 * a0)
    np.testing.assert_allclose(r.vel(tt), s.vel(tt), atol=1e-6)
    np.testing.assert_allclose(r.disp(tt), s.disp(tt), atol=1e-7)


def test_record_is_exact_for_piecewise_linear():
    r = RecordPulse([0.5, 1.0, 2.0], [0.0, 2.0, -1.0])
    assert r.accel(0.25) == 0.0 and r.accel(2.5) == 0.0
    assert r.accel(0.75) == pytest.approx(1.0)
    # v(1) = area of the triangle = 0.5; v(2) = 0.5 + (2 + -1)/2 = 1.0
    assert r.vel(1.0) == pytest.approx(0.5)
    assert r.vel(2.0) == pytest.approx(1.0)
    _integrals_match(r, 3.0)


def test_record_csv(tmp_path):
    f = tmp_path / "rec.csv"
    f.write_text("# a comment\nt_s,accel_mps2\n0,0\n0.1,1\n0.2,0\n")
    r = RecordPulse.from_csv(f)
    assert r.duration_s == pytest.approx(0.2) and r.amplitude_mps2 == 1.0
    assert RecordPulse.from_csv(f, scale=3.0).amplitude_mps2 == 3.0


@pytest.mark.parametrize("text,match", [
    ("", "empty"),
    ("t_s,accel_mps2\n", "empty"),
    ("0,1\n0.1,abc\n", "row 2"),
    ("0,1\n0.2,2\n0.1,3\n", "increase strictly"),
    ("0,1\n0.1,2\n0.1,3\n", "increase strictly"),
    ("0,1\n", "at least two rows"),
    ("0,1\n0.1,nan\n", "non-finite"),
])
def test_bad_record_files(tmp_path, text, match):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(ConfigError, match=match):
        RecordPulse.from_csv(f)


def test_unreadable_record_file(tmp_path):
    with pytest.raises(ConfigError, match="cannot read"):
        RecordPulse.from_csv(tmp_path / "missing.csv")


def test_dt_checks():
    p = SinePulse(1.0, 2 * math.pi)   # 1 s wave
    assert p.check_dt(0.01) == 0.01
    with pytest.raises(ConfigError, match="too coarse"):
        p.check_dt(0.1)
    for bad in (0, -1e-3, float("nan"), float("inf")):
        with pytest.raises(ConfigError):
            p.check_dt(bad)


@pytest.mark.parametrize("a0,w", [(0.0, 1.0), (float("nan"), 1.0), (1.0, 0.0), (1.0, -2.0), (1.0, float("inf"))])
def test_bad_harmonic(a0, w):
    with pytest.raises(ConfigError):
        SinePulse(a0, w)


def test_unknown_pulse_kind():
    with pytest.raises(ConfigError, match="--pulse must be"):
        make_pulse("square", 1.0, 1.0)


# -- record files ------------------------------------------------------------------------

@pytest.mark.parametrize("text, match", [
    ("foo,bar,baz\n0,1,2\n0.1,2,3\n", "has the columns 'foo,bar,baz'"),
    ("time,acc\n0,1\n0.1,2\n", "has the columns 'time,acc'"),
    ("t_s,accel_mps2\n0,1,5\n0.1,2,5\n", "row 1"),
    ("0,1\n0.1,1e300\n0.2,-1e300\n", "1e\\+300 m/s\\^2"),
])
def test_bad_record_columns_and_values(tmp_path, text, match):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(ConfigError, match=match):
        RecordPulse.from_csv(f)


def test_huge_record_values_give_no_numpy_warning(tmp_path):
    import warnings
    f = tmp_path / "big.csv"
    f.write_text("0,1\n0.1,1e300\n0.2,-1e300\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ConfigError, match="check the units"):
            RecordPulse.from_csv(f)


@pytest.mark.parametrize("text", [
    "t_s,accel_mps2\n0,0\n0.1,1\n0.2,0\n",
    "accel_mps2,t_s\n0,0\n1,0.1\n0,0.2\n",                 # swapped, named: read by name
    "\ufeff0,0\n0.1,1\n0.2,0\n",                             # a BOM and no header: the first row is data
    "\ufefft_s,accel_mps2\n0,0\n0.1,1\n0.2,0\n",
    "0;0\n0.1;1\n0.2;0\n",                                   # semicolons, no header
    "t_s;accel_mps2\n0;0\n0.1;1\n0.2;0\n",
    "0\t0\n0.1\t1\n0.2\t0\n",
    " T_S , Accel_MPS2 \n0, 0\n0.1, 1\n0.2, 0\n",
])
def test_record_formats_all_read_the_same(tmp_path, text):
    f = tmp_path / "rec.csv"
    f.write_bytes(text.encode("utf-8"))
    r = RecordPulse.from_csv(f)
    assert list(r.t_s) == [0.0, 0.1, 0.2] and list(r.accel_mps2) == [0.0, 1.0, 0.0]


def test_record_that_is_a_folder_or_binary(tmp_path):
    with pytest.raises(ConfigError, match="cannot read"):
        RecordPulse.from_csv(tmp_path)
    f = tmp_path / "bin.csv"
    f.write_bytes(bytes(range(256)))
    with pytest.raises(ConfigError, match="UTF-8"):
        RecordPulse.from_csv(f)


def test_a_step_that_cannot_finish_is_refused():
    from rockbench.reference_solver.pulses import MAX_STEPS
    p = SinePulse(1.0, 2 * math.pi)   # 1 s wave
    assert p.check_dt(1.0 / MAX_STEPS) == 1.0 / MAX_STEPS
    with pytest.raises(ConfigError, match=r"1e\+12 steps.*use --dt >= 1e-07 s"):
        p.check_dt(1e-12)
