"""The map stage that locates the boundary below the cell: the bisection rule
(:mod:`rockbench.benchmark.maps.bisection`) run on a map's cells, its samples computed by the map's
own engine path (the adapter's ``solve_grid`` in this process, or the executor's workers) and stored in
bisection.csv as they finish; samples already stored (a resumed map) are taken from there, never
computed twice.

The same rule reads a stored map back (:func:`stored_boundary`): the bisection replayed with the
stored samples alone.
"""

from __future__ import annotations

import numpy as np

from rockbench.engines.contract import CellResult
from rockbench.reference_solver.classify import Outcome
from rockbench.benchmark.maps import adaptive as adaptive_mod
from rockbench.benchmark.maps.bisection import AXIS_NAMES, UNSAMPLED, overturn_regime, regime_key, sample_regime
from rockbench.benchmark.maps.boundary import LocatedBoundary, cell_validity, locate
from rockbench.benchmark.maps.result import MapResult

_OUTCOME_NAMES = {0: Outcome.REST.value, 1: Outcome.ROCKING.value, 2: Outcome.OVERTURN.value}


def cell_regimes(result: MapResult) -> np.ndarray:
    """The overturn regime of every cell of a map: its simulated cells', and an adaptive map's inferred
    cells by the sweep's own fill rule (a block left unrefined has corners of one regime)."""
    key = regime_key(result.outcome, result.n_impacts)
    key = np.where(result.simulated, key, np.minimum(key, -1))   # inferred cells: filled below
    if result.adaptive:
        adaptive_mod.fill(key, result.simulated, result.coarse_stride)
    return overturn_regime(key)


def stored_boundary(result: MapResult, samples: dict, depth: int) -> LocatedBoundary:
    """The boundary of a stored map: the bisection replayed on its cells with its stored ``samples``
    (``{(i, j, axis, t): row}``); an edge whose bisection needs a sample not stored is flagged
    ``unfinished`` where it stopped."""
    def sample(ii, jj, aa, tt):
        out = np.empty(len(ii), dtype=int)
        for k, key in enumerate(zip(ii.tolist(), jj.tolist(), aa.tolist(), tt.tolist())):
            row = samples.get(key)
            out[k] = UNSAMPLED if row is None else sample_regime(row["status"], row["outcome"], row["n_impacts"])
        return out

    return locate(cell_regimes(result), result.w_ratio, result.a_ratio, depth, sample,
                  cell_validity(_valid_cells(result), samples))


def _valid_cells(result: MapResult) -> np.ndarray:
    """Cells known valid: simulated valid ones (an inferred cell's validity is not known)."""
    return np.asarray(result.valid, bool) & np.asarray(result.simulated, bool) & (np.asarray(result.outcome) >= 0)


def locate_in_sweep(sweep, depth: int) -> LocatedBoundary:
    """Bisect a computed map's boundary (``sweep``: the map stage's
    :class:`~rockbench.benchmark.sweep._Sweep`), each round one batch of the samples not yet stored."""
    memo = sweep.store.samples

    def sample(ii, jj, aa, tt):
        keys = list(zip(ii.tolist(), jj.tolist(), aa.tolist(), tt.tolist()))
        todo = [k for k, key in enumerate(keys) if key not in memo]
        if todo:
            rows = _run_samples(sweep, [keys[k] for k in todo])
            sweep.store.append_samples(rows)
            for k, row in zip(todo, rows):
                memo[keys[k]] = row
        return np.array([sample_regime(memo[key]["status"], memo[key]["outcome"], memo[key]["n_impacts"])
                         for key in keys], dtype=int)

    return locate(cell_regimes(sweep.result), sweep.result.w_ratio, sweep.result.a_ratio, depth, sample,
                  cell_validity(_valid_cells(sweep.result), memo))


def _run_samples(sweep, keys: list) -> list[dict]:
    """Simulate the samples ``[(i, j, axis, t), ...]`` through the map's engine path; their rows."""
    spec, store = sweep.spec, sweep.store
    i, j, a, t = (np.array(v) for v in zip(*keys))
    pts = spec.edge_points(i, j, a, t)
    results = _results(sweep, pts["omega_rad_s"], pts["amplitude_mps2"])
    sweep.bar.add(len(keys))
    sweep.bar.update(len(keys))
    return [store.sample_row(spec, int(i[k]), int(j[k]), int(a[k]), float(t[k]),
                             {name: v[k] for name, v in pts.items()}, results[k]) for k in range(len(keys))]


def _results(sweep, omega: np.ndarray, amp: np.ndarray) -> list[CellResult]:
    """One :class:`CellResult` per point: as arrays through the adapter's ``solve_grid`` where the map's
    cells run that way, else one case each through the executor (time limits, crash isolation)."""
    spec = sweep.spec
    if sweep.grid is not None:
        solve_grid, threads = sweep.grid
        try:
            with threads:
                cols = solve_grid(spec.block, spec.pulse, spec.restitution, omega, amp, dt_s=spec.dt_s,
                                  linearized=spec.linearized)
            return _from_columns(cols)
        except Exception:  # noqa: BLE001 - the per-case path records each sample's failure
            pass
    out: list = [None] * omega.size

    def on_results(pairs):
        for k, r in pairs:
            out[k] = r

    sweep.executor.run(list(enumerate(spec.cases_at(omega, amp))), on_results,
                       cell_timeout_s=sweep.opts.cell_timeout_s, batch=sweep.adapter.batching != "none")
    return [r if r is not None else CellResult.failed("missing", "no result came back") for r in out]


def _from_columns(cols) -> list[CellResult]:
    """The :class:`CellResult` of each case of a :class:`~rockbench.engines.contract.CellColumns`."""
    names = tuple(cols.flag_names)

    def opt(x):
        return None if not np.isfinite(x) else float(x)

    return [CellResult(outcome=_OUTCOME_NAMES[int(cols.outcome[k])], n_impacts=int(cols.n_impacts[k]),
                       max_abs_theta_rad=float(cols.max_abs_theta_rad[k]), t_overturn_s=opt(cols.t_overturn_s[k]),
                       t_uplift_s=opt(cols.t_uplift_s[k]), valid=bool(cols.flag_bits[k] == 0),
                       flags=[f for b, f in enumerate(names) if int(cols.flag_bits[k]) >> b & 1],
                       wall_s=float(cols.wall_s), min_normal_mg=opt(cols.min_normal_mg[k]),
                       max_friction_ratio=opt(cols.max_friction_ratio[k]))
            for k in range(cols.outcome.size)]


def boundary_rows(b: LocatedBoundary) -> list[list]:
    """boundary.csv's rows (:data:`~rockbench.benchmark.store.files.BOUNDARY_COLUMNS`) of a boundary."""
    flag_of = {tuple(e): f for e, f in zip(b.edges.tolist(), b.flags.tolist())}
    return [[float(b.points[k, 0]), float(b.points[k, 1]), int(b.cell_a[k, 0]), int(b.cell_a[k, 1]),
             AXIS_NAMES[int(b.axis[k])], float(b.t[k]), "band" if b.band[k] else "overturn",
             flag_of.get((int(b.cell_a[k, 0]), int(b.cell_a[k, 1]), int(b.axis[k])), "")]
            for k in range(b.n_crossings)]

