"""tests/measurements/bench_suite_cluster.py counts the CPU of a process tree: a live process's own CPU and that
of the children it has reaped, and its live descendants'; a client's CPU with that of every process it waited for."""

import os
import signal
import subprocess
import sys

import pytest

from measurement_scripts import load_script

pytest.importorskip("psutil")
bench = load_script("bench_suite_cluster")

#: a child that burns CPU in a grandchild it waits for, then in a grandchild it leaves running, then sleeps
TREE = """
import subprocess, sys, time
burn = "import time\\nt = time.process_time()\\nwhile time.process_time() - t < 0.3: pass\\n"
subprocess.run([sys.executable, "-c", burn])
live = subprocess.Popen([sys.executable, "-c", burn + "print('burnt', flush=True)\\ntime.sleep(60)"])
print("ready", flush=True)
time.sleep(60)
"""


def test_a_tree_counts_reaped_and_live_descendants():
    p = subprocess.Popen([sys.executable, "-c", TREE], stdout=subprocess.PIPE, text=True, start_new_session=True)
    try:
        assert sorted(p.stdout.readline().strip() for _ in range(2)) == ["burnt", "ready"]
        assert bench.tree_cpu_s(p.pid) >= 0.6   # 0.3 s in each grandchild
    finally:
        os.killpg(p.pid, signal.SIGKILL)   # the live grandchild with it
        p.wait()


def test_a_dead_process_counts_nothing():
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    assert bench.tree_cpu_s(p.pid) == 0.0
