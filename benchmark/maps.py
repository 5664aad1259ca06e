"""Stability maps: a grid over frequency and amplitude, one simulation per cell (issue 3).

A map is described by a :class:`MapSpec` (block, pulse kind, restitution, engine, the two axes) and
computed by :func:`run_map` into a run directory (see :mod:`rockbench.benchmark.store`): every
finished cell is appended to ``cells.csv`` at once, so an interrupted map resumes where it stopped.
:func:`load_map` reads a run directory back into a :class:`MapResult`.

Grid layout: ``outcome[i, j]`` is the cell with amplitude index ``i`` (vertical axis, a₀/(g·tanα))
and frequency index ``j`` (horizontal axis, ω/p), the way the paper's stability graphs are drawn.
The axes may be given in normalised units (``w_ratio`` = ω/p, ``a_ratio`` = a₀/(g·tanα)) or in
physical ones (``omega_rad_s`` [rad/s]; ``amplitude_mps2`` [m/s^2] or ``amplitude_g`` [g]); both
are stored for every cell. Each axis holds ``n`` values from ``lo`` to ``hi`` inclusive, evenly
spaced in the unit it was given in.
"""

from __future__ import annotations

import functools
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..engines.base import Case, CellResult
from ..reference_solver.classify import OUTCOME_CODES, Outcome
from ..reference_solver.errors import ConfigError
from ..reference_solver.model import G, Block, a_ratio_to_amplitude, amplitude_to_a_ratio
from ..reference_solver.pulses import MIN_STEPS_PER_WAVE, check_accel, check_step_count, make_pulse
from ..reference_solver.restitution import Restitution
from ..reference_solver.validity import LEFT_MODEL_FLAGS

#: Pulse kinds a map accepts (a record has no frequency to sweep).
MAP_PULSES = ("sine", "cosine", "half-sine")

#: Horizontal-axis units: option name → unit label.
X_AXES = {"w_ratio": "ω/p [-]", "omega_rad_s": "ω [rad/s]"}
#: Vertical-axis units.
Y_AXES = {"a_ratio": "a0/(g·tanα) [-]", "amplitude_mps2": "a0 [m/s^2]", "amplitude_g": "a0 [g]"}
#: The CLI option of each axis unit (for messages).
AXIS_OPTION = {"w_ratio": "--w-ratio", "omega_rad_s": "--omega", "a_ratio": "--a-ratio",
               "amplitude_mps2": "--amplitude", "amplitude_g": "--amplitude-g"}

#: Outcome codes in a map's grids: the classifier's codes plus these two.
FAILED = -1
MISSING = -2

#: Memory a map holds per cell while it runs (grids, the row written, the case) [bytes]; with
#: :data:`MAX_CELLS` it bounds what ``--w-ratio``/``--a-ratio`` may ask for.
BYTES_PER_CELL = 2048
#: Largest number of cells in one map (4 million = 2000 × 2000).
MAX_CELLS = 4_000_000

#: Cells solved and written at a time by the columnar path (an adapter's ``run_grid`` in this
#: process): large enough for the parallel kernel and the bulk writer, small enough that a killed
#: 1000×1000 map keeps all but the chunk it was on.
COLUMNAR_CHUNK = 65_536

#: Default per-cell wall-time limit [s] (engines with tiny time steps need seconds per cell).
DEFAULT_CELL_TIMEOUT_S = 120.0


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

    # -- persistence --------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {"engine": self.engine, "engine_settings": dict(sorted(self.engine_settings.items())),
                "block": self.block.to_dict(), "pulse": self.pulse, "restitution": self.restitution.to_dict(),
                "eta": self.eta, "x": self.x.to_dict(), "y": self.y.to_dict(), "dt_s": self.dt_s,
                "linearized": self.linearized}

    @classmethod
    def from_dict(cls, d: dict) -> "MapSpec":
        """Inverse of :meth:`to_dict`; ValueError (ConfigError) or TypeError for a damaged description."""
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
                   Axis.from_dict(d["x"]), Axis.from_dict(d["y"]), engine, dict(settings), dt, linearized)

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


