"""The results store of a map: one run directory (docs/maps.md, "The run directory").

``DIR/run.json``
    schema version, UTC times, rockbench version, git commit and dirty flag, Python, platform, the
    engine's name, version, settings and resolved settings (``adapter.describe()``,
    ``adapter.resolve()``), the sweep spec, run options and, once finished, a summary. Always
    written atomically (a temporary file, then ``os.replace``).
``DIR/cells.csv``
    one row per simulation (:data:`~rockbench.benchmark.store.files.COLUMNS`), appended and flushed as cells finish, each row
    written whole with one ``write`` call. A ``kill -9`` can at worst leave a torn last line; it is
    cut off when the directory is opened again, so the rerun neither recomputes finished cells nor
    writes duplicates.
``DIR/bisection.csv``
    one row per off-grid sample of the boundary's bisection (cells.csv's columns, then ``axis`` and
    ``t``), appended and flushed as each round finishes, with the same torn-tail rule: the rerun
    replays the bisection with these samples as a memo and computes none twice.
``DIR/boundary.csv``
    the located crossings (:data:`~rockbench.benchmark.store.files.BOUNDARY_COLUMNS`), written
    atomically when the map finishes.
``DIR/map.png``
    the picture (drawn by :mod:`rockbench.benchmark.report.plots.stability`).

A directory holding another map (a different spec) is refused; a second process writing the same
directory at the same time is refused too (an advisory lock on ``DIR/.lock``).
"""

from __future__ import annotations

import csv
import functools
import io
import platform
import subprocess
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.rules import RULES_VERSION, rules_mismatch
from rockbench.benchmark.store.columnar import format_rows
from rockbench.benchmark.store.atomic import write_bytes_atomic
from rockbench.benchmark.maps.cost import cost_of, machine
from rockbench.benchmark.engine_info.setting_names import stored_settings
from rockbench.benchmark.store.files import (BOUNDARY_COLUMNS, COLUMNS, COST_COLUMNS, NEW_OUT, SAMPLE_COLUMNS, SCHEMA_VERSION, before_cost,
                    check_map_schema, read_cells_file, read_json, read_samples, spec_variant,
                    utc_stamp, write_json)
from rockbench.benchmark.store.lines import exact_text, plain_row


#: what a map directory may hold before its run.json exists: the lock, and the scratch space of a
#: ``--scheduler local`` cluster (executors.DASK_SCRATCH)
_OURS = frozenset((".lock", ".dask-scratch"))


def git_info() -> dict:
    """``{"commit", "dirty"}`` of the source tree rockbench runs from (None when not a git checkout).

    Asked once per process: the code that runs is the code imported at its start (two ``git`` calls
    per map added a few seconds to a suite of a hundred maps). Callers get a copy.
    """
    return dict(_git_info())


@functools.lru_cache(maxsize=1)
def _git_info() -> dict:
    here = Path(__file__).resolve().parent
    try:
        commit = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True, text=True,
                                timeout=10)
        if commit.returncode != 0:
            return {"commit": None, "dirty": None}
        status = subprocess.run(["git", "-C", str(here), "status", "--porcelain", "--untracked-files=no"],
                                capture_output=True, text=True, timeout=10)
        return {"commit": commit.stdout.strip(), "dirty": bool(status.stdout.strip())}
    except (OSError, subprocess.SubprocessError):
        return {"commit": None, "dirty": None}


@functools.lru_cache(maxsize=1)
def rockbench_version() -> str:
    try:
        return version("rockbench")
    except PackageNotFoundError:
        return "source"


