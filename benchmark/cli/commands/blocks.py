"""``rockbench blocks``: the presets of Table 1 with α, R, p, η_H and η_M."""

from __future__ import annotations

import json

from ...blocks.presets import PRESETS


def register(sub) -> None:
    p = sub.add_parser("blocks", help="the preset blocks (paper Table 1) with α, R, p, η_H, η_M")
    p.add_argument("--json", action="store_true", help="machine-readable output on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    rows = [pre.row() for pre in PRESETS.values()]
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    head = f"{'block':6} {'m [g]':>7} {'b [mm]':>7} {'h [mm]':>7} {'α [rad]':>8} {'R [mm]':>7} {'p [rad/s]':>9} " \
           f"{'η_H':>7} {'k avg':>6} {'η_M avg':>7} {'k ex':>6} {'η_M ex':>7}"
    print(head)
    for r in rows:
        print(f"{r['name']:6} {r['mass_kg'] * 1e3:7.1f} {r['width_m'] * 1e3:7.2f} {r['height_m'] * 1e3:7.2f} "
              f"{r['alpha_rad']:8.4f} {r['half_diagonal_m'] * 1e3:7.1f} {r['p_rad_s']:9.3f} {r['eta_housner']:7.4f} "
              f"{r['k_average']:6.4f} {r['eta_modified_average_k']:7.4f} {r['k_exact']:6.4f} "
              f"{r['eta_modified_exact_k']:7.4f}")
    return 0
