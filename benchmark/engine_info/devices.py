"""Where an engine's worlds run on this machine: a CUDA device or the CPU (:func:`device_of`), for the
speed stage's rows (an engine timed on a GPU is costed by the device's wall time and its row says so).

The engines built to run their batches on a GPU are named here (:data:`GPU_ENGINES`); each says in its
own :meth:`~rockbench.engines.contract.EngineAdapter.device_note` when it runs on the CPU instead ("" where it
runs where it is meant to), which is the line the speed stage gives for a GPU row that is absent.
"""

from __future__ import annotations

from rockbench.engines.registry import adapter_class

#: The engines meant for a GPU (the issue's MuJoCo Warp, Newton and Genesis): the speed stage has a GPU row
#: for each, timed where it runs on a CUDA device, else saying why not.
GPU_ENGINES = ("mujoco_warp", "newton", "genesis")


def device_of(engine: str) -> dict:
    """``{"runs_on": "gpu" or "cpu", "note": ...}``: an engine of :data:`GPU_ENGINES` whose device note is
    empty runs on a CUDA device; every other engine, and one that says otherwise, on the CPU (``note``:
    the engine's own line, "" for an engine that runs on the CPU by design)."""
    try:
        note = adapter_class(engine).device_note()
    except Exception as e:  # noqa: BLE001 - an engine that cannot say runs nowhere special
        note = f"its device is not known ({type(e).__name__}: {e})"
    gpu = engine in GPU_ENGINES and not note
    return {"runs_on": "gpu" if gpu else "cpu", "note": note}
