"""Describing a case on the command line (docs/cli.md, "Describing a case"), shared by every subcommand."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ...engines.base import Case
from ...reference_solver.errors import ConfigError, check_positive
from ...reference_solver.model import Block, G, a_ratio_to_amplitude
from ...reference_solver.pulses import Pulse, RecordPulse, make_pulse
from ...reference_solver.restitution import Restitution
from ..blocks.presets import PRESETS, get_preset


def add_block_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("block")
    g.add_argument("--block", metavar="NAME", help=f"a preset: {', '.join(PRESETS)}")
    g.add_argument("--width", type=str, metavar="W", help="full width b [m] (custom block)")
    g.add_argument("--height", type=str, metavar="H", help="full height h [m] (custom block)")
    g.add_argument("--depth", type=str, metavar="D", help="depth [m] (default: the width)")
    g.add_argument("--density", type=str, metavar="RHO", help="density [kg/m^3] (default 2655, aluminium)")


def add_case_options(p: argparse.ArgumentParser, point: bool = True) -> None:
    """Add the block, restitution, pulse, model options; ``point`` adds frequency and amplitude."""
    add_block_options(p)
    g = p.add_argument_group("restitution")
    g.add_argument("--restitution", default="housner", metavar="LAW",
                   help="housner (default) | modified | a number in (0, 1]")
    g.add_argument("--k", type=str, default=None, help="impulse position for modified, in [0, 1] "
                   "(default: the preset's average k)")
    g = p.add_argument_group("pulse")
    g.add_argument("--pulse", default="sine", help="sine (default) | cosine | half-sine | PATH.csv")
    if point:
        g.add_argument("--w-ratio", type=str, help="ω/p [-]")
        g.add_argument("--omega", type=str, help="ω [rad/s]")
        g.add_argument("--period", type=str, help="period of one full wave 2π/ω [s]")
        g.add_argument("--a-ratio", type=str, help="a0/(g·tanα) [-]")
        g.add_argument("--amplitude", type=str, help="a0 [m/s^2]")
        g.add_argument("--amplitude-g", type=str, help="a0 [g]")
    add_model_options(p)


def add_model_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("model")
    g.add_argument("--engine", default="reference", help="engine name (default reference; see `rockbench engines`)")
    g.add_argument("--dt", type=str, default=None, help="time step [s] (default: the engine's)")
    g.add_argument("--linearized", action="store_true", help="linearised equation of motion (reference only)")
    g.add_argument("--settings", default=None, metavar="NAME",
                   help="engine contact settings: calibrated (default) | defaults (the engine as shipped)")
    g.add_argument("--drive", default=None, help="engine table drive: inertial (default) | table")
    g.add_argument("--friction", default=None, metavar="MU",
                   help="friction coefficient μ [-]: an engine's contact friction; for the reference, the μ "
                   "its slip-required test allows (default 10, the engines' anti-slip friction)")
    g.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="any other engine setting (repeatable)")


def block_from_args(args) -> tuple[Block, object]:
    """The block and its preset (None for a custom block)."""
    custom = [args.width, args.height]
    if args.block and any(v is not None for v in custom):
        raise ConfigError(f"give either --block or --width/--height, not both (got --block {args.block}).")
    if args.block:
        pre = get_preset(args.block)
        if args.depth is not None or args.density is not None:
            raise ConfigError("--depth and --density apply to custom blocks only; drop them or use --width/--height.")
        return pre.block(), pre
    if args.width is None or args.height is None:
        raise ConfigError("no block given: use --block NAME (B3M, B6M, B3L, B6L) or --width W --height H [m].")
    return Block(_num("--width", args.width), _num("--height", args.height),
                 None if args.depth is None else _num("--depth", args.depth),
                 density_kg_m3=None if args.density is None else _num("--density", args.density)), None


def jobs_from_args(args) -> int | None:
    """``--jobs N``: a whole number >= 1 of worker processes, or None (not given: all cores)."""
    text = args.jobs
    if text is None:
        return None
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise ConfigError(f"--jobs must be a whole number >= 1, got {text!r}.")
    return n


def restitution_from_args(args, preset, option: str = "--restitution") -> Restitution:
    """``--restitution`` (or ``option``) and ``--k`` into a Restitution (:meth:`Restitution.parse`; a preset
    supplies its average and exact k)."""
    k = None if args.k is None else _num("--k", args.k)
    return Restitution.parse(getattr(args, option.lstrip("-")), k, option=option,
                             k_average=None if preset is None else preset.k_average,
                             k_exact=None if preset is None else preset.k_exact)


def _one_of(args, names: list[str], what: str):
    given = [(n, getattr(args, n.lstrip("-").replace("-", "_"))) for n in names]
    given = [(n, v) for n, v in given if v is not None]
    if len(given) > 1:
        raise ConfigError(f"the {what} is given twice ({' and '.join(n for n, _ in given)}); give exactly one of "
                          f"{', '.join(names)}.")
    if not given:
        raise ConfigError(f"no {what} given: use one of {', '.join(names)}.")
    return given[0]


def frequency_from_args(args, block: Block) -> float:
    """ω [rad/s] from --w-ratio, --omega or --period."""
    name, v = _one_of(args, ["--w-ratio", "--omega", "--period"], "frequency")
    x = check_positive(name, _num(name, v), {"--omega": "rad/s", "--period": "s"}.get(name, ""))
    if name == "--w-ratio":
        return x * block.p_rad_s
    if name == "--period":
        return 2.0 * math.pi / x
    return x


def amplitude_from_args(args, block: Block) -> float:
    """a0 [m/s^2] from --a-ratio, --amplitude or --amplitude-g."""
    name, v = _one_of(args, ["--a-ratio", "--amplitude", "--amplitude-g"], "amplitude")
    x = check_positive(name, _num(name, v), {"--amplitude": "m/s^2", "--amplitude-g": "g"}.get(name, ""))
    if name == "--a-ratio":
        return a_ratio_to_amplitude(block, x)
    if name == "--amplitude-g":
        return x * G
    return x


def pulse_from_args(args, block: Block) -> Pulse:
    kind = str(args.pulse)
    if Path(kind).is_dir():
        raise ConfigError(f"--pulse names a directory ({kind!r}); give sine, cosine, half-sine or the path of a "
                          "PATH.csv record with columns t_s,accel_mps2.")
    if kind.lower().endswith(".csv") or Path(kind).suffix:
        freq_given = any(getattr(args, n, None) is not None for n in ("w_ratio", "omega", "period"))
        if freq_given:
            raise ConfigError(f"a record ({kind}) has its own time scale: drop --w-ratio/--omega/--period.")
        scale = 1.0
        amp = [n for n in ("a_ratio", "amplitude", "amplitude_g") if getattr(args, n, None) is not None]
        rec = RecordPulse.from_csv(kind)
        if amp:
            scale = amplitude_from_args(args, block) / rec.amplitude_mps2 if rec.amplitude_mps2 > 0 else 1.0
            rec = RecordPulse.from_csv(kind, scale=scale)
        return rec
    return make_pulse(kind.lower(), amplitude_from_args(args, block), frequency_from_args(args, block))


def dt_from_args(args) -> float | None:
    return None if args.dt is None else check_positive("--dt", _num("--dt", args.dt), "s")


def engine_settings_from_args(args) -> dict:
    """Engine settings given on the command line (only those the user set)."""
    s = {}
    if getattr(args, "settings", None) is not None:
        if args.settings not in ("calibrated", "defaults"):
            raise ConfigError(f"--settings must be calibrated or defaults, got {args.settings!r}.")
        s["settings"] = args.settings
    if getattr(args, "drive", None) is not None:
        if args.drive not in ("inertial", "table"):
            raise ConfigError(f"--drive must be inertial or table, got {args.drive!r}.")
        s["drive"] = args.drive
    if getattr(args, "friction", None) is not None:
        s["friction"] = check_positive("--friction", _num("--friction", args.friction))
    for item in getattr(args, "set", []) or []:
        key, eq, val = item.partition("=")
        if not eq or not key:
            raise ConfigError(f"--set takes KEY=VALUE, got {item!r}.")
        s[key.strip()] = _auto(val.strip())
    return s


def case_from_args(args) -> tuple[Case, object]:
    """A full single case (for ``simulate``) and the preset (or None)."""
    block, preset = block_from_args(args)
    rest = restitution_from_args(args, preset)
    rest.eta_for(block.alpha_rad)   # a law that gives no η for this block is refused here, not by the engine
    pulse = pulse_from_args(args, block)
    dt = dt_from_args(args)
    if dt is not None:
        pulse.check_dt(dt)
    return Case(block, pulse, rest, dt, bool(args.linearized)), preset


def _num(name: str, v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} must be a number, got {v!r}.") from None


def _auto(v: str):
    low = v.lower()
    if low in ("true", "false"):
        return low == "true"
    try:
        return int(v)
    except ValueError:
        pass
    try:
        return float(v)
    except ValueError:
        pass
    if "," in v:
        return [_auto(x) for x in v.split(",")]
    return v


def add_figure_format_option(p, default: str = "png", what: str = "figures") -> None:
    """``--figure-format png,svg,pdf`` (one or more; :mod:`rockbench.harness.report.plots.output`)."""
    p.add_argument("--figure-format", default=default, metavar="FMT[,FMT...]",
                   help=f"write the {what} as png, svg and/or pdf, comma-separated (default {default}); "
                   "PNG at 300 dpi, SVG and PDF with their text as text")


def figure_formats_from_args(args) -> tuple[str, ...]:
    """The formats ``--figure-format`` names, checked (ConfigError otherwise)."""
    from ..report.plots.output import parse_formats
    return parse_formats(args.figure_format)
