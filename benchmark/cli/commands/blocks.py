"""``rockbench blocks``: the preset blocks with α, R, p, η_H and η_M (Table 1's four, and two from the
paper's measured range, marked)."""

from __future__ import annotations

import json

from rockbench.benchmark.blocks.presets import PRESETS


def register(sub) -> None:
    p = sub.add_parser("blocks", help="the preset blocks (paper Table 1, and two from its measured range) with α, R, p, "
                       "η_H, η_M")
    p.add_argument("--json", action="store_true", help="machine-readable output on stdout")
    p.set_defaults(func=run)


def _or_dash(x, fmt: str, width: int) -> str:
    return f"{'—':>{width}}" if x is None else f"{x:{width}{fmt}}"


def run(args) -> int:
    rows = [pre.row() for pre in PRESETS.values()]
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    head = f"{'block':6} {'h/b':>5} {'m [g]':>7} {'b [mm]':>7} {'h [mm]':>7} {'α [rad]':>8} {'R [mm]':>7} " \
           f"{'p [rad/s]':>9} {'η_H':>7} {'k avg':>6} {'η_M avg':>7} {'k ex':>6} {'η_M ex':>7}"
    print(head)
    for r in rows:
        print(f"{r['name']:6} {r['h_over_b']:5.2f} {r['mass_kg'] * 1e3:7.1f} {r['width_m'] * 1e3:7.2f} "
              f"{r['height_m'] * 1e3:7.2f} {r['alpha_rad']:8.4f} {r['half_diagonal_m'] * 1e3:7.1f} {r['p_rad_s']:9.3f} "
              f"{r['eta_housner']:7.4f} {r['k_average']:6.4f} {r['eta_modified_average_k']:7.4f} "
              f"{_or_dash(r['k_exact'], '.4f', 6)} {_or_dash(r['eta_modified_exact_k'], '.4f', 7)}"
              + (f"  {r['note']}" if r["note"] else ""))
    notes = [r for r in rows if r["note"]]
    if notes:
        print(f"{', '.join(r['name'] for r in notes)}: medium blocks inside the h/b range 1.5–9.75 of the nine "
              "blocks whose average k the paper quotes (its §3.1); named as Table 1 numbers h/b in steps of 0.75 "
              "(inferred); mass from the mean density of Table 1's blocks; no k of their own was measured (—), so "
              "no η_M with an exact k and no shaking-table points.")
    return 0
