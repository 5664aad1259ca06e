"""Cell by cell differences of one engine variant's maps between two run folders (the skeleton_alt experiment).

For each map of the variant (``maps/<folder>/<block>-<pulse>-<restitution>/cells.csv``) counts the
cells simulated in only one run (adaptive refinement follows the outcomes) and, among the cells of
both, those whose outcome, validity flags or n_impacts differ; ``--show MAP`` lists those cells::

    python tests/measurements/probes/skeleton_alt/alt_cells.py OLD_RUN NEW_RUN mujoco-settings=calibrated [--show B3M-sine-housner]
"""

from __future__ import annotations

import argparse
import csv
from collections import Counter
from pathlib import Path


def cells(path: Path) -> dict:
    """``{(i, j): row}`` of the finished cells of a map's cells.csv."""
    with open(path, newline="") as f:
        return {(int(r["i"]), int(r["j"])): r for r in csv.DictReader(f) if r["status"] == "ok"}


def compare(old: dict, new: dict) -> tuple[Counter, list]:
    """Counts of the kinds of change and the changed cells ``(i, j, w, a, old, new)``."""
    n = Counter(only_old=len(old.keys() - new.keys()), only_new=len(new.keys() - old.keys()))
    changed = []
    for k in sorted(old.keys() & new.keys()):
        a, b = old[k], new[k]
        kinds = [f for f in ("outcome", "flags", "n_impacts") if a[f] != b[f]]
        for f in kinds:
            n[f] += 1
        if kinds:
            n["any"] += 1
            changed.append((*k, float(a["w_ratio"]), float(a["a_ratio"]),
                            (a["outcome"], a["flags"], a["n_impacts"]), (b["outcome"], b["flags"], b["n_impacts"])))
    n["both"] = len(old.keys() & new.keys())
    return n, changed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("folder")
    ap.add_argument("--show", help="list the changed cells of this map")
    a = ap.parse_args()
    for d in sorted((a.old / "maps" / a.folder).iterdir()):
        if not (d / "cells.csv").is_file():
            continue
        n, changed = compare(cells(d / "cells.csv"), cells(a.new / "maps" / a.folder / d.name / "cells.csv"))
        print(f"{d.name:22s} cells in both {n['both']}, only old {n['only_old']}, only new {n['only_new']}; "
              f"changed {n['any']}: outcome {n['outcome']}, flags {n['flags']}, n_impacts {n['n_impacts']}")
        if a.show == d.name:
            for i, j, w, ar, o, x in changed:
                print(f"    ({i:2d},{j:2d}) ω/p {w:5.2f} a {ar:5.2f}: {o} → {x}")


if __name__ == "__main__":
    main()
