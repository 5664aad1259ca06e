"""A small on-disk cache of calibrated contact settings, shared by the engine adapters.

A calibration maps (engine, engine version, the adapter's own identity, block geometry, target η,
time step, drive) to the engine settings that reach it, the η measured with them and its spread.
It lives in one JSON file per key under ``$ROCKBENCH_CACHE`` (default
``~/.cache/rockbench``)/``calibration``; writes are atomic (write, then rename), so concurrent
workers never read a torn file. Every record names its engine (``"engine"``), so one engine's
records can be removed (:func:`clear`, ``rockbench calibrate --clear ENGINE``).

The adapter's identity (:func:`adapter_identity`) is part of every key: the distribution that
installed the adapter's module and its version (rockbench's own for a built-in adapter; for a
plugin the package whose entry point names it) and a hash of the source of the adapter's own
modules. An adapter whose code changes gets a fresh calibration without anyone bumping a number;
``CALIBRATION_VERSION`` stays for what changes outside those modules.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import json
import os
import sys
import tempfile
from importlib import metadata
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


def adapter_key(ad, **parts) -> str:
    """The cache key of a record of adapter ``ad`` (an instance or class): its engine's name and
    version, the adapter's identity (:func:`adapter_identity`) and ``parts``."""
    cls = ad if isinstance(ad, type) else type(ad)
    return cache_key(engine=ad.name, version=ad.version(), adapter=adapter_identity(cls), **parts)


@functools.cache
def adapter_identity(cls: type) -> dict:
    """What an adapter class is, for the cache key: ``distribution`` and ``distribution_version`` (the
    distribution that installed the adapter's module: rockbench's own for a built-in, the plugin's
    package otherwise; ``""`` for an adapter no distribution installed) and ``source_sha256``, a
    hash of the source of the adapter's own modules (those of its classes outside rockbench's bases)."""
    own = {c.__module__: c for c in reversed(cls.__mro__) if _adapter_own(c.__module__)}
    top = cls.__module__.partition(".")[0]
    dists = metadata.packages_distributions().get(top, []) if top != "__main__" else []
    name, version = "", ""
    for dist in dists:
        try:
            name, version = dist, metadata.version(dist)
            break
        except metadata.PackageNotFoundError:
            continue
    digest = hashlib.sha256()
    for module in sorted(own):
        digest.update(_source_of(own[module]))
    return {"distribution": name, "distribution_version": version, "source_sha256": digest.hexdigest()[:16]}


def _adapter_own(module: str) -> bool:
    """Whether ``module`` is an adapter's own code: a built-in adapter's module, or any module outside
    rockbench (rockbench's bases, ``contact`` and ``contract``, are versioned with rockbench)."""
    return module.startswith("rockbench.engines.adapters.") or not (module.startswith("rockbench.")
                                                                     or module in ("builtins", "abc"))


def _source_of(cls: type) -> bytes:
    """The source of the module that defines ``cls`` (the class's own source where the module's
    file cannot be read, b"" where neither can)."""
    path = getattr(sys.modules.get(cls.__module__), "__file__", None)
    try:
        return Path(path).read_bytes()
    except (OSError, TypeError):
        pass
    try:
        return inspect.getsource(cls).encode()
    except (OSError, TypeError):
        return b""


def load(key: str) -> dict | None:
    """The cached record for ``key``, or None."""
    p = cache_dir() / f"{key}.json"
    try:
        return json.loads(p.read_text())
    except (OSError, ValueError):
        return None


def store(key: str, record: dict, engine: str) -> Path:
    """Write ``record`` of ``engine`` (the record names it: ``"engine"``) for ``key`` atomically and
    return its path."""
    d = cache_dir()
    fd, tmp = tempfile.mkstemp(dir=d, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        json.dump({**record, "engine": engine}, f, indent=2, sort_keys=True)
    p = d / f"{key}.json"
    os.replace(tmp, p)
    return p


def engines_stored() -> dict[str, int]:
    """``{engine: number of records}`` of the records in the cache, by the engine each names (a
    record written before records named their engine counts under ``""``)."""
    out: dict[str, int] = {}
    for p in cache_dir().glob("*.json"):
        name = str((load(p.stem) or {}).get("engine", ""))
        out[name] = out.get(name, 0) + 1
    return out


def clear(engine: str) -> int:
    """Remove every record that names ``engine``; how many were removed."""
    n = 0
    for p in cache_dir().glob("*.json"):
        if (load(p.stem) or {}).get("engine") == engine:
            p.unlink(missing_ok=True)
            n += 1
    return n
