"""``rockbench simulate``: one case through one engine (CLI.md).

Everything the user typed is checked before anything runs or is written; files are written
atomically (a temporary file in the same folder, then a rename). A simulation that fails (the
engine raised or diverged) prints its reason and exits 1: a failed simulation is not a success.

The text output is drawn from the JSON object alone, each number from one field: ``n_impacts``
and ``t_uplift_s`` are the classifier's (as in a map's cells.csv: sign changes of θ between
samples, the first sample off the base), ``impacts`` and ``uplifts_s`` the engine's own event
record where it keeps one (the reference's exact impact and uplift instants, which also see
flights shorter than a step).
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from pathlib import Path

import numpy as np

from ...engines.base import CellResult
from ...engines.registry import get_adapter
from ...reference_solver.errors import ConfigError, RockbenchError
from ...reference_solver.model import amplitude_to_a_ratio, omega_to_w_ratio
from ...reference_solver.solver import MODES
from ..atomic import check_output_file, write_atomic
from ..cli_options import add_case_options, case_from_args, engine_settings_from_args


def register(sub) -> None:
    p = sub.add_parser("simulate", help="one simulation: outcome, impacts, θ(t) history and plot")
    add_case_options(p)
    p.add_argument("--mode", default=None, help="reference only: energy (default; decide at the pulse's end) "
                   "| to-rest (integrate until rest or overturn)")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.add_argument("--history", metavar="FILE.csv", default=None,
                   help="write t_s,theta_rad,theta_dot_rad_s[,theta_ddot_rad_s2] to FILE.csv")
    p.add_argument("--plot", metavar="FILE.png", default=None, help="draw θ(t), the impacts and the pulse to FILE.png")
    p.set_defaults(func=run)


def _check_output(path: str | None, suffix: str, option: str) -> Path | None:
    if path is None:
        return None
    p = Path(path)
    if p.suffix.lower() != suffix:
        raise ConfigError(f"{option} must name a {suffix} file, got {path!r}.")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise ConfigError(f"{option}: the folder {str(parent)!r} does not exist; create it or choose another path.")
    if p.is_dir():
        raise ConfigError(f"{option}: {path!r} is a folder; give a file name.")
    return check_output_file(p, option)


def _num(x):
    if x is None:
        return None
    x = float(x)
    return None if math.isnan(x) else x


def run(args) -> int:
    case, preset = case_from_args(args)
    settings = engine_settings_from_args(args)
    if args.mode is not None:
        if args.engine != "reference":
            raise ConfigError(f"--mode applies to the reference engine only, got --engine {args.engine}.")
        if args.mode not in MODES:
            raise ConfigError(f"--mode must be energy or to-rest, got {args.mode!r}.")
        settings["mode"] = args.mode
    if case.linearized and args.engine != "reference":
        raise ConfigError(f"--linearized applies to the reference engine only, got --engine {args.engine}.")
    hist_path = _check_output(args.history, ".csv", "--history")
    plot_path = _check_output(args.plot, ".png", "--plot")
    adapter = get_adapter(args.engine, **settings)
    dt = adapter.dt_for(case)

    t0 = time.perf_counter()
    try:
        tr = adapter.simulate(case)
    except RockbenchError:
        raise
    except Exception as e:  # noqa: BLE001 - the engine failed: reported as a failed cell
        tr = None
        res = CellResult.failed("engine-error", f"{type(e).__name__}: {e}", time.perf_counter() - t0)
    else:
        res = adapter.judge(case, tr, time.perf_counter() - t0)

    block, pulse = case.block, case.pulse
    out = {
        "outcome": res.outcome, "n_impacts": res.n_impacts, "max_abs_theta_rad": _num(res.max_abs_theta_rad),
        "t_overturn_s": _num(res.t_overturn_s) if res.outcome == "overturn" else None,
        "t_uplift_s": _num(res.t_uplift_s), "eta": case.eta, "alpha_rad": block.alpha_rad,
        "p_rad_s": block.p_rad_s, "omega_rad_s": _num(pulse.omega_rad_s), "amplitude_mps2": pulse.amplitude_mps2,
        "w_ratio": None if pulse.omega_rad_s is None else omega_to_w_ratio(block, pulse.omega_rad_s),
        "a_ratio": amplitude_to_a_ratio(block, pulse.amplitude_mps2), "engine": adapter.name,
        "valid": res.valid, "flags": list(res.flags), "block": block.name, "pulse": pulse.kind,
        "restitution": case.restitution.label, "linearized": case.linearized, "dt_s": dt,
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

    if tr is not None and hist_path is not None:
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
        write_atomic(hist_path, write_csv)
        out["history"] = str(hist_path)
    if tr is not None and plot_path is not None:
        out["plot"] = str(_plot(plot_path, args.engine, settings, case, tr, res, out))
        out["plot_span_s"] = out.pop("_span")
        if out.get("_note"):
            out["plot_note"] = out.pop("_note")

    failed = res.outcome is None
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        _print_text(out)
    return 1 if failed else 0


def _plot(path: Path, engine: str, settings: dict, case, tr, res, out: dict) -> Path:
    """Draw θ(t) as far as the picture needs (:mod:`rockbench.benchmark.histories`): the reference's
    default mode stops at the pulse's end, so the picture's run is integrated on to rest or
    overturn, over a span that depends on the pulse alone (two runs of one case share it)."""
    from ..histories import impact_times, picture_span_s, trajectory_for_picture
    from ..labels import restitution_symbol, variant_label
    from ..plots.trajectories import plot_theta

    block, pulse = case.block, case.pulse
    pic, mode = trajectory_for_picture(engine, settings, case, tr)
    span = picture_span_s(pulse, res.t_overturn_s if res.outcome == "overturn" else None)
    outcome = res.outcome
    if pic is not tr:
        # the picture's run integrated on: its outcome is the one drawn (it differs from the
        # decision of the energy mode only in cells that touch the boundary)
        from ...engines.registry import get_adapter
        judged = get_adapter(engine, **{**settings, "mode": mode}).judge(case, pic)
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
    write_atomic(path, lambda tmp: drawn["figure"].savefig(tmp, format="png", dpi=130))
    return path


def _print_text(o: dict) -> None:
    lines = [f"{o['engine']}: {o['block']} (α = {o['alpha_rad']:.4f} rad, p = {o['p_rad_s']:.3f} rad/s), "
             f"{o['pulse']} pulse" + (f" ω = {o['omega_rad_s']:.4g} rad/s (ω/p = {o['w_ratio']:.4g})"
                                      if o["omega_rad_s"] is not None else "")
             + f", a₀ = {o['amplitude_mps2']:.4g} m/s² (a₀/(g·tanα) = {o['a_ratio']:.4g})",
             f"restitution {o['restitution']}: η = {o['eta']:.4f}; Δt = {o['dt_s']:g} s"
             + (f", mode {o['mode']}" if o["mode"] else "") + (", linearised" if o["linearized"] else "")]
    if o["outcome"] is None:
        lines.append(f"FAILED: {o['message']}")
    else:
        line = (f"outcome: {o['outcome']}, {o['n_impacts']} impact(s) up to the decision, "
                f"max |θ| = {o['max_abs_theta_rad']:.4f} rad")
        if o["t_uplift_s"] is not None:
            line += f", off the base at {o['t_uplift_s']:.4f} s"
        if o["t_overturn_s"] is not None:
            line += f", |θ| passed α at {o['t_overturn_s']:.4f} s"
        lines.append(line)
        lines += _event_lines(o)
    if o.get("min_normal_mg") is not None:
        lines.append(f"contact demand of the rigid model: min N/(m·g) = {o['min_normal_mg']:.3f}, "
                     f"max |F|/N = {o['max_friction_ratio']:.3f} (μ = {o['friction']:g})")
    if not o["valid"]:
        lines.append(f"not valid: flags {', '.join(o['flags'])}")
    for k in ("history", "plot"):
        if k in o:
            lines.append(f"{k}: {o[k]}")
    if "plot_note" in o:
        lines.append(f"plot: {o['plot_note']}")
    print("\n".join(lines))


#: impacts listed one per line in the text output (the JSON has them all)
SHOWN_IMPACTS = 10


def _event_lines(o: dict) -> list[str]:
    """The engine's event record (``impacts``, ``uplifts_s``), each count and time from those fields."""
    imps, ups = o["impacts"] or [], o["uplifts_s"] or []
    if not imps and not ups:
        return []
    head = f"event record: {len(imps)} impact(s)"
    if ups:
        head += f", {len(ups)} uplift(s), the first at {ups[0]:.5f} s"
    if len(imps) != o["n_impacts"]:
        head += (f" (the {o['n_impacts']} above count the sign changes of θ between samples, as in a map; the "
                 "record also has impacts closer together than a step, or after the decision)")
    out = [head + (":" if imps else "")]
    for d in imps[:SHOWN_IMPACTS]:
        out.append(f"  impact at {d['t_s']:.5f} s: θ̇ {d['theta_dot_minus_rad_s']:+.4f} → "
                   f"{d['theta_dot_plus_rad_s']:+.4f} rad/s")
    if len(imps) > SHOWN_IMPACTS:
        out.append(f"  ... {len(imps) - SHOWN_IMPACTS} more (all of them in --json)")
    return out
