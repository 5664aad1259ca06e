"""The whole benchmark as one job: a suite file → maps (resumed) → scores → report.

A suite is a TOML file (``harness/suites/default.toml`` and ``quick.toml`` are shipped)::

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
    exclude = ["drake"]          # with "available": engines left out even when installed (a note says so)
    variants = [{settings = "calibrated"}, {settings = "defaults"}]    # engine settings, one map each
                                 # a variant may carry its own restitution = "modified-average" (...):
                                 # its η target and its maps' label (scored like for like against
                                 # the reference maps with that restitution), and engines = [...] (the
                                 # engines it applies to, default all); neither is an engine setting
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

from ...reference_solver.errors import ConfigError, EngineUnavailableError
from ...reference_solver.pulses import is_number
from ...reference_solver.restitution import Restitution
from ..engine_info.health import EngineHealth
from ..maps.grid import MapSpec, parse_range
from ..blocks.presets import PRESETS, get_preset
from .progress import SuiteConsole, say_device_notes
from ..store.files import variant_name
from ..store.loading import CALIBRATION_FILE

SUITE_KEYS = {
    "suite": {"name", "description"},
    "grid": {"w_ratio", "a_ratio", "adaptive", "coarse_stride"},
    "cases": {"blocks", "pulses"},
    "reference": {"restitutions", "dt_s"},
    "engines": {"names", "exclude", "variants", "restitution", "dt_s", "own_eta"},
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
    engine_exclude: list = field(default_factory=list)


#: the shipped suites, by name
SHIPPED_SUITES = ("default", "quick", "full")


def suite_path(name_or_path: str | None, quick: bool) -> Path | None:
    """The suite file to run: a shipped suite by name (``default``, ``quick``, ``full``), or a path.

    A bare name (no ``.toml``, no folder part) always means a shipped suite, whatever the working
    directory holds (an output folder called ``quick`` is not a suite file); a path must be a file.
    """
    if name_or_path is None:
        name_or_path = "quick" if quick else "default"
    text = str(name_or_path)
    p = Path(text)
    is_path = p.suffix.lower() == ".toml" or "/" in text or (os.sep in text) or p.is_absolute()
    if not is_path:
        shipped = resources.files("rockbench.harness.suites").joinpath(f"{text}.toml")
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
    exclude = str_list("engines", "exclude", [], empty=True)
    if exclude and names != "available":
        raise ConfigError(f"suite {p.name}: engines.exclude goes with names = \"available\"; with a list of "
                          f"names, leave the engine out of the list instead.")
    variants = get("engines", "variants", [{}])
    if not isinstance(variants, list) or not all(isinstance(v, dict) for v in variants) or not variants:
        raise ConfigError(f"suite {p.name}: engines.variants must be a non-empty list of tables of settings.")
    eng_rest = get("engines", "restitution", "housner")
    if not isinstance(eng_rest, (str, int, float)) or isinstance(eng_rest, bool):
        raise ConfigError(f"suite {p.name}: engines.restitution must be a text or a number, got {eng_rest!r}.")
    eng_rest = str(eng_rest)
    for b in blocks:
        restitution_for(eng_rest, b, where("engines", "restitution"))
    for k, v in enumerate(variants):
        if "engines" in v and not (isinstance(v["engines"], list) and v["engines"]
                                   and all(isinstance(n, str) for n in v["engines"])):
            raise ConfigError(f"suite {p.name}: engines.variants[{k}].engines must be a non-empty list of engine "
                              f"names, got {v['engines']!r}.")
        if "restitution" in v:
            if not isinstance(v["restitution"], (str, int, float)) or isinstance(v["restitution"], bool):
                raise ConfigError(f"suite {p.name}: engines.variants[{k}].restitution must be a text or a number, "
                                  f"got {v['restitution']!r}.")
            for b in blocks:
                restitution_for(str(v["restitution"]), b, f"suite {p.name}: engines.variants[{k}].restitution")
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
    from ..report.html import parse_case
    for c in cases:
        parse_case(c, where("report", "cases"))
    exp = get("report", "experiments")
    if exp is not None:
        if not isinstance(exp, str):
            raise ConfigError(f"suite {p.name}: report.experiments must be a path, got {exp!r}.")
        exp = str((p.parent / exp).resolve())
        from ..blocks.experiments import load_outcomes
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
                  report_cases=cases, experiments=exp, raw=raw, engine_exclude=exclude)
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
    from ...engines.base import EngineAdapter
    from ...engines.registry import adapter_class

    kept, refused = [], {}
    for engine in engines:
        cls = adapter_class(engine)
        for k, variant in enumerate(suite.engine_variants):
            if not variant_applies(engine, variant):
                continue
            try:
                # the base class's check of names and values, without the adapter's own constructor
                # (which may start its engine: nothing may run for --plan)
                EngineAdapter.__init__(object.__new__(cls), **variant_settings(variant))
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
    """A suite's restitution token (``housner``, ``modified-average``, ``modified-exact``,
    ``modified:K`` or a number) for a preset block: :meth:`Restitution.parse` with the preset's k."""
    pre = PRESETS[block]
    try:
        return Restitution.parse(token, k_average=pre.k_average, k_exact=pre.k_exact)
    except ConfigError as e:
        t = str(token).strip().lower()
        if t.startswith("modified") or is_number(t):    # a known spelling with a value out of range
            raise ConfigError(f"{where}: restitution {token!r}: {e}") from None
        raise ConfigError(f"{where}: restitution {token!r} is not one of housner, modified-average, modified-exact, "
                          "modified:K or a number in (0, 1].") from None


