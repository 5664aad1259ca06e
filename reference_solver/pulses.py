"""Table motions: one full sine or cosine wave (the paper's §4.2), a half-sine, or a record.

Every pulse gives the table's acceleration ``ü(t)``, velocity ``u̇(t)`` and displacement ``u(t)``
exactly (docs/physics.md §4; the paper's eq. (12) for the sine displacement is misprinted, the right
form is ``u = (a₀/ω²)(ωt − sin ωt)``), its duration, and a compact description the compiled
solver understands (:meth:`Pulse.kernel_spec`). Time starts at 0 with the table at rest.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rockbench.reference_solver.errors import ConfigError, check_positive

#: Integer codes the compiled solver uses for the pulse kinds.
PULSE_CODES = {"sine": 0, "cosine": 1, "half-sine": 2, "record": 3}

#: Fewest time steps per pulse duration (per wave for the harmonic pulses) the solvers accept.
MIN_STEPS_PER_WAVE = 20

#: Largest table acceleration accepted [m/s^2] (about 100 000 g): far beyond any shaking table, and a
#: bound that keeps every solver's numbers finite (a record of 1e300 m/s^2 is a units mistake).
MAX_ACCEL_MPS2 = 1e6

#: Most time steps one simulation may take to cover its pulse: a finer step could not finish (the
#: reference takes about 150 ns per step, the engines 10-100 µs, and a history of that many samples
#: fills gigabytes), so it is refused before anything runs.
MAX_STEPS = 10_000_000


def check_accel(amplitude_mps2: float, what: str) -> None:
    """ConfigError when ``|amplitude_mps2|`` exceeds :data:`MAX_ACCEL_MPS2`."""
    if abs(amplitude_mps2) > MAX_ACCEL_MPS2:
        raise ConfigError(f"{what} reaches {abs(amplitude_mps2):.3g} m/s^2 ({abs(amplitude_mps2) / 9.81:.3g} g), more "
                          f"than the {MAX_ACCEL_MPS2:.0e} m/s^2 rockbench accepts; check the units (m/s^2) and the "
                          "amplitude.")


def check_step_count(dt_s: float, duration_s: float, what: str) -> None:
    """ConfigError when covering ``duration_s`` [s] in steps of ``dt_s`` [s] takes more than
    :data:`MAX_STEPS` steps (the message says how many it would take)."""
    n = duration_s / dt_s
    if not n <= MAX_STEPS:
        raise ConfigError(f"--dt {dt_s:g} s would take {n:.3g} steps to cover {what} ({duration_s:.4g} s), more than "
                          f"the {MAX_STEPS:,} one simulation may take; use --dt >= {duration_s / MAX_STEPS:.3g} s.")


class Pulse:
    """Base class: a prescribed horizontal table motion starting at ``t = 0``.

    Subclasses define :meth:`accel`, :meth:`vel`, :meth:`disp` (vectorised over ``t`` [s]),
    :attr:`duration_s` and :meth:`kernel_spec`.
    """

    kind: str = ""
    #: circular frequency ω [rad/s] (None for a record)
    omega_rad_s: float | None = None
    #: amplitude a₀: the peak of |ü| [m/s^2]
    amplitude_mps2: float = 0.0

    @property
    def duration_s(self) -> float:  # pragma: no cover - overridden
        raise NotImplementedError

    def accel(self, t):
        """Table acceleration ``ü(t)`` [m/s^2]."""
        raise NotImplementedError  # pragma: no cover - abstract

    def vel(self, t):
        """Table velocity ``u̇(t)`` [m/s]."""
        raise NotImplementedError  # pragma: no cover - abstract

    def disp(self, t):
        """Table displacement ``u(t)`` [m]."""
        raise NotImplementedError  # pragma: no cover - abstract

    def kernel_spec(self):
        """``(code, a0 [m/s^2], omega [rad/s], duration [s], t_knots [s], a_knots [m/s^2])``.

        The arrays are empty for the harmonic pulses; for a record they are its samples.
        """
        raise NotImplementedError  # pragma: no cover - abstract

    def check_dt(self, dt_s: float) -> float:
        """Validate a time step against this pulse: finite, > 0, and fine enough to follow it.

        Raises
        ------
        ConfigError
            When ``dt_s`` is not a positive number or gives fewer than
            :data:`MIN_STEPS_PER_WAVE` steps per wave (per sample spacing for a record).
        """
        dt = check_positive("--dt", dt_s, "s")
        limit = self.max_dt_s()
        if dt > limit:
            raise ConfigError(
                f"--dt {dt_s:g} s is too coarse for this {self.kind} pulse (duration {self.duration_s:.4g} s): "
                f"use --dt <= {limit:.3g} s.")
        check_step_count(dt, self.duration_s, f"this {self.kind} pulse")
        return dt

    def max_dt_s(self) -> float:
        """The coarsest time step this pulse accepts [s]."""
        return self.duration_s / MIN_STEPS_PER_WAVE

    def to_dict(self) -> dict:
        return {"kind": self.kind, "omega_rad_s": self.omega_rad_s, "amplitude_mps2": self.amplitude_mps2,
                "duration_s": self.duration_s}


@dataclass(frozen=True)
class _Harmonic(Pulse):
    amplitude_mps2: float
    omega_rad_s: float

    def __post_init__(self):
        a = float(self.amplitude_mps2)
        if not math.isfinite(a) or a == 0.0:
            raise ConfigError(f"the amplitude must be a finite non-zero number in m/s^2, got {self.amplitude_mps2!r}.")
        check_positive("the frequency ω", self.omega_rad_s, "rad/s",
                       "Give --w-ratio, --omega or --period as a positive number.")
        check_accel(a, f"the {self.kind} pulse's amplitude")

    @property
    def period_s(self) -> float:
        """Period of one full wave ``2π/ω`` [s]."""
        return 2.0 * math.pi / self.omega_rad_s

    def max_dt_s(self) -> float:
        return self.period_s / MIN_STEPS_PER_WAVE

    def kernel_spec(self):
        empty = np.empty(0)
        return (PULSE_CODES[self.kind], float(self.amplitude_mps2), float(self.omega_rad_s),
                float(self.duration_s), empty, empty)


@dataclass(frozen=True)
class SinePulse(_Harmonic):
    """One full sine wave ``ü = a₀·sin ωt`` for ``0 ≤ t ≤ 2π/ω``, then 0.

    ``u̇ = (a₀/ω)(1 − cos ωt)``, ``u = (a₀/ω²)(ωt − sin ωt)``; the table ends at rest displaced by
    ``2π·a₀/ω²``.
    """

    kind = "sine"

    @property
    def duration_s(self) -> float:
        return self.period_s

    def accel(self, t):
        t = np.asarray(t, dtype=float)
        a, w = self.amplitude_mps2, self.omega_rad_s
        return np.where((t >= 0) & (t <= self.duration_s), a * np.sin(w * t), 0.0)

    def vel(self, t):
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration_s)
        a, w = self.amplitude_mps2, self.omega_rad_s
        return a / w * (1.0 - np.cos(w * t))

    def disp(self, t):
        t = np.asarray(t, dtype=float)
        a, w = self.amplitude_mps2, self.omega_rad_s
        tc = np.clip(t, 0.0, self.duration_s)
        return a / w**2 * (w * tc - np.sin(w * tc))


@dataclass(frozen=True)
class CosinePulse(_Harmonic):
    """One full cosine wave ``ü = a₀·cos ωt`` for ``0 ≤ t ≤ 2π/ω``, then 0.

    ``u̇ = (a₀/ω)·sin ωt``, ``u = (a₀/ω²)(1 − cos ωt)``; the table ends at rest where it started.
    """

    kind = "cosine"

    @property
    def duration_s(self) -> float:
        return self.period_s

    def accel(self, t):
        t = np.asarray(t, dtype=float)
        a, w = self.amplitude_mps2, self.omega_rad_s
        return np.where((t >= 0) & (t <= self.duration_s), a * np.cos(w * t), 0.0)

    def vel(self, t):
        tc = np.clip(np.asarray(t, dtype=float), 0.0, self.duration_s)
        return self.amplitude_mps2 / self.omega_rad_s * np.sin(self.omega_rad_s * tc)

    def disp(self, t):
        tc = np.clip(np.asarray(t, dtype=float), 0.0, self.duration_s)
        w = self.omega_rad_s
        return self.amplitude_mps2 / w**2 * (1.0 - np.cos(w * tc))


@dataclass(frozen=True)
class HalfSinePulse(_Harmonic):
    """A half sine ``ü = a₀·sin ωt`` for ``0 ≤ t ≤ π/ω``, then 0 (the classic literature pulse).

    ``u̇ = (a₀/ω)(1 − cos ωt)`` and ``u = (a₀/ω²)(ωt − sin ωt)`` during the pulse; afterwards the
    table keeps its final velocity ``2a₀/ω`` (a velocity pulse), so ``u`` grows linearly.
    """

    kind = "half-sine"

    @property
    def duration_s(self) -> float:
        return math.pi / self.omega_rad_s

    def accel(self, t):
        t = np.asarray(t, dtype=float)
        a, w = self.amplitude_mps2, self.omega_rad_s
        return np.where((t >= 0) & (t <= self.duration_s), a * np.sin(w * t), 0.0)

    def vel(self, t):
        tc = np.clip(np.asarray(t, dtype=float), 0.0, self.duration_s)
        a, w = self.amplitude_mps2, self.omega_rad_s
        return a / w * (1.0 - np.cos(w * tc))

    def disp(self, t):
        t = np.asarray(t, dtype=float)
        a, w, T = self.amplitude_mps2, self.omega_rad_s, self.duration_s
        tc = np.clip(t, 0.0, T)
        inside = a / w**2 * (w * tc - np.sin(w * tc))
        return inside + np.where(t > T, (2.0 * a / w) * (t - T), 0.0)


@dataclass(frozen=True, eq=False)
class RecordPulse(Pulse):
    """A recorded ground acceleration, linearly interpolated between samples, zero outside them.

    Velocity and displacement are the exact integrals of the piecewise-linear acceleration.

    Parameters
    ----------
    t_s : array_like
        Strictly increasing sample times [s], the first ≥ 0.
    accel_mps2 : array_like
        Accelerations at those times [m/s^2].
    scale : float
        Factor applied to the accelerations [-] (for amplitude sweeps).
    source : str
        Where the record came from (a file path), for provenance.
    """

    t_s: np.ndarray
    accel_mps2: np.ndarray
    scale: float = 1.0
    source: str = ""
    kind = "record"
    omega_rad_s = None
    _v: np.ndarray = field(init=False, repr=False)
    _u: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        t = np.asarray(self.t_s, dtype=float)
        a = np.asarray(self.accel_mps2, dtype=float) * float(self.scale)
        where = f" in {self.source}" if self.source else ""
        if t.ndim != 1 or t.size < 2 or a.shape != t.shape:
            raise ConfigError(f"a ground-acceleration record needs at least two rows of t_s,accel_mps2{where}, "
                              f"got {t.size}.")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
            raise ConfigError(f"the record{where} has non-finite values; give plain numbers in both columns.")
        if t[0] < 0:
            raise ConfigError(f"the record{where} starts at t = {t[0]:g} s; times must be >= 0.")
        check_accel(float(np.max(np.abs(a))), f"the record{where}" + (f" scaled by {self.scale:g}"
                                                                    if self.scale != 1.0 else ""))
        bad = np.nonzero(np.diff(t) <= 0)[0]
        if bad.size:
            i = int(bad[0])
            raise ConfigError(f"the record's times must increase strictly{where}: row {i + 2} has t = {t[i + 1]:g} s "
                              f"after t = {t[i]:g} s; sort the file and remove duplicate times.")
        h = np.diff(t)
        with np.errstate(over="ignore", invalid="ignore"):   # an overflow is reported below, in one line
            v = np.concatenate([[0.0], np.cumsum(0.5 * h * (a[:-1] + a[1:]))])
            du = v[:-1] * h + h * h * (2.0 * a[:-1] + a[1:]) / 6.0
            u = np.concatenate([[0.0], np.cumsum(du)])
        if not (np.all(np.isfinite(v)) and np.all(np.isfinite(u))):
            raise ConfigError(f"the record{where} is too large to integrate: the table's velocity or displacement "
                              f"overflows (peak |ü| = {np.max(np.abs(a)):.3g} m/s^2, {t[-1]:.3g} s long); check the "
                              "units (accel_mps2 in m/s^2, t_s in s).")
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "accel_mps2", a)
        object.__setattr__(self, "_v", v)
        object.__setattr__(self, "_u", u)
        object.__setattr__(self, "amplitude_mps2", float(np.max(np.abs(a))))

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1])

    def max_dt_s(self) -> float:
        return float(np.median(np.diff(self.t_s)))

    def _segment(self, t):
        t = np.asarray(t, dtype=float)
        i = np.clip(np.searchsorted(self.t_s, t, side="right") - 1, 0, self.t_s.size - 2)
        tau = t - self.t_s[i]
        slope = (self.accel_mps2[i + 1] - self.accel_mps2[i]) / (self.t_s[i + 1] - self.t_s[i])
        return t, i, tau, slope

    def accel(self, t):
        t, i, tau, s = self._segment(t)
        inside = (t >= self.t_s[0]) & (t <= self.t_s[-1])
        return np.where(inside, self.accel_mps2[i] + s * tau, 0.0)

    def vel(self, t):
        t, i, tau, s = self._segment(t)
        a = self.accel_mps2
        inside = self._v[i] + a[i] * tau + 0.5 * s * tau**2
        return np.where(t < self.t_s[0], 0.0, np.where(t > self.t_s[-1], self._v[-1], inside))

    def disp(self, t):
        t, i, tau, s = self._segment(t)
        a = self.accel_mps2
        inside = self._u[i] + self._v[i] * tau + 0.5 * a[i] * tau**2 + s * tau**3 / 6.0
        after = self._u[-1] + self._v[-1] * (t - self.t_s[-1])
        return np.where(t < self.t_s[0], 0.0, np.where(t > self.t_s[-1], after, inside))

    def kernel_spec(self):
        return (PULSE_CODES["record"], float(self.amplitude_mps2), 0.0, self.duration_s,
                self.t_s.copy(), self.accel_mps2.copy())

    def to_dict(self) -> dict:
        d = super().to_dict()
        d.update(source=self.source, scale=self.scale, n_samples=int(self.t_s.size))
        return d

    #: the columns of a record file, in this order when it has no header
    CSV_COLUMNS = ("t_s", "accel_mps2")

    @classmethod
    def from_csv(cls, path, scale: float = 1.0) -> "RecordPulse":
        """Read a ``t_s,accel_mps2`` CSV.

        A header line is optional; when there is one it must name the two columns (in either
        order). ``#`` lines are comments; a byte-order mark is skipped; fields may be separated by
        commas, semicolons or tabs (the first line decides).

        Raises
        ------
        ConfigError
            The file cannot be read, is not UTF-8 text, names other columns, or has a row that is
            not two numbers (one line naming the file and the row).
        """
        p = Path(path)
        hint = "give a CSV with columns t_s,accel_mps2 (time [s], ground acceleration [m/s^2])"
        try:
            data = p.read_bytes()
        except OSError as e:
            raise ConfigError(f"cannot read the record file {str(path)!r}: {e.strerror or e}; {hint}.") from None
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as e:
            raise ConfigError(f"the record file {str(path)!r} is not UTF-8 text (byte 0x{data[e.start]:02x} at "
                              f"offset {e.start}); {hint}.") from None
        if "\x00" in text:
            raise ConfigError(f"the record file {str(path)!r} is binary, not text; {hint}.")
        lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
        if not lines:
            raise ConfigError(f"the record file {str(path)!r} is empty; {hint}.")
        first = lines[0]
        delim = ";" if ";" in first else ("\t" if "\t" in first and "," not in first else ",")
        rows = [[f.strip() for f in r] for r in csv.reader(lines, delimiter=delim)]
        order = (0, 1)
        if rows[0] and not is_number(rows[0][0]):      # a header: it must name the two columns
            names = [f.lower() for f in rows[0]]
            if sorted(names) != sorted(cls.CSV_COLUMNS):
                raise ConfigError(f"the record file {str(path)!r} has the columns {delim.join(rows[0])!r}; {hint}.")
            order = (names.index("t_s"), names.index("accel_mps2"))
            rows = rows[1:]
        if not rows:
            raise ConfigError(f"the record file {str(path)!r} is empty; {hint}.")
        ts, accs = [], []
        for n, r in enumerate(rows, start=1):
            if len(r) != 2 or not (is_number(r[0]) and is_number(r[1])):
                raise ConfigError(f"row {n} of the record file {str(path)!r} is not two numbers "
                                  f"(t_s,accel_mps2): got {delim.join(r)!r}.")
            ts.append(float(r[order[0]]))
            accs.append(float(r[order[1]]))
        return cls(np.array(ts), np.array(accs), scale=scale, source=str(path))


def is_number(s: str) -> bool:
    """Whether a text (a record's CSV field, a map's restitution label) reads as a number."""
    try:
        float(s)
        return True
    except ValueError:
        return False


def make_pulse(kind: str, amplitude_mps2: float, omega_rad_s: float) -> Pulse:
    """A harmonic pulse by name: ``sine``, ``cosine`` or ``half-sine``."""
    classes = {"sine": SinePulse, "cosine": CosinePulse, "half-sine": HalfSinePulse}
    try:
        cls = classes[kind]
    except KeyError:
        raise ConfigError(f"--pulse must be sine, cosine, half-sine or a PATH.csv record, got {kind!r}.") from None
    return cls(amplitude_mps2, omega_rad_s)
