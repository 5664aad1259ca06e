"""The maps a suite asks for (:func:`plan`, :class:`MapJob`): the reference maps, the planted variants
of its ``[power]`` table, then each engine variant's maps on each block and pulse, and which engines run
(:func:`engine_names`, :func:`check_suite`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rockbench.engines.adapters.reference import PLANTED
from rockbench.engines.calibration import held_out
from rockbench.engines.contract import EngineAdapter
from rockbench.engines.registry import adapter_class, availability, names
from rockbench.reference_solver.errors import ConfigError
from rockbench.engines.errors import EngineUnavailableError
from rockbench.reference_solver.restitution import Restitution
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.engine_info.adapters import engine_settings
from rockbench.benchmark.engine_info.devices import GPU_ENGINES, device_of
from rockbench.benchmark.store.files import own_eta_map_name, variant_name
from rockbench.benchmark.store.loading import SPEED_STAGE
from rockbench.benchmark.suites.model import Suite, reference_tokens, restitution_for



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
    stage : str or None
        The suite stage it belongs to (:data:`SPEED_STAGE` for the speed stage's maps), None for the
        maps the verdict judges and their references.
    """

    engine: str
    settings: dict
    block: str
    pulse: str
    restitution: Restitution
    dt_s: float | None
    subdir: str
    stage: str | None = None


def check_suite(suite: "Suite", engines: list[str], explicit: bool) -> tuple[list[str], list[str]]:
    """What :func:`load_suite` cannot check alone: every engine variant's settings (the adapter is
    built, nothing runs), and a ``calibrate_on`` block for each block the variant maps. Called by
    ``--plan`` and before the first map.

    Returns the engines to run and notes. An engine picked because it is available (``explicit``
    false) that cannot take a variant's settings is skipped with a note, as an engine that is not
    installed is, unless no engine can take them (a typo).

    Raises
    ------
    ConfigError
        A setting an engine named explicitly (suite list or ``--engines``), or every engine, refuses:
        one line naming the suite key.
    """
    kept, refused = [], {}
    for engine in engines:
        cls = adapter_class(engine)
        for k, variant in enumerate(suite.engines.variants):
            if not variant_applies(engine, variant):
                continue
            try:
                # the base class's check of names and values, without the adapter's own constructor
                # (which may start its engine: nothing may run for --plan)
                adapter = object.__new__(cls)
                EngineAdapter.__init__(adapter, **engine_settings(engine, variant_settings(variant)))
                for block in blocks_of(suite, variant):   # calibrate_on: a block of each one's slenderness
                    held_out.calibration_block(adapter.settings.get("calibrate_on"), get_preset(block).block())
            except ConfigError as e:
                refused[engine] = f"engines.variants[{k}] {variant}: {e}"
                break
        else:
            kept.append(engine)
    if refused and (explicit or not kept):
        raise ConfigError(f"suite {Path(suite.path).name}: {next(iter(refused.values()))}")
    return kept, [f"engine {n} skipped: {why}" for n, why in refused.items()]


def parse_engines(text: str | None) -> list[str] | None:
    """``--engines NAME,...`` into a list of names (None when not given); every name must be known.

    Raises
    ------
    ConfigError
        An empty list or an unknown name (with a "did you mean").
    """
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
    notes = []
    if only is not None:
        for n in only:
            a = availability(n)
            if not a["available"]:
                raise EngineUnavailableError(f"--engines asks for engine {n!r}, which is not available: "
                                             f"{a['reason']}")
        return [n for n in only if n != "reference"], notes
    if suite.engines.names == "available":
        unknown = [n for n in suite.engines.include if n not in names()]
        if unknown:
            raise ConfigError(f"suite {suite.name}: engines.include names engine {unknown[0]!r}, which rockbench does "
                              f"not know; `rockbench engines` lists the engines.")
        out = []
        for n in names():
            if n == "reference":
                continue
            if n in suite.engines.exclude:
                notes.append(f"engine {n} left out by the suite (engines.exclude); run it with --engines {n} "
                             f"or the full suite")
                continue
            a = availability(n)
            if not a["available"]:
                notes.append(f"engine {n} skipped: {a['reason']}")
                continue
            # engines.include: taken wherever installed, even where it would leave such suites (MuJoCo Warp on a CPU)
            why_not = None if n in suite.engines.include else adapter_class(n).default_suite_exclusion()
            if why_not:
                notes.append(f"engine {n} skipped: {why_not}")
            else:
                out.append(n)
        return out, notes
    for n in suite.engines.names:
        a = availability(n)
        if not a["available"]:
            raise EngineUnavailableError(f"the suite asks for engine {n!r}, which is not available: {a['reason']}")
    return [n for n in suite.engines.names if n != "reference"], notes


