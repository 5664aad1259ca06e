"""Words for people: engine variants and restitution laws as a figure legend or a report shows them.

Internal keys such as ``mujoco[settings=calibrated]`` and ``modified(k=0.8608)`` stay the keys of
files and scores; pictures and the report say "MuJoCo 4.0, calibrated to η_H" and "η_M, k = 0.8608
(average for M)".
"""

from __future__ import annotations

import html

from rockbench.engines.calibration.held_out import NEIGHBOUR, SIBLING
from rockbench.engines.adapters.reference import PLANTED, is_planted
from rockbench.engines.registry import adapter_class
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.restitution import Restitution
from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.benchmark.engine_info.versions import version_of


#: Display names of the engines (registry name → name).
ENGINE_NAMES = {"reference": "Reference solver", "mujoco": "MuJoCo", "pybullet": "PyBullet", "exudyn": "Exudyn",
                "mujoco_warp": "MuJoCo Warp", "drake": "Drake", "dart": "DART", "newton": "Newton", "genesis": "Genesis",
                "physx": "PhysX 5 via SAPIEN"}   # the version shown is SAPIEN's (PhysX has none of its own in the wheel)

#: Engine settings that say nothing a reader needs when they have their default value (a planted factor
#: is said with the target it moves).
_QUIET = {"settings", PLANTED}

#: The settings classes the verdict answers apart (best achievable, out of the box), and the suite's
#: yardstick: the reference solver with a planted restitution error (``planted_eta_factor``)
CALIBRATED, AS_SHIPPED, PLANTED_CLASS = "calibrated", "as-shipped", "planted"

#: The class of an engine calibrated to η_target × (1 + δ) (a contact engine's ``planted_eta_factor``):
#: the suite's power against an engine's own restitution error, never in the calibrated standing
ENGINE_PLANTED_CLASS = "engine-planted"

#: The reference adapter's setting that plants a restitution η_target × factor (the suite's power).
PLANTED_SETTING = PLANTED

#: Engine settings a calibration chooses itself (they do not make a variant "custom").
_CALIBRATION_KEYS = {"settings", "contact"}

#: How solvers are named in a variant's name (the engines' setting values → words).
SOLVER_NAMES = {"xpbd": "XPBD", "semi_implicit": "semi-implicit", "featherstone": "Featherstone", "vbd": "VBD",
                "newton": "Newton", "cg": "CG"}


def model_settings(engine: str) -> dict:
    """The settings that choose which of an engine's models runs, with their defaults
    (:attr:`~rockbench.engines.contract.EngineAdapter.MODEL_SETTINGS`; Newton's solver); {} for an
    engine without them, or whose adapter cannot be imported here."""
    try:
        cls = adapter_class(engine)
    except Exception:  # noqa: BLE001 - a label never fails: the settings given are shown as they are
        return {}
    return {k: cls.SETTINGS[k] for k in getattr(cls, "MODEL_SETTINGS", ()) if k in cls.SETTINGS}


def engine_name(engine: str) -> str:
    """``mujoco`` → ``MuJoCo``; unknown engines keep their registry name."""
    return ENGINE_NAMES.get(str(engine), str(engine))


def short_version(version) -> str:
    """``4.0.0`` → ``4.0`` (a zero patch level says nothing); anything else as it is."""
    v = str(version or "").strip()
    parts = v.split(".")
    if len(parts) == 3 and parts[2] == "0" and all(p.isdigit() for p in parts):
        return ".".join(parts[:2])
    return v


def restitution_symbol(label: str, block: str | None = None) -> str:
    """A restitution label in the paper's symbols.

    ``housner`` → ``η_H``; ``modified(k=0.8608)`` → ``η_M, k = 0.8608`` with "(average k)" or
    "(exact k)" when it is the preset's; a number → ``η = 0.75``.
    """
    try:
        law = Restitution.parse(label)
    except ConfigError:
        return str(label)
    if law.kind == "housner":
        return "η_H"
    if law.kind == "constant":
        return f"η = {law.value:.4g}"
    pre = PRESETS.get(str(block).upper()) if block else None
    which = pre.which_k(law.k) if pre is not None else None
    return f"η_M (k = {law.k:g}{f', {which} k' if which else ''})"


def _setting_words(key: str, value) -> str | None:
    if key in _QUIET:
        return None
    if key == "drive":
        return f"{value} drive"
    if key == "friction":
        return f"μ = {value:g}" if isinstance(value, (int, float)) else f"μ = {value}"
    if key == "planar":
        return "planar" if value else "3-D body"
    if key == "mode":
        return "integrated to rest" if value == "to-rest" else None
    if key == "contact":
        return {"distributed": "contact along the base", "corners": "corner contact"}.get(value)
    if key == "solver":
        return f"{SOLVER_NAMES.get(value, value)} solver"
    if key == "calibrate_on":
        if not value:
            return None
        return {SIBLING: "held out: calibrated on the other size",
                NEIGHBOUR: "held out: calibrated on the neighbouring slenderness"}.get(value,
                                                                                     f"held out: calibrated on {value}")
    return f"{key} = {value}"


