"""Run folders on disk: the one module that reads and writes them (docs/data.md, "The files rockbench writes").

A map's run directory holds

``DIR/run.json``
    schema version (:data:`SCHEMA_VERSION`), UTC times, rockbench version, git commit and dirty flag,
    Python, platform, the engine's name, version, settings and resolved settings, the sweep spec,
    run options and, once finished, a summary.
``DIR/cells.csv``
    one row per simulation, the columns :data:`COLUMNS` (the required ones of docs/cli.md,
    :data:`REQUIRED_COLUMNS`, among them); written by :class:`~rockbench.benchmark.store.run_folder.RunStore`,
    read by :func:`read_run` (this rockbench's own files, every field checked) and
    :func:`read_cell_table` (any table with the required columns, e.g. one written by another tool).
``DIR/bisection.csv``
    one row per off-grid sample of the boundary's bisection, the columns :data:`SAMPLE_COLUMNS`
    (cells.csv's, then the edge's direction ``axis`` and the position ``t`` along it); read by
    :func:`read_samples`.
``DIR/boundary.csv``
    the located crossings (:data:`BOUNDARY_COLUMNS`), written when the map finishes, for people and
    other tools; rockbench itself derives the boundary from the samples.

A ``rockbench run`` folder adds ``suite.json``, ``calibration.json`` and ``score.json``. Every JSON
file goes through :func:`write_json`: atomic (a temporary file, then a rename), and with **one
NaN rule**: JSON has no NaN or infinity, so a number that is not finite is written ``null``
(docs/data.md). Every time stamp is :func:`utc_stamp`.
"""

from __future__ import annotations

import csv
import json
import math
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from rockbench.reference_solver.errors import ConfigError

from rockbench.benchmark.errors import IncomparableError
from rockbench.benchmark.engine_info.setting_names import stored_settings
from rockbench.benchmark.store.atomic import write_bytes_atomic

#: Version of the run-directory layout; bumped when columns or run.json keys change meaning
#: (3: the ``variant`` column; 4: bisection.csv, boundary.csv and the ``locate_depth`` option; 5: the
#: ``cpu_s`` and ``simulated_s`` columns, each simulation's cost).
SCHEMA_VERSION = 5

#: Older schemas this rockbench still reads: a schema-3 map has no bisection, so its boundary is the
#: depth-0 one, the edge midpoints; a schema-4 map has no cost columns (read as empty).
READABLE_SCHEMAS = (3, 4, SCHEMA_VERSION)

#: Older schemas a resumed map is brought up to (its tables get the new columns, empty in the rows it
#: has, and it goes on as a map of this schema); a schema-3 map is never resumed (it has no bisection).
RESUMABLE_SCHEMAS = (4,)

#: The cells.csv columns every map directory has (docs/cli.md, "The columns of cells.csv"), in the
#: order the store writes them.
REQUIRED_COLUMNS = ("engine", "block", "pulse", "restitution", "eta", "w_ratio", "a_ratio", "omega_rad_s",
                    "amplitude_mps2", "outcome", "n_impacts", "max_abs_theta_rad", "valid", "flags")

#: The columns of cells.csv as this rockbench writes them, in order: the required ones, with
#: ``variant`` beside the engine (the engine with its non-default settings and time step, e.g.
#: ``mujoco[settings=shipped]``, so that tables of several maps concatenated stay apart), then the
#: store's own.
COLUMNS = [REQUIRED_COLUMNS[0], "variant", *REQUIRED_COLUMNS[1:], "status", "message", "wall_s", "cpu_s",
           "simulated_s", "t_overturn_s", "t_uplift_s", "min_normal_mg", "max_friction_ratio", "i", "j"]

#: The columns of a simulation's cost (schema 5; :mod:`rockbench.benchmark.maps.cost`): its share of the CPU
#: time of the call that ran it and the time the engine simulated [s]; empty for a cell without them.
COST_COLUMNS = ("cpu_s", "simulated_s")