def _slug(s: str) -> str:
    return "".join(c if (c.isalnum() or c in ".=") else "-" for c in str(s)).strip("-")


def plan(suite: Suite, engines: list[str]) -> list[MapJob]:
    """Every map of the suite: the reference maps (each restitution a block has, :func:`reference_tokens`),
    the planted variants (:func:`power_jobs`), then each engine variant's maps."""
    jobs = []
    for block in suite.cases.blocks:
        for pulse in suite.cases.pulses:
            for tok in reference_tokens(suite, block):
                r = restitution_for(tok, block)
                jobs.append(MapJob("reference", {}, block, pulse, r, suite.reference.dt_s,
                                   f"maps/reference/{block}-{pulse}-{_slug(r.label)}"))
    jobs += power_jobs(suite)
    jobs += speed_jobs(suite, speed_engines(suite, engines)[0])
    for engine in engines:
        for variant in suite.engines.variants:
            if not variant_applies(engine, variant):
                continue
            vname = variant_name(engine, variant_settings(variant) | _rest_part(variant), suite.engines.dt_s)
            for block in blocks_of(suite, variant):
                r = restitution_for(variant_restitution(suite, variant), block)
                for pulse in suite.cases.pulses:
                    jobs.append(MapJob(engine, variant_settings(variant), block, pulse, r, suite.engines.dt_s,
                                       f"maps/{_slug(vname)}/{block}-{pulse}-{_slug(r.label)}"))
    return jobs


#: The engine settings of the speed stage's variant: each engine calibrated as the suite's calibrated variant is
SPEED_SETTINGS = {"settings": "calibrated"}


def speed_engines(suite: Suite, engines: list[str]) -> tuple[list[str], list[str]]:
    """``(the engines of the speed stage, notes)``: those of the suite whose calibrated variant can be built
    (settings checked, nothing runs); none without a ``[speed]`` table."""
    if suite.speed is None:
        return [], []
    kept, notes = [], []
    for engine in engines:
        try:
            adapter = object.__new__(adapter_class(engine))
            EngineAdapter.__init__(adapter, **engine_settings(engine, SPEED_SETTINGS))
        except ConfigError as e:
            notes.append(f"engine {engine} left out of the speed stage: it has no calibrated variant ({e})")
            continue
        kept.append(engine)
    return kept, notes


def speed_jobs(suite: Suite, engines: list[str]) -> list[MapJob]:
    """The speed stage's maps: each engine calibrated at each of ``speed.steps_s`` on each of the stage's
    blocks and pulses, at the engines' restitution target, under ``maps/speed/`` (``stage`` "speed")."""
    if suite.speed is None:
        return []
    jobs = []
    for engine in engines:
        for dt in suite.speed.steps_s:
            vname = variant_name(engine, SPEED_SETTINGS, dt)
            for block in suite.speed.blocks:
                r = restitution_for(suite.engines.restitution, block)
                for pulse in suite.speed.pulses:
                    jobs.append(MapJob(engine, dict(SPEED_SETTINGS), block, pulse, r, dt,
                                       f"maps/{SPEED_STAGE}/{_slug(vname)}/{block}-{pulse}-{_slug(r.label)}",
                                       SPEED_STAGE))
    return jobs


def speed_plan_lines(suite: Suite, engines: list[str], cells: int) -> list[str]:
    """What the speed stage will cost, per engine, for ``rockbench run --plan`` (``cells``: a map's grid):
    its maps, the cells they may simulate at most, and the calibrations its steps need."""
    if suite.speed is None:
        return []
    sp = suite.speed
    steps = ", ".join(f"{dt * 1e3:g}" for dt in sp.steps_s)
    head = (f"speed stage: {len(engines)} engine(s) × {len(sp.steps_s)} steps ({steps} ms) × "
            f"{len(sp.blocks)} block(s) ({', '.join(sp.blocks)}) × {len(sp.pulses)} pulse(s) ({', '.join(sp.pulses)}) "
            f"= {len(engines) * len(sp.steps_s) * len(sp.blocks) * len(sp.pulses)} maps")
    per = len(sp.steps_s) * len(sp.blocks) * len(sp.pulses)
    lines = [head]
    for engine in engines:
        lines.append(f"speed stage, {engine}: {per} maps of {cells} cells (adaptive: those near a boundary are "
                     f"simulated, with its bisection samples to depth {speed_depth(suite)}), {len(sp.steps_s) * len(sp.blocks)} calibrations and the "
                     f"time-step rule's search on {len(sp.blocks)} block(s) (both cached)")
    return lines


