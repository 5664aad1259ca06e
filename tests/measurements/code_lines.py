"""Code lines of Python files: the lines that hold a token other than a comment, a docstring (of a
module, class or function, or a bare string after a statement) or blank space.

    python tests/measurements/code_lines.py engines/adapters/*.py

docs/engines.md reports the adapters' counts before and after the engine contract's refactor (issue 45)
with it.
"""

from __future__ import annotations

import argparse
import ast
import io
import sys
import tokenize
from pathlib import Path

_SKIP = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER,
         tokenize.ENCODING}


def _docstring_lines(tree: ast.AST) -> set[int]:
    out: set[int] = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if not isinstance(body, list):
            continue
        for k, stmt in enumerate(body):
            first = k == 0 and isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
            if (first or k > 0) and isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Constant) \
                    and isinstance(stmt.value.value, str):
                out.update(range(stmt.lineno, stmt.end_lineno + 1))
    return out


def code_lines(path) -> int:
    """The code lines of one Python file."""
    src = Path(path).read_text(encoding="utf-8")
    doc = _docstring_lines(ast.parse(src))
    lines: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(src).readline):
        if tok.type not in _SKIP:
            lines.update(ln for ln in range(tok.start[0], tok.end[0] + 1) if ln not in doc)
    return len(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="+", help="Python files")
    args = ap.parse_args(argv)
    for p in args.files:
        print(f"{code_lines(p):5d} {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
