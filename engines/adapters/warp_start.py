"""Starting Warp for the adapters built on it (MuJoCo Warp, Newton): where its kernels are cached,
whether a CUDA driver is there, a start on the CPU that says so in one line of rockbench's own, and
a line before an engine's kernels compile for the first time.

Warp compiles each module of kernels at its first launch and keeps the result in its kernel cache
(``warp.config.kernel_cache_dir``, one folder per Warp version; ``warp.config.cache_kernels`` is
on by default), where every later process finds it. rockbench points the cache at
``<rockbench cache>/warp`` (:func:`warp_cache_dir`), so an empty ``ROCKBENCH_CACHE`` also means
cold kernels.
"""

from __future__ import annotations

import ctypes
import os
import sys
import tempfile

from rockbench.engines import progress
from rockbench.engines.calibration import cache as _cal
from rockbench.engines.contract import DEVICE_NOTED_ENV

__all__ = ["warp_cache_dir", "cuda_driver_present", "init_on_cpu", "start_warp", "kernels_cached",
           "say_first_compile", "FIRST_COMPILE"]

_started = False

#: How long an engine's kernels took to compile at the first run into an empty kernel cache, as the
#: line before it says it (Warp 1.19 on the CPU: docs/mujoco_warp.md "Kernel cache", docs/newton.md
#: "Speed"; under load, the first progress line of a cold and a warm kernel cache 2 min 35 s and
#: 3 min 38 s apart: docs/mujoco_warp.md and docs/newton.md, "The first cell on a new block")
FIRST_COMPILE = {"mujoco_warp": "about a minute of CPU, 2–3 min on a loaded 2-core machine",
                 "newton": "one to two minutes of CPU, 3–4 min on a loaded 2-core machine"}

_said: set = set()


def start_warp(cpu_line: str):
    """The ``warp`` module, started once per process: no banner and no line per loaded kernel module
    on stderr, its kernels cached in rockbench's cache (:func:`warp_cache_dir`), and on a machine
    without a CUDA driver started quietly on the CPU with the adapter's own ``cpu_line``
    (:func:`init_on_cpu`). A runtime someone else started is left as it is."""
    global _started
    import warp as wp   # optional engine library (Warp-based engines)
    if not _started:
        if hasattr(wp, "LOG_WARNING"):   # Warp >= 1.19
            wp.config.log_level = wp.LOG_WARNING
        else:  # pragma: no cover - older Warp
            wp.config.quiet = True
        from warp._src import context as _ctx   # the optional engine library's runtime, to tell whether it started
        if getattr(_ctx, "runtime", None) is None:   # not initialised yet in this process
            wp.config.kernel_cache_dir = warp_cache_dir()
            if cuda_driver_present():
                wp.init()
            else:
                init_on_cpu(wp, cpu_line)
        _started = True
    return wp


def warp_cache_dir() -> str:
    """Where Warp keeps its compiled kernels: ``$WARP_CACHE_PATH`` if set, else ``<rockbench cache>/warp``."""
    env = os.environ.get("WARP_CACHE_PATH")
    if env:
        return env
    return str(_cal.cache_dir().parent / "warp")


def cuda_driver_present() -> bool:
    """Whether the NVIDIA CUDA driver library loads here: asked without starting Warp, which prints
    a warning of its own on a machine without one."""
    names = {"win32": ["nvcuda.dll"]}.get(sys.platform, ["libcuda.so.1", "libcuda.so"])
    if sys.platform == "darwin":
        return False
    for name in names:
        try:
            ctypes.CDLL(name)
            return True
        except OSError:
            continue
    return False


def init_on_cpu(wp, line: str) -> None:
    """``wp.init()`` without the driver warning Warp's native code writes to stderr, and rockbench's
    own ``line`` (each Warp-based adapter says its own) instead: once per run (worker
    processes inherit the mark)."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as tmp:
        try:
            os.dup2(tmp.fileno(), 2)
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        tmp.seek(0)
        other = [ln for ln in tmp.read().decode(errors="replace").splitlines()
                 if ln.strip() and "CUDA driver" not in ln]
    for ln in other:   # anything else Warp said is kept
        print(ln, file=sys.stderr)
    if not os.environ.get(DEVICE_NOTED_ENV):
        os.environ[DEVICE_NOTED_ENV] = "1"
        print(line, file=sys.stderr)


def kernels_cached(module_prefix: str) -> bool:
    """Whether Warp's kernel cache (started: its folder for this Warp version) holds a compiled module
    whose name starts with ``module_prefix`` (``mujoco_warp``, ``newton``): one listing of the folder,
    no hash computed, so a cache of another release of the engine also counts."""
    import warp as wp   # optional engine library (Warp-based engines), already started
    root = wp.config.kernel_cache_dir
    try:
        names = os.listdir(root) if root else []
    except OSError:
        names = []
    return any(n.startswith(f"wp_{module_prefix}") for n in names)


def say_first_compile(engine: str, module_prefix: str) -> None:
    """Before ``engine``'s first launch in this process: where its kernels are not in the kernel cache
    yet (:func:`kernels_cached`), one progress line (:func:`rockbench.engines.progress.announce`)
    saying that they compile now, about how long that takes, and where they are kept."""
    if engine in _said:
        return
    _said.add(engine)
    if not kernels_cached(module_prefix):
        import warp as wp   # optional engine library (Warp-based engines), already started
        progress.announce(f"{engine}: compiling Warp kernels (first run after install or with an empty cache, "
                          f"{FIRST_COMPILE.get(engine, 'a minute or more')} when measured); kept in "
                          f"{wp.config.kernel_cache_dir} for later runs")
