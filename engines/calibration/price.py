"""What a contact setting costs: the checks a calibration to a restitution target must pass.

A contact that reaches a restitution target (for example the modified η_M with a row of contact
points along the base) may pay for it elsewhere. :func:`contact_price` measures, with
the adapter's own simulation and the one judge (nothing here decides a verdict for an engine):

* **static uplift threshold**: the table acceleration is ramped slowly (``RAMP_FROM`` → ``RAMP_TO``
  times g·tanα over ``RAMP_S``), and the threshold is the acceleration at the first sample where
  ``|θ|`` exceeds the classifier's uplift tolerance; the ratio to g·tanα must be within
  ``UPLIFT_RTOL`` (2 %), and below ``(1 − UPLIFT_RTOL)·g·tanα`` the block must not rock;
* **anti-slip**: a set of cells of the default suite's pulses (sine and cosine, ω/p and
  a₀/(g·tanα) spread over the suite's grid, :data:`PRICE_CELLS`) run and judged by the one validity
  rule; of those, the cells where the rigid model itself needs neither lift nor slip (the
  reference's ``lift-required`` / ``slip-required`` demand with the adapter's friction) are the
  ones a contact must get through without ``slip`` or ``jump``: the price counts its flags there;
* **free-rocking period**: the time from a release at α/2 to the first impact, against the rigid
  model's (:func:`rigid_first_quarter_s`), where the adapter reports it;
* **speed**: engine time steps per second of wall time over the anti-slip cells.

A contact *counts* (``counts`` in the result) when its uplift threshold is within 2 % without
rocking below it and no anti-slip cell carries a ``slip`` flag.
"""

from __future__ import annotations

import math
import time

import numpy as np

from rockbench.reference_solver.model import G, Block
from rockbench.reference_solver.pulses import RecordPulse, make_pulse
from rockbench.reference_solver.restitution import Restitution
from rockbench.engines.contract import CalibrationResult, Case
from rockbench.engines.calibration.free_rocking import free_rocking_step, measure_restitution
from rockbench.engines.calibration.layout import with_contact
from rockbench.engines.calibration.rigid import rigid_answers

#: Tolerance on the static uplift threshold ratio (within 2 % to count) [-].
UPLIFT_RTOL = 0.02
#: Ramp of the table acceleration, as fractions of g·tanα, and its length [s]; the ramp starts
#: from 0 over ``RAMP_LEAD_S``.
RAMP_FROM, RAMP_TO, RAMP_S, RAMP_LEAD_S = 0.9, 1.1, 8.0, 1.0
#: Cells for the anti-slip check: (pulse, ω/p, a₀/(g·tanα)) inside the default suite's grid
#: (ω/p 1–16, a₀/(g·tanα) 1–12), strong pulses where the contact's demand is highest.
PRICE_CELLS = tuple((pulse, w, a) for pulse in ("sine", "cosine") for w in (2.0, 4.0, 8.0, 12.0)
                    for a in (1.5, 2.5, 4.0, 6.0))


def rigid_first_quarter_s(block: Block, theta0_frac: float = 0.5) -> float:
    """Time for the rigid block released from rest at ``theta0_frac·α`` to reach θ = 0 [s].

    Nonlinear free rocking (docs/physics.md §1): ``θ̇² = 2p²(cos(α − θ₀) − cos(α − θ))``; the integral
    ``∫dθ/|θ̇|`` is taken with ``θ = θ₀(1 − s²)``, which removes the square-root singularity at the
    release (the integrand tends to ``2θ₀/(p·√(2θ₀·sin(α − θ₀)))`` there).
    """
    a, p = block.alpha_rad, block.p_rad_s
    th0 = theta0_frac * a
    s = np.linspace(0.0, 1.0, 20001)
    th = th0 * (1.0 - s * s)
    v = np.sqrt(np.maximum(2.0 * p * p * (math.cos(a - th0) - np.cos(a - th)), 0.0))
    f = np.empty_like(s)
    f[1:] = 2.0 * th0 * s[1:] / v[1:]
    f[0] = 2.0 * th0 / (p * math.sqrt(2.0 * th0 * math.sin(a - th0)))
    from scipy.integrate import trapezoid   # SciPy on first use (start-up time: about 1 s, for every contact engine)
    return float(trapezoid(f, s))   # SciPy's: np.trapezoid is NumPy 2 only, and NumPy 1.26 is supported


def ramp_pulse(block: Block) -> RecordPulse:
    """The slow ramp of the table acceleration used for the static uplift threshold."""
    A = G * math.tan(block.alpha_rad)
    t = [0.0, RAMP_LEAD_S, RAMP_LEAD_S + RAMP_S, RAMP_LEAD_S + RAMP_S + 0.05]
    return RecordPulse(np.array(t), np.array([0.0, RAMP_FROM * A, RAMP_TO * A, 0.0]), source="uplift ramp")


