"""Which engine versions a score document's pairs rest on, and what differs between two documents.

Each engine map's run.json records the engine's version (``engine.version``, from the adapter's
``describe``); :func:`version_of` reads it for a pair of score.json (``engine_version``), and
:func:`differences` tells `rockbench compare` which engines were compared at other versions, so a
verdict between two releases names them (``rockbench versions`` relies on it).
"""

from __future__ import annotations


def version_of(entry) -> str | None:
    """The engine version recorded in a map's run.json (``entry.run``), or None (an older run.json, a
    cells.csv alone)."""
    run = getattr(entry, "run", None) or {}
    eng = run.get("engine") if isinstance(run, dict) else None
    v = eng.get("version") if isinstance(eng, dict) else None
    return str(v) if v not in (None, "") else None


def versions_by_engine(doc: dict) -> dict[str, list[str]]:
    """``{engine: [versions, sorted]}`` over the pairs of a score document that record one."""
    out: dict[str, set] = {}
    for p in doc.get("pairs", []):
        v = p.get("engine_version")
        if v:
            out.setdefault(p["engine"], set()).add(str(v))
    return {e: sorted(vs) for e, vs in sorted(out.items())}


def differences(base: dict, cur: dict) -> list[dict]:
    """``[{"engine", "baseline", "current"}]`` for each engine whose recorded versions differ between
    the two score documents (an engine on one side only, or without versions, is left out)."""
    b, c = versions_by_engine(base), versions_by_engine(cur)
    return [{"engine": e, "baseline": ", ".join(b[e]), "current": ", ".join(c[e])}
            for e in sorted(set(b) & set(c)) if b[e] != c[e]]


def differences_line(base: dict, cur: dict) -> str | None:
    """One line naming the engine versions of both sides where they differ, e.g. ``"engine versions
    differ: mujoco 3.3.7 (baseline) → 4.0.0 (current)"``; None when they are the same or unknown."""
    diff = differences(base, cur)
    if not diff:
        return None
    return "engine versions differ: " + "; ".join(
        f"{d['engine']} {d['baseline']} (baseline) → {d['current']} (current)" for d in diff)
