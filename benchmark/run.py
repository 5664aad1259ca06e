"""The whole benchmark as one job: a suite file → maps (resumed) → scores → report.

A suite is a TOML file (``benchmark/suites/default.toml`` and ``quick.toml`` are shipped)::

    [suite]
    name = "default"
    description = "..."

    [grid]                       # LO:HI:N, N values from LO to HI inclusive
    w_ratio = "1:16:51"          # ω/p
    a_ratio = "1:12:51"          # a0/(g·tanα)
    adaptive = true              # engine maps: coarse grid, refined where neighbours disagree
                                 # (reference maps are always computed in full)
    coarse_stride = 4

    [cases]
    blocks = ["B3M", "B6M", "B3L", "B6L"]   # Table 1 presets
    pulses = ["sine", "cosine"]

    [reference]                  # one reference map per block, pulse and restitution
    restitutions = ["housner", "modified-average", "modified-exact"]   # or "modified:K", or a number
    # dt_s = 0.001

    [engines]
    names = "available"          # every installed engine but the reference, or a list of names
    variants = [{settings = "calibrated"}, {settings = "defaults"}]    # engine settings, one map each
    restitution = "housner"      # the η calibrated variants are tuned to (and their maps' label)
    own_eta = true               # (d): measure each variant's η in free rocking, add reference maps with it
    # dt_s = 0.0005

    [run]
    cell_timeout_s = 120

    [report]
    cases = ["B3M:sine:6:6.1"]   # θ(t) comparisons, BLOCK:PULSE:W_RATIO:A_RATIO
    # experiments = "path/to/outcomes.csv"   (relative to the suite file)

Layout of the output directory: ``OUT/maps/<engine variant>/<block>-<pulse>-<restitution>/`` (one
``rockbench map`` run directory each, resumable), ``OUT/score.json``, ``OUT/index.html``,
``OUT/report.md``, ``OUT/img/``, ``OUT/suite.json`` (the suite as run, and the timings).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from ..reference_solver.errors import ConfigError, EngineUnavailableError
from ..reference_solver.restitution import Restitution
from .maps import MapSpec, parse_range
from .presets import PRESETS, get_preset
from .scoring import CALIBRATION_FILE, variant_name

SUITE_KEYS = {
    "suite": {"name", "description"},
    "grid": {"w_ratio", "a_ratio", "adaptive", "coarse_stride"},
    "cases": {"blocks", "pulses"},
    "reference": {"restitutions", "dt_s"},
    "engines": {"names", "variants", "restitution", "dt_s", "own_eta"},
    "run": {"cell_timeout_s"},
    "report": {"cases", "experiments"},
}


@dataclass(frozen=True)
class MapJob:
    """One map of a suite.

    Attributes
    ----------
    engine : str
        Registry name.
    settings : dict
        Engine settings (the variant).
    block, pulse : str
        Preset name and pulse kind.
    restitution : Restitution
        The restitution law.
    dt_s : float or None
        Time step [s] (None: the engine's default).
    subdir : str
        Where the run directory goes, relative to the output directory.
    """

    engine: str
    settings: dict
    block: str
    pulse: str
    restitution: Restitution
    dt_s: float | None
    subdir: str


@dataclass
class Suite:
    """A parsed suite file (see the module docstring)."""

    name: str
    description: str
    path: str
    w_ratio: str
    a_ratio: str
    adaptive: bool
    coarse_stride: int | None
    blocks: list
    pulses: list
    reference_restitutions: list
    reference_dt_s: float | None
    engine_names: object
    engine_variants: list
    engine_restitution: str
    engine_dt_s: float | None
    own_eta: bool
    cell_timeout_s: float
    report_cases: list
    experiments: str | None
    raw: dict = field(default_factory=dict)


#: the shipped suites, by name
SHIPPED_SUITES = ("default", "quick")


def suite_path(name_or_path: str | None, quick: bool) -> Path | None:
    """The suite file to run: a shipped suite by name (``default``, ``quick``), or a path.

    A bare name (no ``.toml``, no folder part) always means a shipped suite, whatever the working
    directory holds (an output folder called ``quick`` is not a suite file); a path must be a file.
    """
    if name_or_path is None:
        name_or_path = "quick" if quick else "default"
    text = str(name_or_path)
    p = Path(text)
    is_path = p.suffix.lower() == ".toml" or "/" in text or (os.sep in text) or p.is_absolute()
    if not is_path:
        shipped = resources.files("rockbench.benchmark").joinpath(f"suites/{text}.toml")
        if shipped.is_file():
            return Path(str(shipped))
        if p.is_file():
            raise ConfigError(f"unknown suite {text!r}; to run the file of that name give it as a path "
                              f"(./{text}); shipped suites: {', '.join(SHIPPED_SUITES)}.")
        raise ConfigError(f"unknown suite {text!r}; give a TOML file or one of: {', '.join(SHIPPED_SUITES)}.")
    if p.is_dir():
        raise ConfigError(f"suite file {text!r} is a folder; give a TOML suite file or one of: "
                          f"{', '.join(SHIPPED_SUITES)}.")
    if not p.is_file():
        raise ConfigError(f"suite file {text!r} does not exist; give a TOML suite file or one of: "
                          f"{', '.join(SHIPPED_SUITES)}.")
    return p


def load_suite(path) -> Suite:
    """Read and check a suite file: everything that does not need the engines (see
    :func:`check_suite` for the rest), so a bad suite fails before the first map, and ``--plan``
    fails the same way.

    Raises
    ------
    ConfigError
        Unreadable TOML, an unknown table or key, or a bad value: one line naming the key.
    """
    p = Path(path)
    try:
        raw = tomllib.loads(p.read_bytes().decode("utf-8-sig"))
    except OSError as e:
        raise ConfigError(f"cannot read suite {str(p)!r}: {e.strerror or e}.") from None
    except UnicodeDecodeError as e:
        raise ConfigError(f"suite {str(p)!r} is not UTF-8 text (byte {e.start}); give a TOML suite file.") from None
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"suite {str(p)!r} is not valid TOML: {e}.") from None
    for table, val in raw.items():
        if table not in SUITE_KEYS or not isinstance(val, dict):
            raise ConfigError(f"suite {p.name}: unknown table [{table}]; tables: {', '.join(SUITE_KEYS)}.")
        extra = sorted(set(val) - SUITE_KEYS[table])
        if extra:
            raise ConfigError(f"suite {p.name}: unknown key {table}.{extra[0]}; [{table}] takes "
                              f"{', '.join(sorted(SUITE_KEYS[table]))}.")

    def get(table, key, default=None):
        return raw.get(table, {}).get(key, default)

    def str_list(table, key, default, *, empty: bool = False):
        v = get(table, key, default)
        if not isinstance(v, list) or not all(isinstance(x, (str, int, float)) and not isinstance(x, bool)
                                              for x in v):
            raise ConfigError(f"suite {p.name}: {table}.{key} must be a list, got {v!r}.")
        if not v and not empty:
            raise ConfigError(f"suite {p.name}: {table}.{key} is empty; list at least one, or leave the key out "
                              f"for the default {default!r}.")
        return [str(x) for x in v]

    def where(table, key):
        return f"suite {p.name}: {table}.{key}"

    for key in ("w_ratio", "a_ratio"):
        if not isinstance(get("grid", key), str):
            raise ConfigError(f"suite {p.name}: grid.{key} must be a string LO:HI:N, got {get('grid', key)!r}.")
    try:
        x = parse_range("grid.w_ratio", get("grid", "w_ratio"), "w_ratio")
        y = parse_range("grid.a_ratio", get("grid", "a_ratio"), "a_ratio")
    except ConfigError as e:
        raise ConfigError(f"suite {p.name}: {e}") from None
    block_names = str_list("cases", "blocks", list(PRESETS))
    try:
        blocks = [get_preset(b).name for b in block_names]
    except ConfigError as e:
        raise ConfigError(f"{where('cases', 'blocks')}: {e}") from None
    pulses = [x_.lower() for x_ in str_list("cases", "pulses", ["sine", "cosine"])]
    for x_ in pulses:
        if x_ not in ("sine", "cosine", "half-sine"):
            raise ConfigError(f"suite {p.name}: cases.pulses has {x_!r}; use sine, cosine or half-sine.")
    refs = str_list("reference", "restitutions", ["housner"])
    for r in refs:
        for b in blocks:
            restitution_for(r, b, where("reference", "restitutions"))  # checks the token for every block
    names = get("engines", "names", "available")
    if not (names == "available" or (isinstance(names, list) and all(isinstance(n, str) for n in names))):
        raise ConfigError(f"suite {p.name}: engines.names must be \"available\" or a list of names, got {names!r}.")
    variants = get("engines", "variants", [{}])
    if not isinstance(variants, list) or not all(isinstance(v, dict) for v in variants) or not variants:
        raise ConfigError(f"suite {p.name}: engines.variants must be a non-empty list of tables of settings.")
    eng_rest = get("engines", "restitution", "housner")
    if not isinstance(eng_rest, (str, int, float)) or isinstance(eng_rest, bool):
        raise ConfigError(f"suite {p.name}: engines.restitution must be a text or a number, got {eng_rest!r}.")
    eng_rest = str(eng_rest)
    for b in blocks:
        restitution_for(eng_rest, b, where("engines", "restitution"))
    for table, key in (("grid", "adaptive"), ("engines", "own_eta")):
        if not isinstance(get(table, key, False), bool):
            raise ConfigError(f"suite {p.name}: {table}.{key} must be true or false, got {get(table, key)!r}.")
    stride = get("grid", "coarse_stride")
    if stride is not None and (isinstance(stride, bool) or not isinstance(stride, int) or stride < 1):
        raise ConfigError(f"suite {p.name}: grid.coarse_stride must be a whole number >= 1, got {stride!r}.")
    timeout = get("run", "cell_timeout_s", 120.0)
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not (0 < timeout < math.inf):
        raise ConfigError(f"suite {p.name}: run.cell_timeout_s must be a number of seconds > 0, got {timeout!r}.")
    for key in ("name", "description"):
        if not isinstance(get("suite", key, ""), str):
            raise ConfigError(f"suite {p.name}: suite.{key} must be a text, got {get('suite', key)!r}.")
    cases = str_list("report", "cases", ["B3M:sine:6:6.1"], empty=True)
    from .report import parse_case
    for c in cases:
        parse_case(c, where("report", "cases"))
    exp = get("report", "experiments")
    if exp is not None:
        if not isinstance(exp, str):
            raise ConfigError(f"suite {p.name}: report.experiments must be a path, got {exp!r}.")
        exp = str((p.parent / exp).resolve())
        from .experiments import load_outcomes
        try:
            load_outcomes(exp)
        except ConfigError as e:
            raise ConfigError(f"{where('report', 'experiments')}: {e}") from None
    suite = Suite(name=str(get("suite", "name", p.stem)), description=str(get("suite", "description", "")),
                  path=str(p), w_ratio=get("grid", "w_ratio"), a_ratio=get("grid", "a_ratio"),
                  adaptive=bool(get("grid", "adaptive", False)), coarse_stride=stride, blocks=blocks, pulses=pulses,
                  reference_restitutions=refs, reference_dt_s=_dt(get("reference", "dt_s"), p.name, "reference"),
                  engine_names=names, engine_variants=variants, engine_restitution=eng_rest,
                  engine_dt_s=_dt(get("engines", "dt_s"), p.name, "engines"),
                  own_eta=bool(get("engines", "own_eta", False)), cell_timeout_s=float(timeout),
                  report_cases=cases, experiments=exp, raw=raw)
    # every map's spec, built once here, checks the grid's size and each time step against the
    # highest frequency of each block
    for block in blocks:
        for pulse in pulses:
            for dt, table in ((suite.reference_dt_s, "reference"), (suite.engine_dt_s, "engines")):
                try:
                    MapSpec(get_preset(block).block(), pulse, Restitution(), x, y, dt_s=dt)
                except ConfigError as e:
                    keys = "grid" + (f" and {table}.dt_s" if dt is not None else "")
                    raise ConfigError(f"suite {p.name}: {keys} ({block} {pulse}): {e}") from None
    return suite


def check_suite(suite: "Suite", engines: list[str], explicit: bool) -> tuple[list[str], list[str]]:
    """What :func:`load_suite` cannot check alone: every engine variant's settings (the adapter is
    built, nothing runs). Called by ``--plan`` and before the first map.

    Returns the engines to run and notes. An engine picked because it is available (``explicit``
    false) that cannot take a variant's settings is skipped with a note, as an engine that is not
    installed is, unless no engine can take them (a typo).

    Raises
    ------
    ConfigError
        A setting an engine named explicitly (suite list or ``--engines``), or every engine, refuses:
        one line naming the suite key.
    """
    from ..engines.base import EngineAdapter
    from ..engines.registry import adapter_class

    kept, refused = [], {}
    for engine in engines:
        cls = adapter_class(engine)
        for k, variant in enumerate(suite.engine_variants):
            try:
                # the base class's check of names and values, without the adapter's own constructor
                # (which may start its engine: nothing may run for --plan)
                EngineAdapter.__init__(object.__new__(cls), **variant)
            except ConfigError as e:
                refused[engine] = f"engines.variants[{k}] {variant}: {e}"
                break
        else:
            kept.append(engine)
    if refused and (explicit or not kept):
        raise ConfigError(f"suite {Path(suite.path).name}: {next(iter(refused.values()))}")
    return kept, [f"engine {n} skipped: {why}" for n, why in refused.items()]


def _dt(v, name, table):
    if v is None:
        return None
    if not isinstance(v, (int, float)) or not (v > 0 and math.isfinite(v)):
        raise ConfigError(f"suite {name}: {table}.dt_s must be a number of seconds > 0, got {v!r}.")
    return float(v)


def restitution_for(token: str, block: str, where: str = "suite") -> Restitution:
    """``housner``, ``modified-average``, ``modified-exact``, ``modified:K`` or a number → a Restitution."""
    t = str(token).strip().lower()
    pre = PRESETS[block]
    if t == "housner":
        return Restitution()
    if t == "modified-average":
        return Restitution("modified", k=pre.k_average)
    if t == "modified-exact":
        return Restitution("modified", k=pre.k_exact)
    try:
        if t.startswith("modified:"):
            return Restitution("modified", k=float(t.split(":", 1)[1]))
        return Restitution("constant", value=float(t))
    except ConfigError as e:    # a number out of range
        raise ConfigError(f"{where}: restitution {token!r}: {e}") from None
    except ValueError:
        raise ConfigError(f"{where}: restitution {token!r} is not one of housner, modified-average, modified-exact, "
                          "modified:K or a number in (0, 1].") from None


def parse_engines(text: str | None) -> list[str] | None:
    """``--engines NAME,...`` into a list of names (None when not given); every name must be known.

    Raises
    ------
    ConfigError
        An empty list or an unknown name (with a "did you mean").
    """
    from ..engines.registry import adapter_class

    if text is None:
        return None
    items = [n.strip() for n in str(text).split(",")]
    if not items or any(not n for n in items):
        raise ConfigError(f"--engines takes NAME,... (e.g. --engines mujoco,pybullet), got {text!r}.")
    for n in items:
        try:
            adapter_class(n)
        except ConfigError as e:
            raise ConfigError(f"--engines: {e}") from None
        except EngineUnavailableError:
            pass    # known but not installed: engine_names says so with exit code 3
    return list(dict.fromkeys(items))


def engine_names(suite: Suite, only: list[str] | None = None) -> tuple[list[str], list[str]]:
    """(engines to run, notes on the ones skipped) for a suite; ``only`` (``run --engines``) replaces
    the suite's ``engines.names`` (the reference maps are always computed).

    Raises
    ------
    EngineUnavailableError
        An engine named explicitly (in the suite or in ``only``) is not installed.
    """
    from ..engines.registry import availability, names

    notes = []
    if only is not None:
        for n in only:
            a = availability(n)
            if not a["available"]:
                raise EngineUnavailableError(f"--engines asks for engine {n!r}, which is not available: "
                                             f"{a['reason']}")
        return [n for n in only if n != "reference"], notes
    if suite.engine_names == "available":
        out = []
        for n in names():
            if n == "reference":
                continue
            a = availability(n)
            if a["available"]:
                out.append(n)
            else:
                notes.append(f"engine {n} skipped: {a['reason']}")
        return out, notes
    for n in suite.engine_names:
        a = availability(n)
        if not a["available"]:
            raise EngineUnavailableError(f"the suite asks for engine {n!r}, which is not available: {a['reason']}")
    return [n for n in suite.engine_names if n != "reference"], notes


def _slug(s: str) -> str:
    return "".join(c if (c.isalnum() or c in ".=") else "-" for c in str(s)).strip("-")


def plan(suite: Suite, engines: list[str]) -> list[MapJob]:
    """Every map of the suite: the reference maps, then each engine variant's maps."""
    jobs = []
    for block in suite.blocks:
        for pulse in suite.pulses:
            for tok in suite.reference_restitutions:
                r = restitution_for(tok, block)
                jobs.append(MapJob("reference", {}, block, pulse, r, suite.reference_dt_s,
                                   f"maps/reference/{block}-{pulse}-{_slug(r.label)}"))
    for engine in engines:
        for variant in suite.engine_variants:
            vname = variant_name(engine, variant, suite.engine_dt_s)
            for block in suite.blocks:
                r = restitution_for(suite.engine_restitution, block)
                for pulse in suite.pulses:
                    jobs.append(MapJob(engine, dict(variant), block, pulse, r, suite.engine_dt_s,
                                       f"maps/{_slug(vname)}/{block}-{pulse}-{_slug(r.label)}"))
    return jobs


