"""Write a run's verdict as a record: what the README's results and docs/scores.md's tables are read from.

    python tests/measurements/record_verdict.py RUN_DIR NAME [--time-file F] [--install-s S] [--command C]

RUN_DIR is a finished ``rockbench run`` folder (its score.json and suite.json); NAME the record's name
(``verdict-default`` for the default suite). The record's figures hold the suite's name, the metrics
version, the whole ``verdict`` object of score.json (every variant's value, interval, class standing,
per-scenario values, equivalence, held-out test, the suite's power), the spurious invalid cells per
variant (like-for-like pairs), the maps' count and the run's timings from suite.json. With
``--time-file`` (the output of ``/usr/bin/time -f "%e %U %S"`` around the command) the wall and CPU
time of the command itself are added, and with ``--install-s`` the install's seconds, so a record of
the README's first command holds its whole time.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from records import write_record  # noqa: E402
from verdict_before_after import spurious_invalid  # noqa: E402


def timing(run_dir: Path, time_file: Path | None, install_s: float | None) -> dict:
    """The run's timings: suite.json's, and the command's wall and CPU time when measured outside."""
    suite = json.loads((run_dir / "suite.json").read_text())
    out = {k: round(v, 1) for k, v in suite.items() if k.endswith("wall_s") and isinstance(v, (int, float))}
    if time_file is not None:
        wall, user, system = (float(x) for x in time_file.read_text().split()[:3])
        out.update(run=round(wall), run_cpu_user_sys=round(user + system))
        if install_s is not None:
            out.update(install=round(install_s), total=round(wall + install_s))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("name")
    ap.add_argument("--time-file", type=Path, help="/usr/bin/time -f '%%e %%U %%S' output of the command")
    ap.add_argument("--install-s", type=float, help="seconds the install took before the command")
    ap.add_argument("--command", default="rockbench run", help="the command that made RUN_DIR")
    a = ap.parse_args(argv)
    score = json.loads((a.run_dir / "score.json").read_text())
    suite = json.loads((a.run_dir / "suite.json").read_text())
    figures = {"suite": suite.get("suite_name") or (suite.get("suite") or {}).get("suite", {}).get("name"),
               "metrics_version": score["metrics_version"], "maps": len(suite.get("maps") or []),
               "timing_s": timing(a.run_dir, a.time_file, a.install_s), "verdict": score["verdict"],
               "spurious_invalid": spurious_invalid(score),
               "reference_gaps": score.get("reference_gaps", [])}
    path = write_record(a.name, f"The verdict of `{a.command}` (suite {figures['suite']!r}, metrics version "
                                f"{figures['metrics_version']}): every variant's value, interval, class standing and "
                                "per-scenario values, the suite's power, spurious invalid cells, and the run's time.",
                        a.command, figures, packages=("mujoco", "pybullet", "exudyn", "dartpy", "sapien", "drake"))
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
