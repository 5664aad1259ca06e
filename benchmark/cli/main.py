"""The ``rockbench`` command line (docs/cli.md): parse, call one Python function, map errors to exit codes.

Each subcommand lives in :mod:`rockbench.benchmark.cli.commands` as a module with a
``register(subparsers)`` function; :data:`COMMANDS` lists them in the order ``--help`` shows, with
the help line ``rockbench --help`` prints. Only the module of the command that runs is imported
(``rockbench --help`` and ``rockbench blocks`` start in a fraction of the time importing all of
them, numpy and numba included, would take); the others appear in ``--help`` as one-line stubs
(a test keeps those lines equal to the modules' own).

Exit codes: 0 done, 1 a gate failed (or ``simulate``'s simulation failed), 2 bad usage or input
(including a file that cannot be read or written), 3 engine unavailable, 5 results not comparable,
70 internal error, 130 interrupted by Ctrl-C (SIGINT), 143 stopped by SIGTERM.

The engines' progress lines (a long calibration, the time-step rule, Warp's first kernel compile:
:mod:`rockbench.engines.progress`) go to stderr as ``rockbench: ...`` lines for every command
(:func:`rockbench.benchmark.suites.progress.show_engine_progress`); stdout stays the command's own.

SIGTERM is handled like Ctrl-C: it raises :class:`Terminated` (a ``KeyboardInterrupt``) in the
main thread, so the same clean-up runs (worker processes stopped, finished cells kept).
"""

from __future__ import annotations

import argparse
import errno
import importlib
import signal
import sys
import threading
from importlib.metadata import version

from rockbench.reference_solver.errors import RockbenchError
from rockbench.benchmark.suites.progress import hide_engine_progress, show_engine_progress

#: subcommands (modules under rockbench.benchmark.cli.commands, ``-`` written ``_``) and their help lines
COMMANDS = {
    "blocks": "the preset blocks (paper Table 1, and two from its measured range) with α, R, p, η_H, η_M",
    "simulate": "one simulation: outcome, impacts, θ(t) history and plot",
    "map": "a stability map over ω/p × a0/(g·tanα) (or ω × a0) into a run directory",
    "figures": "recompute the paper's Figures 4–9 with the reference solver",
    "engines": "the engines: available or not, version, why not",
    "check-adapter": "run the adapter conformance suite on an engine",
    "calibrate": "measure an engine's η in free rocking; with --target, search its contact settings to reach it",
    "score": "score engine maps against reference maps; gate with --fail-under",
    "compare": "compare two scored runs; exit 1 on a regression beyond the tolerance",
    "report": "write the benchmark report (index.html, report.md) for run directories",
    "run": "the whole benchmark: every engine, block and pulse, reference maps, scores, report (a suite file; "
           "default: the shipped suite 'default', see --show-suite)",
    "versions": "one engine release against another: a cached environment per version, the same suite in each, "
                "compare's verdict",
}


class UsageError(Exception):
    """argparse found bad usage; carries its message (exit code 2)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived: unwinds like Ctrl-C (exit code 143)."""


def _on_sigterm(signum, frame):
    raise Terminated()


def _file_error(e: OSError) -> str:
    """One line for a file the system refused: which file, what the system said, what to do."""
    why = e.strerror or str(e)
    code = errno.errorcode.get(e.errno, "") if e.errno else ""
    hint = {errno.ENOSPC: "free some space and rerun (finished cells are kept)",
            errno.EDQUOT: "free some space and rerun (finished cells are kept)",
            errno.EROFS: "choose a folder on a writable file system",
            errno.ENAMETOOLONG: "choose a shorter name",
            errno.EISDIR: "give a file name, not a folder"}.get(e.errno, "check the path and its permissions")
    name = e.filename2 if e.filename2 is not None else e.filename   # a rename names its target second
    what = f"cannot use {str(name)!r}" if name is not None else f"the system refused ({type(e).__name__})"
    return f"{what}: {why}{f' ({code})' if code else ''}; {hint}."


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2, no usage dump
        raise UsageError(f"{self.prog}: {message} (see `{self.prog} --help`)")


def command_of(argv: list[str]) -> str | None:
    """The subcommand ``argv`` asks for: its first word that is not an option (the top-level
    options take no value), or None."""
    for a in argv:
        if a == "--":
            return None
        if not a.startswith("-"):
            return a
    return None


def build_parser(command: str | None = "*") -> argparse.ArgumentParser:
    """The parser with the full options of ``command`` (``"*"``: of every subcommand), the other
    subcommands as stubs that only name themselves in ``--help``."""
    parser = _Parser(prog="rockbench", description="How faithfully do physics engines reproduce a rocking "
                     "and overturning rigid block? Reference solver, engine adapters, stability maps, scores.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    parser.add_argument("--version", action="store_true", help="print the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, help_line in COMMANDS.items():
        if command == "*" or name == command:
            importlib.import_module(f"{__package__}.commands.{name.replace('-', '_')}").register(sub)
        else:
            sub.add_parser(name, help=help_line)
    return parser


def _one_line(text: str) -> str:
    """An error message as one line: line breaks that came in with a name or value from a file or
    the command line are shown escaped (``str.splitlines`` breaks at more than ``\\n``)."""
    lines = text.splitlines()
    if len(lines) <= 1:
        return text
    return "".join(c if (c + "x").splitlines() == [c + "x"] else repr(c)[1:-1] for c in text.rstrip("\n"))


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``rockbench`` console script; returns the exit code."""
    argv = sys.argv[1:] if argv is None else argv
    debug = "--debug" in argv
    old_term = None
    if threading.current_thread() is threading.main_thread():
        old_term = signal.signal(signal.SIGTERM, _on_sigterm)
    shown = show_engine_progress()
    try:
        parser = build_parser(command_of(argv))
        args = parser.parse_args(argv)
        if args.version:
            print(version("rockbench"))
            return 0
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)
            return 2
        return int(args.func(args) or 0)
    except UsageError as e:
        print(_one_line(str(e)), file=sys.stderr)
        return 2
    except RockbenchError as e:
        if debug:
            raise
        print(_one_line(f"rockbench: error: {e}"), file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt as e:
        how, code = ("SIGTERM", 143) if isinstance(e, Terminated) else ("Ctrl-C (SIGINT)", 130)
        print(f"rockbench: interrupted by {how}: workers stopped, finished cells kept; rerun the same command "
              "to resume", file=sys.stderr)
        return code
    except BrokenPipeError:
        return 0
    except OSError as e:   # the file system refused a path the user gave (full, read-only, too long, ...)
        if debug:
            raise
        print(_one_line(f"rockbench: error: {_file_error(e)}"), file=sys.stderr)
        return 2
    except Exception as e:  # noqa: BLE001 - last resort: one line and code 70
        if debug:
            raise
        print(_one_line(f"rockbench: internal error: {type(e).__name__}: {e} (rerun with --debug for the traceback)"),
              file=sys.stderr)
        return 70
    finally:
        hide_engine_progress(shown)
        if old_term is not None:
            signal.signal(signal.SIGTERM, old_term)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
