"""``rockbench check-adapter NAME``: the conformance suite on a registered adapter.

Exit codes: 0 every check passed, 1 a check failed (the report says which), 2 unknown engine,
3 engine not installed.
"""

from __future__ import annotations

import json

from ...engines.checker import check_adapter
from ...engines.registry import get_adapter
from ..cli_options import engine_settings_from_args


def register(sub) -> None:
    p = sub.add_parser("check-adapter", help="run the adapter conformance suite on an engine")
    p.add_argument("name", help="engine name (see `rockbench engines`)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="an engine setting (repeatable)")
    p.add_argument("--json", action="store_true", help="machine-readable report on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    adapter = get_adapter(args.name, **engine_settings_from_args(args))
    rep = check_adapter(adapter)
    if args.json:
        print(json.dumps(rep.to_dict(), indent=2))
    else:
        print(rep.text())
    return 0 if rep.passed else 1
