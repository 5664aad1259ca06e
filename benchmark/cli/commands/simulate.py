"""``rockbench simulate``: one case through one engine (docs/cli.md).

Everything the user typed is checked before anything runs or is written; the simulation, its JSON
object and its files are :func:`rockbench.benchmark.simulation.simulate_case`'s; this command prints
them. A simulation that fails (the engine raised or diverged) prints its reason and exits 1: a failed
simulation is not a success. The text output is drawn from the JSON object alone, each number from
one field.
"""

from __future__ import annotations

import json
from pathlib import Path

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.solver import MODES
from rockbench.benchmark.simulation import simulate_case
from rockbench.benchmark.store.atomic import check_output_file
from rockbench.benchmark.request import CaseRequest
from rockbench.benchmark.cli.options import add_case_options

def register(sub) -> None:
    p = sub.add_parser("simulate", help="one simulation: outcome, impacts, θ(t) history and plot")
    add_case_options(p)
    p.add_argument("--mode", default=None, help="reference only: energy (default; decide at the pulse's end) "
                   "| to-rest (integrate until rest or overturn)")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.add_argument("--history", metavar="FILE.csv", default=None,
                   help="write t_s,theta_rad,theta_dot_rad_s[,theta_ddot_rad_s2] to FILE.csv")
    p.add_argument("--plot", metavar="FILE.png", default=None,
                   help="draw θ(t), the impacts and the pulse to FILE.png, FILE.svg or FILE.pdf (by the suffix)")
    p.set_defaults(func=run)


def _check_output(path: str | None, suffixes: tuple[str, ...], option: str) -> Path | None:
    if path is None:
        return None
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        names = ", ".join(suffixes[:-1]) + " or " + suffixes[-1] if len(suffixes) > 1 else suffixes[0]
        raise ConfigError(f"{option} must name a {names} file, got {path!r}.")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise ConfigError(f"{option}: the folder {str(parent)!r} does not exist; create it or choose another path.")
    if p.is_dir():
        raise ConfigError(f"{option}: {path!r} is a folder; give a file name.")
    return check_output_file(p, option)


def run(args) -> int:
    request = CaseRequest.from_args(args)
    case, preset = request.case()
    settings = request.engine_settings()
    if args.mode is not None:
        if args.engine != "reference":
            raise ConfigError(f"--mode applies to the reference engine only, got --engine {args.engine}.")
        if args.mode not in MODES:
            raise ConfigError(f"--mode must be energy or to-rest, got {args.mode!r}.")
        settings["mode"] = args.mode
    if case.linearized and args.engine != "reference":
        raise ConfigError(f"--linearized applies to the reference engine only, got --engine {args.engine}.")
    hist_path = _check_output(args.history, (".csv",), "--history")
    plot_path = _check_output(args.plot, (".png", ".svg", ".pdf"), "--plot")
    out = simulate_case(args.engine, settings, case, history=hist_path, plot=plot_path)
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        _print_text(out)
    return 1 if out["outcome"] is None else 0


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
