"""The grid of a stability map: its two axes and the case each cell simulates (:class:`MapSpec`).

Grid layout: ``outcome[i, j]`` is the cell with amplitude index ``i`` (vertical axis, a₀/(g·tanα))
and frequency index ``j`` (horizontal axis, ω/p), the way the paper's stability graphs are drawn.
The axes may be given in normalised units (``w_ratio`` = ω/p, ``a_ratio`` = a₀/(g·tanα)) or in
physical ones (``omega_rad_s`` [rad/s]; ``amplitude_mps2`` [m/s^2] or ``amplitude_g`` [g]); both
are stored for every cell. Each axis holds ``n`` values from ``lo`` to ``hi`` inclusive, evenly
spaced in the unit it was given in. A grid is a part of a map, not a map: the map in memory is
:class:`rockbench.benchmark.maps.result.MapResult` (docs/maps.md).
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, field

import numpy as np

from rockbench.engines.contract import Case
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import Block, G, a_ratio_to_amplitude, amplitude_to_a_ratio
from rockbench.reference_solver.pulses import MIN_STEPS_PER_WAVE, check_accel, check_step_count, make_pulse
from rockbench.reference_solver.restitution import Restitution
from rockbench.benchmark.engine_info.setting_names import stored_settings



#: Pulse kinds a map accepts (a record has no frequency to sweep).
MAP_PULSES = ("sine", "cosine", "half-sine")


#: Horizontal-axis units: option name → unit label.
X_AXES = {"w_ratio": "ω/p [-]", "omega_rad_s": "ω [rad/s]"}


#: Vertical-axis units.
Y_AXES = {"a_ratio": "a0/(g·tanα) [-]", "amplitude_mps2": "a0 [m/s^2]", "amplitude_g": "a0 [g]"}


#: The CLI option of each axis unit (for messages).
AXIS_OPTION = {"w_ratio": "--w-ratio", "omega_rad_s": "--omega", "a_ratio": "--a-ratio",
               "amplitude_mps2": "--amplitude", "amplitude_g": "--amplitude-g"}


#: Memory a map holds per cell while it runs (grids, the row written, the case) [bytes]; with
#: :data:`MAX_CELLS` it bounds what ``--w-ratio``/``--a-ratio`` may ask for.
BYTES_PER_CELL = 2048


#: Largest number of cells in one map (4 million = 2000 × 2000).
MAX_CELLS = 4_000_000


@dataclass(frozen=True)
class Axis:
    """One axis of a map: ``n`` values from ``lo`` to ``hi`` inclusive in the unit ``name``.

    Attributes
    ----------
    name : str
        ``w_ratio``, ``omega_rad_s`` (horizontal) or ``a_ratio``, ``amplitude_mps2``,
        ``amplitude_g`` (vertical).
    lo, hi : float
        First and last value, in that unit (> 0, ``lo < hi`` unless ``n == 1``).
    n : int
        Number of values (≥ 1).
    """

    name: str
    lo: float
    hi: float
    n: int

    def values(self) -> np.ndarray:
        """The axis values in its own unit."""
        return np.linspace(self.lo, self.hi, self.n)

    def to_dict(self) -> dict:
        return {"name": self.name, "lo": self.lo, "hi": self.hi, "n": self.n}

    @classmethod
    def from_dict(cls, d: dict) -> "Axis":
        name = str(d["name"])
        return make_axis(f"the axis {name}", name, float(d["lo"]), float(d["hi"]), _whole(d["n"], f"{name}.n"))


def _whole(v, what: str) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise ValueError(f"{what} must be a whole number, got {v!r}")
    return v


def parse_range(option: str, text: str, name: str) -> Axis:
    """Parse ``LO:HI:N`` given to ``option`` into an :class:`Axis` in unit ``name``.

    Raises
    ------
    ConfigError
        Malformed text, non-numbers, values ≤ 0, a reversed or empty range, or N < 1.
    """
    parts = str(text).split(":")
    if len(parts) != 3:
        raise ConfigError(f"{option} takes LO:HI:N (N values from LO to HI inclusive), got {text!r}; "
                          f"e.g. {option} 1:10:100.")
    try:
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise ConfigError(f"{option} LO and HI must be numbers, got {text!r}; e.g. {option} 1:10:100.") from None
    try:
        n = int(parts[2])
    except ValueError:
        raise ConfigError(f"{option} N must be a whole number of points, got {parts[2]!r} in {text!r}.") from None
    return make_axis(option, name, lo, hi, n)


def make_axis(option: str, name: str, lo: float, hi: float, n: int) -> Axis:
    """A checked :class:`Axis` (see :func:`parse_range` for the rules)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo <= 0 or hi <= 0:
        raise ConfigError(f"{option} LO and HI must be finite numbers > 0, got {lo:g}:{hi:g}.")
    if n < 1:
        raise ConfigError(f"{option} needs at least one point, got N = {n}.")
    if hi < lo:
        raise ConfigError(f"{option} range is reversed ({lo:g} > {hi:g}); give LO:HI:N with LO < HI.")
    if hi == lo and n > 1:
        raise ConfigError(f"{option} range {lo:g}:{hi:g} is empty but asks for {n} points; "
                          "give LO < HI, or N = 1 for a single value.")
    if n == 1 and hi != lo:
        raise ConfigError(f"{option} asks for one point between {lo:g} and {hi:g}; give N >= 2, or LO = HI.")
    return Axis(name, float(lo), float(hi), int(n))


