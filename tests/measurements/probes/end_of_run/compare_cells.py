"""Cell-by-cell comparison of two runs of the same maps (the record tests/measurements/results/end-of-run-rule.json).

    python compare_cells.py BEFORE_ROOT AFTER_ROOT MAP [MAP ...]

For each map folder name, the cells simulated in both runs (matched by grid index i, j): how many
changed status, outcome, n_impacts, validity or flags, the n_impacts changes of cells whose outcome
stayed, and the outcome, validity and flag changes by (before, after).
"""
import collections
import csv
import sys

FIELDS = ("status", "outcome", "n_impacts", "valid", "flags")


def load(folder: str) -> dict:
    with open(f"{folder}/cells.csv", newline="") as f:
        return {(r["i"], r["j"]): r for r in csv.DictReader(f)}


def compare(before: str, after: str) -> None:
    a, b = load(before), load(after)
    both = sorted(set(a) & set(b))
    changed, pairs = collections.Counter(), collections.defaultdict(collections.Counter)
    for k in both:
        x, y = a[k], b[k]
        diff = [f for f in FIELDS if x[f] != y[f]]
        changed.update(diff)
        changed["any"] += bool(diff)
        for f in diff:
            pairs[f][(x[f], y[f])] += 1
        if "n_impacts" in diff and "outcome" not in diff and x["n_impacts"] and y["n_impacts"]:
            changed["n_impacts %+d" % (int(y["n_impacts"]) - int(x["n_impacts"]))] += 1
    print(f"{after}: {len(a)} cells before, {len(b)} after, {len(both)} in both; changed: {dict(changed)}")
    for f in ("status", "outcome", "valid", "flags"):
        if pairs[f]:
            print(f"   {f}: {dict(pairs[f])}")


if __name__ == "__main__":
    for name in sys.argv[3:]:
        compare(f"{sys.argv[1]}/{name}", f"{sys.argv[2]}/{name}")
