"""Stability maps: a grid over frequency and amplitude, one simulation per cell.

A map is described by a :class:`MapSpec` (block, pulse kind, restitution, engine, the two axes) and
computed by :func:`run_map` into a run directory (see :mod:`rockbench.benchmark.store.run_folder`): every
finished cell is appended to ``cells.csv`` at once, so an interrupted map resumes where it stopped. The
sweep joins the maps (:mod:`rockbench.benchmark.maps`) and the run folders they are stored in
(:mod:`rockbench.benchmark.store`, which reads and writes the maps' types), so it lives above both.
:func:`rockbench.benchmark.store.loading.load_map` reads a run directory back into a
:class:`~rockbench.benchmark.maps.result.MapResult`; the grid (:class:`~rockbench.benchmark.maps.grid.MapSpec`)
lives in :mod:`rockbench.benchmark.maps.grid`.

Grid layout: ``outcome[i, j]`` is the cell with amplitude index ``i`` (vertical axis, a₀/(g·tanα))
and frequency index ``j`` (horizontal axis, ω/p), the way the paper's stability graphs are drawn.
The axes may be given in normalised units (``w_ratio`` = ω/p, ``a_ratio`` = a₀/(g·tanα)) or in
physical ones (``omega_rad_s`` [rad/s]; ``amplitude_mps2`` [m/s^2] or ``amplitude_g`` [g]); both
are stored for every cell. Each axis holds ``n`` values from ``lo`` to ``hi`` inclusive, evenly
spaced in the unit it was given in.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np
from tqdm import tqdm

from rockbench.engines.adapters.reference import is_planted
from rockbench.engines.calibration import held_out
from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.engine_info.adapters import build_adapter
from rockbench.benchmark.store.run_folder import RunStore
from rockbench.benchmark.maps import adaptive as adaptive_mod
from rockbench.benchmark.maps.adaptive import DEFAULT_STRIDE
from rockbench.benchmark.maps.executors import DASK_SCRATCH, SerialExecutor, cap_jobs, make_executor
from rockbench.benchmark.maps.bisection import DEFAULT_DEPTH, MAX_DEPTH, sample_regime
from rockbench.benchmark.maps.boundary import locate
from rockbench.benchmark.maps.grid import MAP_PULSES, MapSpec
from rockbench.benchmark.maps.locating import boundary_rows, cell_regimes, locate_in_sweep
from rockbench.benchmark.maps.result import MapResult, empty_result, put_columns, put_row, record_result


#: Cells solved and written at a time by the columnar path (an adapter's ``solve_grid`` in this
#: process): large enough for the parallel kernel and the bulk writer, small enough that a killed
#: 1000×1000 map keeps all but the chunk it was on.
COLUMNAR_CHUNK = 65_536

#: Default per-cell wall-time limit [s] (engines with tiny time steps need seconds per cell).
DEFAULT_CELL_TIMEOUT_S = 120.0


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
    locate_depth : int
        Rounds of bisection of each boundary edge (:mod:`rockbench.benchmark.maps.bisection`; 0: the
        edge midpoints); the tolerance is a step over ``2**locate_depth``.
    stage : dict or None
        The stage of a suite the map belongs to, recorded in run.json's ``options.stage`` (the speed
        stage's maps: ``{"name": "speed", ...}``, :mod:`rockbench.benchmark.store.loading`); None for
        an ordinary map.
    """

    jobs: int | None = None
    scheduler: str | None = None
    serial: bool = False
    adaptive: bool = False
    stride: int = 1
    cell_timeout_s: float = DEFAULT_CELL_TIMEOUT_S
    progress: bool | None = None
    log: Callable[[str], None] | None = None
    locate_depth: int = DEFAULT_DEPTH
    stage: dict | None = None

    @classmethod
    def checked(cls, *, coarse_stride: int | None = None, **kw) -> "MapOptions":
        """The options of :func:`run_map`'s keywords; ConfigError for a time limit or stride out of range."""
        t = kw.get("cell_timeout_s", DEFAULT_CELL_TIMEOUT_S)
        if not (isinstance(t, (int, float)) and math.isfinite(t) and t > 0):
            raise ConfigError(f"--cell-timeout must be a number of seconds > 0, got {t!r}.")
        stride = DEFAULT_STRIDE if coarse_stride is None else int(coarse_stride)
        if stride < 1:
            raise ConfigError(f"the coarse stride must be a whole number >= 1, got {coarse_stride!r}.")
        depth = kw.get("locate_depth", DEFAULT_DEPTH)
        if isinstance(depth, bool) or not isinstance(depth, int) or not 0 <= depth <= MAX_DEPTH:
            raise ConfigError(f"--locate-depth must be a whole number from 0 to {MAX_DEPTH}, got {depth!r}.")
        return cls(stride=stride if kw.get("adaptive") else 1, **kw)

    def note(self, text: str) -> None:
        if self.log:
            self.log(text)