@dataclass
class MapResult:
    """A computed (or loaded) map.

    Attributes
    ----------
    spec : MapSpec
        What was computed.
    outcome : ndarray of int8, shape ``spec.shape``
        Outcome codes (:data:`~rockbench.reference_solver.classify.OUTCOME_CODES`: 0 rest,
        1 rocking, 2 overturn), :data:`FAILED` (-1) for a failed cell, :data:`MISSING` (-2) for a
        cell neither simulated nor inferred (an unfinished run).
    simulated : ndarray of bool
        True where the cell was simulated; adaptive maps infer the others.
    n_impacts : ndarray of int32
        Impacts up to the decision [-]; -1 where not simulated.
    max_abs_theta_rad : ndarray of float
        Largest |θ| [rad]; NaN where not simulated.
    valid : ndarray of bool
        False where the run broke the model's assumptions or failed.
    left_model : ndarray of bool
        True where the run left the rigid model through its contact: an engine's ``slip`` or
        ``jump``, the reference's ``lift-required`` or ``slip-required``.
    failures : list of dict
        ``{"i", "j", "flag", "message"}`` of each failed cell.
    adaptive : bool
        Whether unsimulated cells were inferred by adaptive refinement.
    coarse_stride : int
        The adaptive coarse grid's spacing in cells (1 for a full map).
    wall_s : float
        Wall time of the run that produced it [s] (0 when loaded).
    n_resumed : int
        Cells found already done in the run directory when the run started.
    """

    spec: MapSpec
    outcome: np.ndarray
    simulated: np.ndarray
    n_impacts: np.ndarray
    max_abs_theta_rad: np.ndarray
    valid: np.ndarray
    left_model: np.ndarray | None = None
    failures: list = field(default_factory=list)
    adaptive: bool = False
    coarse_stride: int = 1
    wall_s: float = 0.0
    n_resumed: int = 0

    def __post_init__(self):
        if self.left_model is None:
            self.left_model = np.zeros(self.outcome.shape, bool)

    @property
    def w_ratio(self) -> np.ndarray:
        """ω/p of each column [-]."""
        return self.spec.w_ratios()

    @property
    def a_ratio(self) -> np.ndarray:
        """a₀/(g·tanα) of each row [-]."""
        return self.spec.a_ratios()

    @property
    def n_simulated(self) -> int:
        return int(self.simulated.sum())

    @property
    def fraction_simulated(self) -> float:
        """Simulated cells over all cells [-]."""
        return self.n_simulated / self.spec.n_cells

    @property
    def complete(self) -> bool:
        return not bool((self.outcome == MISSING).any())

    def counts(self) -> dict:
        """Cells per outcome (``rest``, ``rocking``, ``overturn``, ``failed``, ``missing``)."""
        codes = {o.value: OUTCOME_CODES[o] for o in Outcome}
        codes.update(failed=FAILED, missing=MISSING)
        return {name: int((self.outcome == c).sum()) for name, c in codes.items()}

    def summary(self) -> dict:
        """JSON-ready summary (what ``rockbench map --json`` prints)."""
        return {"engine": self.spec.engine, "block": self.spec.block.name, "pulse": self.spec.pulse,
                "restitution": self.spec.restitution.label, "eta": self.spec.eta,
                "shape": list(self.spec.shape), "n_cells": self.spec.n_cells, "n_simulated": self.n_simulated,
                "fraction_simulated": self.fraction_simulated, "adaptive": self.adaptive,
                "complete": self.complete, "counts": self.counts(), "n_failed": len(self.failures),
                "n_invalid": int(np.count_nonzero(self.simulated & ~self.valid & (self.outcome >= 0))),
                "n_resumed": self.n_resumed, "wall_s": self.wall_s}


def empty_result(spec: MapSpec) -> MapResult:
    """A result with every cell :data:`MISSING`."""
    shape = spec.shape
    return MapResult(spec, np.full(shape, MISSING, np.int8), np.zeros(shape, bool), np.full(shape, -1, np.int32),
                     np.full(shape, np.nan), np.zeros(shape, bool))


