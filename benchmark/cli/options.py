"""Describing a case on the command line (docs/cli.md, "Describing a case"), shared by every subcommand:
the options; :class:`~rockbench.benchmark.request.CaseRequest` reads them."""

from __future__ import annotations

import argparse

from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.benchmark.report.plots.output import parse_formats

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
                   help="engine contact settings: calibrated (default) | shipped (the engine as shipped)")
    g.add_argument("--drive", default=None, help="engine table drive: inertial (default) | table")
    g.add_argument("--friction", default=None, metavar="MU",
                   help="friction coefficient μ [-]: an engine's contact friction; for the reference, the μ "
                   "its slip-required test allows (default 10, the engines' anti-slip friction)")
    g.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="any other engine setting (repeatable)")


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


def add_figure_format_option(p, default: str = "png", what: str = "figures") -> None:
    """``--figure-format png,svg,pdf`` (one or more; :mod:`rockbench.benchmark.report.plots.output`)."""
    p.add_argument("--figure-format", default=default, metavar="FMT[,FMT...]",
                   help=f"write the {what} as png, svg and/or pdf, comma-separated (default {default}); "
                   "PNG at 300 dpi, SVG and PDF with their text as text")


def figure_formats_from_args(args) -> tuple[str, ...]:
    """The formats ``--figure-format`` names, checked (ConfigError otherwise)."""
    return parse_formats(args.figure_format)
