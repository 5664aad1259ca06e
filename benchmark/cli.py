"""The ``rockbench`` command line (CLI.md): parse, call one Python function, map errors to exit codes.

Each subcommand lives in :mod:`rockbench.benchmark.commands` as a module with a
``register(subparsers)`` function; :data:`COMMANDS` lists them in the order ``--help`` shows.
Exit codes: 0 done, 1 a gate failed (or ``simulate``'s simulation failed), 2 bad usage or input
(including a file that cannot be read or written), 3 engine unavailable, 5 results not comparable,
70 internal error, 130 interrupted by Ctrl-C (SIGINT), 143 stopped by SIGTERM.

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

from ..reference_solver.errors import RockbenchError

#: subcommand modules under rockbench.benchmark.commands
COMMANDS = ["blocks", "simulate", "map", "figures", "engines", "check-adapter", "calibrate", "score", "compare",
            "report", "run"]


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


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="rockbench", description="How faithfully do physics engines reproduce a rocking "
                     "and overturning rigid block? Reference solver, engine adapters, stability maps, scores.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    parser.add_argument("--version", action="store_true", help="print the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMANDS:
        importlib.import_module(f"{__package__}.commands.{name.replace('-', '_')}").register(sub)
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
        if old_term is not None:
            signal.signal(signal.SIGTERM, old_term)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