@dataclass(frozen=True)
class MapOptions:
    """How a map is computed (what it computes is its :class:`MapSpec`); made and checked once by
    :meth:`checked`, then handed down whole instead of one argument per layer.

    Attributes
    ----------
    jobs : int or None
        Worker processes (None: all cores) or, with ``scheduler="local"``, Dask workers.
    scheduler : str or None
        A Dask scheduler address, ``"local"``, or None (local processes).
    serial : bool
        Run in this process, one batch after another.
    adaptive : bool
        Refine a coarse grid where neighbours disagree.
    stride : int
        Spacing of the adaptive coarse grid in cells (1 when not adaptive).
    cell_timeout_s : float
        Wall-time limit of one cell [s].
    progress : bool or None
        Progress bar on stderr (None: when stderr is a terminal).
    log : callable or None
        Receives one-line notes.
    """

    jobs: int | None = None
    scheduler: str | None = None
    serial: bool = False
    adaptive: bool = False
    stride: int = 1
    cell_timeout_s: float = DEFAULT_CELL_TIMEOUT_S
    progress: bool | None = None
    log: Callable[[str], None] | None = None

    @classmethod
    def checked(cls, *, coarse_stride: int | None = None, **kw) -> "MapOptions":
        """The options of :func:`run_map`'s keywords; ConfigError for a time limit or stride out of range."""
        from .adaptive import DEFAULT_STRIDE

        t = kw.get("cell_timeout_s", DEFAULT_CELL_TIMEOUT_S)
        if not (isinstance(t, (int, float)) and math.isfinite(t) and t > 0):
            raise ConfigError(f"--cell-timeout must be a number of seconds > 0, got {t!r}.")
        stride = DEFAULT_STRIDE if coarse_stride is None else int(coarse_stride)
        if stride < 1:
            raise ConfigError(f"the coarse stride must be a whole number >= 1, got {coarse_stride!r}.")
        return cls(stride=stride if kw.get("adaptive") else 1, **kw)

    def note(self, text: str) -> None:
        if self.log:
            self.log(text)


def run_map(spec: MapSpec, out_dir, *, jobs: int | None = None, scheduler: str | None = None,
            serial: bool = False, adaptive: bool = False, coarse_stride: int | None = None,
            cell_timeout_s: float = DEFAULT_CELL_TIMEOUT_S, progress: bool | None = None,
            plot: bool = True, log: Callable[[str], None] | None = None, executor=None,
            figure_formats=("png",)) -> MapResult:
    """Compute a map into ``out_dir``, resuming whatever a previous run of the same spec finished.

    Parameters
    ----------
    spec : MapSpec
        The map.
    out_dir : path
        The run directory (created; must be empty, or hold a run of the same spec).
    jobs : int, optional
        Worker processes (default: all cores) or, with ``scheduler="local"``, Dask workers.
    scheduler : str, optional
        A Dask scheduler address (``tcp://host:8786``), or ``"local"`` for a LocalCluster on
        127.0.0.1; None runs on local processes.
    serial : bool
        Run in this process, one batch after another (no time limit, no crash isolation).
    adaptive : bool
        Simulate a coarse grid and refine only where neighbours disagree
        (:mod:`rockbench.benchmark.adaptive`).
    coarse_stride : int, optional
        Spacing of the adaptive coarse grid in cells (default
        :data:`~rockbench.benchmark.adaptive.DEFAULT_STRIDE`).
    cell_timeout_s : float
        Wall-time limit of one cell [s]; a cell past it is recorded as failed (``timeout``).
    progress : bool, optional
        Progress bar on stderr; default: when stderr is a terminal.
    plot : bool
        Draw ``map.png`` at the end.
    figure_formats : sequence of str
        The formats of the map's picture (``png``, ``svg``, ``pdf``): ``map.png``, ``map.svg``, ...
    log : callable, optional
        Receives one-line notes (resumed cells, ...).
    executor : optional
        An executor from :func:`~rockbench.benchmark.executors.make_executor` for this spec's
        engine and settings, to keep its warm workers across many maps (it is not closed here);
        ``jobs``, ``scheduler`` and ``serial`` are then ignored.

    Returns
    -------
    MapResult
    """
    from .plots.picture import MapPicture

    opts = MapOptions.checked(jobs=jobs, scheduler=scheduler, serial=serial, adaptive=adaptive,
                              coarse_stride=coarse_stride, cell_timeout_s=cell_timeout_s, progress=progress,
                              log=log)
    # map.png's helper process loads matplotlib on another core while this one computes the map
    picture = MapPicture() if plot else None
    try:
        result = _compute_map(spec, Path(out_dir), opts, executor)
        if picture is not None:
            picture.draw(result, Path(out_dir) / "map", figure_formats)
        return result
    finally:
        if picture is not None:
            picture.close()