def variant_label(engine: str, settings: dict | None = None, *, version=None, restitution: str | None = None,
                  dt_s: float | None = None, block: str | None = None) -> str:
    """A human label for an engine variant: ``MuJoCo 4.0, calibrated to η_H`` / ``PyBullet 3.2.7, as shipped``.

    Parameters
    ----------
    engine : str
        Registry name.
    settings : dict, optional
        The engine settings the map was run with (only those given); ``settings = "shipped"``
        reads "as shipped", ``"calibrated"`` (the default) "calibrated to <target>".
    version : str, optional
        The engine's version (``run.json``).
    restitution : str, optional
        The map's restitution label: the target a calibrated variant was tuned to.
    dt_s : float, optional
        A time step other than the engine's default [s].
    block : str, optional
        Names the preset's average or exact k in a modified target.
    """
    s = {**(model_settings(engine) if engine != "reference" else {}), **(settings or {})}
    name = engine_name(engine)
    v = short_version(version)
    head = f"{name} {v}" if v and v not in ("test", "source", "None") and engine != "reference" else name
    words = []
    if engine == "reference" and PLANTED_SETTING in s:
        return f"{head}, {planted_words(restitution, s[PLANTED_SETTING], block)}"
    if engine != "reference":
        if s.get("settings", "calibrated") == "shipped":
            words.append("as shipped")
        elif s.get(PLANTED_SETTING) is not None:
            words.append(f"calibrated to {planted_words(restitution, s[PLANTED_SETTING], block)}")
        else:
            words.append(f"calibrated to {restitution_symbol(restitution, block)}" if restitution else "calibrated")
    elif restitution:
        words.append(restitution_symbol(restitution, block))
    words += [w for w in (_setting_words(k, val) for k, val in sorted(s.items())) if w]
    if dt_s is not None:
        words.append(f"Δt = {dt_s * 1e3:g} ms")
    return head + (", " + ", ".join(words) if words else "")


def planted_words(restitution: str | None, factor, block: str | None = None) -> str:
    """``η_H × 0.990 (planted)``: the restitution a planted variant runs with (three decimals: δ in steps of
    0.1 %)."""
    target = restitution_symbol(restitution, block) if restitution else "η"
    try:
        f = f"{float(factor):.3f}"
    except (TypeError, ValueError):
        f = str(factor)
    return f"{target} × {f} (planted)"


def entry_label(entry, *, with_restitution: bool = True) -> str:
    """:func:`variant_label` of a :class:`~rockbench.benchmark.store.loading.MapEntry` (its settings and time
    step, and the engine version its run.json recorded)."""
    return variant_label(entry.engine, entry.settings, version=version_of(entry),
                         restitution=entry.restitution if with_restitution else None, dt_s=entry.dt_s,
                         block=entry.block)


PULSE_WORDS = {"sine": "one sine wave", "cosine": "one cosine wave", "half-sine": "one half-sine pulse"}


def case_title(block: str, pulse: str) -> str:
    """``B3M, one sine wave``."""
    return f"{block}, {PULSE_WORDS.get(pulse, pulse)}"


def for_matplotlib(text: str) -> str:
    """The paper's symbols in matplotlib's mathtext: ``η_H`` → η with a subscript H (and η_M)."""
    return (str(text).replace("η_H", r"$\eta_\mathrm{H}$").replace("η_M", r"$\eta_\mathrm{M}$"))


def for_html(text: str) -> str:
    """The paper's symbols in HTML (escaped): ``η_H`` → ``η<sub>H</sub>``."""
    return html.escape(str(text)).replace("η_H", "η<sub>H</sub>").replace("η_M", "η<sub>M</sub>")


def variant_labels(cands) -> dict[str, str]:
    """Engine variant key → its label in words ("MuJoCo 4.0, calibrated to η_H") for the maps ``cands``
    (:class:`~rockbench.benchmark.store.loading.MapEntry`); two variants that would read alike keep their keys."""
    by: dict[str, list] = {}
    for e in cands:
        by.setdefault(e.variant, []).append(e)
    out = {}
    for v, es in by.items():
        same = len({e.restitution for e in es}) == 1
        out[v] = entry_label(es[0], with_restitution=same)
    # two variants that read alike keep their keys apart
    seen: dict[str, list[str]] = {}
    for v, lab in out.items():
        seen.setdefault(lab, []).append(v)
    for lab, vs in seen.items():
        if len(vs) > 1:
            for v in vs:
                out[v] = f"{lab} [{v}]"
    return out


def settings_class(engine_settings: dict | None, variant: str, engine: str | None = None) -> str:
    """``calibrated`` (rockbench's calibration, any contact layout it chose), ``as-shipped`` (the
    engine's defaults and nothing else), ``planted`` (the reference solver with a planted restitution
    error, :func:`~rockbench.engines.adapters.reference.is_planted`), ``engine-planted`` (an engine
    calibrated to the target × its ``planted_eta_factor``) or, for anything else set by hand,
    the variant's own name. The settings that choose the ``engine``'s model (:func:`model_settings`:
    Newton's solver) are the engine's, not a tweak: they leave the class as it is."""
    if engine is not None and is_planted(engine, engine_settings):
        return PLANTED_CLASS
    if engine not in (None, "reference") and (engine_settings or {}).get(PLANTED_SETTING) is not None:
        return ENGINE_PLANTED_CLASS
    model = model_settings(engine) if engine else {}
    s = {k: v for k, v in (engine_settings or {}).items() if k not in model}
    kind = s.get("settings", "calibrated")
    if kind == "shipped" and set(s) <= {"settings"}:
        return AS_SHIPPED
    if kind == "calibrated" and set(s) <= _CALIBRATION_KEYS:
        return CALIBRATED
    return variant
