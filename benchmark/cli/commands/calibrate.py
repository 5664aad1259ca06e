"""``rockbench calibrate``: an engine's restitution in free rocking, and contact settings that reach a target."""

from __future__ import annotations

import json

from rockbench.engines.calibration import cache, held_out, time_step
from rockbench.engines.calibration.layout import contact_layout
from rockbench.engines.calibration.price import price_line
from rockbench.engines.registry import names
from rockbench.reference_solver.errors import ConfigError, RockbenchError
from rockbench.benchmark.engine_info.adapters import build_adapter
from rockbench.benchmark.engine_info.health import refuse_outside_range
from rockbench.benchmark.request import CaseRequest
from rockbench.benchmark.cli.options import add_block_options
from rockbench.engines.calibration.free_rocking import measure_restitution
from rockbench.engines.calibration.price import calibration_price
from rockbench.engines.contact import ContactEngine
from rockbench.engines.calibration.routine import calibrate


def register(sub) -> None:
    p = sub.add_parser("calibrate", help="measure an engine's η in free rocking; with --target, search "
                       "its contact settings to reach it")
    add_block_options(p)
    p.add_argument("--engine", default=None, help="engine name (see `rockbench engines`); required unless --clear")
    p.add_argument("--target", default=None, help="housner | modified | modified-average | modified-exact | a number "
                   "in (0, 1] (default: measure only); above Housner's η the contact along the base is searched")
    p.add_argument("--k", default=None, help="impulse position for --target modified (default: the preset's average k; "
                   "--target modified-exact: its exact k)")
    p.add_argument("--dt", default=None, help="time step [s] (default: the engine's)")
    p.add_argument("--theta0", default="0.5", help="release angle as a fraction of α (measurement only; default 0.5)")
    p.add_argument("--settings", default=None, help="calibrated | shipped (measurement only)")
    p.add_argument("--drive", default=None, help="inertial | table")
    p.add_argument("--friction", default=None, help="friction coefficient [-]")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="any other engine setting")
    p.add_argument("--price", action="store_true", help="with --target: also measure what the contact found costs "
                   "(static uplift threshold, anti-slip, period change, speed) when the calibration has not")
    p.add_argument("--no-cache", action="store_true", help="search again even when a stored calibration exists")
    p.add_argument("--json", action="store_true", help="machine-readable output on stdout")
    p.add_argument("--clear", default=None, metavar="ENGINE", help="remove ENGINE's stored calibrations and "
                   "time-step rules (and nothing else), say how many, and exit")
    p.set_defaults(func=run)


def run(args) -> int:
    if args.clear is not None:
        return _clear(args.clear)
    if args.engine is None:
        raise ConfigError("calibrate needs --engine NAME (see `rockbench engines`), or --clear NAME to remove an "
                          "engine's stored calibrations.")
    request = CaseRequest.from_args(args)
    block, preset = request.block_and_preset()
    adapter = build_adapter(args.engine, **request.engine_settings())
    if getattr(adapter, "settings", {}).get("calibrate_on"):   # a calibration is of the block it ran on
        on = held_out.calibration_block(adapter.settings["calibrate_on"], block)
        raise ConfigError(f"calibrate_on is a setting of maps and runs (the held-out check); the calibration it uses "
                          f"is {on.name}'s own: rockbench calibrate --engine {args.engine} --block {on.name}.")
    try:
        out = _calibrate(args, request, adapter, block, preset)
    except RockbenchError:
        raise
    except Exception as e:  # noqa: BLE001 - an engine version outside the supported range: exit 3, one line
        refuse_outside_range(args.engine, e, "calibrating it")
        raise
    return _print(args, out)


def _clear(engine: str) -> int:
    """``--clear ENGINE``: remove the calibration cache's records of one engine (a known engine, or one
    that records name) and say how many; an unknown engine is a ConfigError (exit 2)."""
    stored = cache.engines_stored()
    if engine not in names() and engine not in stored:
        named = ", ".join(sorted(e for e in stored if e)) or "none"
        raise ConfigError(f"--clear: unknown engine {engine!r}; known engines: {', '.join(names())} (with stored "
                          f"calibrations: {named}); give one of them.")
    n = cache.clear(engine)
    print(f"removed {n} stored calibration record{'s' if n != 1 else ''} of {engine} from {cache.cache_dir()}")
    return 0


def _calibrate(args, request: CaseRequest, adapter, block, preset) -> dict:
    """What ``calibrate`` prints: the measured η, or the search for a target (and its price)."""
    dt = request.dt_s()
    if args.target is None:
        try:
            frac = float(args.theta0)
        except ValueError:
            raise ConfigError(f"--theta0 must be a number in (0, 1), got {args.theta0!r}.") from None
        if not 0.0 < frac < 1.0:
            raise ConfigError(f"--theta0 must be a fraction of α in (0, 1), got {args.theta0!r}.")
        m = measure_restitution(adapter, block, theta0_frac=frac, dt_s=dt)
        out = {"engine": adapter.name, "block": block.name, "eta_measured": m.eta_mean, "eta_std": m.eta_std,
               "eta_target": None, "n_impacts": len(m.etas), "etas": m.etas, "settings": m.settings,
               "dt_s": m.dt_s, "method": m.method}
    else:
        rest = request.restitution_law(preset, token=args.target, option="--target")
        target = rest.eta(block.alpha_rad)
        step_rule = None
        if dt is None and isinstance(adapter, ContactEngine):   # the step the benchmark runs the block at (the
            dt = time_step.step_for(adapter, block, target)        # one resolver), and the rule's record
            if adapter.calibrated() and contact_layout(adapter, block, target) == "corners":
                step_rule = time_step.rule_step(adapter, block, target)[1]
        c = calibrate(adapter, block, target, dt_s=dt, use_cache=not args.no_cache)
        if args.price and c.price is None:
            if not isinstance(adapter, ContactEngine):
                raise ConfigError(f"--price: engine {adapter.name!r} does not measure a contact price; "
                                  "leave --price out.")
            c.price = calibration_price(adapter, block, c, dt)
        out = {"engine": adapter.name, "block": block.name, "target": rest.label, **c.to_dict(),
               "dt_s": dt, "step_rule": step_rule}
    return out


def _print(args, out: dict) -> int:
    if args.json:
        print(json.dumps(out, indent=2, default=float))
        return 0
    print(f"{out['engine']} on {out['block']}: η measured {out['eta_measured']:.4f} ± {out['eta_std']:.4f}"
          + (f", target {out['eta_target']:.4f} ({'reached' if out['reached'] else 'NOT reached'}, "
             f"{100 * out['rel_error']:+.2f} %)" if out.get("eta_target") is not None else ""))
    if out.get("note"):
        print(out["note"])
    if out.get("step_rule"):
        r = out["step_rule"]
        print(f"time step {1e3 * r['dt_s']:g} ms: the time-step rule's "
              + ("coarsest step agreeing with the finest" if r["converged"] else
                 "finest step (no coarser step of the ladder agreed with it)"))
    if out.get("price") is not None and "price:" not in (out.get("note") or ""):
        print(price_line(out["price"]))
    print("settings: " + json.dumps(out["settings"], default=float))
    return 0