def speed_record(suite: Suite, engines: list[str], notes: list[str]) -> dict:
    """What a run's speed.json says of its speed stage (:mod:`rockbench.benchmark.scoring.speed_runs`): what
    it declared, its engines, and each engine meant for a GPU that has no GPU row here and why (it is not in
    the stage: the run's note on it; it runs on the CPU: its own line)."""
    sp = suite.speed
    absent = []
    for e in GPU_ENGINES:
        if e in engines:
            dev = device_of(e)
            if dev["runs_on"] != "gpu":
                absent.append({"engine": e, "why": f"timed on the CPU: {dev['note'] or 'no GPU device'}"})
            continue
        said = next((n for n in notes if n.startswith(f"engine {e} ")), None)
        absent.append({"engine": e, "why": said[len(f"engine {e} "):] if said else "not among this run's engines"})
    return {"kind": "rockbench-speed-stage", "engines": list(engines), "absent": absent,
            "declared": {"steps_s": list(sp.steps_s), "blocks": list(sp.blocks), "pulses": list(sp.pulses),
                         "matched_distance": sp.matched_distance, "locate_depth": speed_depth(suite),
                         "source": f"the suite {suite.name!r}"}}


def speed_depth(suite: Suite) -> int:
    """The rounds of bisection of the speed stage's boundaries: its own ``locate_depth``, else the grid's."""
    sp = suite.speed
    return sp.locate_depth if sp is not None and sp.locate_depth is not None else suite.grid.locate_depth


def planted_factor(reduction: float) -> float:
    """The reference solver's ``planted_eta_factor`` for a planted reduction δ: 1 − δ [-]."""
    return round(1.0 - float(reduction), 12)


def in_sample_blocks(suite: Suite) -> list[str]:
    """The blocks the suite's in-sample variants map (those without ``calibrate_on``), in the suite's
    order; every block of the suite when all its variants are held out."""
    mapped = {b for v in suite.engines.variants if not v.get("calibrate_on") for b in blocks_of(suite, v)}
    return [b for b in suite.cases.blocks if b in mapped] or list(suite.cases.blocks)


def power_jobs(suite: Suite) -> list[MapJob]:
    """The planted variants of the suite's ``[power]`` table: for each reduction δ, the reference solver
    with ``planted_eta_factor`` = 1 − δ on every in-sample block (:func:`in_sample_blocks`) and pulse,
    at the engines' restitution target and the reference's step. They are engine maps in every respect
    but their η, which is known (no own-η step): adaptive as the suite's engine maps, scored like for
    like against the reference maps of that restitution."""
    jobs = []
    for delta in suite.power.eta_reductions:
        settings = {PLANTED: planted_factor(delta)}
        vname = variant_name("reference", settings, suite.reference.dt_s)
        for block in in_sample_blocks(suite):
            r = restitution_for(suite.engines.restitution, block)
            for pulse in suite.cases.pulses:
                jobs.append(MapJob("reference", settings, block, pulse, r, suite.reference.dt_s,
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
        for pulse in suite.cases.pulses:
            jobs.append(MapJob("reference", {}, m["block"], pulse, Restitution("constant", value=eta),
                               suite.reference.dt_s, f"maps/reference/{own_eta_map_name(m['block'], pulse, eta)}"))
    return jobs


def variant_blocks(suite: Suite, engines: list[str]):
    for engine in engines:
        for variant in suite.engines.variants:
            if not variant_applies(engine, variant):
                continue
            for block in blocks_of(suite, variant):
                yield engine, variant, block


def variant_settings(variant: dict) -> dict:
    """A suite variant's engine settings (its ``restitution``, ``engines`` and ``blocks``, suite keys, left out)."""
    return {k: v for k, v in variant.items() if k not in ("restitution", "engines", "blocks")}


def blocks_of(suite: "Suite", variant: dict) -> list[str]:
    """The blocks a suite variant maps: its ``blocks`` (in the suite's order), default all the suite's."""
    return [b for b in suite.cases.blocks if "blocks" not in variant or b in variant["blocks"]]


def variant_applies(engine: str, variant: dict) -> bool:
    """Whether a suite variant runs for ``engine`` (its ``engines`` list, default every engine)."""
    return "engines" not in variant or engine in variant["engines"]


def _rest_part(variant: dict) -> dict:
    return {"restitution": variant["restitution"]} if "restitution" in variant else {}


def variant_restitution(suite: "Suite", variant: dict) -> str:
    """The restitution a suite variant is calibrated to and labelled with: its own, else the suite's."""
    return str(variant.get("restitution", suite.engines.restitution))
