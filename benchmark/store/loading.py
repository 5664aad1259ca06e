"""The maps of run folders read back: one map directory as a :class:`~rockbench.benchmark.maps.result.MapResult`
(:func:`load_map`), as the scores and reports read it (:class:`MapEntry`, :func:`load_entries`), and on
its full grid (:func:`full_grid_rows`: adaptive maps get their inferred cells by the sweep's own fill rule).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable

import numpy as np

from rockbench.engines.adapters.reference import is_planted
from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.errors import IncomparableError
from rockbench.benchmark.maps import adaptive as adaptive_mod
from rockbench.benchmark.maps.bisection import MAX_DEPTH
from rockbench.benchmark.maps.grid import MapSpec
from rockbench.benchmark.maps.locating import stored_boundary
from rockbench.benchmark.maps.result import FAILED, MapResult, put_row, empty_result, from_cells
from rockbench.benchmark.engine_info.setting_names import stored_settings
from rockbench.benchmark.store.files import (COLUMNS, read_cell_table, read_json, read_run, read_samples, spec_variant,
                    stored_variant,
                    variant_name)
from rockbench.benchmark.store.frames import OUTCOME_OF_CODE, rows_to_dataframe, rows_to_dataset


def load_map(out_dir) -> MapResult:
    """Read a run directory written by :func:`run_map` back into a :class:`MapResult`.

    Adaptive maps get their inferred cells back by the same fill rule that produced them, and the
    located boundary (:attr:`MapResult.located`) is the map stage's bisection replayed with the samples
    of bisection.csv (:func:`~rockbench.benchmark.maps.locating.stored_boundary`; a map of schema 3, or
    one computed with ``--locate-depth 0``, has the depth-0 boundary, the edge midpoints).

    Raises
    ------
    ConfigError
        When the directory holds no map (no ``run.json``) or a map of another schema.
    """

    meta, rows = read_run(out_dir)
    spec, adaptive, stride, depth = _spec_of_run(meta, Path(out_dir) / "run.json")
    result = empty_result(spec)
    result.adaptive, result.coarse_stride = adaptive, stride
    for (i, j), row in rows.items():
        put_row(result, i, j, row)
    if result.adaptive:
        adaptive_mod.fill(result.outcome, result.simulated, result.coarse_stride)
    samples, _ = read_samples(Path(out_dir) / "bisection.csv", spec.shape)
    result.located = stored_boundary(result, samples, depth)
    result.failures = [{"i": i, "j": j, "flag": r["flags"], "message": r["message"]}
                       for (i, j), r in sorted(rows.items()) if r["status"] != "ok"]
    summary = meta.get("summary")
    try:
        result.wall_s = float(summary.get("wall_s", 0.0)) if isinstance(summary, dict) else 0.0
    except (TypeError, ValueError):
        result.wall_s = 0.0   # only shown in reports; a damaged summary does not change the map
    return result


def _spec_of_run(meta: dict, where: Path) -> tuple[MapSpec, bool, int, int]:
    """The spec, the adaptive options and the bisection depth a run.json records (depth 0 where it
    records none: schema 3); ConfigError naming the file when damaged."""
    try:
        spec = MapSpec.from_dict(meta["spec"])
        opts = meta.get("options") or {}
        adaptive = opts.get("adaptive", False)
        stride = opts.get("coarse_stride", 1)
        depth = opts.get("locate_depth", 0)
        if not isinstance(adaptive, bool) or isinstance(stride, bool) or not isinstance(stride, int) or stride < 1:
            raise ValueError(f"options adaptive={adaptive!r}, coarse_stride={stride!r}")
        if isinstance(depth, bool) or not isinstance(depth, int) or not 0 <= depth <= MAX_DEPTH:
            raise ValueError(f"options locate_depth={depth!r}")
    except KeyError as e:
        raise ConfigError(f"{str(where)!r} is damaged: it lacks {e}; give a new --out directory "
                          "(or rerun `rockbench map` into a new one).") from None
    except IncomparableError as e:   # stored under older names (stored_settings): one line, exit 5
        raise IncomparableError(f"{str(where)!r}: {e}") from None
    except (TypeError, ValueError, AttributeError) as e:
        raise ConfigError(f"{str(where)!r} is damaged: {e}; give a new --out directory.") from None
    return spec, adaptive, stride, depth


def full_grid_rows(map_dir) -> list[dict]:
    """Every cell of a map directory's grid, row by row (amplitude index ``i``, then frequency ``j``).

    Parameters
    ----------
    map_dir : path
        A run directory written by ``rockbench map`` (or one map of ``rockbench run``).

    Returns
    -------
    list of dict
        cells.csv's columns (text as written there for simulated cells) plus ``filled`` (True for a
        cell the adaptive fill rule inferred) and ``left_model`` (True where the run left the
        rigid model: slip, jump, lift-required, slip-required).
    """

    meta, rows = read_run(map_dir)
    res = load_map(map_dir)
    spec = res.spec
    head = {"engine": spec.engine, "variant": spec_variant(spec), "block": spec.block.name, "pulse": spec.pulse,
            "restitution": spec.restitution.label, "eta": repr(float(spec.eta))}
    w, a, om, am = spec.w_ratios(), spec.a_ratios(), spec.omegas(), spec.amplitudes()
    out = []
    for i in range(spec.y.n):
        for j in range(spec.x.n):
            row = rows.get((i, j))
            if row is not None:
                r = {c: row[c] for c in COLUMNS}
                # a map written before the variant column existed gets it from its spec; one stored under older
                # names is refused (stored_variant)
                r["variant"] = stored_variant(r.get("variant") or head["variant"], str(map_dir))
                r["filled"] = False
            else:
                code = int(res.outcome[i, j])
                r = {c: "" for c in COLUMNS}
                r.update(head, w_ratio=repr(float(w[j])), a_ratio=repr(float(a[i])), omega_rad_s=repr(float(om[j])),
                         amplitude_mps2=repr(float(am[i])), outcome=OUTCOME_OF_CODE[code] if code >= 0 else "",
                         status="filled" if code >= 0 else "missing", i=str(i), j=str(j))
                r["filled"] = code >= 0
            r["left_model"] = bool(res.left_model[i, j])
            out.append(r)
    return out


# -- the maps of run folders, as the scores and reports read them ----------------------------------

#: The name a speed-stage map records in run.json's ``options.stage`` (``{"name": "speed", ...}``).
SPEED_STAGE = "speed"


@dataclass
class MapEntry:
    """One map found on disk.

    Attributes
    ----------
    path : Path
        Its run directory.
    map : MapResult
        The map in memory, as the scores read it: a cell without an outcome is :data:`FAILED`, and an
        inferred (adaptive) cell counts as valid.
    engine : str
        Registry name of the engine.
    variant : str
        The engine with its non-default settings and time step, e.g. ``mujoco[settings=shipped]``;
        equals ``engine`` when nothing was set.
    block, pulse, restitution : str
        Block name, pulse kind and restitution label (``housner``, ``modified(k=0.8608)``, ``0.9``).
    eta : float
        The restitution coefficient of the map [-].
    run : dict
        The run.json contents.
    settings : dict
        The engine settings the map was run with (those given; what ``variant`` names).
    dt_s : float or None
        Its time step when not the engine's default [s].
    """

    path: Path
    map: MapResult
    engine: str
    variant: str
    block: str
    pulse: str
    restitution: str
    eta: float
    run: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    dt_s: float | None = None

    @property
    def is_reference(self) -> bool:
        """A map of the reference solver itself (the yardstick); a planted variant of it
        (``planted_eta_factor``) is scored as an engine map."""
        return self.engine == "reference" and not self.is_planted

    @property
    def is_planted(self) -> bool:
        """A planted variant of the reference solver: the suite's yardstick of power, not an engine."""
        return is_planted(self.engine, self.settings)

    @property
    def stage(self) -> dict:
        """The suite stage the map was computed for (run.json's ``options.stage``; {} for an ordinary map)."""
        st = (self.run.get("options") or {}).get("stage") if isinstance(self.run, dict) else None
        return st if isinstance(st, dict) else {}

    @property
    def in_speed_stage(self) -> bool:
        """A map of a suite's speed stage (:data:`SPEED_STAGE`): scored like any map, kept out of the verdict
        (:mod:`rockbench.benchmark.scoring.speed`)."""
        return self.stage.get("name") == SPEED_STAGE

    @property
    def resolved_settings(self) -> dict:
        """The concrete settings the map ran with (run.json's ``engine.resolved_settings``), as recorded."""
        resolved = (self.run.get("engine") or {}).get("resolved_settings") or {}
        return dict(resolved) if isinstance(resolved, dict) else {}

    def to_dataframe(self):
        """Every cell of the full grid (adaptive fills marked ``filled``), outcome categorical
        (``pandas.DataFrame``)."""
        return rows_to_dataframe(full_grid_rows(self.path))

    def to_dataset(self):
        """The full grid as an ``xarray.Dataset`` on dims ``(a_ratio, w_ratio)``."""
        return rows_to_dataset(full_grid_rows(self.path))

    def describe(self) -> dict:
        m = self.map
        return {"dir": str(self.path), "engine": self.engine, "variant": self.variant, "block": self.block,
                "pulse": self.pulse, "restitution": self.restitution, "eta": self.eta,
                "grid": grid_of(m)}