def parse_engines(text: str | None) -> list[str] | None:
    """``--engines NAME,...`` into a list of names (None when not given); every name must be known.

    Raises
    ------
    ConfigError
        An empty list or an unknown name (with a "did you mean").
    """
    from ...engines.registry import adapter_class

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
    from ...engines.registry import adapter_class, availability, names

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
            if n in suite.engine_exclude:
                notes.append(f"engine {n} left out by the suite (engines.exclude); run it with --engines {n} "
                             f"or the full suite")
                continue
            a = availability(n)
            if not a["available"]:
                notes.append(f"engine {n} skipped: {a['reason']}")
                continue
            why_not = adapter_class(n).default_suite_exclusion()
            if why_not:
                notes.append(f"engine {n} skipped: {why_not}")
            else:
                out.append(n)
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
            if not variant_applies(engine, variant):
                continue
            vname = variant_name(engine, variant_settings(variant) | _rest_part(variant), suite.engine_dt_s)
            for block in suite.blocks:
                r = restitution_for(variant_restitution(suite, variant), block)
                for pulse in suite.pulses:
                    jobs.append(MapJob(engine, variant_settings(variant), block, pulse, r, suite.engine_dt_s,
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


def _variant_blocks(suite: Suite, engines: list[str]):
    for engine in engines:
        for variant in suite.engine_variants:
            if not variant_applies(engine, variant):
                continue
            for block in suite.blocks:
                yield engine, variant, block


def variant_settings(variant: dict) -> dict:
    """A suite variant's engine settings (its ``restitution`` and ``engines``, suite keys, left out)."""
    return {k: v for k, v in variant.items() if k not in ("restitution", "engines")}


def variant_applies(engine: str, variant: dict) -> bool:
    """Whether a suite variant runs for ``engine`` (its ``engines`` list, default every engine)."""
    return "engines" not in variant or engine in variant["engines"]


def _rest_part(variant: dict) -> dict:
    return {"restitution": variant["restitution"]} if "restitution" in variant else {}


def variant_restitution(suite: "Suite", variant: dict) -> str:
    """The restitution a suite variant is calibrated to and labelled with: its own, else the suite's."""
    return str(variant.get("restitution", suite.engine_restitution))


def _prepare_one(engine: str, variant: dict, block: str, restitution: str, dt_s, measure: bool) -> dict:
    """One engine variant on one block: its calibration for the suite's restitution (computed once
    and cached on disk, where the map workers find it) and, with ``measure``, its free-rocking η
    (by a fresh adapter, as measured before the maps always was)."""
    from ...engines.registry import get_adapter

    b = get_preset(block).block()
    variant = variant_settings(variant)
    out: dict = {"measurement": None, "error": None}
    try:
        get_adapter(engine, **variant).resolve(b, restitution_for(restitution, block), dt_s=dt_s)
    except Exception:  # noqa: BLE001 - not fatal here: the maps meet it again and record it
        pass
    if measure:
        try:
            m = get_adapter(engine, **variant).measure_restitution(b, dt_s=dt_s)
            out["measurement"] = {"eta_measured": float(m.eta_mean), "eta_std": float(m.eta_std),
                                  "n_impacts": len(m.etas), "method": m.method}
        except Exception as e:  # noqa: BLE001 - a failed measurement drops map (d) only
            out["error"] = f"{type(e).__name__}: {e}"
    return out


def prepare_engines(suite: Suite, engines: list[str], out: Path, log, *, workers: int = 1,
                    own_eta: bool | None = None) -> tuple[list[dict], list[str], float]:
    """Everything the engine maps need before they start, on ``workers`` cores at once: each engine
    variant's calibration on each block (cached on disk) and, with ``own_eta`` (default: the
    suite's), its free-rocking η (kept in OUT/calibration.json and reused).

    The tasks run in helper processes (one per core; forked where that is safe, so they share what
    this process has imported), the costliest engines first; a task that fails is noted, and if the
    helpers themselves cannot run, the rest runs here one task after another. The measurements are
    the same wherever they run (the simulations are deterministic).

    Returns
    -------
    rows, notes, wall_s
        The η measurements in suite order (engine, variant, block), notes on those that failed,
        and the wall time spent [s].
    """
    return _Preparation(suite, engines, out, log, workers=workers, own_eta=own_eta).finish()


class _Preparation:
    """:func:`prepare_engines` in two halves: made, it starts the helpers; :meth:`finish` waits for
    them (the suite computes its reference maps in between)."""

    def __init__(self, suite: Suite, engines: list[str], out: Path, log, *, workers: int = 1,
                 own_eta: bool | None = None):
        from ..store.files import read_json

        self.t0 = time.perf_counter()
        self.suite, self.out = suite, out
        self.own_eta = suite.own_eta if own_eta is None else own_eta
        self.path = out / CALIBRATION_FILE
        self.old = {(r["variant"], r["block"]): r
                    for r in (read_json(self.path).get("measurements", []) if self.path.is_file() else [])}
        self.tasks = []
        for engine, variant, block in _variant_blocks(suite, engines):
            vname = variant_name(engine, variant_settings(variant), suite.engine_dt_s)
            cached = (vname, block) in self.old and self.old[(vname, block)].get("eta_measured") is not None
            # a variant with its own restitution is scored against that restitution's reference
            # maps; its own-η map (d) would measure the Housner calibration, so it has none
            self.tasks.append((engine, variant, block, self.own_eta and not cached and "restitution" not in variant))
        self.results: dict = {}
        # work to do: a measurement, or a calibration (an engine with none has nothing to prepare);
        # the costliest engines first (finer default steps), so the last tasks are short
        self.todo = sorted((k for k, t in enumerate(self.tasks) if t[3] or _calibrates(t[0])),
                           key=lambda k: _cost_rank(self.tasks[k][0]))
        for k in self.todo:
            engine, variant, block, measure = self.tasks[k]
            if measure:
                log(f"measuring η of {variant_name(engine, variant_settings(variant), suite.engine_dt_s)} on {block} (free rocking)")
        self.pool, self.futs = None, {}
        if workers > 1 and len(self.todo) > 1:
            self._start_helpers(workers)

    def own_eta_slots(self) -> int:
        """How many (variant, block) pairs get a reference map at their own measured η, at most (per
        pulse): the upper bound of :func:`own_eta_jobs`, known before any η is measured."""
        if not self.own_eta:
            return 0
        return sum(1 for _, variant, _, _ in self.tasks if "restitution" not in variant)

    def _start_helpers(self, workers: int) -> None:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        from ..maps.executors import worker_init
        from ..report.plots.picture import can_fork_helper

        suite = self.suite
        try:
            # a fork shares what this process has imported (the engines: seconds of start-up per
            # helper); it is safe only from a single thread, else a fresh interpreter is spawned
            ctx = multiprocessing.get_context("fork" if can_fork_helper() else "spawn")
            init = worker_init("", {})   # this process's extra engines and sys.path, as map workers get them
            self.pool = ProcessPoolExecutor(max_workers=min(workers, len(self.todo)), mp_context=ctx,
                                            initializer=_helper_init, initargs=(init["registry"], init["sys_path"]))
            for k in self.todo:
                engine, variant, block, measure = self.tasks[k]
                self.futs[k] = self.pool.submit(_prepare_one, engine, variant, block, variant_restitution(suite, variant),
                                                suite.engine_dt_s, measure)
        except (OSError, RuntimeError, ValueError):
            self._stop()

    def _stop(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
            self.pool = None

    def finish(self) -> tuple[list[dict], list[str], float]:
        from concurrent.futures.process import BrokenProcessPool

        from ..store.files import write_json

        suite = self.suite
        try:
            for k, f in self.futs.items():
                try:
                    self.results[k] = f.result()
                except BrokenProcessPool:
                    break
        finally:
            self._stop()
        for k in self.todo:   # here: one worker, or what the helpers could not do
            if k not in self.results:
                engine, variant, block, measure = self.tasks[k]
                self.results[k] = _prepare_one(engine, variant, block, variant_restitution(suite, variant), suite.engine_dt_s,
                                               measure)
        rows, notes = [], []
        if self.own_eta:
            for k, (engine, variant, block, measure) in enumerate(self.tasks):
                vname = variant_name(engine, variant_settings(variant), suite.engine_dt_s)
                if "restitution" in variant:
                    continue      # no own-η map for a variant with its own restitution (see above)
                if not measure:
                    rows.append(self.old[(vname, block)])
                    continue
                r = self.results[k]
                if r["measurement"] is not None:
                    rows.append({"variant": vname, "engine": engine, "settings": dict(variant), "block": block,
                                 **r["measurement"]})
                else:
                    notes.append(f"η of {vname} on {block} not measured: {r['error']}")
            self.out.mkdir(parents=True, exist_ok=True)
            write_json(self.path, {"kind": "rockbench-calibration", "measurements": rows})
        return rows, notes, time.perf_counter() - self.t0


def _helper_init(registry: dict, sys_path: list) -> None:
    import os
    from ...engines.registry import register
    for p in sys_path:
        if p not in sys.path and os.path.isdir(p):
            sys.path.append(p)
    for name, target in registry.items():
        register(name, target)


def _calibrates(engine: str) -> bool:
    """Whether the engine's adapter has a calibration of its own to compute (and cache)."""
    from ...engines.base import EngineAdapter
    from ...engines.registry import adapter_class
    try:
        return adapter_class(engine).calibrate is not EngineAdapter.calibrate
    except Exception:  # noqa: BLE001 - an adapter that cannot load has nothing to prepare here
        return False


def _cost_rank(engine: str) -> tuple:
    """How costly an engine's cells are, roughly, for ordering work (smaller: costlier, first): a
    finer default time step costs more, and an engine with a native batch (MuJoCo's rollouts) less
    per cell than one stepped from Python at the same step. Lanes then end on the cheapest maps,
    when one core may have to wait for the other."""
    from ...engines.registry import adapter_class
    try:
        cls = adapter_class(engine)
    except Exception:  # noqa: BLE001 - an engine that cannot even load its adapter class goes last
        return (math.inf, 1)
    return (float(getattr(cls, "default_dt_s", 1.0)), 1 if cls.batching != "none" else 0)


def _score_and_report(suite: Suite, out: Path, result: dict, experiments, report: bool, figure_formats, log,
                      unfinished: set) -> None:
    """The run's scores (``result["score"]``), its report (or score.json alone) and the console's verdict
    and summary table (``result["summary"]``); the ``unfinished`` maps (of an engine that cannot
    simulate) are scored as incomplete instead of refused."""
    if report:
        from ..report.html import build_report, parse_case
        cases = tuple(parse_case(c) for c in suite.report_cases)
        rep = build_report([out / "maps"], out, experiments=experiments, cases=cases, log=log,
                           figure_formats=figure_formats, allow_incomplete=unfinished)
        result["score"] = rep["doc"]
        result["notes"] = list(dict.fromkeys(result["notes"] + rep["notes"]))   # each note once
        result["report"] = {k: rep[k] for k in ("html", "markdown") if k in rep}
    else:
        from ...reference_solver.errors import IncomparableError
        from ..store.files import write_json
        from ..scoring.score_runs import score_dirs
        try:
            result["score"] = score_dirs([out / "maps"], experiments=experiments, allow_incomplete=unfinished)
            write_json(out / "score.json", result["score"])
        except IncomparableError as e:  # e.g. no engine installed: the maps are still worth having
            result["notes"].append(f"No scores: {e}")
    if result["score"] is not None:
        from ..scoring.tables import SUMMARY_TITLE, summary_table, verdict_block
        result["summary"] = "\n".join([verdict_block(result["score"]), SUMMARY_TITLE, summary_table(result["score"])])


def _warm_report() -> None:
    """Import what the report draws with and load the reference solver's history kernel (numba's
    cache), so that the report, which needs every map, starts at once when the last one is done."""
    try:
        from matplotlib import figure  # noqa: F401
        from matplotlib.backends import backend_agg  # noqa: F401

        from ...reference_solver.pulses import make_pulse
        from ...reference_solver.solver import solve
        from ..report import html as report  # noqa: F401
        from ..blocks.presets import get_preset
        solve(get_preset("B3M").block(), make_pulse("sine", 30.0, 60.0), 0.8, history=True)
    except Exception:  # noqa: BLE001 - only a head start; the report imports what it needs itself
        pass


def _variant_key(job: MapJob):
    return None if job.engine == "reference" else (job.engine, json.dumps(dict(job.settings), sort_keys=True))


class _ReferenceThread:
    """The suite's reference maps, computed one after another by one thread while the calibrations
    and the engine maps run (:func:`run_suite`): ``add`` hands it maps, ``close`` says no more will
    come, ``abort`` lets it start no more, ``join`` waits for the last and raises what stopped it."""

    def __init__(self, announce, one_map):
        import queue
        import threading

        self.q = queue.Queue()
        self.error: list = []
        self.closed = False
        self.aborted = False

        def work():
            while True:
                k = self.q.get()
                if k is None or self.error or self.aborted:
                    return
                try:
                    announce(k)
                    one_map(k, None)
                except BaseException as e:  # noqa: BLE001 - raised by join() in the main thread
                    self.error.append(e)
                    return

        self.thread = threading.Thread(target=work, name="rockbench-reference", daemon=True)
        self.thread.start()

    def add(self, ks) -> None:
        for k in ks:
            self.q.put(k)

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.q.put(None)

    def abort(self) -> None:
        self.aborted = True
        self.close()

    def failed(self) -> bool:
        return bool(self.error)

    def join(self) -> None:
        while self.thread.is_alive():
            self.thread.join(0.2)
        if self.error:
            raise self.error[0]


def _run_lanes(order: list[int], todo: list[MapJob], out: Path, lanes: int, announce, one_map, stop=None) -> None:
    """Run the engine maps ``todo[k]`` for ``k`` in ``order`` on ``lanes`` lanes at once.

    Each lane is a thread that takes the next map from the shared queue and runs it with its own
    worker process for that engine variant (kept for the variant's maps it runs; the workers' stderr
    goes to one workers.log beside the variant's maps). One worker per map and several maps at a
    time keep every core busy: within a map, adaptive refinement waits at the end of each round for
    its last cells, and one worker never waits for another. A lane stops its worker as soon as the
    queue holds no more maps of that variant. When the queue is empty, a lane that finishes lends its
    core to a lane still running a map (that map's executor starts a second worker), so the last
    maps do not run on one core while the other waits. On an interrupt every lane's workers are
    stopped and nothing more is recorded; finished cells stay, and a rerun resumes.
    """
    import threading
    from collections import deque

    from ..maps import executors as ex_mod

    queue = deque(order)
    lock = threading.Lock()
    live: list = []
    running: dict = {}   # lane → the executor running its map now
    errors: list = []
    cores = ex_mod.cpu_count()

    def lend(n: int) -> None:
        """Nothing left to start: this lane's core goes to the lane running with the fewest workers
        (its executor starts one more worker for the rest of that map's rounds)."""
        others = [e for m, e in running.items() if m != n and isinstance(e, ex_mod.ProcessExecutor)]
        if others:
            e = min(others, key=lambda e: e.jobs)
            e.jobs += 1

    def lane(n: int) -> None:
        key, ex = None, None
        try:
            while True:
                with lock:
                    if stop is not None and stop():
                        return
                    if errors or not queue:
                        if not errors:
                            lend(n)
                        return
                    k = queue.popleft()
                job = todo[k]
                announce(k)
                if _variant_key(job) != key:
                    if ex is not None:
                        ex.close()
                    key = _variant_key(job)
                    d = out / job.subdir
                    d.parent.mkdir(parents=True, exist_ok=True)
                    ex = ex_mod.make_executor(job.engine, dict(job.settings), jobs=1, log_path=d.parent / "workers.log",
                                              threads_per_worker=max(1, cores // lanes))
                    with lock:
                        live.append(ex)
                with lock:
                    running[n] = ex
                try:
                    one_map(k, ex)
                finally:
                    with lock:
                        running.pop(n, None)
                with lock:
                    more = any(_variant_key(todo[q]) == key for q in queue)
                if not more:
                    # a variant's worker stops after its last map, so idle engines do not hold their memory
                    ex.close()
                    key, ex = None, None
        except ex_mod.Cancelled:
            pass
        except BaseException as e:  # noqa: BLE001 - handed to the main thread, which raises it
            with lock:
                errors.append(e)
            for other in list(live):
                if other is not ex and hasattr(other, "cancel"):
                    other.cancel()
        finally:
            if ex is not None:
                ex.close()

    if lanes <= 1:
        lane(0)
    else:
        threads = [threading.Thread(target=lane, args=(n,), name=f"rockbench-lane-{n}", daemon=True)
                   for n in range(lanes)]
        for t in threads:
            t.start()
        try:
            while any(t.is_alive() for t in threads):
                for t in threads:
                    t.join(0.2)
        except BaseException:
            # Ctrl-C (delivered to this thread only): stop every lane's workers, record nothing more
            with lock:
                queue.clear()
                for e in list(live):
                    if hasattr(e, "cancel"):
                        e.cancel()
            for t in threads:
                t.join(10.0)
            raise
    if errors:
        raise errors[0]


def _started(k: int) -> None:
    """A map starts: nothing is printed (a map is reported when it finishes, by
    :meth:`SuiteConsole.finished`, so that the lines come in order)."""


def run_suite(suite: Suite, out_dir, *, jobs: int | None = None, experiments=None, report: bool = True,
              log=None, engines: list[str] | None = None, figure_formats=("png",)) -> dict:
    """Compute what is missing, score, and write the report (see the module docstring).

    ``engines`` (``run --engines``) restricts the engine maps to those engines; ``figure_formats``
    are the formats of the report's pictures (png, svg, pdf).

    Returns
    -------
    dict
        ``maps`` (per map: dir and wall time), ``wall_s``, ``score`` (the score document or None),
        ``notes``, ``report`` (paths) and ``summary`` (the summary table as text).
    """
    from ..maps.executors import cpu_count
    from ..maps.grid import MapSpec, parse_range
    from ..store.files import write_json

    from ..store.atomic import check_output_dir
    from ..maps.executors import cap_jobs

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
    workers = max(1, jobs or cpu_count())

    def specs_of(jobs_):
        return [MapSpec(get_preset(j.block).block(), j.pulse, j.restitution, x, y, engine=j.engine,
                        engine_settings=dict(j.settings), dt_s=j.dt_s) for j in jobs_]

    # every spec is built (and so checked) before the first map runs (the own-η reference maps, which
    # wait for the measured η, differ from the others only in a constant restitution)
    specs = specs_of(todo)
    t0 = time.perf_counter()
    records: dict = {}
    # calibrations (and the engines' own η) once, on every core, before the engine maps need them;
    # the helpers start now and work while this process computes the reference maps
    prep = _Preparation(suite, engines, out, log, workers=workers) if engines else None
    # [k/N]: N planned now, own-η reference maps included; k counts maps as they finish
    own_planned = prep.own_eta_slots() * len(suite.pulses) if prep is not None else 0
    console = SuiteConsole(len(todo) + own_planned, log)
    say_device_notes(engines, console)

    def one_map(k: int, ex) -> None:
        from ..maps.sweep import run_map
        job, spec = todo[k], specs[k]
        d = out / job.subdir
        t1 = time.perf_counter()
        # reference maps are computed in full: they cost milliseconds, and scoring needs the
        # rigid model's domain (lift-/slip-required) in every cell, not just where refinement looked;
        # an engine that cannot simulate is stopped after its first map (EngineHealth.guard)
        res = health.guard(job.engine, lambda: run_map(
            spec, d, jobs=jobs, serial=job.engine == "reference", adaptive=suite.adaptive and job.engine != "reference",
            coarse_stride=suite.coarse_stride, cell_timeout_s=suite.cell_timeout_s, plot=False, log=log, executor=ex))
        if res is None:   # the engine cannot simulate: its map is skipped, and counted off
            console.not_needed(1, f"{spec.label()} skipped: {job.engine} cannot simulate (see the end of the run)")
            unfinished.add(d)
            return
        records[k] = {"dir": str(d), "label": spec.label(), "wall_s": time.perf_counter() - t1,
                      "n_simulated": res.n_simulated, "n_cells": spec.n_cells, "n_failed": len(res.failures)}
        console.finished(spec.label(), d, records[k]["wall_s"])

    # The reference runs in this process: its compiled batch kernel is parallel already, and worker
    # processes would each load it again; engines keep the workers' time limit and crash isolation.
    # Its maps are computed by one thread (one caller of the parallel kernel at a time) beside the
    # calibrations and then the engine maps, which need none of them: on a fresh install the
    # kernel's first compile (about 12 s of one core) no longer holds the engine maps back.
    health = EngineHealth()
    unfinished: set = set()   # map folders of engines that cannot simulate: scored as incomplete, not refused
    refs = _ReferenceThread(_started, one_map)
    refs.add(k for k, job in enumerate(todo) if job.engine == "reference")
    try:
        if prep is not None:
            etas, more, _ = prep.finish()
            notes += more
            if suite.own_eta:
                extra = own_eta_jobs(suite, etas)
                console.not_needed(own_planned - len(extra), "variants with the same measured η on a block share "
                                   "one reference map, and a failed η measurement has none")
                first = len(todo)
                specs += specs_of(extra)
                todo += extra
                refs.add(range(first, len(todo)))
        refs.close()
        if report:
            # the report's start-up (matplotlib, the reference's history kernel) costs a few seconds of one
            # core at the end; a thread pays it while the workers compute the engine maps
            import threading
            threading.Thread(target=_warm_report, name="rockbench-warm-report", daemon=True).start()
        engine_maps = [k for k, job in enumerate(todo) if job.engine != "reference"]
        # the costliest engines first, so that the last maps, when one core may wait for the other, are short
        engine_maps.sort(key=lambda k: _cost_rank(todo[k].engine))
        _run_lanes(engine_maps, todo, out, min(workers, max(1, len(engine_maps))), _started, one_map,
                   stop=refs.failed)
    except BaseException:
        refs.abort()   # e.g. Ctrl-C: no reference map is started after the one running now
        raise
    refs.join()
    done = [records[k] for k in sorted(records)]
    maps_wall = time.perf_counter() - t0
    result = {"suite": suite.name, "maps": done, "maps_wall_s": maps_wall, "notes": list(dict.fromkeys(notes)),
              "score": None, "report": None, "summary": "", "cannot_simulate": health.broken_lines(),
              "failed_cells": health.failure_lines()}
    if experiments is None and suite.experiments:
        from ..blocks.experiments import load_outcomes
        experiments = load_outcomes(suite.experiments)
    t2 = time.perf_counter()
    _score_and_report(suite, out, result, experiments, report, figure_formats, log, unfinished)
    result["report_wall_s"] = time.perf_counter() - t2
    result["wall_s"] = time.perf_counter() - t0
    write_json(out / "suite.json", {"suite": suite.raw, "path": suite.path, "jobs": jobs,
                                           **{k: v for k, v in result.items() if k not in ("suite", "score", "summary")},
                                           "suite_name": suite.name})
    return result
