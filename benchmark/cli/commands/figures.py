"""``rockbench figures --out DIR``: the paper's Figures 4–9 recomputed with the reference solver."""

from __future__ import annotations

import json
import sys

from rockbench.reference_solver.errors import ConfigError
from rockbench.benchmark.figures import FIGURES, make_figures
from rockbench.benchmark.store.atomic import check_output_dir
from rockbench.benchmark.cli.options import add_figure_format_option, figure_formats_from_args, jobs_from_args


def register(sub) -> None:
    p = sub.add_parser("figures", help="recompute the paper's Figures 4–9 with the reference solver")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (maps are kept under DIR/maps)")
    p.add_argument("--resolution", type=str, default="100", metavar="N", help="points per axis (default 100)")
    p.add_argument("--figure", action="append", default=None, metavar="N", help="only figure N (4–9; repeatable)")
    p.add_argument("--jobs", type=str, default=None, metavar="N", help="worker processes (default: all cores)")
    p.add_argument("--serial", action="store_true", help="run in this process")
    p.add_argument("--json", action="store_true", help="print the written files as JSON")
    add_figure_format_option(p, default="png,svg")
    p.set_defaults(func=run)


def run(args) -> int:
    try:
        n = int(args.resolution)
    except ValueError:
        raise ConfigError(f"--resolution must be a whole number >= 2, got {args.resolution!r}.") from None
    if n < 2:
        raise ConfigError(f"--resolution must be a whole number >= 2, got {args.resolution!r}.")
    figs = None
    if args.figure:
        try:
            figs = [int(f) for f in args.figure]
        except ValueError:
            raise ConfigError(f"--figure takes numbers 4–9, got {args.figure!r}.") from None
        bad = [f for f in figs if f not in FIGURES]
        if bad:
            raise ConfigError(f"--figure takes numbers 4–9, got {bad[0]}.")
    jobs = jobs_from_args(args)
    formats = figure_formats_from_args(args)
    check_output_dir(args.out, "--out")
    out = make_figures(args.out, resolution=n, figures=figs, jobs=jobs, serial=args.serial,
                       progress=not args.json and sys.stderr.isatty(), formats=formats)
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        for num, paths in out["figures"].items():
            print(f"Fig. {num}: {', '.join(paths)}")
    return 0
