"""One case through one engine, as ``rockbench simulate`` and :func:`rockbench.benchmark.simulate` show it.

:func:`run_case` simulates and judges (an engine that raises gives a failed result, as a map's cell
does); :func:`simulate_case` builds the command's JSON object (docs/cli.md), writes the θ(t) history and
the picture when asked. The command only checks the options and prints.

In the object, ``n_impacts`` and ``t_uplift_s`` are the classifier's (as in a map's cells.csv: sign
changes of θ between samples, the first sample off the base), ``impacts`` and ``uplifts_s`` the
engine's own event record where it keeps one (the reference's exact impact and uplift instants, which
also see flights shorter than a step).
"""

from __future__ import annotations

import csv
import io
import math
import time
from pathlib import Path

import numpy as np

from rockbench.engines.contract import CellResult
from rockbench.reference_solver.errors import RockbenchError
from rockbench.reference_solver.model import amplitude_to_a_ratio, omega_to_w_ratio
from rockbench.benchmark.engine_info.adapters import build_adapter
from rockbench.benchmark.report.histories import impact_times, picture_span_s
from rockbench.benchmark.report.plots.output import save_figure
from rockbench.benchmark.report.plots.trajectories import plot_theta
from rockbench.benchmark.scoring.labels import restitution_symbol, variant_label
from rockbench.benchmark.store.atomic import write_atomic


def run_case(adapter, case):
    """``(trajectory or None, CellResult)`` of ``case`` through ``adapter``: simulated, then judged by
    the one judge; an engine that raises (other than a RockbenchError, which is the user's) gives a
    failed result flagged ``engine-error`` and no trajectory."""
    t0 = time.perf_counter()
    try:
        tr = adapter.simulate(case)
    except RockbenchError:
        raise
    except Exception as e:  # noqa: BLE001 - the engine failed: reported as a failed cell
        return None, CellResult.failed("engine-error", f"{type(e).__name__}: {e}", time.perf_counter() - t0)
    return tr, adapter.judge(case, tr, time.perf_counter() - t0)


def _num(x):
    if x is None:
        return None
    x = float(x)
    return None if math.isnan(x) else x


def simulation_record(adapter, case, res, dt_s: float) -> dict:
    """The JSON object of one simulation (docs/cli.md, "What ``simulate --json`` prints"), from the case, its result and
    the time step it ran with [s]."""
    block, pulse = case.block, case.pulse
    out = {
        "outcome": res.outcome, "n_impacts": res.n_impacts, "max_abs_theta_rad": _num(res.max_abs_theta_rad),
        "t_overturn_s": _num(res.t_overturn_s) if res.outcome == "overturn" else None,
        "t_uplift_s": _num(res.t_uplift_s), "eta": case.eta, "alpha_rad": block.alpha_rad,
        "p_rad_s": block.p_rad_s, "omega_rad_s": _num(pulse.omega_rad_s), "amplitude_mps2": pulse.amplitude_mps2,
        "w_ratio": None if pulse.omega_rad_s is None else omega_to_w_ratio(block, pulse.omega_rad_s),
        "a_ratio": amplitude_to_a_ratio(block, pulse.amplitude_mps2), "engine": adapter.name,
        "valid": res.valid, "flags": list(res.flags), "block": block.name, "pulse": pulse.kind,
        "restitution": case.restitution.label, "linearized": case.linearized, "dt_s": dt_s,
        "mode": adapter.settings.get("mode") if adapter.name == "reference" else None,
        "t_pulse_end_s": pulse.duration_s,
        "impacts": (res.diagnostics or {}).get("impacts", []),
        "uplifts_s": (res.diagnostics or {}).get("uplifts_s"),
        "message": res.message,
    }
    if res.min_normal_mg is not None:
        # the rigid model's contact demand (reference only): what the pivot must supply
        out["min_normal_mg"] = _num(res.min_normal_mg)
        out["max_friction_ratio"] = _num(res.max_friction_ratio)
        out["friction"] = adapter.friction
    return out


