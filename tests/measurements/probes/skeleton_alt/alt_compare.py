"""Compare the score.json of two run folders of the same suite (the skeleton_alt experiment), pair by pair.

Pairs are matched by key; a pair against a changed variant's own-η reference map is matched to the
one at the variant's new own η (block by block, from each folder's calibration.json), so the count
covers every pair. Prints how many per-pair values differ (by variant and by reference kind), the
largest changes of ``agreement`` and ``boundary_mean``, and each variant's verdict (value, rank,
fails) before and after::

    python tests/measurements/probes/skeleton_alt/alt_compare.py rockbench-results/default rockbench-results/alt-A [--json OUT.json]
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

VALUE_KEYS = ("filled_cells", "cells_in_domain", "cells_outside_domain", "cells_outside_domain_simulated",
              "invalid_cells", "like_for_like")


def own_eta_moves(old_dir: Path, new_dir: Path) -> dict:
    """``{(block, old η label): new η label}`` for the variants whose own η changed."""
    def etas(d):
        return {(m["variant"], m["block"]): m.get("eta_measured")
                for m in json.loads((d / "calibration.json").read_text())["measurements"]}
    a, b = etas(old_dir), etas(new_dir)
    return {(k[1], f"{a[k]:.4g}"): f"{b[k]:.4g}" for k in a
            if k in b and a[k] is not None and b[k] is not None and a[k] != b[k]}


def pair_values(doc: dict, moves: dict | None = None) -> dict:
    """``{(pair key, field): value}`` over every pair, own-η keys renamed by ``moves``."""
    out = {}
    for p in doc["pairs"]:
        key = p["key"]
        head, _, vs = key.rpartition(" | vs ")
        if moves and (p["block"], vs) in moves:
            key = f"{head} | vs {moves[(p['block'], vs)]}"
        for group in ("scores", "cells"):
            for m, v in (p.get(group) or {}).items():
                out[(key, f"{group}.{m}")] = v
        for k in VALUE_KEYS:
            out[(key, k)] = p.get(k)
    return out


def largest(va: dict, vb: dict, field: str):
    """The largest |new − old| of ``field`` over the matched pairs, and its pair key."""
    best = (0.0, None, None, None)
    for (key, f), x in va.items():
        y = vb.get((key, f))
        if f == field and isinstance(x, (int, float)) and isinstance(y, (int, float)) and abs(y - x) > best[0]:
            best = (abs(y - x), key, x, y)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    da, db = (json.loads((d / "score.json").read_text()) for d in (a.old, a.new))
    moves = own_eta_moves(a.old, a.new)
    va, vb = pair_values(da, moves), pair_values(db)
    diff = [k for k in set(va) & set(vb) if repr(va[k]) != repr(vb[k])]
    pairs_changed = {k[0] for k in diff}
    print(f"own η moved (block, old → new): {sorted((k[0], k[1], v) for k, v in moves.items())}")
    print(f"values: {len(va)} vs {len(vb)}; unmatched old {len(set(va) - set(vb))}, new {len(set(vb) - set(va))}; "
          f"different {len(diff)} in {len(pairs_changed)} of {len(da['pairs'])} pairs")
    by_variant = Counter(k.split(" | ")[0] for k in pairs_changed)
    print("changed pairs by variant:", dict(by_variant))
    for field in ("scores.agreement", "scores.boundary_mean"):
        d, key, x, y = largest(va, vb, field)
        print(f"largest change of {field}: {d:.4g} ({key}: {x} → {y})")
    lfl = sorted({k[0] for k in diff if va.get((k[0], "like_for_like"))})
    for key in lfl:
        print(f"  like for like {key}: agreement {va[(key, 'scores.agreement')]:.4f} → "
              f"{vb[(key, 'scores.agreement')]:.4f}, boundary_mean {va[(key, 'scores.boundary_mean')]:.4g} → "
              f"{vb[(key, 'scores.boundary_mean')]:.4g}, invalid_cells {va[(key, 'invalid_cells')]} → "
              f"{vb[(key, 'invalid_cells')]}")
    vo = {v["variant"]: v for v in da["verdict"]["variants"]}
    vn = {v["variant"]: v for v in db["verdict"]["variants"]}
    same = json.dumps(da["verdict"], sort_keys=True) == json.dumps(db["verdict"], sort_keys=True)
    print(f"verdict identical: {same}")
    rows = []
    for name in vo:
        o, n = vo[name], vn.get(name, {})
        rows.append({"variant": name, "old": [o.get("value"), o.get("rank"), o.get("fails")],
                     "new": [n.get("value"), n.get("rank"), n.get("fails")]})
        print(f"  {name:32s} boundary_mean {o.get('value'):.4g} → {n.get('value'):.4g}; "
              f"rank {o.get('rank')} → {n.get('rank')}; fails {o.get('fails')} → {n.get('fails')}")
    if a.json:
        a.json.write_text(json.dumps({"moves": {f"{k[0]} {k[1]}": v for k, v in moves.items()},
                                      "different": len(diff), "pairs_changed": len(pairs_changed),
                                      "by_variant": by_variant, "verdict_identical": same, "verdict": rows},
                                     indent=2, default=str))


if __name__ == "__main__":
    main()
