"""``rockbench engines``: every known engine, whether it is available, its version, and why not."""

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
    print(f"{'engine':{w}}  {'available':9}  {'version':12}  why not")
    for r in rows:
        why = r["reason"] or ""
        print(f"{r['engine']:{w}}  {'yes' if r['available'] else 'no':9}  {str(r['version'] or '-'):12}  {why}")
    return 0