def _executor_for(spec: MapSpec, out_dir: Path, opts: MapOptions, executor):
    """``(executor, own)``: the one given (checked against the spec) or a new one this map owns."""
    from .executors import DASK_SCRATCH, cap_jobs, make_executor

    if executor is not None:
        if executor.init["engine"] != spec.engine or executor.init["settings"] != dict(spec.engine_settings):
            raise ConfigError(f"the executor given runs engine {executor.init['engine']!r} with settings "
                              f"{executor.init['settings']}, the map needs {spec.engine!r} with "
                              f"{dict(spec.engine_settings)}.")
        return executor, False
    jobs, note = cap_jobs(opts.jobs, spec.n_cells)
    if note:
        opts.note(note)
    return make_executor(spec.engine, spec.engine_settings, jobs=jobs, scheduler=opts.scheduler, serial=opts.serial,
                         log_path=None,
                         scratch_dir=out_dir / DASK_SCRATCH if opts.scheduler == "local" else None), True


def _compute_map(spec: MapSpec, out_dir: Path, opts: MapOptions, executor) -> MapResult:
    """:func:`run_map` without the picture: open the store, resume, sweep, fill, finish."""
    from ..engines.registry import get_adapter
    from . import adaptive as adaptive_mod
    from .store import RunStore

    adapter = get_adapter(spec.engine, **spec.engine_settings)   # bad engine/settings fail before any file is made
    t0 = time.perf_counter()
    executor, own = _executor_for(spec, out_dir, opts, executor)
    store = RunStore(out_dir)
    try:
        done = store.open(spec, adapter, options={"adaptive": opts.adaptive, "coarse_stride": opts.stride,
                                                  "cell_timeout_s": opts.cell_timeout_s,
                                                  "executor": executor.describe()})
        if done:
            opts.note(f"resuming {out_dir}: {len(done)} cells already done")
        if own:
            executor.log_path = store.dir / "workers.log"
        sweep = _Sweep(spec, adapter, executor, store, opts, done)
        if opts.adaptive:
            adaptive_mod.refine(sweep.key, sweep.result.simulated, sweep.evaluate, opts.stride)
        else:
            ii, jj = np.indices(spec.shape).reshape(2, -1)
            sweep.evaluate_arrays(ii, jj)
        sweep.bar.close()
        result = sweep.result
        if opts.adaptive:
            adaptive_mod.fill(result.outcome, result.simulated, opts.stride)
        result.wall_s = time.perf_counter() - t0
        result.failures = store.failures()
        store.finish(result.summary())
    finally:
        if own:
            executor.close()
        store.close()
    return result


