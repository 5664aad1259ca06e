"""A regular (non-editable) install works from any working folder, the repository's root included.

Run from the root, ``python -m`` puts the working folder first on the path; no folder there may
shadow the installed package (``rockbench`` is a namespace of three packages mapped from
``reference_solver/``, ``engines/`` and ``benchmark/``) in the map's worker processes. The test
copies the repository's tracked files, installs the copy into a fresh venv with ``pip install
--no-deps`` (its build backend fetched by pip as usual; the dependencies come from this interpreter's site-packages, added by a .pth file, so
nothing is downloaded), and runs a map with two worker processes from the copy's root.
"""

from __future__ import annotations

import shutil
import site
import subprocess
import sys
import venv
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytestmark = [pytest.mark.slow, pytest.mark.engine]


def _tracked_copy(dest: Path) -> Path:
    """The repository's tracked files (what a clone has) under ``dest``."""
    files = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True, check=True).stdout
    for rel in filter(None, files.decode().split("\0")):
        src = REPO / rel
        if src.is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)
    return dest


def _venv_with_our_deps(where: Path) -> Path:
    """A venv that sees this interpreter's packages (numpy, the engines, setuptools) through a .pth
    file; only its own site-packages is a site dir, so the editable rockbench of the outer
    environment (a finder installed by a .pth in the outer site-packages) is not seen."""
    venv.EnvBuilder(with_pip=True).create(where)
    py = where / "bin" / "python"
    own = subprocess.run([py, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                         capture_output=True, text=True, check=True).stdout.strip()
    outer = [p for p in site.getsitepackages() if Path(p).is_dir()]
    (Path(own) / "_outer_site.pth").write_text("\n".join(outer) + "\n")
    return py


def test_regular_install_runs_a_map_with_workers_from_the_repository_root(tmp_path):
    pytest.importorskip("mujoco")
    if not shutil.which("git") or not (REPO / ".git").exists():
        pytest.skip("needs the git checkout to copy its tracked files")
    src = _tracked_copy(tmp_path / "src")
    py = _venv_with_our_deps(tmp_path / "venv")
    r = subprocess.run([py, "-m", "pip", "install", "-q", "--no-deps", str(src)],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    # the installed copy, not the source folder, is what a process outside the root imports
    where = subprocess.run([py, "-P", "-c", "import rockbench.benchmark as b; print(b.__file__)"],
                           capture_output=True, text=True, cwd=tmp_path).stdout
    assert "site-packages" in where, where
    rb = tmp_path / "venv" / "bin" / "rockbench"
    out = tmp_path / "map"
    r = subprocess.run([rb, "map", "--engine", "mujoco", "--block", "B3M", "--w-ratio", "2:6:2",
                        "--a-ratio", "2:6:2", "--jobs", "2", "--out", str(out)],
                       capture_output=True, text=True, cwd=src, timeout=600)
    log = (out / "workers.log").read_text() if (out / "workers.log").exists() else ""
    assert r.returncode == 0, (r.stderr[-2000:], log[-2000:])
    rows = (out / "cells.csv").read_text().splitlines()
    assert len(rows) == 1 + 4