def grid_of(m: MapResult) -> dict:
    """The grid of a map, as score.json records it (for comparability checks)."""
    return {"n_w": int(m.w_ratio.size), "n_a": int(m.a_ratio.size), "w_lo": float(m.w_ratio[0]),
            "w_hi": float(m.w_ratio[-1]), "a_lo": float(m.a_ratio[0]), "a_hi": float(m.a_ratio[-1])}


def find_map_dirs(paths: Iterable) -> list[Path]:
    """Map directories at or below each path, sorted, no duplicates: a directory with cells.csv, or
    with a run.json of a map whose cells.csv is gone (so a deleted cell table is found, and refused
    as an incomplete map, instead of the map silently dropping out of the scores).

    Raises
    ------
    ConfigError
        A path that does not exist, or holds no map at all.
    """
    out: list[Path] = []
    for p in paths:
        p = Path(p)
        if not p.is_dir():
            raise ConfigError(f"{str(p)!r} is not a directory; give run directories written by `rockbench map` "
                              "or `rockbench run`.")
        if (p / "cells.csv").is_file() or _is_map_run(p):
            found = [p]
        else:
            with_cells = {c.parent for c in p.rglob("cells.csv")}
            # a run.json is read here only where its cells.csv is gone
            found = sorted(with_cells | {c.parent for c in p.rglob("run.json")
                                         if c.parent not in with_cells and _is_map_run(c.parent)})
        if not found:
            raise ConfigError(f"{str(p)!r} holds no map (no cells.csv in it or below); compute one with "
                              "`rockbench map ... --out DIR`.")
        out.extend(f for f in found if f not in out)
    return out


