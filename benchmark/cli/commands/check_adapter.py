"""``rockbench check-adapter NAME``: the conformance suite on a registered adapter.

Exit codes: 0 every check passed, 1 a check failed (the report says which), 2 unknown engine,
3 engine not installed. An installed version outside the supported range (pyproject's extras, a
plugin's ``SUPPORTED_VERSIONS``, see :mod:`rockbench.engines.support`) is said on stderr before the report.
"""

from __future__ import annotations

import json
import sys

from rockbench.reference_solver.errors import check_positive
from rockbench.engines.checker import check_adapter
from rockbench.engines.support import install_advice, outside_range, supported_range
from rockbench.benchmark.engine_info.adapters import build_adapter
from rockbench.benchmark.request import CaseRequest


def register(sub) -> None:
    p = sub.add_parser("check-adapter", help="run the adapter conformance suite on an engine")
    p.add_argument("name", help="engine name (see `rockbench engines`)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="an engine setting (repeatable)")
    p.add_argument("--dt", default=None, metavar="SECONDS",
                   help="run every check at this time step [s] (default: the engine's own; for a calibrated engine "
                        "the time-step rule's, whose calibrations at each step of its ladder take long on a slow engine)")
    p.add_argument("--json", action="store_true", help="machine-readable report on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    adapter = build_adapter(args.name, **CaseRequest.from_args(args).engine_settings())
    cls = type(adapter)   # a plugin declares its range on its class
    outside = outside_range(cls)
    if outside:
        print(f"rockbench: warning: {outside}; {install_advice(cls)} for a supported one.", file=sys.stderr)
    rep = check_adapter(adapter, dt_s=None if args.dt is None else check_positive("--dt", args.dt, "s"))
    if args.json:
        print(json.dumps({**rep.to_dict(), "supported": supported_range(cls), "outside_range": outside},
                         indent=2))
    else:
        print(rep.text())
    return 0 if rep.passed else 1
