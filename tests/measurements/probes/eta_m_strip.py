"""The B3M sine strip where η_M overturns and η_H does not, cell by cell.

ω/p = 4.5 and 4.75, a₀/(g·tanα) = 3.9 … 5.0 in steps of 0.1 (the issue's acceptance cells (4.5,
4.38) and (4.75, 4.6) lie in it): the reference with η_H and with η_M (average k), and each engine
calibrated to η_H (corners) and to η_M (the contact along the base). One letter per cell: O
overturn, R rocking (or rest); a lower-case letter is an invalid cell.

Run: ``python tests/measurements/probes/eta_m_strip.py``; writes the record ``tests/measurements/results/eta-m-strip.json``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.engines.contract import Case
from rockbench.engines.registry import availability, get_adapter
from rockbench.reference_solver.model import G
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution

# tests/measurements/ holds the one records writer
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from records import write_record  # noqa: E402

MEASURES = ("Cell by cell, the B3M sine strip (a₀/(g·tanα) 3.9-5.0) where the η_M reference overturns and the "
            "η_H reference rocks, for MuJoCo, Exudyn and PyBullet calibrated to each target.")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engines", default="mujoco,exudyn,pybullet")
    args = ap.parse_args()
    pr = PRESETS["B3M"]
    b = pr.block()
    A = G * math.tan(b.alpha_rad)
    aa = np.round(np.arange(3.9, 5.001, 0.1), 2)
    rests = {"η_H": Restitution("housner"), "η_M": Restitution("modified", k=pr.k_average)}
    rows = []
    for w in (4.5, 4.75):
        for eng in ["reference"] + [e for e in args.engines.split(",") if availability(e)["available"]]:
            for label, rest in rests.items():
                res = get_adapter(eng).run_many([Case(b, make_pulse("sine", a * A, w * b.p_rad_s), rest) for a in aa])
                letters = "".join(("O" if r.outcome == "overturn" else "R") if r.valid else
                                  ("o" if r.outcome == "overturn" else "r") for r in res)
                n_o = sum(r.outcome == "overturn" for r in res)
                rows.append((w, eng, label, letters, n_o))
                print(w, eng, label, letters, flush=True)
    lines = [f"B3M sine, a₀/(g·tanα) = {aa[0]:g} … {aa[-1]:g} (step 0.1), one letter per cell: O overturn, "
             "R rocking/rest, lower case: invalid.", "",
             "| ω/p | engine | calibrated to / restitution | cells | overturns |", "|---|---|---|---|---|"]
    lines += [f"| {w:g} | {eng} | {label} | `{letters}` | {n} of {len(letters)} |" for w, eng, label, letters, n in rows]
    out = write_record("eta-m-strip", MEASURES, "python tests/measurements/probes/eta_m_strip.py",
                       {"table_md": "\n".join(lines) + "\n"}, packages=("mujoco", "pybullet", "exudyn"))
    print("\n".join(lines))
    print("wrote", out)


if __name__ == "__main__":
    main()
