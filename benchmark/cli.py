"""The ``rockbench`` command line (CLI.md): parse, call one Python function, map errors to exit codes.

Each subcommand lives in :mod:`rockbench.benchmark.commands` as a module with a
``register(subparsers)`` function; :data:`COMMANDS` lists them in the order ``--help`` shows.
Exit codes: 0 done, 1 a gate failed, 2 bad usage or input, 3 engine unavailable, 5 results not
comparable, 70 internal error.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ..reference_solver.errors import RockbenchError

#: subcommand modules under rockbench.benchmark.commands
COMMANDS = ["blocks", "simulate", "map", "figures", "engines", "check-adapter", "calibrate"]


class UsageError(Exception):
    """argparse found bad usage; carries its message (exit code 2)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2, no usage dump
        raise UsageError(f"{self.prog}: {message} (see `{self.prog} --help`)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="rockbench", description="How faithfully do physics engines reproduce a rocking "
                     "and overturning rigid block? Reference solver, engine adapters, stability maps, scores.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    parser.add_argument("--version", action="store_true", help="print the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMANDS:
        importlib.import_module(f"{__package__}.commands.{name.replace('-', '_')}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``rockbench`` console script; returns the exit code."""
    argv = sys.argv[1:] if argv is None else argv
    debug = "--debug" in argv
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if args.version:
            from importlib.metadata import version
            print(version("rockbench"))
            return 0
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)
            return 2
        return int(args.func(args) or 0)
    except UsageError as e:
        print(str(e), file=sys.stderr)
        return 2
    except RockbenchError as e:
        if debug:
            raise
        print(f"rockbench: error: {e}", file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt:
        print("rockbench: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except Exception as e:  # noqa: BLE001 - last resort: one line and code 70
        if debug:
            raise
        print(f"rockbench: internal error: {type(e).__name__}: {e} (rerun with --debug for the traceback)",
              file=sys.stderr)
        return 70


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
