"""A ``dask worker --preload`` of tests/test_suite_dask.py: every map task on the worker lasts at least
:data:`MIN_MAP_S`, so that the test that kills a busy worker mid-suite finds one busy however fast the
machine computes the reduced suite's maps (the answer is unchanged: the task only waits before it returns)."""

import time

from rockbench.benchmark.suites import cluster

#: the least time a map task takes on a worker with this preload [s]
MIN_MAP_S = 2.0

#: the task itself (the preload may be imported twice: the second import wraps the same function)
_map_task = getattr(cluster.map_task, "__wrapped__", cluster.map_task)


def _map_task_at_least(*args, **kwargs):
    t0 = time.monotonic()
    done = _map_task(*args, **kwargs)
    time.sleep(max(0.0, MIN_MAP_S - (time.monotonic() - t0)))
    return done


_map_task_at_least.__wrapped__ = _map_task
# a task names its function by module and name, and the worker looks it up by them: this one answers
cluster.map_task = _map_task_at_least
