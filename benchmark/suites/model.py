"""A suite file (``benchmark/suites/*.toml``) read into a checked :class:`Suite`: a typed model per table.

The tables and their keys are pydantic models (:class:`SuiteFile`, one class per table, unknown keys
refused); each key's rule is one function (:func:`_grid_axis`, :func:`_names`, :func:`_flag`, ...)
that says what was wrong, what was given and what to do. What depends on several keys (a
restitution for every block, a time step for every block's highest frequency, the experiments file
beside the suite) is checked once the tables are read (:meth:`SuiteFile._across_tables`).
:func:`load_suite` turns the first problem into one :class:`ConfigError` line naming the suite file
and the key, as ``rockbench run`` prints it (exit 2).
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, get_args

from pydantic import BaseModel, BeforeValidator, ConfigDict, ValidationError, ValidationInfo, model_validator
from pydantic_core import PydanticCustomError

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.pulses import is_number
from rockbench.reference_solver.restitution import Restitution
from rockbench.benchmark.blocks.cases import parse_case
from rockbench.benchmark.blocks.experiments import load_outcomes
from rockbench.benchmark.blocks.presets import NOT_IN_TABLE_1, PRESETS, TABLE_1, get_preset, no_exact_k_note
from rockbench.benchmark.maps.bisection import DEFAULT_DEPTH, MAX_DEPTH
from rockbench.benchmark.maps.grid import MapSpec, parse_range
from rockbench.benchmark.scoring.declared import DEFAULTS, KEY_RULES, Declared
from rockbench.benchmark.scoring.speed import MATCHED_DISTANCE, SPEED_STEPS_S

#: the shipped suites, by name
SHIPPED_SUITES = ("default", "quick", "full", "newton", "speed")

#: the pulses a suite may name
PULSES = ("sine", "cosine", "half-sine")


@dataclass(frozen=True)
class Suite:
    """A parsed suite file (see :mod:`rockbench.benchmark.suites.runner` for its tables): its name (the
    ``[suite]`` name, else the file's), description and path, the file as read (``raw``, which
    suite.json records), and one attribute per table holding that table's checked keys
    (``suite.grid.w_ratio``, ``suite.engines.variants``, ...). A new key is one field of its table's
    model below, and nothing else here."""

    name: str
    description: str
    path: str
    raw: dict
    grid: GridTable
    cases: CasesTable
    reference: ReferenceTable
    engines: EnginesTable
    run: RunTable
    report: ReportTable
    verdict: Declared
    power: PowerTable
    speed: SpeedTable | None = None


# -- one rule per kind of key ------------------------------------------------------------------------

def _bad(tail: str):
    """A key's value is wrong: ``tail`` follows the key's dotted name in the message (``" must be ..."``,
    ``": unknown block ..."``). Raised as pydantic's own error type (not a ValueError, whose text
    pydantic rewrites), so that the line reads the same on every pydantic 2 release."""
    return PydanticCustomError("suite_key", "{tail}", {"tail": tail})


def _whole(message: str, kind: str = "suite_whole"):
    """A message that names its key itself (``suite_whole``) or also the suite file (``suite_line``)."""
    return PydanticCustomError(kind, "{tail}", {"tail": message})


def _is_text_or_number(v) -> bool:
    return isinstance(v, (str, int, float)) and not isinstance(v, bool)


def _text(v):
    if not isinstance(v, str):
        raise _bad(f" must be a text, got {v!r}.")
    return v


def _flag(v):
    if not isinstance(v, bool):
        raise _bad(f" must be true or false, got {v!r}.")
    return v


def _seconds(v):
    """A time step: None (the engine's default) or a finite number of seconds > 0."""
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not (v > 0 and math.isfinite(v)):
        raise _bad(f" must be a number of seconds > 0, got {v!r}.")
    return float(v)


def _timeout(v):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not (0 < v < math.inf):
        raise _bad(f" must be a number of seconds > 0, got {v!r}.")
    return float(v)


def _stride(v):
    if v is not None and (isinstance(v, bool) or not isinstance(v, int) or v < 1):
        raise _bad(f" must be a whole number >= 1, got {v!r}.")
    return v


def _locate_depth(v):
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= MAX_DEPTH:
        raise _bad(f" must be a whole number from 0 to {MAX_DEPTH} (rounds of bisection of each boundary edge), "
                   f"got {v!r}.")
    return v


def _locate_depth_or_none(v):
    """``speed.locate_depth``: None (the grid's) or a depth (:func:`_locate_depth`)."""
    return None if v is None else _locate_depth(v)


def _restitution_token(v):
    if not _is_text_or_number(v):
        raise _bad(f" must be a text or a number, got {v!r}.")
    return str(v)


def _list(default, *, empty: bool = False):
    """A list of texts or numbers, as texts; ``empty``: whether ``[]`` is allowed (else the
    message names the default, which leaving the key out gives)."""
    def check(v):
        if not isinstance(v, list) or not all(_is_text_or_number(x) for x in v):
            raise _bad(f" must be a list, got {v!r}.")
        if not v and not empty:
            raise _bad(f" is empty; list at least one, or leave the key out for the default {default!r}.")
        return [str(x) for x in v]
    return BeforeValidator(check)


def _grid_axis(option: str, name: str):
    def check(v):
        if not isinstance(v, str):
            raise _bad(f" must be a string LO:HI:N, got {v!r}.")
        try:
            parse_range(option, v, name)
        except ConfigError as e:
            raise _whole(str(e)) from None
        return v
    return BeforeValidator(check)


def _blocks(v):
    try:
        return [get_preset(b).name for b in v]
    except ConfigError as e:
        raise _bad(f": {e}") from None


def _pulses(v):
    v = [p.lower() for p in v]
    for p in v:
        if p not in PULSES:
            raise _bad(f" has {p!r}; use sine, cosine or half-sine.")
    return v


def _names(v):
    if not (v == "available" or (isinstance(v, list) and all(isinstance(n, str) for n in v))):
        raise _bad(f" must be \"available\" or a list of names, got {v!r}.")
    return v


def _variants(v):
    if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
        raise _bad(" must be a list of tables of settings.")
    for k, variant in enumerate(v):
        if "engines" in variant and not (isinstance(variant["engines"], list) and variant["engines"]
                                         and all(isinstance(n, str) for n in variant["engines"])):
            raise _bad(f"[{k}].engines must be a non-empty list of engine names, got {variant['engines']!r}.")
        if "restitution" in variant and not _is_text_or_number(variant["restitution"]):
            raise _bad(f"[{k}].restitution must be a text or a number, got {variant['restitution']!r}.")
        if "blocks" in variant:
            if not (isinstance(variant["blocks"], list) and variant["blocks"]
                    and all(isinstance(n, str) for n in variant["blocks"])):
                raise _bad(f"[{k}].blocks must be a non-empty list of block names, got {variant['blocks']!r}.")
            try:
                variant["blocks"] = [get_preset(b).name for b in variant["blocks"]]
            except ConfigError as e:
                raise _bad(f"[{k}].blocks: {e}") from None
    return v


def _reductions(v):
    """``power.eta_reductions``: distinct numbers δ in [0, 1), the planted η being η·(1 − δ)."""
    if not isinstance(v, list) or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
        raise _bad(f" must be a list of numbers δ in [0, 1) (the planted η is η·(1 − δ)), got {v!r}.")
    for x in v:
        if not (math.isfinite(x) and 0.0 <= x < 1.0):
            raise _bad(f" must hold numbers δ in [0, 1) (the planted η is η·(1 − δ)), got {x!r}; "
                       "e.g. [0.0, 0.005, 0.01, 0.02].")
    twice = [x for k, x in enumerate(v) if x in v[:k]]
    if twice:
        raise _bad(f" lists δ = {twice[0]!r} twice; list each reduction once.")
    return [float(x) for x in v]


def _steps(v):
    """``speed.steps_s``: at least two distinct time steps [s], each a number > 0."""
    if not isinstance(v, list) or len(v) < 2:
        raise _bad(f" must list at least two time steps in seconds (a curve), e.g. [0.001, 0.0005, 0.0002, 0.0001]; "
                   f"got {v!r}.")
    out = [_seconds(x) for x in v]
    if None in out:
        raise _bad(f" must hold numbers of seconds > 0, got {v!r}.")
    twice = [x for k, x in enumerate(out) if x in out[:k]]
    if twice:
        raise _bad(f" lists {twice[0]!r} s twice; list each step once.")
    return sorted(out, reverse=True)


def _or_none(rule, default: str):
    """A list key whose default is worked out from other tables (None until then): a non-empty list of
    texts, checked by ``rule``."""
    def check(v):
        if v is None:
            return None
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            raise _bad(f" must be a list of names, got {v!r}.")
        if not v:
            raise _bad(f" is empty; list at least one, or leave the key out for {default}.")
        return rule(v)
    return check


def _distance(v):
    """``speed.matched_distance``: a boundary distance > 0 in the normalised plane."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
        raise _bad(f" must be a number > 0 in the normalised plane (ω/p, a0/(g·tanα)), got {v!r}.")
    return float(v)


def _report_case(v):
    for c in v:
        try:
            parse_case(c, "report.cases")
        except ConfigError as e:
            raise _whole(str(e)) from None
    return v


def _experiments(v, info: ValidationInfo):
    if v is None:
        return None
    if not isinstance(v, str):
        raise _bad(f" must be a path, got {v!r}.")

    path = str((info.context["folder"] / v).resolve())   # relative to the suite file
    try:
        load_outcomes(path)
    except ConfigError as e:
        raise _bad(f": {e}") from None
    return path


def restitution_for(token: str, block: str, where: str = "suite") -> Restitution:
    """A suite's restitution token (``housner``, ``modified-average``, ``modified-exact``,
    ``modified:K`` or a number) for a preset block: :meth:`Restitution.parse` with the preset's k.
    ``modified-exact`` for a block without a measured k (:meth:`Preset.has_restitution`) is refused
    here; the reference maps skip it instead (:func:`reference_tokens`)."""
    pre = PRESETS[block]
    if not pre.has_restitution(token):
        raise ConfigError(f"{where}: restitution {token!r} is not defined for block {block}, which is {NOT_IN_TABLE_1} "
                          f"and has no measured k; map it with another restitution, or keep the variant to Table 1's "
                          f"blocks ({', '.join(TABLE_1)}) with its blocks key.")
    try:
        return Restitution.parse(token, k_average=pre.k_average, k_exact=pre.k_exact)
    except ConfigError as e:
        t = str(token).strip().lower()
        if t.startswith("modified") or is_number(t):    # a known spelling with a value out of range
            raise ConfigError(f"{where}: restitution {token!r}: {e}") from None
        raise ConfigError(f"{where}: restitution {token!r} is not one of housner, modified-average, modified-exact, "
                          "modified:K or a number in (0, 1].") from None


def _declared(key: str):
    """A ``[verdict]`` key, checked by its one rule (:data:`~rockbench.benchmark.scoring.declared.KEY_RULES`)."""
    def check(v):
        try:
            return KEY_RULES[key](v)
        except ConfigError as e:
            raise _bad(str(e)) from None
    return BeforeValidator(check)
def reference_tokens(suite_or_tokens, block: str) -> list[str]:
    """The reference restitutions (``reference.restitutions``, or a list of tokens) a block's reference
    maps are computed with: all but ``modified-exact`` on a block without a measured k."""
    tokens = suite_or_tokens if isinstance(suite_or_tokens, list) else suite_or_tokens.reference.restitutions
    return [t for t in tokens if PRESETS[block].has_restitution(t)]


def skipped_reference_note(suite: "Suite") -> str | None:
    """The note a run and its plan give when a reference restitution is skipped on some blocks (the
    exact k's η_M on a block without a measured k); None when none is."""
    return no_exact_k_note(b for b in suite.cases.blocks if reference_tokens(suite, b) != suite.reference.restitutions)


# -- the tables ---------------------------------------------------------------------------------------

Text = Annotated[str, BeforeValidator(_text)]
Flag = Annotated[bool, BeforeValidator(_flag)]
Seconds = Annotated[float | None, BeforeValidator(_seconds)]


class _Table(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_default=True)


class SuiteTable(_Table):
    name: Text | None = None          # default: the file's name
    description: Text = ""


class GridTable(_Table):
    w_ratio: Annotated[str, _grid_axis("grid.w_ratio", "w_ratio")] = None
    a_ratio: Annotated[str, _grid_axis("grid.a_ratio", "a_ratio")] = None
    adaptive: Flag = False
    coarse_stride: Annotated[int | None, BeforeValidator(_stride)] = None
    locate_depth: Annotated[int, BeforeValidator(_locate_depth)] = DEFAULT_DEPTH


class CasesTable(_Table):
    blocks: Annotated[list[str], BeforeValidator(_blocks), _list(list(TABLE_1))] = list(TABLE_1)
    pulses: Annotated[list[str], BeforeValidator(_pulses), _list(["sine", "cosine"])] = ["sine", "cosine"]


class ReferenceTable(_Table):
    restitutions: Annotated[list[str], _list(["housner"])] = ["housner"]
    dt_s: Seconds = None


class EnginesTable(_Table):
    names: Annotated[Any, BeforeValidator(_names)] = "available"
    exclude: Annotated[list[str], _list([], empty=True)] = []
    include: Annotated[list[str], _list([], empty=True)] = []
    variants: Annotated[list[dict], BeforeValidator(_variants)] = [{}]
    restitution: Annotated[str, BeforeValidator(_restitution_token)] = "housner"
    dt_s: Seconds = None
    own_eta: Flag = False


class RunTable(_Table):
    cell_timeout_s: Annotated[float, BeforeValidator(_timeout)] = 120.0


class ReportTable(_Table):
    cases: Annotated[list[str], BeforeValidator(_report_case), _list(["B3M:sine:6:6.1"], empty=True)] = \
        ["B3M:sine:6:6.1"]
    experiments: Annotated[str | None, BeforeValidator(_experiments)] = None


class VerdictTable(_Table):
    """What the verdict is judged by, declared before it is computed (docs/scores.md, "What a suite
    declares"); a key left out takes the default suite's value."""

    fail_distance: Annotated[str | float, _declared("fail_distance")] = DEFAULTS.fail_distance
    equivalence_margin: Annotated[str | float, _declared("equivalence_margin")] = DEFAULTS.equivalence_margin
    held_out_margin: Annotated[str | float, _declared("held_out_margin")] = DEFAULTS.held_out_margin
    general_range_h_over_b: Annotated[tuple, _declared("general_range_h_over_b")] = \
        list(DEFAULTS.general_range_h_over_b)
class SpeedTable(_Table):
    """The accuracy–cost stage (docs/speed.md): every engine of the suite calibrated at each step, on the
    stage's problems, scored like any map and timed; kept out of the verdict. A key left out: the time-step
    rule's ladder, one block per slenderness of ``cases.blocks`` (the first of each), ``cases.pulses``'
    first pulse, the declared distance of the default (its argument in docs/speed.md), and the grid's
    ``locate_depth`` (the rounds of bisection of the stage's boundaries)."""

    steps_s: Annotated[list[float], BeforeValidator(_steps)] = list(SPEED_STEPS_S)
    blocks: Annotated[list[str] | None, BeforeValidator(_or_none(_blocks, "one block per slenderness of cases.blocks"))] \
        = None
    pulses: Annotated[list[str] | None, BeforeValidator(_or_none(_pulses, "the first of cases.pulses"))] = None
    matched_distance: Annotated[float, BeforeValidator(_distance)] = MATCHED_DISTANCE
    locate_depth: Annotated[int | None, BeforeValidator(_locate_depth_or_none)] = None


class PowerTable(_Table):
    """The suite's yardstick: the reference solver mapped as an engine with η·(1 − δ), one variant per δ."""

    eta_reductions: Annotated[list[float], BeforeValidator(_reductions)] = []


class SuiteFile(_Table):
    """The whole file; tables in the order their keys are checked (an absent table takes its defaults)."""

    grid: GridTable = {}
    cases: CasesTable = {}
    reference: ReferenceTable = {}
    engines: EnginesTable = {}
    run: RunTable = {}
    suite: SuiteTable = {}
    report: ReportTable = {}
    verdict: VerdictTable = {}
    power: PowerTable = {}
    speed: SpeedTable | None = None

    @model_validator(mode="after")
    def _across_tables(self, info: ValidationInfo):
        try:
            self._check_tokens(info.context["name"])
            self._check_specs(info.context["name"])
            self._check_speed(info.context["name"])
        except ConfigError as e:
            raise _whole(str(e), "suite_line") from None
        return self

    def _check_tokens(self, name: str) -> None:
        """Every restitution token for every block, and engines.exclude/include only with every engine."""
        blocks = self.cases.blocks
        for b in blocks:
            for r in reference_tokens(self.reference.restitutions, b):   # every token for every block that has it
                restitution_for(r, b, f"suite {name}: reference.restitutions")
        for key in ("exclude", "include"):
            if getattr(self.engines, key) and self.engines.names != "available":
                raise ConfigError(f"suite {name}: engines.{key} goes with names = \"available\"; with a list of "
                                  f"names, {'leave the engine out of' if key == 'exclude' else 'put the engine in'} "
                                  f"the list instead.")
        both = sorted(set(self.engines.exclude) & set(self.engines.include))
        if both:
            raise ConfigError(f"suite {name}: engine {both[0]!r} is in both engines.exclude and engines.include; "
                              f"keep it in one.")
        for k, v in enumerate(self.engines.variants):
            extra = [b for b in v.get("blocks", ()) if b not in blocks]
            if extra:
                raise ConfigError(f"suite {name}: engines.variants[{k}].blocks names {extra[0]}, which is not in "
                                  f"cases.blocks ({', '.join(blocks)}); a variant maps some of the suite's blocks.")
        for b in blocks:   # the spelling, on every block it is defined for
            for token in reference_tokens([self.engines.restitution], b):
                restitution_for(token, b, f"suite {name}: engines.restitution")
        if self.power.eta_reductions:   # the planted variants' target, on every block
            for b in blocks:
                restitution_for(self.engines.restitution, b, f"suite {name}: engines.restitution (the target of "
                                f"[power]'s planted variants)")
        for k, v in enumerate(self.engines.variants):   # each variant's target on each block it maps
            where = f"engines.variants[{k}].restitution" if "restitution" in v else "engines.restitution"
            for b in (b for b in blocks if "blocks" not in v or b in v["blocks"]):
                restitution_for(str(v.get("restitution", self.engines.restitution)), b, f"suite {name}: {where}")

    def _check_specs(self, name: str) -> None:
        """Every map's spec, built once here, checks the grid's size and each time step against the
        highest frequency of each block."""
        x = parse_range("grid.w_ratio", self.grid.w_ratio, "w_ratio")
        y = parse_range("grid.a_ratio", self.grid.a_ratio, "a_ratio")
        for block in self.cases.blocks:
            for pulse in self.cases.pulses:
                for dt, table in ((self.reference.dt_s, "reference"), (self.engines.dt_s, "engines")):
                    try:
                        MapSpec(get_preset(block).block(), pulse, Restitution(), x, y, dt_s=dt)
                    except ConfigError as e:
                        keys = "grid" + (f" and {table}.dt_s" if dt is not None else "")
                        raise ConfigError(f"suite {name}: {keys} ({block} {pulse}): {e}") from None


    def _check_speed(self, name: str) -> None:
        """The speed stage's problems among the suite's (their reference maps are the suite's), the engines'
        target among the reference restitutions, and each step against each problem's highest frequency;
        no engine variant only with a speed stage (a suite of that stage alone)."""
        sp = self.speed
        if sp is None:
            if not self.engines.variants:
                raise ConfigError(f"suite {name}: engines.variants is empty; list at least one variant, or add a "
                                  f"[speed] table (a suite that runs the speed stage alone).")
            return
        sp.blocks = sp.blocks or first_per_slenderness(self.cases.blocks)
        sp.pulses = sp.pulses or self.cases.pulses[:1]
        for key, have, given in (("blocks", self.cases.blocks, sp.blocks), ("pulses", self.cases.pulses, sp.pulses)):
            extra = [x for x in given if x not in have]
            if extra:
                raise ConfigError(f"suite {name}: speed.{key} names {extra[0]}, which is not in cases.{key} "
                                  f"({', '.join(have)}); the speed stage is scored against the suite's reference maps.")
        x = parse_range("grid.w_ratio", self.grid.w_ratio, "w_ratio")
        y = parse_range("grid.a_ratio", self.grid.a_ratio, "a_ratio")
        for block in sp.blocks:
            target = restitution_for(self.engines.restitution, block, f"suite {name}: engines.restitution")
            refs = [restitution_for(t, block).label for t in reference_tokens(self.reference.restitutions, block)]
            if target.label not in refs:
                raise ConfigError(f"suite {name}: the speed stage calibrates to engines.restitution "
                                  f"{self.engines.restitution!r}, which reference.restitutions lacks; add it there.")
            for pulse in sp.pulses:
                for dt in sp.steps_s:
                    try:
                        MapSpec(get_preset(block).block(), pulse, target, x, y, dt_s=dt)
                    except ConfigError as e:
                        raise ConfigError(f"suite {name}: speed.steps_s {dt:g} s on the grid ({block} {pulse}): {e}") \
                            from None


def grid_cells(suite: "Suite") -> int:
    """The cells of one map of the suite's grid."""
    return parse_range("grid.w_ratio", suite.grid.w_ratio, "w_ratio").n * parse_range("grid.a_ratio", suite.grid.a_ratio,
                                                                                         "a_ratio").n


def first_per_slenderness(blocks: list[str]) -> list[str]:
    """The first block of each slenderness h/b among ``blocks`` (presets), in their order: the speed stage's
    default problems (two sizes of one slenderness pose one problem)."""
    seen, out = set(), []
    for b in blocks:
        pre = get_preset(b)
        key = round(pre.height_m / pre.width_m, 4)
        if key not in seen:
            seen.add(key)
            out.append(pre.name)
    return out


TABLES = ("suite", "grid", "cases", "reference", "engines", "power", "speed", "run", "report", "verdict")


# -- reading a file ------------------------------------------------------------------------------------

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
        shipped = resources.files("rockbench.benchmark.suites").joinpath(f"{text}.toml")
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


def _read_toml(p: Path) -> dict:
    try:
        return tomllib.loads(p.read_bytes().decode("utf-8-sig"))
    except OSError as e:
        raise ConfigError(f"cannot read suite {str(p)!r}: {e.strerror or e}.") from None
    except UnicodeDecodeError as e:
        raise ConfigError(f"suite {str(p)!r} is not UTF-8 text (byte {e.start}); give a TOML suite file.") from None
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"suite {str(p)!r} is not valid TOML: {e}.") from None


