"""A stored verdict record re-scored with this rockbench's verdict (no map needed).

    python tests/measurements/verdict_rescore.py RECORD.json [--json]

RECORD.json is a verdict record (tests/measurements/results/verdict-default.json and the like): its
variants' per-scenario values, cell diagonals, reference gaps and held-out marks are turned back into
the pairs of a score document, and :func:`rockbench.benchmark.scoring.verdict.verdict` is computed on
them with the code's declarations (the default suite's). What a record does not keep is rebuilt from
what it does: a failing variant's cell counts from the percentages of its stored reasons (so the
reasons read alike), each scenario's grid error from its cell diagonal as the scores compute it
(:func:`rockbench.benchmark.scoring.scenarios.resolution_sd`). Prints the short verdict, the full
sentences and one line per variant (value, interval, class standing); ``--json`` prints the verdict.
"""

from __future__ import annotations

import argparse
import json
import math
import re
from pathlib import Path

from rockbench.benchmark.scoring.verdict import verdict
from rockbench.benchmark.scoring.verdict_words import number, words

#: A stored reason's words → the cell counts that give it back.
_REASONS = {"overturns in": ("overturn_extra", "reference_standing"),
            "stays standing in": ("overturn_missed", "reference_overturn"),
            "fails to simulate": ("failed_in_domain", "cells_in_domain"),
            "flags slip, jump": ("invalid_in_domain", "cells_in_domain")}


def _counts(reasons: list[str]) -> dict:
    out = {"cells_in_domain": 1000, "reference_standing": 1000, "reference_overturn": 1000}
    for text in reasons:
        for head, (part, whole) in _REASONS.items():
            if text.startswith(head):
                share = float(re.search(r"(\d+) %", text).group(1)) / 100
                out[part] = round(share * out[whole])
    return out


def pairs_of(record_verdict: dict) -> list[dict]:
    """The pairs of a score document, one per stored scenario of every variant."""
    pairs = []
    for r in record_verdict["variants"]:
        held = r.get("held_out") or {}
        counts = _counts(r.get("reasons") or [])
        n = len(r["per_scenario"])
        for s in r["per_scenario"]:
            step = s["cell_diagonal"] / math.sqrt(2)
            p = {"variant": r["variant"], "engine": r["engine"], "label": r["label"], "settings": r["settings"],
                 "block": s["block"], "pulse": s["pulse"], "like_for_like": True, "slenderness": s["cluster"][0],
                 "scores": {"boundary_mean": s["value"]}, "cells": {"w_step": step, "a_step": step},
                 "held_out": s["held_out"], **{k: v // n for k, v in counts.items()}}
            if s["held_out"] and held.get("in_sample_variant"):
                p["in_sample_variant"] = held["in_sample_variant"]
            if r.get("shipped_note"):
                p["shipped_note"] = r["shipped_note"]
            pairs.append(p)
    return pairs


def gaps_of(record_verdict: dict) -> list[dict]:
    seen = {}
    for r in record_verdict["variants"]:
        for s in r["per_scenario"]:
            if s.get("reference_gap") is not None:
                seen[(s["block"], s["pulse"])] = s["reference_gap"]
    return [{"block": b, "pulse": p, "boundary_mean": g} for (b, p), g in sorted(seen.items())]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("record", type=Path)
    ap.add_argument("--json", action="store_true", help="print the verdict object")
    a = ap.parse_args()
    rec = json.loads(a.record.read_text())
    rv = rec.get("figures", rec)["verdict"]
    v = verdict({"pairs": pairs_of(rv), "reference_gaps": gaps_of(rv)})
    if a.json:
        print(json.dumps(v, indent=1, ensure_ascii=False))
        return
    print(f"Short verdict ({words(v['short'])} words):")
    for t in v["short"]:
        print("  " + t)
    print("\nIn full:")
    for t in v["text"]:
        print("- " + t)
    print("\nPer variant: group, value [95 %], standing")
    for r in v["variants"]:
        ci = r["ci95"] or [math.nan, math.nan]
        standing = ("fails" if r["fails"] else "best subset" if r["in_best_subset"] else
                    "behind the best" if r["in_best_subset"] is False else "-")
        h = r["held_out"]
        extra = (f"; held out {number(h['value'])}, carries over: {h['carries_over']}" if h else "")
        print(f"  {r['group']:<10} {r['label']:<48} {number(r['value'])} [{number(ci[0])}, {number(ci[1])}] "
              f"{standing}{extra}")


if __name__ == "__main__":
    main()
