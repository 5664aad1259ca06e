"""A regressed engine for the CI-gate test: MuJoCo, through the real engine, with its table drive 40 %
too weak (the kind of bug a pull request to an engine could bring). Registered under the name
``mujoco`` it keeps the variant's name, so its maps are compared with the baseline's pair by pair.

Importable by worker processes: they get this folder on their ``sys.path`` from the executor.
"""

from __future__ import annotations

import dataclasses

from rockbench.engines.adapters.mujoco import MujocoAdapter
from rockbench.reference_solver.pulses import make_pulse

#: how much of the table's acceleration reaches the block
DRIVE = 0.6


class RegressedMujoco(MujocoAdapter):
    def run_many(self, cases):
        weaker = [dataclasses.replace(c, pulse=make_pulse(c.pulse.kind, DRIVE * c.pulse.amplitude_mps2,
                                                          c.pulse.omega_rad_s)) for c in cases]
        return super().run_many(weaker)


def main() -> int:
    """``rockbench`` with the regressed MuJoCo in place of the shipped one."""
    import sys

    from rockbench.benchmark.cli.main import main as cli
    from rockbench.engines import registry
    registry.register("mujoco", f"{__name__}:RegressedMujoco")
    return cli(sys.argv[1:])


if __name__ == "__main__":
    raise SystemExit(main())
