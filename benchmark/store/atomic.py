"""Atomic file writes: write a temporary file in the target's folder, flush it to disk, then rename.

A reader (or a rerun after ``kill -9``) sees the old file or the new one, never a torn one, and a
failed write leaves nothing behind. Every file rockbench writes for a user goes through here (JSON
through :func:`rockbench.benchmark.store.files.write_json`, the one JSON writer).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Callable

from rockbench.reference_solver.errors import ConfigError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_atomic(path, write: Callable[[str], None]) -> Path:
    """Call ``write(tmp_path)`` to produce the file, then rename it onto ``path``.

    ``write`` gets a path (so libraries that write by file name, such as matplotlib, can be used).
    The temporary file is hidden (``.NAME.*.tmp``) and removed if anything fails.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes it private; give it a normal file's mode
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def write_bytes_atomic(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically."""
    return write_atomic(path, lambda tmp: Path(tmp).write_bytes(data))


def _probe_folder(folder: Path, option: str, target: Path) -> None:
    """ConfigError unless a file can be created in ``folder`` (an existing folder)."""
    try:
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as e:
        raise ConfigError(f"{option} {str(target)!r} cannot be written: the folder {str(folder)!r} refuses new files "
                          f"({e.strerror or e}); choose another place.") from None


def _check_new_path(p: Path, option: str) -> None:
    """The nearest existing folder above ``p`` must take new files, and no missing name may be too long."""
    missing = []
    q = p
    while True:
        if _exists(q):
            break
        missing.append(q.name)
        if q.parent == q:
            break
        q = q.parent
    if not q.is_dir():
        raise ConfigError(f"{option} {str(p)!r} cannot be created: {str(q)!r} is a file, not a folder.")
    try:
        limit = os.pathconf(q, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    for name in missing:
        if len(os.fsencode(name)) > limit:
            raise ConfigError(f"{option} {str(p)!r} cannot be created: the name {name[:40]!r}... is too long "
                              f"({len(os.fsencode(name))} bytes, more than the {limit} this file system takes); "
                              "choose a shorter name.")
    _probe_folder(q, option, p)


def check_output_dir(path, option: str) -> Path:
    """Refuse, before any work, an output folder that cannot be created or written (a file in its place,
    a read-only or immutable place, a name too long).

    Raises
    ------
    ConfigError
        One line naming the path and what is wrong.
    """
    p = Path(path)
    if _isdir(p):
        _probe_folder(p, option, p)
    elif _exists(p):
        raise ConfigError(f"{option} {str(p)!r} is a file; give a folder.")
    else:
        _check_new_path(p, option)
    return p


def _isdir(p: Path) -> bool:
    try:
        return p.is_dir()
    except OSError:    # a name too long even to look up: it does not exist
        return False


def _exists(p: Path) -> bool:
    try:
        return p.exists()
    except OSError:
        return False


def check_output_file(path, option: str) -> Path:
    """Refuse, before any work, an output file that cannot be written (a folder in its place, a folder that
    refuses new files, a name too long); the folders above it may be missing (they are created).

    Raises
    ------
    ConfigError
        One line naming the path and what is wrong.
    """
    p = Path(path)
    if _isdir(p):
        raise ConfigError(f"{option} {str(p)!r} is a folder; give a file name.")
    if _exists(p):
        _probe_folder(p.parent, option, p)
    else:
        _check_new_path(p, option)
    return p
