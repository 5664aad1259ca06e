"""The θ(t) runs of one case as a run stores them and the report reads them: ``trajectories/theta_<case>.npz``.

One file per case (:class:`~rockbench.benchmark.blocks.cases.TrajectoryCase`): the reference at each
restitution the case needs and every engine variant of the run, each as its time samples, θ, its
impact times and its outcome, plus the notes of the runs that failed. ``meta`` (JSON) holds the case,
what was run (``runs``, to tell whether a later run of other variants needs the file made again) and
per drawn curve its label, outcome and overturn time; the arrays ``t_s_K``, ``theta_rad_K`` and
``impacts_s_K`` hold curve K. Numbers are stored as float64, so they read back exactly.
"""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np

from rockbench.benchmark.store.atomic import write_bytes_atomic

#: The folder of a run (or report) directory that holds the θ(t) files.
FOLDER = "trajectories"

#: Bump when the file's layout changes; a file of another version is made again.
FORMAT_VERSION = 1


def case_stem(case) -> str:
    """The file name (without suffix) of a case's θ(t) runs, and of its picture: ``theta_b3m_sine_6_6.1``."""
    def slug(s):
        return "".join(c if c.isalnum() else "-" for c in str(s)).strip("-").lower()

    return f"theta_{slug(case.block)}_{slug(case.pulse)}_{case.w_ratio:g}_{case.a_ratio:g}"


def case_path(folder, case) -> Path:
    return Path(folder) / f"{case_stem(case)}.npz"


def write_case(folder, case, runs: list, curves: list[dict], notes: list[str]) -> Path:
    """Store a case's θ(t) curves (atomically).

    Parameters
    ----------
    folder : path
        The ``trajectories`` folder (created).
    case : TrajectoryCase
    runs : list
        What was run, as JSON-able values (compared by :func:`read_case`'s caller to decide whether
        the file is current).
    curves : list of dict
        ``label`` (str), ``reference`` (bool), ``outcome`` (str or None), ``t_overturn_s`` (float or
        None), ``t_s`` [s], ``theta_rad`` [rad] and ``impacts_s`` [s] (arrays).
    notes : list of str
        Runs that failed, in words.
    """
    meta = {"format_version": FORMAT_VERSION, "case": [case.block, case.pulse, case.w_ratio, case.a_ratio],
            "runs": runs, "notes": list(notes),
            "curves": [{k: c[k] for k in ("label", "reference", "outcome", "t_overturn_s")} for c in curves]}
    arrays = {"meta": np.array(json.dumps(meta))}
    for k, c in enumerate(curves):
        for key in ("t_s", "theta_rad", "impacts_s"):
            arrays[f"{key}_{k}"] = np.asarray(c[key], dtype=np.float64)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    Path(folder).mkdir(parents=True, exist_ok=True)
    return write_bytes_atomic(case_path(folder, case), buf.getvalue())


def read_case(folder, case) -> dict | None:
    """A case's stored θ(t) runs: ``{"runs", "notes", "curves"}`` (each curve as :func:`write_case`
    takes it), or None when none is stored, it is unreadable or of another format version."""
    p = case_path(folder, case)
    if not p.is_file():
        return None
    try:
        with np.load(p, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            if meta.get("format_version") != FORMAT_VERSION:
                return None
            curves = [{**c, "t_s": z[f"t_s_{k}"], "theta_rad": z[f"theta_rad_{k}"],
                       "impacts_s": z[f"impacts_s_{k}"].tolist()} for k, c in enumerate(meta["curves"])]
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return None
    # the runs as stored: a file written under older names does not match this rockbench's plan, and is simulated again
    return {"runs": meta["runs"], "notes": meta["notes"], "curves": curves}
