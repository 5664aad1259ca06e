"""Probe: can MuJoCo reach the modified restitution η_M in free rocking?

Contact variants tried, each on B3M and B6M (planar block: slide x, slide z, hinge y; friction 10,
elliptic cones, no-slip solver, implicitfast, Δt = 0.5 ms, like the calibrated adapter):

* ``corners``: the adapter's box–plane contact (MuJoCo keeps the box's corner contacts), with
  ``solref`` (time constant, damping ratio), ``solimp`` width/d0 and ``margin`` (never tried before);
* ``distributed``: the box's own contact switched off and ``n`` small spheres (radius ``r``) in a
  row along the bottom face, the outermost ones exactly under the corners (so the static pivot
  stays at the corner and uplift is at g·tanα), with ``solref`` time constant and damping ratio
  and ``solimp``'s impedance d (dmin = dmax = d: the share of each contact that is MuJoCo's hard
  constraint; the rest is solref's spring-damper).

Each setting: free rocking from rest at α/2 (η measured impact by impact with the adapter's
``PEAK_RATIO``, the reader every calibration uses), and for the best settings a slow ramp of
the table acceleration (inertial force −m·a(t), a from 0.9 to 1.1 g·tanα over 8 s) giving the
static uplift threshold (the acceleration at the first instant with |θ| above the classifier's
uplift tolerance, 2 % of α, as :func:`rockbench.engines.calibration.price.uplift_threshold` reads it), and the
time from the release at α/2 to the first impact against the rigid model's (here to the step,
0.5 ms, i.e. ±0.4 % for B3M; the adapter's measurement interpolates). The "closest" settings
are picked by η alone: some of them fail the uplift check (one B6M setting tips over during the
ramp), which is why the adapter's calibration checks the price of each candidate.

Run: ``python tests/measurements/probes/probe_eta_m_mujoco.py [--quick]``; writes
the record ``tests/measurements/results/probe-eta-m-mujoco.json``.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import itertools
import json
import math
import sys
import time
from pathlib import Path

import numpy as np



import mujoco  # noqa: E402
from mujoco import rollout  # noqa: E402

from rockbench.benchmark.blocks.presets import get_preset  # noqa: E402
from rockbench.engines.calibration.free_rocking import PEAK_RATIO  # noqa: E402
from rockbench.reference_solver.model import G  # noqa: E402
from rockbench.reference_solver.restitution import housner_eta, modified_eta  # noqa: E402
from rockbench.reference_solver.validity import uplift_tol_rad  # noqa: E402

# tests/measurements/ holds the one records writer
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from records import write_record  # noqa: E402

MEASURES = "Can MuJoCo reach the modified restitution η_M in free rocking: η per block, per contact and contact setting."

DT = 5e-4


def build(block, contact: str, tc: float, dr: float, n: int = 2, r: float = 5e-4,
          solimp=None, margin: float = 0.0, mu: float = 10.0):
    b, h, d, m = block.width_m, block.height_m, block.depth_m, block.mass_kg
    spec = mujoco.MjSpec()
    spec.option.timestep = DT
    spec.option.gravity = [0, 0, -G]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.noslip_iterations = 10
    plane = spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1])
    body = spec.worldbody.add_body(name="block", pos=[0, 0, 0.5 * h])
    body.add_joint(name="x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
    body.add_joint(name="z", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
    body.add_joint(name="th", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0])
    box = body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.5 * b, 0.5 * d, 0.5 * h], mass=m)
    geoms = [plane]
    if contact == "corners":
        geoms.append(box)
    else:
        box.contype = 0
        box.conaffinity = 0
        for x in np.linspace(-0.5 * b, 0.5 * b, n):
            g = body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0],
                              pos=[float(x), 0.0, -0.5 * h + r], mass=0.0)
            geoms.append(g)
    for g in geoms:
        g.friction = [mu, 0.005, 0.0001]
        g.solref = [tc, dr]
        if solimp is not None:
            g.solimp = list(solimp)
        g.margin = margin
    act = spec.add_actuator()
    act.trntype = mujoco.mjtTrn.mjTRN_JOINT
    act.target = "x"
    act.gear = [1, 0, 0, 0, 0, 0]
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for _ in range(int(0.3 / DT)):
        mujoco.mj_step(model, data)
    data.qvel[:] = 0
    data.time = 0
    sp = mujoco.mjtState.mjSTATE_FULLPHYSICS
    s0 = np.empty(mujoco.mj_stateSize(model, sp))
    mujoco.mj_getState(model, data, s0, sp)
    return model, s0


def release_state(block, s0, th0):
    b, h = block.width_m, block.height_m
    s = s0.copy()
    sink = s[2]
    cx = 0.5 * b - 0.5 * b * math.cos(th0) + 0.5 * h * math.sin(th0)
    cz = 0.5 * b * math.sin(th0) + 0.5 * h * math.cos(th0)
    s[1:4] = [cx, cz - 0.5 * h + sink, th0]
    return s


def free_rocking(block, built, duration=3.0):
    """Free rocking of each model; models of one structure (geom count) share a native batch."""
    groups = {}
    for i, (model, _) in enumerate(built):
        groups.setdefault(model.ngeom, []).append(i)
    out = [None] * len(built)
    for idx in groups.values():
        res = _free_rocking([built[i] for i in idx], block, duration)
        for i, r in zip(idx, res):
            out[i] = r
    return out, None


def _free_rocking(built, block, duration):
    th0 = 0.5 * block.alpha_rad
    nstep = int(round(duration / DT))
    init = np.array([release_state(block, s0, th0) for _, s0 in built])
    models = [m for m, _ in built]
    datas = [mujoco.MjData(models[0]) for _ in range(2)]
    with rollout.Rollout(nthread=2) as ro:
        st, _ = ro.rollout(models, datas, init, np.zeros((len(models), nstep, 1)),
                           initial_warmstart=np.zeros((len(models), models[0].nv)))
    out = []
    for s_init, traj in zip(init, st):
        full = np.concatenate([s_init[None], traj])
        th, thd = full[:, 3], full[:, 6]
        etas = PEAK_RATIO.etas(block, th, th0)
        bounce = any(not (0 < e < 1) for e in etas)
        # first quarter period: time from release to θ = 0
        zc = np.nonzero(np.sign(th[1:]) != np.sign(th[:-1]))[0]
        t_quarter = float(zc[0] * DT) if zc.size else math.nan
        out.append({"etas": [float(e) for e in etas[:6]],
                    "eta": float(np.mean(etas[:4])) if len(etas) >= 2 and not bounce else math.nan,
                    "n_impacts": len(etas), "bounce": bounce, "t_quarter_s": t_quarter})
    return out


def rigid_quarter_period(block, frac=0.5):
    """Time from rest at frac·α to θ = 0 in the nonlinear rigid model (quadrature)."""
    a, p = block.alpha_rad, block.p_rad_s
    th0 = frac * a
    # θ̇² = 2p²(cos(α−θ0) − cos(α−θ)); t = ∫ dθ/θ̇; θ = θ0·(1 − s²) removes the 1/√ singularity at release
    s = np.linspace(0.0, 1.0, 20001)
    th = th0 * (1 - s**2)
    v = np.sqrt(np.maximum(2 * p**2 * (math.cos(a - th0) - np.cos(a - th)), 0.0))
    f = np.empty_like(s)
    f[1:] = 2 * th0 * s[1:] / v[1:]
    f[0] = 2 * th0 / (p * math.sqrt(2 * math.sin(a - th0) * th0))
    return float(np.trapezoid(f, s))


def uplift_ramp(block, model, s0, lo=0.9, hi=1.1, ramp_s=8.0):
    """Slow ramp of the table acceleration; the threshold as a fraction of g·tanα."""
    m = block.mass_kg
    a_ref = G * math.tan(block.alpha_rad)
    nstep = int(round(ramp_s / DT))
    t = (np.arange(nstep) + 0.5) * DT
    a = a_ref * (lo + (hi - lo) * t / ramp_s)
    ctrl = (-m * a)[None, :, None]
    datas = [mujoco.MjData(model)]
    with rollout.Rollout(nthread=1) as ro:
        st, _ = ro.rollout([model], datas, s0[None], ctrl, initial_warmstart=np.zeros((1, model.nv)))
    st = st[0]
    th = st[:, 3]
    tol = uplift_tol_rad(block)
    i_rock = np.nonzero(np.abs(th) > tol)[0]
    ratio_theta = float(a[i_rock[0]] / a_ref) if i_rock.size else math.nan
    pre = a < 0.98 * a_ref
    return {"ratio_theta_tol": ratio_theta,
            "max_abs_theta_below_0.98_rad": float(np.max(np.abs(th[pre]))), "uplift_tol_rad": tol,
            "rest_sink_m": float(-s0[2])}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    results = {"engine": "mujoco", "version": mujoco.__version__, "dt_s": DT, "date": str(_dt.date.today()),
               "method": "free rocking from α/2, η per impact by the shared peak-ratio reader, "
                         "mean of the first 4 impacts; NaN when a corner bounces or fewer than 2 impacts",
               "blocks": {}}
    for name in ("B3M", "B6M"):
        pr = get_preset(name)
        block = pr.block()
        a = block.alpha_rad
        targets = {"housner": housner_eta(a), "modified_average": modified_eta(a, pr.k_average),
                   "modified_exact": modified_eta(a, pr.k_exact)}
        rows = []
        grids = []
        # corners: solref, solimp width and d0, margin
        for f, dr in itertools.product((2, 4, 8, 16), (0.5, 1.0, 2.0)):
            grids.append({"contact": "corners", "tc": f * DT, "dr": dr})
        for f, w, d0 in itertools.product((2, 4, 8), (0.001, 0.01, 0.05), (0.5, 0.9)):
            grids.append({"contact": "corners", "tc": f * DT, "dr": 1.0, "solimp": (d0, 0.95, w, 0.5, 2)})
        for f, mg in itertools.product((2, 4, 8), (1e-4, 5e-4, 2e-3)):
            grids.append({"contact": "corners", "tc": f * DT, "dr": 1.0, "margin": mg})
        # distributed along the base: solref, and solimp's impedance d (dmin = dmax = d), which
        # decides how much of each contact is the solver's hard constraint and how much the soft
        # spring-damper of solref
        ns = (5, 9, 17) if not args.quick else (9,)
        for n, d, f, dr in itertools.product(ns, (0.3, 0.5, 0.7, 0.9), (2, 4, 8, 16), (0.5, 1.0, 2.0)):
            grids.append({"contact": "distributed", "n": n, "tc": f * DT, "dr": dr, "solimp": (d, d, 0.001, 0.5, 2)})
        built, ok = [], []
        for g in grids:
            try:
                built.append(build(block, g["contact"], g["tc"], g["dr"], n=g.get("n", 2),
                                   solimp=g.get("solimp"), margin=g.get("margin", 0.0)))
                ok.append(g)
            except Exception as e:  # noqa: BLE001
                rows.append({**g, "error": str(e)})
        t0 = time.perf_counter()
        meas = []
        for i in range(0, len(built), 16):
            mm, _ = free_rocking(block, built[i:i + 16])
            meas += mm
        wall = time.perf_counter() - t0
        for g, (model, s0), mm in zip(ok, built, meas):
            rows.append({**{k: (list(v) if isinstance(v, tuple) else v) for k, v in g.items()}, **mm,
                         "rest_sink_m": float(-s0[2])})
        tq_rigid = rigid_quarter_period(block)
        for r in rows:
            if "t_quarter_s" in r:
                r["quarter_period_change"] = r["t_quarter_s"] / tq_rigid - 1.0
        # uplift and price for the settings closest to each target, per contact variant
        best = {}
        for tname, tval in targets.items():
            for variant in ("corners", "distributed"):
                cand = [r for r in rows if r.get("contact") == variant and math.isfinite(r.get("eta", math.nan))]
                if not cand:
                    continue
                rb = min(cand, key=lambda r: abs(r["eta"] - tval))
                g = {k: rb[k] for k in ("contact", "tc", "dr", "n", "solimp", "margin") if k in rb}
                model, s0 = build(block, g["contact"], g["tc"], g["dr"], n=g.get("n", 2),
                                  solimp=g.get("solimp"), margin=g.get("margin", 0.0))
                up = uplift_ramp(block, model, s0)
                best[f"{tname}/{variant}"] = {"target": tval, **g, "eta": rb["eta"],
                                              "rel_error": rb["eta"] / tval - 1.0,
                                              "quarter_period_change": rb.get("quarter_period_change"), **up}
        etas = [r["eta"] for r in rows if math.isfinite(r.get("eta", math.nan))]
        results["blocks"][name] = {"targets": targets, "rigid_quarter_period_s": tq_rigid,
                                   "eta_span": [min(etas), max(etas)], "wall_s": wall,
                                   "best": best, "rows": rows}
        print(name, "targets", {k: round(v, 4) for k, v in targets.items()}, "span", min(etas), max(etas),
              f"{wall:.1f}s", flush=True)
        for k, v in best.items():
            print("  ", k, {kk: (round(vv, 4) if isinstance(vv, float) else vv) for kk, vv in v.items()}, flush=True)
    out = write_record("probe-eta-m-mujoco", MEASURES, "python tests/measurements/probes/probe_eta_m_mujoco.py " + " ".join(sys.argv[1:]),
                       results, packages=("mujoco",))
    print("wrote", out)


if __name__ == "__main__":
    main()
