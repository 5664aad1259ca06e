"""Whether two report folders hold the same report, byte for byte (exit 0 when they do, 1 when not).

    python tests/measurements/report_identity.py DIR_A DIR_B

Compares score.json, report.md, index.html and every file of img/ and trajectories/ (the file lists
too). The only bytes masked are the report's own time stamps: the page's "Generated ... UTC" and
score.json's ``created_utc``; a file that differs only there is reported as the same, stamps masked.
Both reports must be made from the same run folder path, since the pages and score.json name it.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

STAMP = re.compile(rb"(?<=Generated )\d{4}-\d\d-\d\d \d\d:\d\d UTC|(?<=\"created_utc\": \")[0-9T:Z-]+")
PAGES = ("score.json", "report.md", "index.html")


def report_files(root: Path) -> list[Path]:
    """The report's files under ``root``, relative to it."""
    found = [root / f for f in PAGES if (root / f).is_file()]
    for sub in ("img", "trajectories"):
        found += sorted((root / sub).glob("*"))
    return [p.relative_to(root) for p in found]


def differences(a: Path, b: Path) -> tuple[list[str], int]:
    """``(lines naming each difference, files compared)``."""
    fa, fb = report_files(a), report_files(b)
    out = [f"only in one: {name}" for name in sorted(set(map(str, fa)) ^ set(map(str, fb)))]
    for rel in (r for r in fa if r in fb):
        x, y = (a / rel).read_bytes(), (b / rel).read_bytes()
        if x != y and STAMP.sub(b"", x) == STAMP.sub(b"", y):
            print(f"same, stamps masked: {rel}")
        elif x != y:
            out.append(f"differs: {rel}")
    return out, len(fa)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2:
        print("usage: python tests/measurements/report_identity.py DIR_A DIR_B", file=sys.stderr)
        return 2
    diff, n = differences(Path(argv[0]), Path(argv[1]))
    print("\n".join(diff + [f"{n} files compared, {len(diff)} differ"]))
    return 1 if diff else 0


if __name__ == "__main__":
    sys.exit(main())