def run_map(spec: MapSpec, out_dir, *, jobs: int | None = None, scheduler: str | None = None,
            serial: bool = False, adaptive: bool = False, coarse_stride: int | None = None,
            cell_timeout_s: float = DEFAULT_CELL_TIMEOUT_S, progress: bool | None = None,
            picture=None, log: Callable[[str], None] | None = None, executor=None,
            figure_formats=("png",), locate_depth: int = DEFAULT_DEPTH, stage: dict | None = None) -> MapResult:
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
        (:mod:`rockbench.benchmark.maps.adaptive`).
    coarse_stride : int, optional
        Spacing of the adaptive coarse grid in cells (default
        :data:`~rockbench.benchmark.maps.adaptive.DEFAULT_STRIDE`).
    cell_timeout_s : float
        Wall-time limit of one cell [s]; a cell past it is recorded as failed (``timeout``).
    progress : bool, optional
        Progress bar on stderr; default: when stderr is a terminal.
    picture : optional
        Draws ``map.png`` at the end: ``picture.draw(result, stem, formats, reference=...)``, with
        the reference map of the same grid (:func:`reference_for`) to overlay, and
        ``picture.close()`` whatever happens (a
        :class:`~rockbench.benchmark.report.plots.picture.MapPicture`, made by the caller before the
        map starts so that its helper loads matplotlib meanwhile). None draws nothing.
    figure_formats : sequence of str
        The formats of the map's picture (``png``, ``svg``, ``pdf``): ``map.png``, ``map.svg``, ...
    locate_depth : int
        Rounds of bisection of each boundary edge after the cells (default
        :data:`~rockbench.benchmark.maps.bisection.DEFAULT_DEPTH`; 0 keeps the edge midpoints): the
        located boundary is stored in bisection.csv and boundary.csv and loaded with the map.
    stage : dict, optional
        The suite stage the map belongs to, recorded in run.json (:class:`MapOptions`).
    log : callable, optional
        Receives one-line notes (resumed cells, ...).
    executor : optional
        An executor from :func:`~rockbench.benchmark.maps.executors.make_executor` for this spec's
        engine and settings, to keep its warm workers across many maps (it is not closed here);
        ``jobs``, ``scheduler`` and ``serial`` are then ignored.

    Returns
    -------
    MapResult
    """
    try:
        opts = MapOptions.checked(jobs=jobs, scheduler=scheduler, serial=serial, adaptive=adaptive,
                                  coarse_stride=coarse_stride, cell_timeout_s=cell_timeout_s, progress=progress,
                                  log=log, locate_depth=locate_depth, stage=stage)
        result = _compute_map(spec, Path(out_dir), opts, executor)
        if picture is not None:
            picture.draw(result, Path(out_dir) / "map", figure_formats, reference=reference_for(result))
        return result
    finally:
        if picture is not None:
            picture.close()


def reference_for(result):
    """The reference map of an engine map's case and grid, computed in memory (milliseconds per
    thousand cells), for its picture; None for a reference map or when it cannot be computed."""
    if result.spec.engine == "reference" and not is_planted(result.spec.engine, result.spec.engine_settings):
        return None
    try:
        spec = replace(result.spec, engine="reference", engine_settings={}, dt_s=None)
        ref = empty_result(spec)
        cells = [(i, j) for i in range(spec.y.n) for j in range(spec.x.n)]
        adapter = build_adapter("reference")
        for (i, j), r in zip(cells, adapter.run_many(spec.cases(cells))):
            record_result(ref, i, j, r)
        depth = result.located.depth if result.located is not None else 0

        def sample(ii, jj, aa, tt):
            pts = spec.edge_points(ii, jj, aa, tt)
            return [sample_regime(r.status, r.outcome, r.n_impacts)
                    for r in adapter.run_many(spec.cases_at(pts["omega_rad_s"], pts["amplitude_mps2"]))]

        ref.located = locate(cell_regimes(ref), ref.w_ratio, ref.a_ratio, depth, sample)
        return ref
    except Exception:  # noqa: BLE001 - a picture without the overlay is still a picture
        return None


def _executor_for(spec: MapSpec, out_dir: Path, opts: MapOptions, executor):
    """``(executor, own)``: the one given (checked against the spec) or a new one this map owns."""
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
    adapter = build_adapter(spec.engine, **spec.engine_settings)   # bad engine/settings fail before any file is made
    held_out.calibration_block(adapter.settings.get("calibrate_on"), spec.block)   # so does a calibrate_on block
                                                                                   # of another slenderness
    t0 = time.perf_counter()
    executor, own = _executor_for(spec, out_dir, opts, executor)
    store = RunStore(out_dir)
    try:
        done = store.open(spec, adapter, options={"adaptive": opts.adaptive, "coarse_stride": opts.stride,
                                                  "locate_depth": opts.locate_depth,
                                                  "cell_timeout_s": opts.cell_timeout_s,
                                                  "executor": executor.describe(),
                                                  **({"stage": opts.stage} if opts.stage else {})})
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
        result = sweep.result
        if opts.adaptive:
            adaptive_mod.fill(result.outcome, result.simulated, opts.stride)
        if store.samples:
            opts.note(f"resuming {out_dir}: {len(store.samples)} bisection samples already done")
        result.located = locate_in_sweep(sweep, opts.locate_depth)
        store.write_boundary(boundary_rows(result.located))
        sweep.bar.close()
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

        self.spec, self.adapter, self.executor, self.store, self.opts = spec, adapter, executor, store, opts
        self.result = empty_result(spec)
        self.result.adaptive, self.result.coarse_stride = opts.adaptive, opts.stride
        for (i, j), row in done.items():
            put_row(self.result, i, j, row)
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
        spec, (solve_grid, threads) = self.spec, self.grid
        try:
            with threads:
                cols = solve_grid(spec.block, spec.pulse, spec.restitution, spec.omega_axis[b], spec.amplitude_axis[a],
                                dt_s=spec.dt_s, linearized=spec.linearized)
        except Exception:  # noqa: BLE001 - the per-case path records each cell's failure
            self.evaluate_cases(list(zip(a.tolist(), b.tolist())))
            return
        put_columns(self.result, a, b, cols)
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


def _grid_runner(executor, spec: MapSpec):
    """``(adapter.solve_grid, threads)`` when the map's cells run in this process on an adapter that
    solves them as arrays (contract item 6), else None; ``threads`` is a context that gives the
    batch the executor's threads."""
    if type(executor) is not SerialExecutor or spec.pulse not in MAP_PULSES:
        return None
    solve_grid = getattr(executor.adapter, "solve_grid", None)
    if solve_grid is None:
        return None
    return solve_grid, executor.threads()


class _Progress:
    """A tqdm bar on stderr whose total grows as adaptive rounds add cells; silent when disabled."""

    def __init__(self, show: bool, desc: str):
        self.bar = None
        self.show, self.desc = show, desc

    def add(self, n: int) -> None:
        if self.show and self.bar is None:
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