class _Sweep:
    """The cells of one map being computed: its grids, its store, its progress bar, and the two ways a
    batch of cells runs (as arrays in this process, or one case each through the executor)."""

    def __init__(self, spec: MapSpec, adapter, executor, store, opts: MapOptions, done: dict):
        from . import adaptive as adaptive_mod

        self.spec, self.adapter, self.executor, self.store, self.opts = spec, adapter, executor, store, opts
        self.result = empty_result(spec)
        self.result.adaptive, self.result.coarse_stride = opts.adaptive, opts.stride
        for (i, j), row in done.items():
            _put(self.result, i, j, row)
        self.result.n_resumed = len(done)
        # what adaptive neighbours compare
        self.key = adaptive_mod.regime_key(self.result.outcome, self.result.n_impacts)
        self.bar = _Progress(sys.stderr.isatty() if opts.progress is None else opts.progress, spec.label())
        self.grid = _grid_runner(executor, spec)

    def evaluate(self, cells: list[tuple[int, int]]) -> None:
        """Compute the cells ``[(i, j), ...]`` (the adaptive sweep's callback)."""
        if cells:
            ij = np.array(cells, dtype=np.int64).reshape(-1, 2)
            self.evaluate_arrays(ij[:, 0], ij[:, 1])

    def evaluate_arrays(self, ii: np.ndarray, jj: np.ndarray) -> None:
        """Compute the cells ``(ii[k], jj[k])`` not yet simulated, each once, in the order given (even if
        a caller lists one twice)."""
        keep = ~self.result.simulated[ii, jj]
        ii, jj = ii[keep], jj[keep]
        _, first = np.unique(ii * self.spec.x.n + jj, return_index=True)
        if first.size < ii.size:
            first.sort()
            ii, jj = ii[first], jj[first]
        if not ii.size:
            return
        self.bar.add(ii.size)
        if self.grid is None:
            self.evaluate_cases(list(zip(ii.tolist(), jj.tolist())))
            return
        for k in range(0, ii.size, COLUMNAR_CHUNK):
            self._evaluate_columns(ii[k:k + COLUMNAR_CHUNK], jj[k:k + COLUMNAR_CHUNK])

    def _evaluate_columns(self, a: np.ndarray, b: np.ndarray) -> None:
        """One chunk as arrays (contract item 6); a chunk that raises goes case by case instead."""
        from . import adaptive as adaptive_mod

        spec, (run_grid, threads) = self.spec, self.grid
        try:
            with threads:
                cols = run_grid(spec.block, spec.pulse, spec.restitution, spec.omega_axis[b], spec.amplitude_axis[a],
                                dt_s=spec.dt_s, linearized=spec.linearized)
        except Exception:  # noqa: BLE001 - the per-case path records each cell's failure
            self.evaluate_cases(list(zip(a.tolist(), b.tolist())))
            return
        _put_columns(self.result, a, b, cols)
        self.key[a, b] = adaptive_mod.regime_key(cols.outcome, cols.n_impacts)
        with threads:
            self.store.append_columns(spec, a, b, cols)
        self.bar.update(a.size)

    def evaluate_cases(self, todo: list[tuple[int, int]]) -> None:
        """The cells one object each, through the executor (workers, time limits, crash isolation)."""
        result, key = self.result, self.key

        def on_results(pairs):
            triples = []
            for k, r in pairs:
                i, j = todo[k]
                triples.append((i, j, r))
                o = record_result(result, i, j, r)
                # regime_key of one cell, without numpy's per-scalar overhead
                key[i, j] = 2 + 10 * min(max(int(r.n_impacts), 0), 3) if o == 2 else o
            self.store.append_results(self.spec, triples)
            self.bar.update(len(pairs))

        self.executor.run(list(enumerate(self.spec.cases(todo))), on_results,
                          cell_timeout_s=self.opts.cell_timeout_s, batch=self.adapter.batching != "none")


def load_map(out_dir) -> MapResult:
    """Read a run directory written by :func:`run_map` back into a :class:`MapResult`.

    Adaptive maps get their inferred cells back by the same fill rule that produced them.

    Raises
    ------
    ConfigError
        When the directory holds no map (no ``run.json``) or a map of another schema.
    """
    from . import adaptive as adaptive_mod
    from .results import read_run

    meta, rows = read_run(out_dir)
    spec, adaptive, stride = _spec_of_run(meta, Path(out_dir) / "run.json")
    result = empty_result(spec)
    result.adaptive, result.coarse_stride = adaptive, stride
    for (i, j), row in rows.items():
        _put(result, i, j, row)
    if result.adaptive:
        adaptive_mod.fill(result.outcome, result.simulated, result.coarse_stride)
    result.failures = [{"i": i, "j": j, "flag": r["flags"], "message": r["message"]}
                       for (i, j), r in sorted(rows.items()) if r["status"] != "ok"]
    summary = meta.get("summary")
    try:
        result.wall_s = float(summary.get("wall_s", 0.0)) if isinstance(summary, dict) else 0.0
    except (TypeError, ValueError):
        result.wall_s = 0.0   # only shown in reports; a damaged summary does not change the map
    return result


