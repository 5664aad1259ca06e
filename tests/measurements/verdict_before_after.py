"""The default suite's verdict before and after a change of rules: one row per engine variant.

    python tests/measurements/verdict_before_after.py BEFORE.json AFTER_SCORE.json [--markdown]

BEFORE.json is a verdict record (tests/measurements/results/verdict-default.json and the like: the verdict's variants with
value, 95 % interval and rank, and per variant the spurious invalid cells summed over its like-for-like
pairs); AFTER_SCORE.json is a run's score.json (or a record like BEFORE). Prints per variant: value,
interval, rank (or "fails", or "held out"), spurious invalid cells (like-for-like pairs), before and
after; variants stored under an old name (``settings=defaults``) are read under today's by this
script's own table of the renames made before 0.1.0 (:data:`OLD_NAMES`: the verdict records kept here
predate them; rockbench itself no longer reads an old name).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

#: the renames made before 0.1.0, per engine (settings) and for every engine (``settings`` values): the
#: history the verdict records in results/ were written under
OLD_NAMES = {
    "mujoco": {"timeconst": "timeconst_s"},
    "pybullet": {"contact_stiffness": "contact_stiffness_n_m", "contact_damping": "contact_damping_n_s_m",
                 "contact_breaking_threshold": "contact_breaking_threshold_m", "restitution_coef": "contact_restitution"},
    "dart": {"restitution_coeff": "contact_restitution"},
    "physx": {"restitution_coeff": "contact_restitution"},
    "exudyn": {"chunk_s": "segment_s", "max_tail_s": "tail_s", "stiffness_n_m": "contact_stiffness_n_m",
               "damping_n_s_m": "contact_damping_n_s_m"},
}
OLD_VALUES = {"settings": {"defaults": "shipped"}}


def canonical_variant(name: str) -> str:
    """A variant name ``engine[k=v,...]`` under today's names (:data:`OLD_NAMES`); another form as it is."""
    engine, bracket, inner = str(name).partition("[")
    if not bracket or not inner.endswith("]"):
        return name
    parts = [p.partition("=") for p in inner[:-1].split(",")]
    if any(not eq or not k for k, eq, _ in parts):
        return name
    renamed = OLD_NAMES.get(engine, {})
    new = {renamed.get(k, k): OLD_VALUES.get(k, {}).get(v, v) for k, _, v in parts if k != "dt"}
    dt = [f"dt={v}" for k, _, v in parts if k == "dt"]
    return f"{engine}[{','.join([f'{k}={v}' for k, v in sorted(new.items())] + dt)}]"


def spurious_invalid(doc: dict) -> dict:
    """Spurious invalid cells per variant, summed over its like-for-like pairs."""
    out: dict = {}
    for p in doc.get("pairs", []):
        if p.get("like_for_like"):
            v = p["variant"]
            out[v] = out.get(v, 0) + int(p["scores"].get("spurious_invalid") or 0)
    return out


def rows_of(verdict: dict, spurious: dict) -> dict:
    """``{variant: (label, value, [lo, hi], rank or 'fails', spurious)}``, variants under today's names
    (a record stored before a rename pairs with a run after it)."""
    out = {}
    spurious = {canonical_variant(k): n for k, n in spurious.items()}
    for r in verdict["variants"]:
        rank = "fails" if r.get("fails") else r.get("rank")
        if rank is None and r.get("held_out"):
            rank, value, ci = "held out", r["held_out"]["value"], r["held_out"]["ci95"]
        else:
            value, ci = r.get("value"), r.get("ci95")
        name = canonical_variant(r["variant"])
        out[name] = (r["label"], value, ci, rank, spurious.get(name))
    return out


def _fmt(v, ci) -> str:
    if v is None:
        return "–"
    return f"{v:.3g} [{ci[0]:.3g}, {ci[1]:.3g}]" if ci else f"{v:.3g}"


def table(before: dict, after: dict) -> str:
    lines = ["| engine variant | before: value [95 %] | rank | spurious invalid | after: value [95 %] | rank | spurious invalid |",
             "|---|---|---|---|---|---|---|"]
    for k in sorted(set(before) | set(after), key=lambda k: (after.get(k) or before.get(k))[0]):
        b, a = before.get(k), after.get(k)
        label = (a or b)[0]
        cells = [_fmt(b[1], b[2]) if b else "not run", str(b[3]) if b else "", str(b[4]) if b else "",
                 _fmt(a[1], a[2]) if a else "not run", str(a[3]) if a else "", str(a[4]) if a else ""]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    a = ap.parse_args()
    b = json.loads(a.before.read_text())
    b = b.get("figures", b)       # a benchmark record holds the verdict among its figures
    c = json.loads(a.after.read_text())
    c = c.get("figures", c)       # a score.json, or a record like BEFORE
    print(table(rows_of(b["verdict"], b.get("spurious_invalid", {})),
                rows_of(c["verdict"], c.get("spurious_invalid") or spurious_invalid(c))))


if __name__ == "__main__":
    main()
