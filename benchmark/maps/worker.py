"""A worker process of the map executors: ``python -m rockbench.benchmark.maps.worker``.

It reads length-prefixed pickled messages on stdin and answers on the file descriptor that was
stdout when it started; fd 1 is then pointed at stderr, so whatever an engine prints (PyBullet
prints to the C stdout) cannot corrupt the protocol.

Messages in: ``("init", {"sys_path", "registry", "engine", "settings"})``, then
``("chunk", chunk_id, [(key, Case), ...], batch)`` any number of times, then ``("stop",)``.
Messages out: ``("ready", pid)`` or ``("init-error", text)``; per chunk either one
``("results", chunk_id, [(key, CellResult), ...])`` (batch) or ``("start", key)`` /
``("result", key, CellResult)`` per cell, then ``("done", chunk_id)``; ``("batch-failed",
chunk_id, text)`` when a batch raised (the executor reruns its cells one by one).

A worker never outlives the process that started it (whose pid the executor puts in
``ROCKBENCH_PARENT_PID``): on Linux the kernel kills it when that process dies (``PR_SET_PDEATHSIG``,
which works even while an engine holds the GIL in C code), and everywhere a watchdog thread stops
it within half a second once it has been handed to another parent.
"""

from __future__ import annotations

import ctypes
import os
import pickle
import signal
import struct
import sys
import threading
import time

from rockbench.engines.contract import CellResult
from rockbench.engines.registry import register
from rockbench.benchmark.engine_info.adapters import build_adapter
from rockbench.benchmark.maps.cost import CELL_CPU, CELL_SIMULATED, run_measured

_HEADER = struct.Struct(">Q")

#: environment variable holding the pid of the process that started the worker
PARENT_ENV = "ROCKBENCH_PARENT_PID"
#: seconds between the watchdog's looks at the parent
WATCH_INTERVAL_S = 0.5


def send(f, msg) -> None:
    data = pickle.dumps(msg, protocol=pickle.HIGHEST_PROTOCOL)
    f.write(_HEADER.pack(len(data)) + data)
    f.flush()


def recv(f):
    """One message, or None at end of file."""
    head = _read_exact(f, _HEADER.size)
    if head is None:
        return None
    (n,) = _HEADER.unpack(head)
    body = _read_exact(f, n)
    if body is None:
        return None
    return pickle.loads(body)


def _read_exact(f, n: int):
    buf = bytearray()
    while len(buf) < n:
        chunk = f.read(n - len(buf))
        if not chunk:
            return None
        buf += chunk
    return bytes(buf)


def without_diagnostics(r):
    """The cell result ``r`` with its diagnostics dropped but its cost (:mod:`.cost`: they can hold long
    impact lists; cells.csv stores none of them but the cost, so nothing else is sent between processes)."""
    d = r.diagnostics or {}
    r.diagnostics = {k: d[k] for k in (CELL_CPU, CELL_SIMULATED) if k in d}
    return r


def serve(inp, out) -> int:
    """Run the worker loop on binary streams ``inp``/``out``; returns an exit code."""
    msg = recv(inp)
    if msg is None or msg[0] != "init":
        return 2
    init = msg[1]
    for p in init.get("sys_path", []):
        if p not in sys.path and os.path.isdir(p):
            sys.path.append(p)
    try:
        for name, target in init.get("registry", {}).items():
            register(name, target)
        adapter = build_adapter(init["engine"], **init.get("settings", {}))
    except Exception as e:  # noqa: BLE001 - reported to the parent, which raises it
        send(out, ("init-error", f"{type(e).__name__}: {e}"))
        return 1
    send(out, ("ready", os.getpid()))
    while True:
        msg = recv(inp)
        if msg is None or msg[0] == "stop":
            return 0
        _, chunk_id, items, batch = msg
        if batch:
            try:
                rs = run_measured(adapter, [c for _, c in items])
            except Exception as e:  # noqa: BLE001 - the parent reruns the cells one by one
                send(out, ("batch-failed", chunk_id, f"{type(e).__name__}: {e}"))
            else:
                send(out, ("results", chunk_id, [(k, without_diagnostics(r)) for (k, _), r in zip(items, rs)]))
        else:
            for k, c in items:
                send(out, ("start", k))
                t0 = time.perf_counter()
                try:
                    r = run_measured(adapter, [c])[0]
                except Exception as e:  # noqa: BLE001 - a bad cell is recorded and the map goes on
                    r = CellResult.failed("engine-error", f"{type(e).__name__}: {e}", time.perf_counter() - t0)
                send(out, ("result", k, without_diagnostics(r)))
        send(out, ("done", chunk_id))


def watch_parent(parent_pid: int) -> None:
    """Die with the parent ``parent_pid`` (see the module docstring)."""
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)   # 1 = PR_SET_PDEATHSIG
        except (OSError, AttributeError):   # no libc prctl: the watchdog below still holds
            pass
    if os.getppid() != parent_pid:     # the parent died before the kernel was told
        os._exit(1)

    def watch():
        while True:
            time.sleep(WATCH_INTERVAL_S)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="rockbench-parent-watch", daemon=True).start()


def main() -> int:
    parent = os.environ.get(PARENT_ENV)
    if parent and parent.isdigit():
        watch_parent(int(parent))
    out = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    return serve(sys.stdin.buffer, out)


if __name__ == "__main__":
    sys.exit(main())
