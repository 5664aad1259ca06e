"""Print pip constraints that pin every declared lower bound of pyproject.toml: `name>=X` becomes
`name==X` (the base dependencies and the extras named on the command line).

Usage: python .ci/floor_pins.py [EXTRA ...] > pins.txt   (see .ci/floors)
"""

import sys
import tomllib
from pathlib import Path

from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]


def floors(extras: list[str]) -> list[str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    texts = list(project["dependencies"])
    for e in extras:
        texts += project["optional-dependencies"][e]
    pins = {}
    for text in texts:
        req = Requirement(text)
        if req.name == "rockbench":
            continue
        for spec in req.specifier:
            if spec.operator in (">=", "=="):
                pins[req.name] = f"{req.name}=={spec.version}"
    return sorted(pins.values())


if __name__ == "__main__":
    print("\n".join(floors(sys.argv[1:])))
