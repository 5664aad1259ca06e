"""Writing small map directories by hand, in the store's layout (run.json + cells.csv), for tests."""

import csv
import json
import math
from pathlib import Path

import numpy as np

from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.benchmark.store.files import variant_name
from rockbench.reference_solver.model import G
from rockbench.reference_solver.restitution import Restitution
from rockbench.reference_solver.rules import RULES_VERSION

NAMES = {-1: "", 0: "rest", 1: "rocking", 2: "overturn"}
from rockbench.benchmark.store.files import COLUMNS, SCHEMA_VERSION  # the store's own layout, so fixtures follow it


def write_map(d, codes, *, engine="reference", block="B6M", pulse="sine", restitution=None,
              w=(1.0, 10.0), a=(0.5, 8.0), settings=None, invalid=None, shuffle_seed=None):
    """A map directory with outcome ``codes`` (n_a × n_w, -1 failed) on linspace axes.

    ``invalid`` (a boolean grid) marks cells not valid: ``slip`` in an engine map, ``lift-required``
    (with a negative ``min_normal_mg``) in a reference map.
    """
    d = Path(d)
    d.mkdir(parents=True, exist_ok=True)
    codes = np.asarray(codes)
    n_a, n_w = codes.shape
    rest = restitution or Restitution()
    b = PRESETS[block].block()
    eta = rest.eta(b.alpha_rad)
    wr, ar = np.linspace(w[0], w[1], n_w), np.linspace(a[0], a[1], n_a)
    spec = {"engine": engine, "engine_settings": dict(settings or {}), "block": b.to_dict(), "pulse": pulse,
            "restitution": rest.to_dict(), "eta": eta, "x": {"name": "w_ratio", "lo": w[0], "hi": w[1], "n": n_w},
            "y": {"name": "a_ratio", "lo": a[0], "hi": a[1], "n": n_a}, "dt_s": None, "linearized": False}
    run = {"schema_version": SCHEMA_VERSION, "kind": "rockbench-map", "created_utc": "2026-01-01T00:00:00Z",
           "rules_version": RULES_VERSION,
           "engine": {"engine": engine, "version": "test", "settings": dict(settings or {})},
           "spec": spec, "spec_identity": spec, "options": {"adaptive": False}, "summary": None,
           "python": "3.11", "platform": "test", "git": {"commit": None, "dirty": None}}
    (d / "run.json").write_text(json.dumps(run))
    rows = []
    is_ref = engine == "reference"
    bad_flag = "lift-required" if is_ref else "slip"
    for i in range(n_a):
        for j in range(n_w):
            c = int(codes[i, j])
            ok = c >= 0
            valid = ok and not (invalid is not None and invalid[i, j])
            rows.append([engine, variant_name(engine, settings), block, pulse, rest.label, repr(eta), repr(float(wr[j])), repr(float(ar[i])),
                         repr(float(wr[j] * b.p_rad_s)), repr(float(ar[i] * G * math.tan(b.alpha_rad))),
                         NAMES[c], "1" if ok else "0", "0.1" if ok else "", "true" if valid else "false",
                         "" if valid else ("engine-error" if not ok else bad_flag), "ok" if ok else "failed",
                         "" if ok else "boom", "0.01", "", "", "", "",   # wall_s; cpu_s, simulated_s; times
                         ("1.0" if valid else "-0.5") if is_ref and ok else "",
                         ("0.5" if valid else "2.0") if is_ref and ok else "", str(i), str(j)])
    if shuffle_seed is not None:
        np.random.default_rng(shuffle_seed).shuffle(rows)
    with open(d / "cells.csv", "w", newline="") as f:
        wri = csv.writer(f, lineterminator="\n")
        wri.writerow(COLUMNS)
        wri.writerows(rows)
    return d


def band(n_a, n_w, first_row, below=1):
    c = np.full((n_a, n_w), below)
    c[first_row:] = 2
    return c