def write_history(path: Path, tr) -> Path:
    """``t_s,theta_rad,theta_dot_rad_s[,theta_ddot_rad_s2]`` of a trajectory to ``path`` (atomically;
    every number as Python's ``repr``, so it reads back exactly)."""
    cols = [("t_s", tr.t_s), ("theta_rad", tr.theta_rad), ("theta_dot_rad_s", tr.theta_dot_rad_s)]
    if tr.theta_ddot_rad_s2 is not None:
        cols.append(("theta_ddot_rad_s2", tr.theta_ddot_rad_s2))

    def write_csv(tmp):
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow([c for c, _ in cols])
        for row in zip(*(np.asarray(v) for _, v in cols)):
            w.writerow([repr(float(x)) for x in row])
        Path(tmp).write_text(buf.getvalue())
    return write_atomic(path, write_csv)


def simulate_case(engine: str, settings: dict, case, *, history: Path | None = None,
                  plot: Path | None = None) -> dict:
    """Simulate ``case`` with ``engine`` (``settings``), and write its history and picture when paths are
    given; the JSON object of ``rockbench simulate`` (:func:`simulation_record`, plus ``history``,
    ``plot``, ``plot_span_s`` and ``plot_note`` where written). ``outcome`` is None when it failed."""
    adapter = build_adapter(engine, **settings)
    dt = adapter.posed(case).dt_s   # the one resolver: a bad step refused first
    tr, res = run_case(adapter, case)
    out = simulation_record(adapter, case, res, dt)
    if tr is not None and history is not None:
        out["history"] = str(write_history(history, tr))
    if tr is not None and plot is not None:
        out["plot"] = str(plot_simulation(plot, engine, settings, case, tr, res, out))
        out["plot_span_s"] = out.pop("_span")
        if out.get("_note"):
            out["plot_note"] = out.pop("_note")
    return out


def trajectory_for_picture(engine: str, settings: dict, case, trajectory=None):
    """A trajectory of ``case`` that runs as far as its picture needs.

    The reference is integrated on until rest or overturn (``mode="to-rest"``) unless
    ``trajectory`` already came from that mode; an engine's own trajectory already runs to its own
    decision (a bounded tail after the pulse) and is returned as it is (simulated when None).

    Returns
    -------
    (Trajectory, str or None)
        The trajectory, and the mode it was integrated in (reference only).
    """
    if engine == "reference":
        if trajectory is not None and (trajectory.diagnostics or {}).get("mode") == "to-rest":
            return trajectory, "to-rest"
        s = {**dict(settings or {}), "mode": "to-rest"}
        return build_adapter("reference", **s).simulate(case), "to-rest"
    if trajectory is None:
        trajectory = build_adapter(engine, **dict(settings or {})).simulate(case)
    return trajectory, None


def plot_simulation(path: Path, engine: str, settings: dict, case, tr, res, out: dict) -> Path:
    """Draw θ(t) as far as the picture needs (:mod:`rockbench.benchmark.report.histories`): the reference's
    default mode stops at the pulse's end, so the picture's run is integrated on to rest or
    overturn, over a span that depends on the pulse alone (two runs of one case share it)."""
    block, pulse = case.block, case.pulse
    pic, mode = trajectory_for_picture(engine, settings, case, tr)
    span = picture_span_s(pulse, res.t_overturn_s if res.outcome == "overturn" else None)
    outcome = res.outcome
    if pic is not tr:
        # the picture's run integrated on: its outcome is the one drawn (it differs from the
        # decision of the energy mode only in cells that touch the boundary)
        judged = build_adapter(engine, **{**settings, "mode": mode}).judge(case, pic)
        if judged.outcome != res.outcome:
            out["_note"] = (f"integrated to rest for the picture, the run gives {judged.outcome} "
                            f"(the energy decision gives {res.outcome})")
        outcome = judged.outcome
        if outcome == "overturn":
            span = picture_span_s(pulse, judged.t_overturn_s)
    who = variant_label(engine, settings, restitution=case.restitution.label, block=block.name)
    law = restitution_symbol(case.restitution.label, block.name)
    label = f"{who if engine != 'reference' else 'reference'}, {law} = {case.eta:.4f}: {outcome}"
    title = (f"{block.name}, {pulse.kind}" + (f", ω/p = {out['w_ratio']:.3g}" if out["w_ratio"] is not None else "")
             + f", a₀/(g·tanα) = {out['a_ratio']:.3g}")
    drawn = plot_theta([{"label": label, "t_s": pic.t_s, "theta_rad": pic.theta_rad, "impacts_s": impact_times(pic),
                         "reference": engine == "reference", "outcome": outcome}],
                       alpha_rad=block.alpha_rad, pulse=pulse, t_end_s=span, title=title)
    out["_span"] = span
    return save_figure(drawn["figure"], path)