def uplift_threshold(adapter, block: Block, restitution: Restitution, dt_s: float | None = None) -> dict:
    """The static uplift threshold under a slow ramp (module docstring), with the adapter's settings."""
    A = G * math.tan(block.alpha_rad)
    pulse = ramp_pulse(block)
    try:
        tr = adapter.simulate(Case(block, pulse, restitution, dt_s))
    except Exception as e:  # noqa: BLE001 - a contact the ramp breaks does not count; recorded
        return {"error": f"{type(e).__name__}: {e}", "within": False}
    t = np.asarray(tr.t_s)
    th = np.abs(np.asarray(tr.theta_rad))
    acc = np.abs(np.asarray(pulse.accel(t)))
    ramp = (t >= RAMP_LEAD_S) & (t <= RAMP_LEAD_S + RAMP_S)
    tol = float(tr.uplift_tol_rad)
    lifted = np.nonzero(ramp & (th > tol))[0]
    ratio = float(acc[lifted[0]] / A) if lifted.size else math.nan
    below = t <= RAMP_LEAD_S + RAMP_S * ((1.0 - UPLIFT_RTOL) - RAMP_FROM) / (RAMP_TO - RAMP_FROM)
    max_below = float(th[below].max()) if below.any() else math.nan
    rocks_below = bool(max_below > tol)
    return {"ratio": ratio, "within": bool(math.isfinite(ratio) and abs(ratio - 1.0) <= UPLIFT_RTOL
                                           and not rocks_below),
            "rtol": UPLIFT_RTOL, "max_abs_theta_below_rad": max_below, "rocks_below": rocks_below,
            "uplift_tol_rad": tol,
            "ramp": f"{RAMP_FROM:g}→{RAMP_TO:g}·g·tanα over {RAMP_S:g} s (after {RAMP_LEAD_S:g} s from 0)"}


def anti_slip(adapter, block: Block, restitution: Restitution, dt_s: float | None = None,
              cells=PRICE_CELLS) -> dict:
    """The default suite's pulses on ``cells``, judged by the one validity rule: flag counts and speed."""
    A = G * math.tan(block.alpha_rad)
    cases = [Case(block, make_pulse(kind, a * A, w * block.p_rad_s), restitution, None) for kind, w, a in cells]
    rigid_ok = [not flags for _, flags in rigid_answers(cases, adapter.friction)]
    cases = [Case(c.block, c.pulse, c.restitution, dt_s) for c, ok in zip(cases, rigid_ok) if ok]
    kept = [c for c, ok in zip(cells, rigid_ok) if ok]
    t0 = time.perf_counter()
    res = adapter.run_many(cases)
    wall = time.perf_counter() - t0
    steps = sum(int((r.diagnostics or {}).get("steps", 0)) for r in res)
    count = {f: sum(f in r.flags for r in res) for f in ("slip", "jump", "energy-gain", "engine-error", "diverged")}
    return {"cells": len(cases), "cells_tried": len(cells), "valid": sum(bool(r.valid) for r in res),
            **{f"n_{k.replace('-', '_')}": v for k, v in count.items()},
            "slip_cells": [list(c) for c, r in zip(kept, res) if "slip" in r.flags],
            "jump_cells": [list(c) for c, r in zip(kept, res) if "jump" in r.flags],
            "steps_per_s": steps / wall if wall > 0 and steps else None, "wall_s": wall}


def contact_price(adapter, block: Block, restitution: Restitution, dt_s: float | None = None, *,
                  first_quarter_s: float | None = None, slip_cells=PRICE_CELLS, uplift: dict | None = None) -> dict:
    """Uplift threshold, anti-slip, period change and speed of ``adapter``'s contact (module docstring).

    ``adapter`` must already hold explicit contact settings (no calibration is triggered by the
    cases run here); ``first_quarter_s`` is the adapter's free-rocking time from α/2 to the first
    impact, when it measured one; ``uplift`` is :func:`uplift_threshold` of this adapter, block,
    restitution and step where the caller ran it already (the ramp is then not run again).
    """
    up = uplift_threshold(adapter, block, restitution, dt_s) if uplift is None else uplift
    slip = anti_slip(adapter, block, restitution, dt_s, slip_cells) if slip_cells else None
    rigid = rigid_first_quarter_s(block)
    out = {"uplift": up, "anti_slip": slip,
           "period_change": (first_quarter_s / rigid - 1.0) if first_quarter_s else None,
           "rigid_first_quarter_s": rigid, "first_quarter_s": first_quarter_s,
           "steps_per_s": slip["steps_per_s"] if slip else None}
    # the contact counts when it keeps the static threshold and holds the anti-slip (jumps are
    # reported: a contact may hop where the rigid model's normal force comes close to zero)
    out["counts"] = bool(up.get("within")) and (slip is None or slip["n_slip"] == 0)
    return out


def calibration_price(ad, block: Block, c: CalibrationResult, dt_s: float | None = None) -> dict:
    """The price (:func:`contact_price`) of calibration ``c``'s contact in contact engine ``ad`` at step
    ``dt_s`` [s] (default: the step of the contact given, :func:`free_rocking_step`: no rule chooses
    it), with the free-rocking period change measured at that step."""
    fixed = with_contact(ad, c.settings)
    dt = free_rocking_step(fixed, dt_s)
    m = measure_restitution(fixed, block, dt_s=dt)
    return contact_price(fixed, block, Restitution("constant", value=c.eta_target), dt, first_quarter_s=m.first_quarter_s)


def price_line(price: dict | None) -> str:
    """One line for the CLI: the contact's price."""
    if not price:
        return "price: not measured"
    up = price["uplift"]
    parts = []
    if "error" in up:
        parts.append(f"uplift ramp failed ({up['error']})")
    else:
        parts.append(f"static uplift at {up['ratio']:.4f}·g·tanα ({'within' if up['within'] else 'NOT within'} "
                     f"{100 * UPLIFT_RTOL:g} %{', rocks below' if up['rocks_below'] else ''})")
    s = price.get("anti_slip")
    if s:
        parts.append(f"{s['n_slip']} slip / {s['n_jump']} jump in {s['cells']} default-suite cells the rigid model "
                     "rocks through without lift or slip")
    if price.get("period_change") is not None:
        parts.append(f"free-rocking quarter period {100 * price['period_change']:+.2f} % vs rigid")
    if price.get("steps_per_s"):
        parts.append(f"{price['steps_per_s']:.3g} steps/s")
    return "price: " + "; ".join(parts)