#: The columns of bisection.csv: cells.csv's (``i``, ``j`` the edge's first cell), the edge's direction
#: ``axis`` (``w``: towards cell ``(i, j + 1)``, ``a``: towards ``(i + 1, j)``) and the position ``t``
#: in (0, 1) along it.
SAMPLE_COLUMNS = [*COLUMNS, "axis", "t"]


#: The columns of boundary.csv: a crossing's position, its edge, its kind (``overturn``: between a
#: standing and an overturning cell; ``band``: a side of a band inside an overturn(n) | overturn(m)
#: edge) and its edge's flag.
BOUNDARY_COLUMNS = ["w_ratio", "a_ratio", "i", "j", "axis", "t", "kind", "flag"]

#: :func:`utc_stamp` formats: files carry ISO 8601, the report's page a shorter line for people.
ISO_UTC = "%Y-%m-%dT%H:%M:%SZ"
DISPLAY_UTC = "%Y-%m-%d %H:%M UTC"


def utc_stamp(fmt: str = ISO_UTC) -> str:
    """The time now in UTC, as ``2026-11-23T02:30:00Z`` (or another ``strftime`` format)."""
    return datetime.now(timezone.utc).strftime(fmt)


# -- JSON ----------------------------------------------------------------------------------------
def json_safe(x):
    """A copy of ``x`` that JSON can hold: NaN and infinities become null (JSON has no NaN), numpy
    scalars and arrays plain Python, tuples lists, keys strings, anything else its ``str``."""
    if isinstance(x, dict):
        return {str(k): json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if isinstance(x, np.ndarray):
        return json_safe(x.tolist())
    if isinstance(x, (np.floating, np.integer, np.bool_)):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if x is None or isinstance(x, (str, int, float, bool)):
        return x
    return str(x)


def write_json(path, data) -> Path:
    """Write ``data`` as indented JSON (final newline) to ``path`` atomically, through :func:`json_safe`;
    the folders above are created."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(json_safe(data), indent=2, allow_nan=False) + "\n"
    return write_bytes_atomic(path, text.encode())


def read_json(path, advice: str = "is it a rockbench file?") -> dict:
    """A JSON object from ``path``; ConfigError naming the file, what is wrong and ``advice`` when it is
    unreadable, a folder, or not an object."""
    path = Path(path)
    try:
        doc = json.loads(path.read_bytes().decode("utf-8-sig"))
    except IsADirectoryError:
        raise ConfigError(f"{str(path)!r} is a folder, not a rockbench file; {advice}") from None
    except (OSError, ValueError) as e:   # UnicodeDecodeError and JSONDecodeError are ValueErrors
        why = e.strerror if isinstance(e, OSError) and e.strerror else e
        raise ConfigError(f"cannot read {str(path)!r} ({why}); {advice}") from None
    if not isinstance(doc, dict):
        raise ConfigError(f"{str(path)!r} is damaged: it holds {'null' if doc is None else type(doc).__name__}, not a "
                          f"JSON object; {advice}")
    return doc


#: what to do with a run directory that cannot be read
NEW_OUT = "give a new --out directory."


# -- cells.csv -----------------------------------------------------------------------------------
def read_run(out_dir) -> tuple[dict, dict]:
    """``(run.json as a dict, {(i, j): row})`` of a map directory (a torn last line is ignored)."""
    d = Path(out_dir)
    run_json = d / "run.json"
    if not run_json.exists():
        raise ConfigError(f"{str(d)!r} holds no map (no run.json); give a directory written by `rockbench map`.")
    meta = read_json(run_json, NEW_OUT)
    check_map_schema(meta, d)
    path = d / "cells.csv"
    if not path.exists():
        return meta, {}
    rows, _ = read_cells_file(path, spec_shape(meta, run_json))
    return meta, rows


def spec_shape(meta: dict, where) -> tuple[int, int]:
    """``(n_amplitudes, n_frequencies)`` of the map a run.json describes (ConfigError when damaged)."""
    spec = meta.get("spec")
    if not isinstance(spec, dict):
        raise ConfigError(f"{str(where)!r} is damaged: it lacks the map's 'spec' object; give a new --out directory.")
    try:
        return int(spec["y"]["n"]), int(spec["x"]["n"])
    except (KeyError, TypeError, ValueError) as e:
        raise ConfigError(f"{str(where)!r} is damaged: its spec has no whole-number grid size x.n, y.n "
                          f"({type(e).__name__}: {e}); give a new --out directory.") from None


_BOM = b"\xef\xbb\xbf"
_DAMAGED = "the file was edited or damaged: fix or delete that line (rerunning `rockbench map` recomputes it)"


def _sample_position(r: dict, n: int, path: Path) -> tuple[int, float]:
    """``(axis, t)`` of a bisection.csv row (axis 0 along ω/p, 1 along a₀); ConfigError naming the line."""
    if r["axis"] not in ("w", "a"):
        raise ConfigError(f"{str(path)!r} line {n}: axis {r['axis']!r} is not w or a; {_DAMAGED}.")
    try:
        t = float(r["t"])
    except ValueError:
        t = math.nan
    if not 0.0 < t < 1.0:
        raise ConfigError(f"{str(path)!r} line {n}: t {r['t']!r} is not a number between 0 and 1; {_DAMAGED}.")
    return (0 if r["axis"] == "w" else 1), t


def read_samples(path: Path, shape=None) -> tuple[dict, int | None]:
    """The bisection samples of a bisection.csv by ``(i, j, axis, t)`` and the byte length of its
    well-formed prefix (``({}, None)`` when there is no file); a torn last line is not a row."""
    if not path.exists():
        return {}, None
    return read_cells_file(path, shape, SAMPLE_COLUMNS)


def read_cells_file(path: Path, shape=None, columns=COLUMNS) -> tuple[dict, int]:
    """Rows of a cells.csv by cell and the byte length of its well-formed prefix.

    A torn last line (a kill in mid-write) is not a row; a byte-order mark (a spreadsheet saved the
    file) is skipped. Anything else that is not what this rockbench writes is a ConfigError naming
    the line (an IncomparableError for the header of another version).
    """
    if path.is_dir():
        raise ConfigError(f"{str(path)!r} is a folder, not the map's cell table; remove it, or give a new --out "
                          "directory.")
    data = path.read_bytes()
    start = len(_BOM) if data.startswith(_BOM) else 0
    end = data.rfind(b"\n") + 1       # a row is only complete with its newline
    try:
        text = data[start:end].decode("utf-8")
    except UnicodeDecodeError as e:
        line = data[:start + e.start].count(b"\n") + 1
        raise ConfigError(f"{str(path)!r} line {line} is not UTF-8 text (byte 0x{data[start + e.start]:02x}); "
                          f"{_DAMAGED}.") from None
    rows, good = _parse_rows(text, path, shape, columns)
    return rows, (start + good) if good else 0


def _parse_rows(text: str, path: Path, shape=None, columns=COLUMNS) -> tuple[dict, int]:
    """Rows by cell (by sample, for bisection.csv's ``columns``) and the byte length of the well-formed
    prefix (header plus whole rows)."""
    lines = text.splitlines(keepends=True)
    if not lines:
        return {}, 0
    header = next(csv.reader([lines[0]]), [])
    if header != columns and header != before_cost(columns):
        raise IncomparableError(f"{str(path)!r} has other columns than this rockbench writes; it comes from "
                                "another version: give a new --out directory.")
    missing = dict.fromkeys(c for c in columns if c not in header)   # schema 4: no cost, read as empty
    rows: dict = {}
    good = len(lines[0].encode())
    for n, line in enumerate(lines[1:], start=2):
        vals = next(csv.reader([line]), [])
        if len(vals) != len(header):
            if n == len(lines):
                break   # a torn last row that still ended in a newline inside a quoted field
            raise ConfigError(f"{str(path)!r} line {n} is malformed ({len(vals)} fields, expected {len(header)}); "
                              f"{_DAMAGED}.")
        r = dict(zip(header, vals))
        if missing:
            r.update((c, "") for c in missing)
        key = _check_row(r, n, path, shape)
        if columns is SAMPLE_COLUMNS:
            key = (*key, *_sample_position(r, n, path))
        rows[key] = r   # a repeated cell keeps its last row
        good += len(line.encode())
    return rows, good


_OUTCOMES = frozenset(("rest", "rocking", "overturn"))
_STATUSES = frozenset(("ok", "failed"))
_BOOLS = frozenset(("true", "false"))


def _check_row(r: dict, n: int, path: Path, shape) -> tuple[int, int]:
    """The cell ``(i, j)`` of a row, after checking the fields a map is read from (ConfigError naming the
    line and the field otherwise)."""
    # the common case, a whole successful row, in as few steps as possible (a 200×200 map has 40 000)
    try:
        if r["status"] == "ok" and r["outcome"] in _OUTCOMES and r["valid"] in _BOOLS:
            int(r["n_impacts"])
            float(r["max_abs_theta_rad"])
            i, j = int(r["i"]), int(r["j"])
            if shape is None or (0 <= i < shape[0] and 0 <= j < shape[1]):
                return i, j
    except ValueError:
        pass
    return _check_row_slowly(r, n, path, shape)


def _check_row_slowly(r: dict, n: int, path: Path, shape) -> tuple[int, int]:
    """:func:`_check_row` field by field, to name the first bad one."""
    def bad(col: str, what: str):
        return ConfigError(f"{str(path)!r} line {n}: {col} {r[col]!r} is not {what}; {_DAMAGED}.")

    ij = []
    for col in ("i", "j"):
        try:
            ij.append(int(r[col]))
        except ValueError:
            raise bad(col, "a whole number") from None
    i, j = ij
    if shape is not None:
        for col, v, size in (("i", i, shape[0]), ("j", j, shape[1])):
            if not 0 <= v < size:
                raise bad(col, f"a cell index of this {shape[0]}×{shape[1]} map (0 to {size - 1})")
    if r["status"] not in _STATUSES:
        raise bad("status", "ok or failed")
    ok = r["status"] == "ok"
    if ok and r["outcome"] not in _OUTCOMES:
        raise bad("outcome", "rest, rocking or overturn")
    if not ok and r["outcome"] not in _OUTCOMES and r["outcome"] != "":
        raise bad("outcome", "rest, rocking, overturn or empty")
    if r["valid"] not in _BOOLS:
        raise bad("valid", "true or false")
    if ok:
        try:
            int(r["n_impacts"])
        except ValueError:
            raise bad("n_impacts", "a whole number") from None
        try:
            float(r["max_abs_theta_rad"])
        except ValueError:
            raise bad("max_abs_theta_rad", "a number") from None
    return i, j


def before_cost(columns) -> list[str]:
    """A table's columns as schemas 3 and 4 wrote them: without :data:`COST_COLUMNS` (read as empty)."""
    return [c for c in columns if c not in COST_COLUMNS]


def check_map_schema(meta: dict, d: Path, writing: bool = False) -> None:
    """ConfigError unless ``meta`` is a map's run.json; IncomparableError when of a schema this rockbench
    cannot read (:data:`READABLE_SCHEMAS`), or, ``writing``, of another schema than its own."""
    if meta.get("kind") != "rockbench-map":
        raise ConfigError(f"{str(d)!r} is not a rockbench map directory (its run.json is of kind "
                          f"{meta.get('kind')!r}); give a new or empty directory.")
    version = meta.get("schema_version")
    if writing and version in READABLE_SCHEMAS and version not in (SCHEMA_VERSION, *RESUMABLE_SCHEMAS):
        raise IncomparableError(f"{str(d)!r} holds a map of schema {version}, which this rockbench reads but does not "
                                f"resume (schema 4 added the boundary's bisection); delete it to compute "
                                "the map again, or give a new --out directory.")
    if version not in READABLE_SCHEMAS:
        raise IncomparableError(f"{str(d)!r} was written with schema {version}, this rockbench "
                                f"reads schema {SCHEMA_VERSION} (and {', '.join(map(str, READABLE_SCHEMAS[:-1]))}); "
                                "give a new --out directory.")


def read_cell_table(path) -> list[dict]:
    """The rows of any cells.csv that has the required columns (:data:`REQUIRED_COLUMNS`, in any order,
    others allowed), as dicts of text; for tables without this rockbench's run.json (another tool's).
    A torn last line (the run was killed mid-write) is not a row.

    Raises
    ------
    IncomparableError
        A required column is missing.
    ConfigError
        Unreadable, no rows, or rows of more than one map.
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except OSError as e:
        raise ConfigError(f"cannot read {str(path)!r}: {e.strerror or e}.") from None
    except UnicodeDecodeError as e:
        raise ConfigError(f"{str(path)!r} is not UTF-8 text (byte {e.start}); is it a cells.csv?") from None
    text = text[: text.rfind("\n") + 1]
    rows = list(csv.DictReader(text.splitlines()))
    header = rows[0].keys() if rows else next(csv.reader(text.splitlines()), [])
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise IncomparableError(f"{str(path)!r} lacks the column {missing[0]!r} of cells.csv; it was "
                                "written by another tool or version.")
    if not rows:
        raise ConfigError(f"{str(path)!r} has no cells yet; let `rockbench map` finish (rerun it to resume).")
    keys = {(r["engine"], r["block"], r["pulse"], r["restitution"]) for r in rows}
    if len(keys) > 1:
        raise ConfigError(f"{str(path)!r} mixes maps ({len(keys)} engine/block/pulse/restitution combinations); "
                          "one run directory holds one map.")
    return rows


def map_cell_rows(d) -> list[dict]:
    """The cells.csv rows of the map directory ``d``: this rockbench's own (:func:`read_run`, one row per
    cell) when its run.json says so, else any table with the required columns (:func:`read_cell_table`)."""
    d = Path(d)
    if (d / "run.json").is_file() and read_json(d / "run.json").get("kind") == "rockbench-map":
        return list(read_run(d)[1].values())
    return read_cell_table(d / "cells.csv")


def variant_name(engine: str, settings: dict | None = None, dt_s: float | None = None) -> str:
    """``engine[k=v,...,dt=...]``: the engine with its non-default settings and time step."""
    parts = [f"{k}={v}" for k, v in sorted((settings or {}).items())]
    if dt_s is not None:
        parts.append(f"dt={dt_s:g}")
    return f"{engine}[{','.join(parts)}]" if parts else engine


def stored_variant(name: str, where: str) -> str:
    """A stored variant name (:func:`variant_name`'s ``engine[k=v,...]``), its settings checked by
    :func:`~rockbench.benchmark.engine_info.setting_names.stored_settings`; a name of another form is returned as it is."""
    engine, bracket, inner = str(name).partition("[")
    if bracket and inner.endswith("]"):
        parts = [p.partition("=") for p in inner[:-1].split(",")]
        if all(eq and k for k, eq, _ in parts):
            stored_settings(engine, {k: v for k, _, v in parts if k != "dt"}, f"{where} (variant {name})")
    return name


#: what names a reference map at a variant's own measured η in a run folder (``maps/reference/<name>``)
_OWN_ETA_TAG = "-own-eta-"


def own_eta_map_name(block: str, pulse: str, eta: float) -> str:
    """The folder name of the reference map at a variant's own measured η (4 decimals)."""
    return f"{block}-{pulse}{_OWN_ETA_TAG}{eta:.4f}"


def is_own_eta_map(path) -> bool:
    """Whether a map folder is a reference at some variant's own measured η (:func:`own_eta_map_name`)."""
    return _OWN_ETA_TAG in Path(path).name


def spec_variant(spec) -> str:
    """The ``variant`` column of a map: its engine with the non-default settings and time step."""
    return variant_name(spec.engine, spec.engine_settings, spec.dt_s)
