"""``rockbench engines``: every known engine, whether it is available, its version, the versions rockbench
supports, and for a missing one, in one line, the module that cannot be imported and the command that
installs it (``--json`` has the whole error under ``reason``); an installed version outside the supported
range is said there too; a GPU-first engine without a GPU here says "CPU only (slow)" (``note``, also in
``--json``)."""

from __future__ import annotations

import json

from rockbench.engines.registry import adapter_class, availability, names


def register(sub) -> None:
    p = sub.add_parser("engines", help="the engines: available or not, version, why not")
    p.add_argument("--json", action="store_true", help="machine-readable output on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    rows = [{**availability(n), "note": ""} for n in names()]
    for r in rows:
        if r["available"]:
            r["note"] = adapter_class(r["engine"]).device_note()
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    table = [("engine", "available", "version", "supported", "note")]
    for r in rows:
        note = (r["note"] if r["available"] else f"cannot import {r['missing']}: {r['install']}".rstrip(": ")
                if r["missing"] else r["reason"])
        if r.get("outside_range"):
            note = f"{r['outside_range']}: its maps may fail or differ" + (f"; {note}" if note else "")
        table.append((r["engine"], "yes" if r["available"] else "no", str(r["version"] or "-"),
                      r.get("supported") or "-", note or ""))
    widths = [max(len(t[c]) for t in table) for c in range(4)]
    for t in table:
        print(("  ".join(f"{v:{w}}" for v, w in zip(t[:4], widths)) + "  " + t[4]).rstrip())
    return 0
