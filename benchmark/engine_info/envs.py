"""One isolated Python environment per engine version, cached, for ``rockbench versions``.

``rockbench versions mujoco==3.3.7 mujoco==4.0.0 --quick`` needs two installs of the same engine side
by side: each gets a virtual environment under ``<rockbench cache>/versions/<engine>-<version>-py<X.Y>``
(``$ROCKBENCH_CACHE``, default ``~/.cache/rockbench``) holding this rockbench (installed from its
source tree, not editable, so a later edit does not change a cached environment behind its back)
with its dependencies, and the engine's distribution pinned to that version. The engine is pinned
alone, without rockbench's extra, so versions outside the supported range can be tried (and are
then refused with the "cannot simulate" line, exit 3).

A cached environment is reused as it is when it was built for the same engine version and the
same rockbench source (:func:`source_fingerprint`: the package files and pyproject.toml); when only
the source changed, rockbench alone is reinstalled (``--no-deps``), which takes seconds. Nothing here
runs a process itself: :func:`plan_env` says which commands to run, :func:`build_env` runs them with
a ``runner`` (``subprocess.run`` by default; tests pass a fake).
"""

from __future__ import annotations

import difflib
import hashlib
import json
import os
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from packaging.version import InvalidVersion, Version

from rockbench.engines.registry import names
from rockbench.engines.support import DISTRIBUTIONS
from rockbench.reference_solver.errors import ConfigError
from rockbench.engines.errors import EngineUnavailableError

#: the folders (and file) of the source tree that make up the installed package
SOURCE_PARTS = ("pyproject.toml", "reference_solver", "engines", "benchmark")
#: what a cached environment records about itself
MARKER = "rockbench-versions.json"


@dataclass(frozen=True)
class VersionSpec:
    """``ENGINE==VERSION`` from the command line."""

    engine: str
    version: str

    @property
    def distribution(self) -> str:
        """The Python distribution pinned for this engine (e.g. ``mujoco-warp`` for ``mujoco_warp``)."""
        return DISTRIBUTIONS[self.engine][0]

    @property
    def label(self) -> str:
        return f"{self.engine} {self.version}"

    @property
    def slug(self) -> str:
        return f"{self.engine}-{self.version}"


def parse_spec(text: str) -> VersionSpec:
    """``"mujoco==3.3.7"`` → VersionSpec; ConfigError (exit 2) for anything else."""
    engine, sep, ver = str(text).partition("==")
    engine, ver = engine.strip(), ver.strip()
    if not sep or not engine or not ver:
        raise ConfigError(f"versions takes ENGINE==VERSION (e.g. mujoco==3.3.7), got {text!r}.")
    if engine not in names():
        close = difflib.get_close_matches(engine, names(), n=1)
        raise ConfigError(f"unknown engine {engine!r} in {text!r}; known engines: {', '.join(names())}."
                          + (f" Did you mean {close[0]!r}?" if close else ""))
    if engine not in DISTRIBUTIONS:
        raise ConfigError(f"versions installs an engine from its Python distribution; {engine!r} has none that "
                          f"rockbench knows (it can: {', '.join(DISTRIBUTIONS)}).")
    try:
        Version(ver)
    except InvalidVersion:
        raise ConfigError(f"{ver!r} in {text!r} is not a version (e.g. 3.3.7).") from None
    return VersionSpec(engine, ver)


def parse_pair(texts: list[str]) -> tuple[VersionSpec, VersionSpec]:
    """Two specs of the same engine at two different versions (baseline first); ConfigError otherwise."""
    if len(texts) != 2:
        raise ConfigError(f"versions takes two ENGINE==VERSION (the baseline, then the candidate), got {len(texts)}.")
    a, b = (parse_spec(t) for t in texts)
    if a.engine != b.engine:
        raise ConfigError(f"versions compares two versions of one engine, got {a.engine!r} and {b.engine!r}.")
    if a.version == b.version:
        raise ConfigError(f"versions needs two different versions, got {a.version} twice.")
    return a, b


def cache_root() -> Path:
    """``<rockbench cache>/versions`` (not created here)."""
    return Path(os.environ.get("ROCKBENCH_CACHE", Path.home() / ".cache" / "rockbench")) / "versions"