def _is_map_run(d: Path) -> bool:
    """Whether ``d`` holds the run.json of a map (readable or not: a damaged one is reported when read)."""
    f = d / "run.json"
    if not f.is_file():
        return False
    try:
        return json.loads(f.read_bytes().decode("utf-8-sig")).get("kind") == "rockbench-map"
    except (OSError, ValueError, AttributeError):
        return True


def missing_cells(res, meta: dict) -> int:
    """Cells a map on disk lacks: those neither simulated nor inferred, or, when its run.json says the
    map finished with more simulated cells than cells.csv now holds (a cut or emptied file), at least
    that many."""
    gone = int(res.counts()["missing"])
    summary = meta.get("summary")
    declared = summary.get("n_simulated") if isinstance(summary, dict) else None
    if isinstance(declared, int) and not isinstance(declared, bool):
        gone = max(gone, declared - res.n_simulated)
    return gone


def load_entry(d: Path) -> MapEntry:
    """Read one map directory into a :class:`MapEntry`.

    A map this rockbench wrote (run.json of kind ``rockbench-map``) is read by
    :func:`rockbench.benchmark.store.loading.load_map`, so adaptive maps get their inferred cells by the
    harness's own rule; any other folder by the required columns of its cells.csv.
    """
    d = Path(d)
    run = read_json(d / "run.json") if (d / "run.json").is_file() else {}
    if run.get("kind") == "rockbench-map":
        res = load_map(d)
        spec = res.spec
        codes = np.where(np.asarray(res.outcome) < 0, FAILED, np.asarray(res.outcome, dtype=int))
        sim = np.asarray(res.simulated, bool)
        # cells an adaptive sweep inferred were never simulated, so nothing in them broke the model
        lm = MapResult.from_outcomes(res.w_ratio, res.a_ratio, codes, np.asarray(res.valid, bool) | ~sim,
                      np.asarray(res.left_model, bool) & sim, sim,
                      filled=int(np.count_nonzero(~sim & (codes != FAILED))))
        lm.meta["missing_cells"] = missing_cells(res, run)
        lm.located = res.located
        engine, block, pulse = spec.engine, spec.block.name, spec.pulse
        restitution, eta = spec.restitution.label, float(spec.eta)
        settings, dt = dict(spec.engine_settings or {}), spec.dt_s
    else:
        lm, first = _label_map(d / "cells.csv")
        engine, block, pulse, restitution = first["engine"], first["block"], first["pulse"], first["restitution"]
        eta = float(first["eta"])
        spec = run.get("spec") or {}
        settings, dt = stored_settings(engine, spec.get("engine_settings") or {}, str(d)), spec.get("dt_s")
    variant = variant_name(engine, settings, dt)
    lm.meta.update({"engine": engine, "variant": variant, "block": block, "pulse": pulse,
                    "restitution": restitution, "eta": eta})
    return MapEntry(d, lm, engine, variant, block, pulse, restitution, eta, run, settings, dt)