def _unknown(raw: dict, name: str) -> str | None:
    """The line for the first unknown table or key (tables in the file's order, keys alphabetically)."""
    for table, val in raw.items():
        if table not in TABLES or not isinstance(val, dict):
            return f"suite {name}: unknown table [{table}]; tables: {', '.join(TABLES)}."
        ann = SuiteFile.model_fields[table].annotation   # a table's model, or it | None (an optional table)
        known = next((t for t in (ann, *get_args(ann)) if isinstance(t, type) and issubclass(t, BaseModel))).model_fields
        extra = sorted(set(val) - set(known))
        if extra:
            return f"suite {name}: unknown key {table}.{extra[0]}; [{table}] takes {', '.join(sorted(known))}."
    return None


def _first_problem(err: ValidationError, name: str) -> str:
    """One line for the first of pydantic's errors: the key's dotted name and what its rule said."""
    e = err.errors()[0]
    where = ".".join(str(part) for part in e["loc"])
    if e["type"] == "suite_key":
        return f"suite {name}: {where}{e['msg']}"
    if e["type"] == "suite_whole":
        return f"suite {name}: {e['msg']}"
    if e["type"] == "suite_line":
        return e["msg"]
    return f"suite {name}: {where}: {e['msg']}."   # not expected: every key has its own rule


def load_suite(path) -> Suite:
    """Read and check a suite file: everything that does not need the engines (see
    :func:`~rockbench.benchmark.suites.runner.check_suite` for the rest), so a bad suite fails before
    the first map, and ``--plan`` fails the same way.

    Raises
    ------
    ConfigError
        Unreadable TOML, an unknown table or key, or a bad value: one line naming the key.
    """
    p = Path(path)
    raw = _read_toml(p)
    unknown = _unknown(raw, p.name)
    if unknown:
        raise ConfigError(unknown)
    try:
        f = SuiteFile.model_validate(raw, context={"name": p.name, "folder": p.parent})
    except ValidationError as err:
        raise ConfigError(_first_problem(err, p.name)) from None
    name = f.suite.name if f.suite.name is not None else p.stem
    source = f"the suite {name!r}" if "verdict" in raw else \
        f"the code's defaults (the default suite's): the suite {name!r} declares none"
    return Suite(name=name, description=f.suite.description, path=str(p), raw=raw, grid=f.grid, cases=f.cases,
                 reference=f.reference, engines=f.engines, run=f.run, report=f.report,
                 verdict=Declared(**f.verdict.model_dump(), source=source), power=f.power, speed=f.speed)