def own_eta_jobs(suite: Suite, etas: list[dict]) -> list[MapJob]:
    """Reference maps with each engine variant's measured η (4 decimals), one per block and pulse."""
    jobs, seen = [], set()
    for m in etas:
        if m.get("eta_measured") is None:
            continue
        eta = round(float(m["eta_measured"]), 4)
        if not 0.0 < eta <= 1.0 or (m["block"], eta) in seen:
            continue
        seen.add((m["block"], eta))
        for pulse in suite.pulses:
            jobs.append(MapJob("reference", {}, m["block"], pulse, Restitution("constant", value=eta),
                               suite.reference_dt_s, f"maps/reference/{m['block']}-{pulse}-own-eta-{eta:.4f}"))
    return jobs


def measure_own_eta(suite: Suite, engines: list[str], out: Path, log) -> tuple[list[dict], list[str]]:
    """Each engine variant's free-rocking η on each block (kept in OUT/calibration.json and reused).

    Returns the measurements and notes on the ones that failed.
    """
    from ..engines.registry import get_adapter
    from .scoring import _read_json, write_json_atomic

    path = out / CALIBRATION_FILE
    old = {(r["variant"], r["block"]): r for r in (_read_json(path).get("measurements", []) if path.is_file() else [])}
    rows, notes = [], []
    for engine in engines:
        for variant in suite.engine_variants:
            vname = variant_name(engine, variant, suite.engine_dt_s)
            for block in suite.blocks:
                if (vname, block) in old and old[(vname, block)].get("eta_measured") is not None:
                    rows.append(old[(vname, block)])
                    continue
                log(f"measuring η of {vname} on {block} (free rocking)")
                try:
                    m = get_adapter(engine, **variant).measure_restitution(get_preset(block).block(),
                                                                          dt_s=suite.engine_dt_s)
                    rows.append({"variant": vname, "engine": engine, "settings": dict(variant), "block": block,
                                 "eta_measured": float(m.eta_mean), "eta_std": float(m.eta_std),
                                 "n_impacts": len(m.etas), "method": m.method})
                except Exception as e:  # noqa: BLE001 - a failed measurement drops map (d) only
                    notes.append(f"η of {vname} on {block} not measured: {type(e).__name__}: {e}")
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, {"kind": "rockbench-calibration", "measurements": rows})
    return rows, notes