def _spec_of_run(meta: dict, where: Path) -> tuple[MapSpec, bool, int]:
    """The spec and the adaptive options a run.json records; ConfigError naming the file when damaged."""
    try:
        spec = MapSpec.from_dict(meta["spec"])
        opts = meta.get("options") or {}
        adaptive = opts.get("adaptive", False)
        stride = opts.get("coarse_stride", 1)
        if not isinstance(adaptive, bool) or isinstance(stride, bool) or not isinstance(stride, int) or stride < 1:
            raise ValueError(f"options adaptive={adaptive!r}, coarse_stride={stride!r}")
    except KeyError as e:
        raise ConfigError(f"{str(where)!r} is damaged: it lacks {e}; give a new --out directory "
                          "(or rerun `rockbench map` into a new one).") from None
    except (TypeError, ValueError, AttributeError) as e:
        raise ConfigError(f"{str(where)!r} is damaged: {e}; give a new --out directory.") from None
    return spec, adaptive, stride


def _read_only(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    v.flags.writeable = False
    return v


# -- helpers ----------------------------------------------------------------------------------
_CODES = {o.value: c for o, c in OUTCOME_CODES.items()}


def record_result(result: MapResult, i: int, j: int, r: CellResult) -> int:
    """Record a fresh cell result in the grids; returns its outcome code."""
    ok = r.status == "ok" and r.outcome
    code = _CODES[r.outcome] if ok else FAILED
    result.outcome[i, j] = code
    result.simulated[i, j] = True
    result.n_impacts[i, j] = int(r.n_impacts) if ok else -1
    result.max_abs_theta_rad[i, j] = float(r.max_abs_theta_rad) if ok else math.nan
    result.valid[i, j] = bool(ok and r.valid)
    result.left_model[i, j] = bool(ok and LEFT_MODEL_FLAGS.intersection(r.flags))
    return code


def _put_columns(result: MapResult, ii: np.ndarray, jj: np.ndarray, cols) -> None:
    """Record fresh successful cells ``(ii[k], jj[k])`` from a CellColumns in the grids."""
    result.outcome[ii, jj] = cols.outcome
    result.simulated[ii, jj] = True
    result.n_impacts[ii, jj] = cols.n_impacts
    result.max_abs_theta_rad[ii, jj] = cols.max_abs_theta_rad
    result.valid[ii, jj] = cols.flag_bits == 0
    left = sum(1 << k for k, f in enumerate(cols.flag_names) if f in LEFT_MODEL_FLAGS)
    result.left_model[ii, jj] = (cols.flag_bits & left) != 0


def _grid_runner(executor, spec: MapSpec):
    """``(adapter.run_grid, threads)`` when the map's cells run in this process on an adapter that
    solves them as arrays (contract item 6), else None; ``threads`` is a context that gives the
    batch the executor's threads."""
    from .executors import SerialExecutor

    if type(executor) is not SerialExecutor or spec.pulse not in MAP_PULSES:
        return None
    run_grid = getattr(executor.adapter, "run_grid", None)
    if run_grid is None:
        return None
    return run_grid, executor.threads()


def _put(result: MapResult, i: int, j: int, row: dict) -> None:
    ok = row["status"] == "ok" and row["outcome"] not in ("", None)
    result.outcome[i, j] = OUTCOME_CODES[Outcome(row["outcome"])] if ok else FAILED
    result.simulated[i, j] = True
    result.n_impacts[i, j] = int(row["n_impacts"]) if ok else -1
    result.max_abs_theta_rad[i, j] = float(row["max_abs_theta_rad"]) if ok else math.nan
    result.valid[i, j] = ok and str(row["valid"]).lower() in ("true", "1")
    result.left_model[i, j] = ok and bool(LEFT_MODEL_FLAGS.intersection(str(row["flags"]).split(";")))


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


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


class _Progress:
    """A tqdm bar on stderr whose total grows as adaptive rounds add cells; silent when disabled."""

    def __init__(self, show: bool, desc: str):
        self.bar = None
        self.show, self.desc = show, desc

    def add(self, n: int) -> None:
        if self.show and self.bar is None:
            from tqdm import tqdm
            self.bar = tqdm(total=n, desc=self.desc, unit="cell", file=sys.stderr, dynamic_ncols=True)
        elif self.bar is not None:
            self.bar.total += n
            self.bar.refresh()

    def update(self, n: int) -> None:
        if self.bar is not None:
            self.bar.update(n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
