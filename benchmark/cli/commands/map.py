"""``rockbench map``: a stability map over frequency × amplitude into a resumable run directory."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from rockbench.reference_solver.errors import ConfigError

from rockbench.engines.errors import EngineError
from rockbench.benchmark.engine_info.health import EngineCannotSimulate, cannot_simulate_line, common_error
from rockbench.benchmark.maps.bisection import DEFAULT_DEPTH, MAX_DEPTH
from rockbench.benchmark.maps.grid import MAP_PULSES, MapSpec, parse_range
from rockbench.benchmark.sweep import DEFAULT_CELL_TIMEOUT_S, run_map
from rockbench.benchmark.report.plots.picture import MapPicture
from rockbench.benchmark.store.atomic import check_output_dir
from rockbench.benchmark.request import CaseRequest
from rockbench.benchmark.store.export import write_full_grid
from rockbench.benchmark.cli.options import (add_block_options, add_figure_format_option, add_model_options, figure_formats_from_args,
                       jobs_from_args)


def register(sub) -> None:
    p = sub.add_parser("map", help="a stability map over ω/p × a0/(g·tanα) (or ω × a0) into a run directory")
    add_block_options(p)
    g = p.add_argument_group("restitution")
    g.add_argument("--restitution", default="housner", metavar="LAW", help="housner (default) | modified | a number in (0, 1]")
    g.add_argument("--k", default=None, help="impulse position for modified (default: the preset's average k)")
    g = p.add_argument_group("pulse and axes (LO:HI:N = N values from LO to HI inclusive)")
    g.add_argument("--pulse", default="sine", help="sine (default) | cosine | half-sine")
    g.add_argument("--w-ratio", metavar="LO:HI:N", help="horizontal axis in ω/p [-]")
    g.add_argument("--omega", metavar="LO:HI:N", help="horizontal axis in ω [rad/s]")
    g.add_argument("--a-ratio", metavar="LO:HI:N", help="vertical axis in a0/(g·tanα) [-]")
    g.add_argument("--amplitude", metavar="LO:HI:N", help="vertical axis in a0 [m/s^2]")
    g.add_argument("--amplitude-g", metavar="LO:HI:N", help="vertical axis in a0 [g]")
    add_model_options(p)
    g = p.add_argument_group("run")
    g.add_argument("--out", required=True, metavar="DIR", help="run directory (rerunning into it resumes)")
    g.add_argument("--adaptive", action="store_true", help="coarse grid first, refine only where neighbours disagree")
    g.add_argument("--coarse-stride", type=int, default=None, metavar="S",
                   help="adaptive coarse spacing in cells (default 4)")
    g.add_argument("--locate-depth", type=int, default=DEFAULT_DEPTH, metavar="D",
                   help="bisect every boundary edge D times after the cells, to a tolerance of a step over 2**D "
                   f"(default {DEFAULT_DEPTH}; 0 keeps the edge midpoints)")
    g.add_argument("--jobs", type=str, default=None, metavar="N",
                   help="worker processes (default: all cores); for the reference, threads of its batch in this process")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster (tcp://host:8786), or 'local' for a LocalCluster on 127.0.0.1")
    g.add_argument("--serial", action="store_true", help="run in this process (no time limit or crash isolation)")
    g.add_argument("--cell-timeout", type=str, default=str(DEFAULT_CELL_TIMEOUT_S), metavar="S",
                   help=f"wall-time limit of one cell [s] (default {DEFAULT_CELL_TIMEOUT_S:g})")
    g.add_argument("--no-plot", action="store_true", help="do not draw DIR/map.png")
    add_figure_format_option(g, what="map's picture (DIR/map.png, map.svg, map.pdf)")
    g.add_argument("--full-grid", action="store_true",
                   help="also write DIR/cells-full.csv: every cell of the grid, those an adaptive map inferred "
                   "by its fill rule marked filled=true")
    g.add_argument("--json", action="store_true", help="print a JSON summary on stdout (no progress bar)")
    p.set_defaults(func=run)


def _pick(args, names: list[str], what: str) -> tuple[str, str]:
    given = [(n, getattr(args, n)) for n in names if getattr(args, n) is not None]
    opts = ", ".join("--" + n.replace("_", "-") for n in names)
    if not given:
        raise ConfigError(f"no {what} axis given: use one of {opts} LO:HI:N.")
    if len(given) > 1:
        raise ConfigError(f"the {what} axis is given twice ({' and '.join('--' + n.replace('_', '-') for n, _ in given)}); "
                          f"give one of {opts}.")
    return given[0]


def spec_from_args(args) -> MapSpec:
    """The :class:`MapSpec` the command line describes (everything checked, nothing written)."""
    kind = str(args.pulse).strip().lower()
    if kind not in MAP_PULSES:
        if Path(str(args.pulse)).suffix or kind.endswith(".csv"):
            raise ConfigError(f"a map sweeps frequency and amplitude, so its pulse must be harmonic "
                              f"({', '.join(MAP_PULSES)}); got the record {args.pulse!r}: use `rockbench simulate`.")
        raise ConfigError(f"--pulse must be one of {', '.join(MAP_PULSES)} for a map, got {args.pulse!r}.")
    return CaseRequest.from_args(args).map_spec(kind, lambda: _axes(args))


def _axes(args):
    """The frequency and amplitude axes the options give."""
    xn, xt = _pick(args, ["w_ratio", "omega"], "frequency")
    yn, yt = _pick(args, ["a_ratio", "amplitude", "amplitude_g"], "amplitude")
    x = parse_range("--" + xn.replace("_", "-"), xt, {"w_ratio": "w_ratio", "omega": "omega_rad_s"}[xn])
    y = parse_range("--" + yn.replace("_", "-"), yt,
                    {"a_ratio": "a_ratio", "amplitude": "amplitude_mps2", "amplitude_g": "amplitude_g"}[yn])
    return x, y


def run(args) -> int:
    spec = spec_from_args(args)
    try:
        timeout = float(args.cell_timeout)
    except ValueError:
        raise ConfigError(f"--cell-timeout must be a number of seconds > 0, got {args.cell_timeout!r}.") from None
    if args.coarse_stride is not None and args.coarse_stride < 1:
        raise ConfigError(f"--coarse-stride must be >= 1, got {args.coarse_stride}.")
    if not 0 <= args.locate_depth <= MAX_DEPTH:
        raise ConfigError(f"--locate-depth must be a whole number from 0 to {MAX_DEPTH}, got {args.locate_depth}.")
    formats = figure_formats_from_args(args)
    check_output_dir(args.out, "--out")
    quiet = args.json or not sys.stderr.isatty()
    try:
        result = run_map(spec, args.out, jobs=jobs_from_args(args), scheduler=args.scheduler, serial=args.serial,
                         adaptive=args.adaptive, coarse_stride=args.coarse_stride, cell_timeout_s=timeout,
                         progress=not quiet, picture=None if args.no_plot else MapPicture(), figure_formats=formats,
                         locate_depth=args.locate_depth,
                         log=None if args.json else (lambda s: print(s, file=sys.stderr)))
    except EngineError as e:   # its workers could not start the engine: exit 3, the line says why
        raise EngineCannotSimulate(cannot_simulate_line(spec.engine, str(e), "starting it")) from None
    summary = {**result.summary(), "out": str(args.out)}
    broken = _cannot_simulate(spec, result)
    if args.full_grid:
        summary["full_grid"] = str(write_full_grid(args.out))
    if args.json:
        print(json.dumps(summary, indent=2))
        return _exit(broken)
    c = summary["counts"]
    print(f"{spec.label()}: {summary['shape'][0]}×{summary['shape'][1]} cells, "
          f"{summary['n_simulated']} simulated ({100 * summary['fraction_simulated']:.1f} %), "
          f"rest {c['rest']}, rocking {c['rocking']}, overturn {c['overturn']}, failed {c['failed']}"
          + (f", missing {c['missing']}" if c["missing"] else "") + f"; {summary['wall_s']:.1f} s → {args.out}")
    if "full_grid" in summary:
        print(f"every cell of the grid: {summary['full_grid']}")
    return _exit(broken)


def _cannot_simulate(spec, result) -> str | None:
    """The line for an engine whose every simulated cell of this map failed with one error, else None."""
    err = common_error(result.failures, result.n_simulated) if spec.engine != "reference" else None
    if err is None:
        return None
    return cannot_simulate_line(spec.engine, err, f"every one of the {result.n_simulated} simulated cells of the map")


def _exit(broken: str | None) -> int:
    """0, or (the map is written and summarised) the engine-cannot-simulate error, exit code 3."""
    if broken:
        raise EngineCannotSimulate(broken)
    return 0