def run_suite(suite: Suite, out_dir, *, jobs: int | None = None, experiments=None, report: bool = True,
              log=None, engines: list[str] | None = None) -> dict:
    """Compute what is missing, score, and write the report (see the module docstring).

    ``engines`` (``run --engines``) restricts the engine maps to those engines.

    Returns
    -------
    dict
        ``maps`` (per map: dir and wall time), ``wall_s``, ``score`` (the score document or None),
        ``notes``, ``report`` (paths) and ``summary`` (the summary table as text).
    """
    from .executors import make_executor
    from .maps import MapSpec, parse_range, run_map
    from .presets import get_preset
    from .scoring import write_json_atomic

    from .atomic import check_output_dir
    from .executors import cap_jobs

    log = log or (lambda m: print(f"rockbench: {m}", file=sys.stderr))
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"--out {str(out)!r} is a file; give a directory for the benchmark.")
    check_output_dir(out, "--out")
    jobs, note = cap_jobs(jobs)
    if note:
        log(note)
    x = parse_range("grid.w_ratio", suite.w_ratio, "w_ratio")
    y = parse_range("grid.a_ratio", suite.a_ratio, "a_ratio")
    explicit = engines is not None or suite.engine_names != "available"
    engines, notes = engine_names(suite, engines)
    engines, more = check_suite(suite, engines, explicit)
    notes += more
    todo = plan(suite, engines)
    if suite.own_eta and engines:
        etas, more = measure_own_eta(suite, engines, out, log)
        notes += more
        todo += own_eta_jobs(suite, etas)
    # every spec is built (and so checked) before the first map runs
    specs = [MapSpec(get_preset(j.block).block(), j.pulse, j.restitution, x, y, engine=j.engine,
                     engine_settings=dict(j.settings), dt_s=j.dt_s) for j in todo]
    t0 = time.perf_counter()
    done = []
    # One executor per engine and settings, kept for all of its maps: its workers start, import the
    # engine and build their models once instead of once per map (their stderr goes to one
    # workers.log beside the variant's maps).
    executors: dict = {}

    def variant(job):
        return None if job.engine == "reference" else (job.engine, json.dumps(dict(job.settings), sort_keys=True))

    # a variant's workers stop after its last map, so idle engines do not hold their memory
    last_map = {variant(j): k for k, j in enumerate(todo, 1)}
    try:
        for k, (job, spec) in enumerate(zip(todo, specs), 1):
            d = out / job.subdir
            log(f"[{k}/{len(todo)}] {spec.label()} → {d}")
            t1 = time.perf_counter()
            # The reference runs in this process: its compiled batch kernel is parallel already, and
            # worker processes would each compile it again (seconds per map); engines keep the
            # workers' time limit and crash isolation.
            ex = None
            key = variant(job)
            if key is not None:
                ex = executors.get(key)
                if ex is None:
                    d.parent.mkdir(parents=True, exist_ok=True)
                    ex = executors[key] = make_executor(job.engine, dict(job.settings), jobs=jobs,
                                                        log_path=d.parent / "workers.log")
            # reference maps are computed in full: they cost milliseconds, and scoring needs the
            # rigid model's domain (lift-/slip-required) in every cell, not just where refinement looked
            res = run_map(spec, d, jobs=jobs, serial=job.engine == "reference",
                          adaptive=suite.adaptive and job.engine != "reference",
                          coarse_stride=suite.coarse_stride, cell_timeout_s=suite.cell_timeout_s, plot=False,
                          log=log, executor=ex)
            done.append({"dir": str(d), "label": spec.label(), "wall_s": time.perf_counter() - t1,
                         "n_simulated": res.n_simulated, "n_cells": spec.n_cells, "n_failed": len(res.failures)})
            if ex is not None and last_map[key] == k:
                executors.pop(key).close()
    finally:
        for ex in executors.values():
            ex.close()
    maps_wall = time.perf_counter() - t0
    result = {"suite": suite.name, "maps": done, "maps_wall_s": maps_wall, "notes": list(notes),
              "score": None, "report": None, "summary": ""}
    if experiments is None and suite.experiments:
        from .experiments import load_outcomes
        experiments = load_outcomes(suite.experiments)
    t2 = time.perf_counter()
    if report:
        from .report import build_report, parse_case
        cases = tuple(parse_case(c) for c in suite.report_cases)
        rep = build_report([out / "maps"], out, experiments=experiments, cases=cases, log=log)
        result["score"] = rep["doc"]
        result["notes"] += rep["notes"]
        result["report"] = {k: rep[k] for k in ("html", "markdown") if k in rep}
    else:
        from ..reference_solver.errors import IncomparableError
        from .scoring import score_dirs
        try:
            result["score"] = score_dirs([out / "maps"], experiments=experiments)
            write_json_atomic(out / "score.json", result["score"])
        except IncomparableError as e:  # e.g. no engine installed: the maps are still worth having
            result["notes"].append(f"No scores: {e}")
    result["report_wall_s"] = time.perf_counter() - t2
    result["wall_s"] = time.perf_counter() - t0
    if result["score"] is not None:
        from .tables import summary_table
        result["summary"] = summary_table(result["score"])
    write_json_atomic(out / "suite.json", {"suite": suite.raw, "path": suite.path, "jobs": jobs,
                                           **{k: v for k, v in result.items() if k not in ("suite", "score", "summary")},
                                           "suite_name": suite.name})
    return result
