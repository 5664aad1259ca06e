"""A stored verdict record re-scored with this rockbench's verdict (no map needed).

    python tests/measurements/verdict_rescore.py RECORD.json [--json | --write]

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

from rockbench.benchmark.scoring.metrics import METRICS_VERSION
from rockbench.benchmark.scoring.scenarios import RESOLUTION_SD_LOCATED, resolution_share
from rockbench.benchmark.scoring.verdict import verdict
from rockbench.benchmark.report.verdict_words import number, sentences, short_verdict, words

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
            missing = _missing_boundary(s)
            p = {"variant": r["variant"], "engine": r["engine"], "label": r["label"], "settings": r["settings"],
                 "block": s["block"], "pulse": s["pulse"], "like_for_like": True, "slenderness": s["cluster"][0],
                 "scores": {"boundary_mean": _placeholder(s) if missing else s["value"]},
                 "cells": {"w_step": step, "a_step": step, "locate_depth": _depth(s), "engine_crossings": int(missing != "engine"),
                           "reference_crossings": int(missing != "reference")},
                 "held_out": s["held_out"], **{k: v // n for k, v in counts.items()}}
            if s["held_out"] and held.get("in_sample_variant"):
                p["in_sample_variant"] = held["in_sample_variant"]
            if r.get("planted"):
                p["planted_eta_factor"] = r["planted"]["eta_factor"]
            if r.get("shipped_note"):
                p["shipped_note"] = r["shipped_note"]
            pairs.append(p)
    return pairs


def _missing_boundary(s: dict) -> str:
    """Which map of a stored scenario has no boundary: the record's ``missing_boundary`` where it has one;
    in a record written before it did, ``"engine"`` where the value is the map's diagonal, the distance
    ``boundary_mean`` writes for a missing boundary (a whole number, at least 10, of cell diagonals: the
    diagonal of a square grid; the default suite's reference has a boundary in every scenario)."""
    if "missing_boundary" in s:
        return s["missing_boundary"] or ""
    if s["value"] is None:
        return ""
    cells = s["value"] / s["cell_diagonal"]
    return "engine" if cells >= 10 and abs(cells - round(cells)) < 1e-9 * cells else ""


def _depth(s: dict) -> int:
    """The shallowest bisection depth whose share of the cell diagonal gives the stored scenario's own
    error (:func:`~rockbench.benchmark.scoring.scenarios.resolution_share`), so the re-scored error is
    the record's; 0 where none does."""
    share = s["sd"] / s["cell_diagonal"]
    return next((d for d in sorted(RESOLUTION_SD_LOCATED) if math.isclose(resolution_share(d), share, rel_tol=1e-6)), 0)


def _placeholder(s: dict) -> float:
    """The value a missing boundary's pair holds (the map's diagonal; never read as a distance)."""
    return s["value"] if s["value"] is not None else 1e9


def without_cell_shares(v: dict) -> dict:
    """The verdict with the failing scenarios' cell shares removed: a record keeps each variant's reasons,
    not each scenario's cells, so the shares :func:`pairs_of` rebuilds are the variant's spread evenly,
    not the scenario's."""
    for r in v["variants"]:
        for b in r["fails_in"]:
            b.update(missed=None, extra=None)
    return v


def gaps_of(record_verdict: dict) -> list[dict]:
    seen = {}
    for r in record_verdict["variants"]:
        for s in r["per_scenario"]:
            if s.get("reference_gap") is not None:
                seen[(s["block"], s["pulse"])] = s["reference_gap"]
    return [{"block": b, "pulse": p, "boundary_mean": g} for (b, p), g in sorted(seen.items())]


#: What a re-score changes in a record's variant: the rest (cells judged, cell counts, the classes'
#: comparisons) is the run's, which the record's per-scenario values cannot rebuild exactly.
_RESCORED = ("value", "se", "ci95", "basis", "scenarios_with_value", "clusters", "fails_in", "equivalence", "general",
             "held_out",
             "rank", "scope", "in_best_subset", "best_in_class", "behind_best", "on_suite", "across", "offset",
             "offset_percent")


def _write(path: Path, rec: dict, v: dict) -> None:
    """The record with the parts of its verdict the per-scenario values decide re-scored (:data:`_RESCORED`,
    each scenario's value and missing boundary); no map is read again."""
    fig = rec["figures"]
    old = fig["verdict"]
    new = {r["variant"]: r for r in v["variants"]}
    for r in old["variants"]:
        n = new[r["variant"]]
        r.update({k: n[k] for k in _RESCORED})
        for s, t in zip(r["per_scenario"], n["per_scenario"]):
            s.update({k: t[k] for k in ("value", "missing_boundary", "relative_to_gap", "offset", "offset_percent",
                                        "sd_source", "sd_assumed")})
    for cls, fam in old["mcb"].items():
        fam.update(scope=v["mcb"][cls]["scope"], across=v["mcb"][cls]["across"])
    for words_key in ("method", "text", "short"):   # the verdict holds numbers only (metrics 9): words are the report's
        old.pop(words_key, None)
    first = fig.get("rescored", {}).get("from_metrics_version", fig["metrics_version"])
    fig["rescored"] = {"from_metrics_version": first, "by": "tests/measurements/verdict_rescore.py --write",
                       "what": "the verdict's values, intervals, failures and words recomputed from the stored "
                               "per-scenario distances; the maps were not scored again, so metrics new since the "
                               "run are absent"}
    fig["metrics_version"] = METRICS_VERSION
    path.write_text(json.dumps(rec, indent=1, ensure_ascii=False) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("record", type=Path)
    ap.add_argument("--json", action="store_true", help="print the verdict object")
    ap.add_argument("--write", action="store_true",
                    help="replace the record's verdict with the re-scored one, at today's metrics version, and say so "
                         "in its figures' 'rescored' (its maps, commit and timings stay the run's)")
    a = ap.parse_args()
    rec = json.loads(a.record.read_text())
    rv = rec.get("figures", rec)["verdict"]
    v = without_cell_shares(verdict({"pairs": pairs_of(rv), "reference_gaps": gaps_of(rv)}))
    if a.write:
        _write(a.record, rec, v)
        return
    if a.json:
        print(json.dumps(v, indent=1, ensure_ascii=False))
        return
    short = short_verdict(v)
    print(f"Short verdict ({words(short)} words):")
    for t in short:
        print("  " + t)
    print("\nIn full:")
    for t in sentences(v):
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
