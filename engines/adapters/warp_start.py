"""Starting Warp for the adapters built on it (MuJoCo Warp, Newton): where its kernels are cached,
whether a CUDA driver is there, and a start on the CPU that says so in one line of rockbench's own.
"""

from __future__ import annotations

import ctypes
import os
import sys
import tempfile

from ..calibration import cache as _cal
from ..contract import DEVICE_NOTED_ENV

__all__ = ["warp_cache_dir", "cuda_driver_present", "init_on_cpu", "start_warp"]

_started = False


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
