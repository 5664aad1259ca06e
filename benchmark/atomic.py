"""Atomic file writes: write a temporary file in the target's folder, flush it to disk, then rename.

A reader (or a rerun after ``kill -9``) sees the old file or the new one, never a torn one, and a
failed write leaves nothing behind. Every file rockbench writes for a user goes through here.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Callable


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


def write_json_atomic(path, data, default=None) -> Path:
    """Write ``data`` as indented JSON (with a final newline) to ``path`` atomically."""
    text = json.dumps(data, indent=2, default=default) + "\n"
    return write_bytes_atomic(path, text.encode())
