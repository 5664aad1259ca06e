"""Copy a finished run folder with one engine variant's results taken out, to resume it with changed
code (the skeleton_alt experiment: what the skeleton's shared rules change in one engine's answers).

Removes, in the copy, the variant's maps (``maps/<variant folder>/``), its η measurements in
``calibration.json`` (so the run measures η again with the changed code) and the reference maps at
its own η that no other variant shares (scoring reads every map in the folder, so a stale own-η
map would still be scored). Then ``rockbench run default --out DST`` recomputes only those::

    python tests/measurements/probes/skeleton_alt/alt_prepare_run.py rockbench-results/default rockbench-results/alt-A mujoco-settings=calibrated
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("src", type=Path)
    ap.add_argument("dst", type=Path)
    ap.add_argument("folder", help="the variant's map folder, e.g. mujoco-settings=calibrated")
    a = ap.parse_args()
    if a.dst.exists():
        raise SystemExit(f"{a.dst} exists; give a new folder.")
    shutil.copytree(a.src, a.dst)
    shutil.rmtree(a.dst / "maps" / a.folder)
    engine, setting = a.folder.split("-", 1)
    variant = f"{engine}[{setting}]"
    cal_path = a.dst / "calibration.json"
    cal = json.loads(cal_path.read_text())
    mine = [m for m in cal["measurements"] if m["variant"] == variant]
    rest = [m for m in cal["measurements"] if m["variant"] != variant]
    cal["measurements"] = rest
    cal_path.write_text(json.dumps(cal, indent=2))
    shared = {(m["block"], f"{m['eta_measured']:.4f}") for m in rest if m.get("eta_measured") is not None}
    gone = []
    for m in mine:
        if m.get("eta_measured") is None or (m["block"], f"{m['eta_measured']:.4f}") in shared:
            continue
        for d in (a.dst / "maps" / "reference").glob(f"{m['block']}-*-own-eta-{m['eta_measured']:.4f}"):
            shutil.rmtree(d)
            gone.append(d.name)
    print(f"removed maps/{a.folder}, {len(mine)} η measurements of {variant}, own-η reference maps: {gone}")


if __name__ == "__main__":
    main()
