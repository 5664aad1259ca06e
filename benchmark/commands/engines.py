"""``rockbench engines``: every known engine, whether it is available, its version, and why not (an
installed version outside the supported range is said there too)."""

from __future__ import annotations

import json

from ...engines.registry import availability, names


def register(sub) -> None:
    p = sub.add_parser("engines", help="the engines: available or not, version, why not")
    p.add_argument("--json", action="store_true", help="machine-readable output on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    rows = [availability(n) for n in names()]
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    w = max([len(r["engine"]) for r in rows] + [6])
    v = max([len(str(r["version"] or "-")) for r in rows] + [7])
    s = max([len(r.get("supported") or "-") for r in rows] + [9])
    print(f"{'engine':{w}}  {'available':9}  {'version':{v}}  {'supported':{s}}  why not")
    for r in rows:
        why = r["reason"] or ""
        if r.get("outside_range"):
            why = f"{r['outside_range']}: its maps may fail or differ" + (f"; {why}" if why else "")
        print(f"{r['engine']:{w}}  {'yes' if r['available'] else 'no':9}  {str(r['version'] or '-'):{v}}  "
              f"{r.get('supported') or '-':{s}}  {why}".rstrip())
    return 0