class RunStore:
    """Writes one map's run directory (see the module docstring)."""

    def __init__(self, out_dir):
        self.dir = Path(out_dir)
        self._csv = None
        self._samples_csv = None
        self._lock = None
        #: the bisection samples already stored, by ``(i, j, axis, t)`` (filled by :meth:`open`)
        self.samples: dict = {}
        self._meta: dict | None = None
        self._failures: list[dict] = []

    # -- opening ------------------------------------------------------------------------------
    def open(self, spec, adapter, options: dict) -> dict:
        """Create or reopen the directory for ``spec``; returns the rows already done by cell ``(i, j)``.

        Raises
        ------
        ConfigError
            The directory holds another map, is not a map directory, or is being written by
            another process.
        """
        d = self.dir
        if d.exists() and not d.is_dir():
            raise ConfigError(f"--out {str(d)!r} is a file; give a directory for the map.")
        run_json = d / "run.json"
        if d.exists() and any(p.name not in _OURS for p in d.iterdir()) and not run_json.exists():
            raise ConfigError(f"--out {str(d)!r} exists and is not a rockbench map directory (no run.json); "
                              "give a new or empty directory.")
        previous = None
        if run_json.exists():
            previous = read_json(run_json, NEW_OUT)
            check_map_schema(previous, d, writing=True)
            stale = rules_mismatch(previous.get("rules_version"), f"the map in {str(d)!r}")
            if stale:
                raise ConfigError(f"{stale}: delete {str(d)!r} to compute it again, or give another --out directory.")
            before = _checked_identity(previous.get("spec_identity"), d)
            if before != spec.identity():
                diff = _differences(before if isinstance(before, dict) else {}, spec.identity())
                raise ConfigError(f"{str(d)!r} already holds a different map (differs in {diff}); give another "
                                  "--out directory, or delete this one to start over.")
        d.mkdir(parents=True, exist_ok=True)
        self._take_lock()
        describe = adapter.describe()
        try:
            resolved = adapter.resolve(spec.block, spec.restitution, dt_s=spec.dt_s)
        except Exception as e:  # noqa: BLE001 - recorded, not fatal: the cells will show the failure
            resolved = {"error": f"{type(e).__name__}: {e}"}
        meta = {
            "schema_version": SCHEMA_VERSION,
            "kind": "rockbench-map",
            "created_utc": previous.get("created_utc") if previous else utc_stamp(),
            "updated_utc": utc_stamp(),
            "rockbench_version": rockbench_version(),
            "rules_version": RULES_VERSION,
            "git": git_info(),
            "python": sys.version.split()[0],
            "platform": platform.platform(),
            "machine": machine(),
            "engine": {**describe, "resolved_settings": resolved},
            "spec": spec.to_dict(),
            "spec_identity": spec.identity(),
            "options": options,
            "runs": _list(previous, "runs") + [{"started_utc": utc_stamp()}],
            "summary": None,
        }
        before = _dict(previous, "engine").get("version")
        if previous and before != describe.get("version"):
            meta["engine_version_changed"] = {"before": before, "now": describe.get("version")}
        # check cells.csv before anything is written: a resume that cannot read it changes nothing
        done, good = self._read_csv(spec.shape)
        self.samples, good_samples = read_samples(d / "bisection.csv", spec.shape)
        self._cut_torn_tail(good)
        self._cut_torn_tail(good_samples, "bisection.csv")
        if previous and previous.get("schema_version") != SCHEMA_VERSION:
            self._add_cost_columns()
        self._meta = meta
        write_json(run_json, meta)
        self._csv = open(d / "cells.csv", "a", newline="")
        if self._csv.tell() == 0:
            self._write_line(COLUMNS)
        return done

    def _add_cost_columns(self) -> None:
        """A resumed schema-4 map's tables get the cost columns (empty in the rows they have), each file
        rewritten atomically; a table that has them already (an earlier attempt was cut short) is left."""
        for name, columns in (("cells.csv", COLUMNS), ("bisection.csv", SAMPLE_COLUMNS)):
            path = self.dir / name
            if not path.is_file():
                continue
            rows = list(csv.reader(io.StringIO(path.read_bytes().decode("utf-8-sig"), newline="")))
            if not rows or rows[0] != before_cost(columns):
                continue
            at = [k for k, c in enumerate(columns) if c in COST_COLUMNS]
            buf = io.StringIO()
            w = csv.writer(buf, lineterminator="\n")
            w.writerow(columns)
            for row in rows[1:]:
                for k in at:
                    row.insert(k, "")
                w.writerow(row)
            write_bytes_atomic(path, buf.getvalue().encode())

    def _take_lock(self) -> None:
        import fcntl  # POSIX only
        self._lock = open(self.dir / ".lock", "w")
        try:
            fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._lock.close()
            self._lock = None
            raise ConfigError(f"another rockbench process is writing {str(self.dir)!r}; wait for it to finish "
                              "or give another --out.") from None

    def _read_csv(self, shape) -> tuple[dict, int | None]:
        """The finished rows ``{(i, j): row}`` and the byte length of the well-formed prefix (None when
        there is no cells.csv); reads only (see :meth:`_cut_torn_tail`)."""
        path = self.dir / "cells.csv"
        if not path.exists():
            return {}, None
        rows, good = read_cells_file(path, shape)
        for r in rows.values():
            if r["status"] != "ok":
                self._failures.append(r)
        return rows, good

    def _cut_torn_tail(self, good: int | None, name: str = "cells.csv") -> None:
        """Cut off a torn last line left by a kill (a row is only complete with its newline)."""
        path = self.dir / name
        if good is not None and good != path.stat().st_size:
            with open(path, "r+b") as f:
                f.truncate(good)

    # -- writing ------------------------------------------------------------------------------
    def row(self, spec, i: int, j: int, r) -> dict:
        """The cells.csv row of cell ``(i, j)`` with result ``r`` (a CellResult)."""
        if getattr(self, "_spec_cache", (None,))[0] is not spec:
            self._spec_cache = (spec, spec.block.name, spec.restitution.label, spec.eta, spec_variant(spec))
        _, bname, rlabel, eta, variant = self._spec_cache
        return {"engine": spec.engine, "variant": variant, "block": bname, "pulse": spec.pulse,
                "restitution": rlabel, "eta": eta, "w_ratio": float(spec.w_ratio_axis[j]),
                "a_ratio": float(spec.a_ratio_axis[i]), "omega_rad_s": float(spec.omega_axis[j]),
                "amplitude_mps2": float(spec.amplitude_axis[i]),
                "outcome": r.outcome or "", "n_impacts": int(r.n_impacts), "max_abs_theta_rad": r.max_abs_theta_rad,
                "valid": bool(r.valid), "flags": ";".join(r.flags), "status": r.status,
                "message": " ".join(str(r.message).split()), "wall_s": float(r.wall_s),
                **dict(zip(COST_COLUMNS, cost_of(r))), "t_overturn_s": r.t_overturn_s, "t_uplift_s": r.t_uplift_s, "min_normal_mg": r.min_normal_mg,
                "max_friction_ratio": r.max_friction_ratio, "i": int(i), "j": int(j)}

    def sample_row(self, spec, i: int, j: int, axis: int, t: float, point: dict, r) -> dict:
        """The bisection.csv row of the sample at ``t`` along edge ``(i, j, axis)``, at ``point``
        (:meth:`~rockbench.benchmark.maps.grid.MapSpec.edge_points`' four values), result ``r``."""
        row = self.row(spec, i, j, r)
        row.update({k: float(v) for k, v in point.items()})
        row.update(axis="wa"[axis], t=float(t))
        return row

    def append_results(self, spec, triples) -> None:
        """Append the rows of ``[(i, j, CellResult), ...]`` (see :meth:`append`).

        A plain successful cell is formatted straight into its line (a 200×200 map writes 40 000 of
        them, and per-field formatting would cost a good share of the batch solver's time); any
        other cell goes through :meth:`row` and the csv module's quoting.
        """
        head, wr, ar, om, am = self._line_strings(spec)
        lines, others = [], []
        for i, j, r in triples:
            if r.status == "ok" and not r.flags and not r.message and r.outcome:
                lines.append(plain_row(head, wr[j], ar[i], om[j], am[i], i, j, r.outcome, r.n_impacts,
                                       r.max_abs_theta_rad, r.valid, "", repr(float(r.wall_s)), r.t_overturn_s,
                                       r.t_uplift_s, r.min_normal_mg, r.max_friction_ratio, *cost_of(r)))
            else:
                others.append(self.row(spec, i, j, r))
        if others:
            self.append(others, _prefix="".join(lines))
        elif lines:
            self._write("".join(lines))

    def append_columns(self, spec, ii, jj, cols) -> None:
        """Append the rows of successful cells ``(ii[k], jj[k])`` with the verdicts of ``cols`` (a
        :class:`~rockbench.engines.contract.CellColumns`) in one write: the same text, row for row, as
        :meth:`append_results` gives for the same cells (:mod:`rockbench.benchmark.store.columnar`)."""
        if len(ii) == 0:
            return
        head, wr, ar, om, am = self._line_strings(spec)
        names = tuple(cols.flag_names)
        texts = [";".join(f for k, f in enumerate(names) if b >> k & 1) for b in range(2 ** len(names))]
        data = format_rows(head, [wr, ar, om, am], ii, jj, cols.outcome, cols.n_impacts, cols.flag_bits, texts,
                           cols.max_abs_theta_rad, cols.t_overturn_s, cols.t_uplift_s, cols.min_normal_mg,
                           cols.max_friction_ratio, repr(float(cols.wall_s)))
        # whole rows in one write, as append() does: a kill leaves at most one torn line
        try:
            self._csv.flush()
            self._csv.buffer.write(data)
            self._csv.buffer.flush()
        except OSError as e:   # a full disk names the file, as _write does
            if e.filename is not None:
                raise
            raise OSError(e.errno, e.strerror or str(e), str(self.dir / "cells.csv")) from None

    def _line_strings(self, spec) -> tuple:
        """The first five fields of a row (with their commas) and the axis values as ``repr`` writes
        them, computed once per spec."""
        if getattr(self, "_line_cache", (None,))[0] is not spec:
            head = io.StringIO()
            csv.writer(head, lineterminator="").writerow([spec.engine, spec_variant(spec), spec.block.name, spec.pulse,
                                                          spec.restitution.label, repr(float(spec.eta))])
            self._line_cache = (spec, head.getvalue() + ",", [repr(float(x)) for x in spec.w_ratio_axis],
                                [repr(float(x)) for x in spec.a_ratio_axis], [repr(float(x)) for x in spec.omega_axis],
                                [repr(float(x)) for x in spec.amplitude_axis])
        return self._line_cache[1:]

    def append(self, rows: list[dict], _prefix: str = "") -> None:
        """Append rows and flush them to the operating system (survives ``kill -9``)."""
        if not rows:
            return
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        lines = []
        for r in rows:
            fields = [exact_text(r[c]) for c in COLUMNS]
            if r["message"] or any(("," in f or '"' in f) for f in fields[:5]):
                w.writerow(fields)          # needs csv quoting
                lines.append(buf.getvalue())
                buf.seek(0)
                buf.truncate()
            else:
                lines.append(",".join(fields) + "\n")
            if r["status"] != "ok":
                self._failures.append({k: exact_text(v) for k, v in r.items()})
        # one write per row batch; each row ends with its newline, so a kill leaves whole rows
        # plus at most one torn line, which the next open cuts off
        self._write(_prefix + "".join(lines))

    def _write_line(self, cells: list[str]) -> None:
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(cells)
        self._write(buf.getvalue())

    def _write(self, text: str) -> None:
        """Write and flush to cells.csv; a refusal of the file system (a full disk) names the file."""
        try:
            self._csv.write(text)
            self._csv.flush()
        except OSError as e:
            if e.filename is not None:
                raise
            raise OSError(e.errno, e.strerror or str(e), str(self.dir / "cells.csv")) from None

    def append_samples(self, rows: list[dict]) -> None:
        """Append bisection samples (:data:`~rockbench.benchmark.store.files.SAMPLE_COLUMNS` each, values as
        :meth:`row` gives them plus ``axis`` and ``t``) to bisection.csv in one write, flushed."""
        if not rows:
            return
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        if self._samples_csv is None:
            self._samples_csv = open(self.dir / "bisection.csv", "a", newline="")
            if self._samples_csv.tell() == 0:
                w.writerow(SAMPLE_COLUMNS)
        for r in rows:
            w.writerow([exact_text(r[c]) for c in SAMPLE_COLUMNS])
        try:
            self._samples_csv.write(buf.getvalue())
            self._samples_csv.flush()
        except OSError as e:
            if e.filename is not None:
                raise
            raise OSError(e.errno, e.strerror or str(e), str(self.dir / "bisection.csv")) from None

    def write_boundary(self, rows: list[list]) -> None:
        """Write boundary.csv (:data:`~rockbench.benchmark.store.files.BOUNDARY_COLUMNS`) atomically."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(BOUNDARY_COLUMNS)
        for r in rows:
            w.writerow([exact_text(v) for v in r])
        write_bytes_atomic(self.dir / "boundary.csv", buf.getvalue().encode())

    def failures(self) -> list[dict]:
        return [{"i": int(r["i"]), "j": int(r["j"]), "flag": r["flags"], "message": r["message"]}
                for r in self._failures]

    def finish(self, summary: dict) -> None:
        """Record the summary and the end time in run.json (atomically)."""
        if self._meta is None:
            return
        self._meta["updated_utc"] = utc_stamp()
        self._meta["runs"][-1]["finished_utc"] = utc_stamp()
        self._meta["summary"] = summary
        write_json(self.dir / "run.json", self._meta)

    def close(self) -> None:
        if self._csv is not None:
            self._csv.close()
            self._csv = None
        if self._samples_csv is not None:
            self._samples_csv.close()
            self._samples_csv = None
        if self._lock is not None:
            self._lock.close()
            self._lock = None


def _list(d: dict | None, key: str) -> list:
    v = (d or {}).get(key)
    return v if isinstance(v, list) else []


def _dict(d: dict | None, key: str) -> dict:
    v = (d or {}).get(key)
    return v if isinstance(v, dict) else {}


def _checked_identity(identity, d: Path):
    """A stored ``spec_identity``, its engine settings checked against this rockbench's names
    (:func:`~rockbench.benchmark.engine_info.setting_names.stored_settings`: a map stored under older names is not resumed)."""
    if isinstance(identity, dict) and isinstance(identity.get("engine_settings"), dict):
        stored_settings(str(identity.get("engine")), identity["engine_settings"], str(d))
    return identity


def _differences(a: dict, b: dict, prefix: str = "") -> str:
    out = []
    for k in sorted(set(a) | set(b)):
        va, vb = a.get(k), b.get(k)
        if isinstance(va, dict) and isinstance(vb, dict):
            sub = _differences(va, vb, prefix + k + ".")
            if sub:
                out.append(sub)
        elif va != vb:
            out.append(f"{prefix}{k}: {va!r} before, {vb!r} now")
    return "; ".join(out)