@dataclass(frozen=True)
class MapSpec:
    """What a map computes; two runs with equal ``to_dict()`` are the same map.

    Attributes
    ----------
    block : Block
        The block.
    pulse : str
        ``sine``, ``cosine`` or ``half-sine``.
    restitution : Restitution
        The restitution law.
    x, y : Axis
        Horizontal (frequency) and vertical (amplitude) axes.
    engine : str
        Registry name of the engine.
    engine_settings : dict
        Settings passed to the adapter (only those given by the user).
    dt_s : float or None
        Time step [s] (None: the engine's default).
    linearized : bool
        Linearised equation of motion (reference only).
    """

    block: Block
    pulse: str
    restitution: Restitution
    x: Axis
    y: Axis
    engine: str = "reference"
    engine_settings: dict = field(default_factory=dict, hash=False, compare=False)
    dt_s: float | None = None
    linearized: bool = False

    def __post_init__(self):
        if self.pulse not in MAP_PULSES:
            raise ConfigError(f"a map needs a harmonic pulse to sweep ({', '.join(MAP_PULSES)}), got "
                              f"--pulse {self.pulse!r}; use `rockbench simulate` for a record.")
        if self.x.name not in X_AXES:
            raise ConfigError(f"the horizontal axis must be one of {', '.join(X_AXES)}, got {self.x.name!r}.")
        if self.y.name not in Y_AXES:
            raise ConfigError(f"the vertical axis must be one of {', '.join(Y_AXES)}, got {self.y.name!r}.")
        cells = self.x.n * self.y.n
        if cells > MAX_CELLS:
            raise ConfigError(f"a {self.y.n}×{self.x.n} map has {cells:,} cells, more than the {MAX_CELLS:,} "
                              f"one map may hold; use fewer points (e.g. 2000×2000) or split the range.")
        check_accel(float(np.max(np.abs(self.amplitude_axis))), f"the top of this map's amplitude axis "
                    f"({AXIS_OPTION[self.y.name]} up to {self.y.hi:g})")
        need = cells * BYTES_PER_CELL
        avail = _available_memory_bytes()
        if avail is not None and need > 0.5 * avail:
            raise ConfigError(f"a {self.y.n}×{self.x.n} map needs about {need / 2**30:.1f} GiB of memory, more than "
                              f"half of the {avail / 2**30:.1f} GiB available; use fewer points.")
        if self.dt_s is not None:
            # the finest wave of the map must still get MIN_STEPS_PER_WAVE steps: refuse before any work
            omega_max = float(self.omegas().max())
            period = (math.pi if self.pulse == "half-sine" else 2.0 * math.pi) / omega_max
            if self.dt_s > period / MIN_STEPS_PER_WAVE:
                raise ConfigError(f"--dt {self.dt_s:g} s is too coarse for the highest frequency of this map "
                                  f"(ω = {omega_max:.4g} rad/s): use --dt <= {period / MIN_STEPS_PER_WAVE:.3g} s "
                                  "or a lower frequency range.")
            # and the longest wave must finish: a step too fine would hang the map (refused, not waited for)
            longest = (math.pi if self.pulse == "half-sine" else 2.0 * math.pi) / float(self.omegas().min())
            check_step_count(self.dt_s, longest, f"the longest wave of this map (ω = {self.omegas().min():.4g} rad/s)")
        self.restitution.eta_for(self.block.alpha_rad)   # a law that gives no η for this block fails here

    # -- the grid -----------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        """``(n_amplitudes, n_frequencies)``: rows are amplitudes, columns frequencies."""
        return (self.y.n, self.x.n)

    @property
    def n_cells(self) -> int:
        return self.x.n * self.y.n

    # the axis arrays are computed once per spec (a 200×200 map asks for them 40 000 times) and
    # shared read-only; the methods below hand out copies
    @functools.cached_property
    def omega_axis(self) -> np.ndarray:
        """ω of each column [rad/s] (read-only)."""
        v = self.x.values()
        return _read_only(v * self.block.p_rad_s if self.x.name == "w_ratio" else v)

    @functools.cached_property
    def amplitude_axis(self) -> np.ndarray:
        """a₀ of each row [m/s^2] (read-only)."""
        v = self.y.values()
        if self.y.name == "a_ratio":
            return _read_only(a_ratio_to_amplitude(self.block, v))
        return _read_only(v * G if self.y.name == "amplitude_g" else v)

    @functools.cached_property
    def w_ratio_axis(self) -> np.ndarray:
        """ω/p of each column [-] (read-only)."""
        v = self.x.values()
        return _read_only(v if self.x.name == "w_ratio" else v / self.block.p_rad_s)

    @functools.cached_property
    def a_ratio_axis(self) -> np.ndarray:
        """a₀/(g·tanα) of each row [-] (read-only)."""
        v = self.y.values()
        return _read_only(v if self.y.name == "a_ratio" else amplitude_to_a_ratio(self.block, self.amplitude_axis))

    def omegas(self) -> np.ndarray:
        """ω of each column [rad/s]."""
        return self.omega_axis.copy()

    def amplitudes(self) -> np.ndarray:
        """a₀ of each row [m/s^2]."""
        return self.amplitude_axis.copy()

    def w_ratios(self) -> np.ndarray:
        """ω/p of each column [-]."""
        return self.w_ratio_axis.copy()

    def a_ratios(self) -> np.ndarray:
        """a₀/(g·tanα) of each row [-]."""
        return self.a_ratio_axis.copy()

    @property
    def eta(self) -> float:
        return self.restitution.eta(self.block.alpha_rad)

    def case(self, i: int, j: int) -> Case:
        """The case of cell ``(i, j)`` (amplitude row ``i``, frequency column ``j``)."""
        pulse = make_pulse(self.pulse, float(self.amplitudes()[i]), float(self.omegas()[j]))
        return Case(self.block, pulse, self.restitution, self.dt_s, self.linearized)

    def cases(self, cells) -> list[Case]:
        """The cases of many cells ``[(i, j), ...]`` (axis values computed once)."""
        amp, om = self.amplitude_axis, self.omega_axis
        return [Case(self.block, make_pulse(self.pulse, float(amp[i]), float(om[j])), self.restitution,
                     self.dt_s, self.linearized) for i, j in cells]

    # -- off the grid (the bisection's samples) -------------------------------------------------------
    def edge_points(self, i, j, axis, t) -> dict:
        """The points at ``t[k]`` along the edges from cell ``(i[k], j[k])`` to its neighbour in ω/p
        (``axis`` 0) or in a₀ (``axis`` 1): ``{"w_ratio", "a_ratio", "omega_rad_s", "amplitude_mps2"}``,
        arrays. Each axis is even in the unit it was given in, so every unit is linear along an edge."""
        i, j, t = (np.asarray(v) for v in (i, j, t))
        along_a = np.asarray(axis) == 1
        i1, j1 = i + along_a, j + ~along_a

        def lerp(values, k0, k1):
            return values[k0] + t * (values[k1] - values[k0])

        return {"w_ratio": lerp(self.w_ratio_axis, j, j1), "a_ratio": lerp(self.a_ratio_axis, i, i1),
                "omega_rad_s": lerp(self.omega_axis, j, j1), "amplitude_mps2": lerp(self.amplitude_axis, i, i1)}

    def cases_at(self, omega_rad_s, amplitude_mps2) -> list[Case]:
        """The cases at arbitrary frequencies ω [rad/s] and amplitudes a₀ [m/s^2] (pairwise)."""
        return [Case(self.block, make_pulse(self.pulse, float(a), float(w)), self.restitution, self.dt_s,
                     self.linearized) for w, a in zip(np.asarray(omega_rad_s), np.asarray(amplitude_mps2))]

    # -- persistence --------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {"engine": self.engine, "engine_settings": dict(sorted(self.engine_settings.items())),
                "block": self.block.to_dict(), "pulse": self.pulse, "restitution": self.restitution.to_dict(),
                "eta": self.eta, "x": self.x.to_dict(), "y": self.y.to_dict(), "dt_s": self.dt_s,
                "linearized": self.linearized}

    @classmethod
    def from_dict(cls, d: dict) -> "MapSpec":
        """Inverse of :meth:`to_dict`; ValueError (ConfigError) or TypeError for a damaged description, an
        IncomparableError (exit 5) for engine settings stored under older names
        (:func:`~rockbench.benchmark.engine_info.setting_names.stored_settings`)."""
        engine, settings, dt = d.get("engine", "reference"), d.get("engine_settings") or {}, d.get("dt_s")
        linearized = d.get("linearized", False)
        if not isinstance(engine, str) or not engine:
            raise ValueError(f"spec.engine must be an engine name, got {engine!r}")
        if not isinstance(settings, dict):
            raise ValueError(f"spec.engine_settings must be an object, got {settings!r}")
        if dt is not None and (isinstance(dt, bool) or not isinstance(dt, (int, float)) or not 0 < dt < math.inf):
            raise ValueError(f"spec.dt_s must be a number of seconds > 0 or null, got {dt!r}")
        if not isinstance(linearized, bool):
            raise ValueError(f"spec.linearized must be true or false, got {linearized!r}")
        return cls(Block.from_dict(d["block"]), d["pulse"], Restitution.from_dict(d["restitution"]),
                   Axis.from_dict(d["x"]), Axis.from_dict(d["y"]), engine,
                   stored_settings(engine, settings, "its map's description"), dt,
                   linearized)

    def identity(self) -> dict:
        """The fields that make two maps the same (derived numbers excluded), JSON-comparable."""
        d = self.to_dict()
        b = d["block"]
        d["block"] = {k: b[k] for k in ("name", "width_m", "height_m", "depth_m", "mass_kg")}
        d.pop("eta")
        return _jsonable(d)

    def label(self) -> str:
        """Short text: ``reference B3M sine housner``."""
        return f"{self.engine} {self.block.name} {self.pulse} {self.restitution.label}"


def _read_only(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    v.flags.writeable = False
    return v


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


def _available_memory_bytes() -> int | None:
    """Memory a new allocation can get [bytes]: Linux's MemAvailable (free plus reclaimable cache),
    else the free pages, else None (not every platform reports it)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None