def _label_map(path: Path) -> tuple[MapResult, dict]:
    """The :class:`MapResult` of a cells.csv with the required columns, and its first row."""
    rows = read_cell_table(path)
    ok = [r.get("status", "ok") in ("ok", "") for r in rows]
    outcome = [r["outcome"] if good else "" for r, good in zip(rows, ok)]
    valid = [str(r["valid"]).strip().lower() in ("true", "1") for r in rows]
    try:
        w = [float(r["w_ratio"]) for r in rows]
        a = [float(r["a_ratio"]) for r in rows]
    except ValueError as e:
        raise ConfigError(f"{str(path)!r} has a non-numeric w_ratio or a_ratio ({e}).") from None
    return from_cells(w, a, outcome, valid, flags=[r["flags"] for r in rows]), rows[0]


def map_cost(d) -> dict:
    """What a map's simulations cost, from its cells.csv and bisection.csv (every simulation: the grid's
    cells and the boundary's samples): ``simulations`` (those that ran, status ok), ``costed`` (those of
    them with both cost columns: a map of schema 4, or resumed from one, has rows without), and over the
    costed ones ``cpu_s``, ``simulated_s`` and ``wall_s`` summed [s]."""
    d = Path(d)
    meta, rows = read_run(d)
    shape = (int(meta["spec"]["y"]["n"]), int(meta["spec"]["x"]["n"]))
    samples, _ = read_samples(d / "bisection.csv", shape)
    out = {"simulations": 0, "costed": 0, "cpu_s": 0.0, "simulated_s": 0.0, "wall_s": 0.0}
    for r in [*rows.values(), *samples.values()]:
        if r["status"] != "ok":
            continue
        out["simulations"] += 1
        try:
            cpu, sim, wall = float(r["cpu_s"]), float(r["simulated_s"]), float(r["wall_s"])
        except ValueError:
            continue
        out["costed"] += 1
        out["cpu_s"] += cpu
        out["simulated_s"] += sim
        out["wall_s"] += wall
    return out


def load_entries(paths: Iterable) -> list[MapEntry]:
    """Every map at or below ``paths`` (see :func:`find_map_dirs`)."""
    return [load_entry(d) for d in find_map_dirs(paths)]


#: File of each engine variant's free-rocking η written by ``rockbench run`` at the top of its output.
CALIBRATION_FILE = "calibration.json"


def calibration_rows(path) -> list[dict]:
    """The measurements a calibration.json at ``path`` holds (none when it is absent); a ConfigError when it
    is damaged, an IncomparableError (exit 5) when it names a variant under older names (:func:`stored_variant`)."""
    f = Path(path)
    if not f.is_file():
        return []
    try:
        rows = [dict(row) for row in read_json(f).get("measurements", [])]
        variants = [str(row["variant"]) for row in rows]
    except (AttributeError, KeyError, TypeError, ValueError) as e:
        raise _damaged(f, e) from None
    for v in variants:
        stored_variant(v, str(f))
    return rows


def _damaged(f: Path, e: Exception) -> ConfigError:
    return ConfigError(f"{str(f)!r} is damaged ({type(e).__name__}: {e}); delete it (`rockbench run` measures the "
                       "engines' η again).")


def load_own_eta(paths: Iterable) -> dict:
    """``{(variant, block): η}`` from the calibration.json files at the top of ``paths``."""
    out = {}
    for p in paths:
        f = Path(p) / CALIBRATION_FILE
        try:
            for row in calibration_rows(f):
                if row.get("eta_measured") is not None:
                    out[(row["variant"], str(row["block"]))] = float(row["eta_measured"])
        except (KeyError, TypeError, ValueError) as e:
            raise _damaged(f, e) from None
    return out
