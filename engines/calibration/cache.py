"""A small on-disk cache of calibrated contact settings, shared by the engine adapters.

A calibration maps (engine, engine version, block geometry, target η, time step, drive) to the
engine settings that reach it, the η measured with them and its spread. It lives in one JSON
file per key under ``$ROCKBENCH_CACHE`` (default ``~/.cache/rockbench``)/``calibration``; writes
are atomic (write, then rename), so concurrent workers never read a torn file.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path


def cache_dir() -> Path:
    """The calibration cache folder (created on demand)."""
    root = Path(os.environ.get("ROCKBENCH_CACHE", Path.home() / ".cache" / "rockbench"))
    d = root / "calibration"
    d.mkdir(parents=True, exist_ok=True)
    return d


def cache_key(**parts) -> str:
    """A stable file-name key from JSON-able parts (floats rounded to 12 significant digits)."""
    def norm(v):
        if isinstance(v, float):
            return float(f"{v:.12g}")
        if isinstance(v, dict):
            return {k: norm(x) for k, x in sorted(v.items())}
        if isinstance(v, (list, tuple)):
            return [norm(x) for x in v]
        return v
    text = json.dumps(norm(parts), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def load(key: str) -> dict | None:
    """The cached record for ``key``, or None."""
    p = cache_dir() / f"{key}.json"
    try:
        return json.loads(p.read_text())
    except (OSError, ValueError):
        return None


def store(key: str, record: dict) -> Path:
    """Write ``record`` for ``key`` atomically and return its path."""
    d = cache_dir()
    fd, tmp = tempfile.mkstemp(dir=d, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        json.dump(record, f, indent=2, sort_keys=True)
    p = d / f"{key}.json"
    os.replace(tmp, p)
    return p