def source_dir(given: str | None = None) -> Path:
    """The rockbench source tree to install: ``given`` (``--source``), else the tree this rockbench runs
    from (an editable install or a checkout); ConfigError when there is none (a regular install)."""
    if given is not None:
        d = Path(given).resolve()
        if not (d / "pyproject.toml").is_file() or not (d / "benchmark").is_dir():
            raise ConfigError(f"--source {given!r} is not a rockbench source tree (no pyproject.toml and "
                              "benchmark/ there).")
        return d
    d = Path(__file__).resolve().parents[2]
    if (d / "pyproject.toml").is_file() and (d / "benchmark").is_dir():
        return d
    raise ConfigError("versions installs rockbench from its source tree, and this rockbench is a regular install; "
                      "give --source DIR (a checkout of rockbench).")


def source_fingerprint(src: Path) -> str:
    """A hash of the files that make up the installed package (paths and contents)."""
    h = hashlib.sha256()
    for part in SOURCE_PARTS:
        p = src / part
        files = [p] if p.is_file() else sorted(q for q in p.rglob("*") if q.is_file() and "__pycache__" not in q.parts
                                               and q.suffix not in (".pyc", ".pyo"))
        for f in files:
            h.update(str(f.relative_to(src)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:16]


@dataclass
class EnvPlan:
    """Where one version's environment lives and the commands that make it ready (none when cached)."""

    spec: VersionSpec
    path: Path
    fingerprint: str
    steps: list = field(default_factory=list)
    state: str = "cached"          # "new", "rockbench changed" or "cached"

    @property
    def python(self) -> Path:
        return self.path / "bin" / "python"

    @property
    def rockbench(self) -> Path:
        return self.path / "bin" / "rockbench"


def env_path(spec: VersionSpec, root: Path | None = None) -> Path:
    """The cached environment's folder of one engine version for this Python."""
    py = f"py{sys.version_info.major}.{sys.version_info.minor}"
    return (root or cache_root()) / f"{spec.slug}-{py}"


def _marker(path: Path) -> dict:
    try:
        return json.loads((path / MARKER).read_text())
    except (OSError, ValueError):
        return {}


def plan_env(spec: VersionSpec, src: Path, root: Path | None = None, *, python: str = sys.executable,
             fingerprint: str | None = None) -> EnvPlan:
    """The commands that bring ``spec``'s environment up to date (see the module docstring)."""
    path = env_path(spec, root)
    fp = fingerprint or source_fingerprint(src)
    plan = EnvPlan(spec, path, fp)
    have = _marker(path) if (path / "bin" / "python").exists() else {}
    pip = [str(plan.python), "-m", "pip", "install", "-q"]
    if have.get("engine") != spec.engine or have.get("version") != spec.version:
        plan.state = "new"
        plan.steps = [[python, "-m", "venv", "--clear", str(path)],
                      pip + [str(src), f"{spec.distribution}=={spec.version}"]]
    elif have.get("fingerprint") != fp:
        plan.state = "rockbench changed"
        plan.steps = [pip + ["--no-deps", "--force-reinstall", str(src)]]
    return plan


def build_env(plan: EnvPlan, *, runner=subprocess.run, log=None) -> None:
    """Run ``plan``'s commands, then record the environment in its marker file. EngineUnavailableError
    (exit 3) when one fails, e.g. pip finds no such version: its last lines of output say why."""
    for cmd in plan.steps:
        if log:
            log(f"{plan.spec.label}: {' '.join(str(c) for c in cmd[2:5])} ...")
        r = runner([str(c) for c in cmd], capture_output=True, text=True)
        if r.returncode != 0:
            tail = " | ".join((r.stderr or r.stdout or "").strip().splitlines()[-2:])
            raise EngineUnavailableError(f"cannot build the environment of {plan.spec.label} in {plan.path} "
                                         f"({' '.join(str(c) for c in cmd[2:4])} exited {r.returncode}): {tail}")
    if plan.steps:
        plan.path.mkdir(parents=True, exist_ok=True)
        (plan.path / MARKER).write_text(json.dumps({"engine": plan.spec.engine, "version": plan.spec.version,
                                                    "fingerprint": plan.fingerprint}))
