"""The one calibration routine of every contact engine: candidates measured in free rocking, the
one pick among them, cached.

A calibration (:func:`calibrate`, a function of the engine, not a method it inherits) chooses contact
settings whose free-rocking η reaches a target. For the contact at the
two bottom corners (:func:`calibrate_layout` with ``points`` None) the engine's candidates (its
declared knobs searched by :func:`~rockbench.engines.calibration.knobs.search`, or its own
``candidates`` function) are each measured in free rocking and the one pick
(:func:`~rockbench.engines.calibration.pick.pick`) chooses. For a row of ``points`` contact points
along the base (a target above Housner's η, docs/contact.md) the pick's order is tried until a
candidate keeps the static uplift threshold and the anti-slip cells (:mod:`.price`);
:func:`first_reached` tries 9, 5 and 17 points. Notes are written from the knobs; the damping ratio
the pick's tie-break reads comes from the knobs' declarations (:func:`damping_ratio`). The engine is
an argument: these functions call only its public methods (``candidates``, ``measure_many``,
``settings_with``, ``explicit_contact``) and read its declarations and settings
(:mod:`~rockbench.engines.calibration.layout`: the contact it builds).
"""

from __future__ import annotations

import dataclasses
import math

from rockbench.reference_solver.errors import ConfigError

from rockbench.engines.errors import EngineError
from rockbench.reference_solver.model import Block
from rockbench.reference_solver.restitution import Restitution
from rockbench.reference_solver.rules import RULES_VERSION
from rockbench.engines import progress
from rockbench.engines.contract import CONTRACT_VERSION, CalibrationResult
from rockbench.engines.calibration import cache, price as pricing
from rockbench.engines.calibration.layout import contact_layout, with_contact
from rockbench.engines.calibration.free_rocking import free_rocking_step, measure_restitution, require_contact
from rockbench.engines.calibration.pick import ETA_RESOLUTION, Candidate, damping_ratio_of_restitution, pick, ranked, regular

__all__ = ["calibrate", "POINTS_TRIED", "calibrate_layout", "first_reached", "measured_rows", "damping_ratio", "cache_key", "MAX_PRICE_TRIES",
           "IDENTITY_SKIP"]

#: Points of a row along the base a calibration tries in turn where ``contact_points`` is not set (the
#: first is also the default row)
POINTS_TRIED = (9, 5, 17)

#: How many reached candidates the search of a row of points along the base prices at most.
MAX_PRICE_TRIES = 8

#: Settings that do not change a free-rocking run (how long a mapped run lasts, how it is batched,
#: which block it is calibrated on): left out of a calibration's cache key
IDENTITY_SKIP = ("settings", "tail_s", "min_tail_s", "segment_s", "calibrate_on", "threads", "judge_workers")


def calibrate(ad, block: Block, target_eta: float, *, dt_s: float | None = None,
              use_cache: bool = True) -> CalibrationResult:
    """Contact settings of contact engine ``ad`` whose free-rocking η reaches ``target_eta`` (1 %) at step
    ``dt_s`` [s] (default: :func:`~rockbench.engines.calibration.free_rocking.free_rocking_step`'s): at the
    corners, or (``contact = auto`` above 1 % over Housner's η_H, or ``distributed``) a row of points along the base with the set number of
    points, else :data:`POINTS_TRIED` in turn until one reaches the target at an acceptable price
    (:func:`first_reached`). A ConfigError with a contact given: it replaces the calibration (in maps
    too)."""
    require_contact(ad)
    if ad.explicit_contact():
        given = [f"{k} = {ad.settings[k]!r}" for k in ad.SHIPPED if ad.settings.get(k) is not None]
        raise ConfigError(f"{ad.name}: {', '.join(given)} is given, and a given contact replaces the calibration "
                          "(in maps as here), so there is nothing to calibrate: leave out --target to measure η "
                          "with it, or leave it out to calibrate.")
    t = _target(target_eta)
    dt = free_rocking_step(ad, dt_s)
    if contact_layout(ad, block, t) != "distributed":
        return calibrate_layout(ad, block, t, dt, None, use_cache)
    n_set = ad.settings["contact_points"]
    return first_reached(lambda n: calibrate_layout(ad, block, t, dt, n, use_cache),
                         (n_set,) if n_set is not None else POINTS_TRIED, ad.CONTACT_ROWS)


def _target(target_eta) -> float:
    """A calibration target η as a float, or a ConfigError unless it is in (0, 1]."""
    try:
        t = float(target_eta)
    except (TypeError, ValueError):
        t = math.nan
    if not (math.isfinite(t) and 0.0 < t <= 1.0):
        raise ConfigError(f"the target η must be in (0, 1], got {target_eta!r}.")
    return t


def cache_key(ad, block: Block, target: float, dt: float, kind: str, **more) -> str:
    """The cache key of a calibration (``kind``) of engine ``ad`` for ``block``, ``target`` η and step
    ``dt`` [s]: the engine and its version, the adapter's identity (its distribution and the hash of
    its source, :func:`~rockbench.engines.calibration.cache.adapter_identity`), the contract, its
    ``CALIBRATION_VERSION``, the rule set's version and every setting that changes a free-rocking run."""
    identity = {k: str(v) for k, v in sorted(ad.settings_with(None).items()) if k not in IDENTITY_SKIP}
    return cache.adapter_key(ad, contract=CONTRACT_VERSION, kind=kind,
                             calibration_version=ad.CALIBRATION_VERSION, rules_version=RULES_VERSION,
                             block=[block.width_m, block.height_m, block.depth_m, block.mass_kg], target=target,
                             dt=dt, settings=identity, **more)


def damping_ratio(ad, block: Block, s: dict) -> float | None:
    """The damping ratio ζ (1: critical) of contact settings ``s`` of engine ``ad``, for the pick's
    tie-break: a spring-dashpot's ``c/(2√(k·m))`` where ``s`` has ``contact_stiffness_n_m`` k and
    ``contact_damping_n_s_m`` c (m the block's mass), else the first knob that says what its value
    is (``Knob.zeta``) and is set; None where nothing is known (counts as critical)."""
    k, c = s.get("contact_stiffness_n_m"), s.get("contact_damping_n_s_m")
    if k and c is not None:
        return c / (2.0 * math.sqrt(k * block.mass_kg))
    for knob in tuple(ad.KNOBS) + tuple(ad.ROW_KNOBS):
        v = s.get(knob.name)
        if knob.zeta == "ratio" and v is not None:
            return v
        if knob.zeta == "restitution" and v:
            return damping_ratio_of_restitution(v)
    return None


def measured_rows(ad, block: Block, dt: float, candidates: list[dict], points: int | None) -> list[dict]:
    """Free rocking of each candidate (contact settings) of engine ``ad`` at step ``dt`` [s] (a row of
    ``points`` along the base, None: the corners): one row each, the candidate with what the pick reads
    (``eta``, ``eta_std``, ``n``, ``sink_m``, ``hop_m``, ``damping_ratio``); a candidate the engine
    fails on is a row with NaN η and the ``error``."""
    settings = [ad.settings_with(c, points) for c in candidates]
    progress.plan(len(candidates))
    measured = ad.measure_many(block, settings, dt)
    progress.advance(len(candidates))   # a batch engine measures them at once; the others counted one by one
    rows = []
    for c, s, m in zip(candidates, settings, measured):
        if isinstance(m, BaseException):
            rows.append({**c, "eta": math.nan, "eta_std": math.nan, "n": 0, "error": f"{type(m).__name__}: {m}"})
            continue
        rows.append({**c, "eta": m.eta_mean, "eta_std": m.eta_std, "n": len(m.etas), "sink_m": m.sink_m,
                     "hop_m": m.hop_m, "damping_ratio": damping_ratio(ad, block, s)})
    return rows


def _chosen_settings(ad, row: dict, points: int | None) -> dict:
    """What a calibration records as its settings: every contact setting (None: left as shipped), the
    candidate's settings, and for a row of points its layout."""
    out = {k: None for k in ad.SHIPPED} | {k: v for k, v in row.items() if k in ad.SETTINGS}
    return out if points is None else {**out, "contact": "distributed", "contact_points": points}


def calibrate_layout(ad, block: Block, target: float, dt: float, points: int | None,
                     use_cache: bool = True) -> CalibrationResult:
    """The calibration of engine ``ad`` to ``target`` at step ``dt`` [s]: the corners (``points``
    None) or a row of ``points`` along the base (module docstring); cached as ``{"result", "search"}``."""
    key = cache_key(ad, block, target, dt, "corners" if points is None else "row",
                    **({} if points is None else {"points": points,
                                                  "price_cells": [list(c) for c in pricing.PRICE_CELLS]}))
    rec = cache.load(key) if use_cache else None
    if rec is not None and "result" in rec:
        return CalibrationResult(**rec["result"])
    with progress.activity(_activity_label(ad, block, target, dt, points)):
        rows = _searched(ad, block, target, dt, points)
        res, search = (_corners(ad, block, target, rows) if points is None else
                       _row(ad, block, target, dt, points, rows))
    cache.store(key, {"result": {k: v for k, v in res.to_dict().items() if k != "rel_error"}, "search": search},
                ad.name)
    return res


def _searched(ad, block: Block, target: float, dt: float, points: int | None) -> list[dict]:
    """The measured rows of the engine's candidates; an EngineError where free rocking failed for
    every one, a ConfigError where none gave a measurable η."""
    rows = ad.candidates(block, target, dt, points, lambda cands: measured_rows(ad, block, dt, cands, points))
    if not any(math.isfinite(r["eta"]) for r in rows):
        errors = [r["error"] for r in rows if "error" in r]
        if errors and len(errors) == len(rows):
            raise EngineError(f"{ad.name} calibration: free rocking failed for every setting tried: {errors[0]}")
        raise ConfigError(f"{ad.name} calibration: no contact setting gave a measurable free rocking (fewer than "
                          "two impacts); try a smaller --dt.")
    return rows


def _activity_label(ad, block: Block, target: float, dt: float, points: int | None) -> str:
    """What a calibration's progress lines call it (the engine named where nothing encloses it)."""
    where = "" if points is None else f", {points} {ad.CONTACT_ROWS} along the base"
    return (("" if progress.is_open() else f"{ad.name}: ")
            + f"calibration of {block.name} to η {target:.4f} at Δt {1e3 * dt:g} ms{where}")


def _corners(ad, block: Block, target: float, rows: list) -> tuple[CalibrationResult, dict]:
    chosen = pick([Candidate.of_row(r) for r in rows], target, block)
    r = chosen.candidate
    settings = _chosen_settings(ad, r.knobs, None)
    return CalibrationResult(eta_target=target, eta_measured=r.eta, eta_std=r.eta_std, reached=chosen.reached,
                             settings=settings, note=_corners_note(ad, chosen, rows, settings),
                             evaluations=len(rows), sink_m=r.sink_m, hop_m=r.hop_m), {"tried": rows}


def described(ad, row: dict) -> str:
    """A candidate's settings in words: each setting it sets other than to its shipped value, with its
    unit (a knob's); none, the contact as shipped."""
    units = {k.name: k.unit for k in tuple(ad.KNOBS) + tuple(ad.ROW_KNOBS)}
    parts = [f"{k} {v:.4g} {units.get(k, '')}".rstrip() if isinstance(v, float) else f"{k} {v}"
             for k, v in row.items() if k in ad.SETTINGS and v is not None and not _shipped(ad, k, v)]
    return ", ".join(parts) or "the contact as shipped"


def _shipped(ad, key: str, value) -> bool:
    """Whether ``value`` is the engine's stated shipped value of setting ``key``."""
    shipped = ad.SHIPPED.get(key)
    return shipped is not None and type(shipped) is type(value) and shipped == value


def _corners_note(ad, chosen, rows: list, settings: dict) -> str:
    finite = [x["eta"] for x in rows if math.isfinite(x["eta"])]
    what = described(ad, {k: v for k, v in chosen.candidate.knobs.items() if k in settings})
    head = "reached" if chosen.reached else f"not reached: η = {chosen.candidate.eta:.4f}"
    limits = "" if chosen.reached else "".join(f"; {k.note}" for k in ad.KNOBS if k.note)
    return (f"{head} ({chosen.why}) with {what}; η over the {len(rows)} settings searched spans "
            f"{min(finite):.4f}–{max(finite):.4f}{limits}.")


def _row(ad, block: Block, t: float, dt: float, n: int, rows: list) -> tuple[CalibrationResult, dict]:
    """A row of ``n`` points along the base: the candidates the one pick reaches tried in its order
    (:func:`~rockbench.engines.calibration.pick.ranked`, at most :data:`MAX_PRICE_TRIES`) until one keeps
    the static uplift threshold within 2 % of g·tanα and raises no ``slip`` flag in the anti-slip
    cells (:func:`~rockbench.engines.calibration.price.contact_price`); its price is recorded, with
    its free-rocking period change."""
    cands = [Candidate.of_row(r) for r in rows]
    regular_rows = [c.knobs for c in cands if regular(c, t, block)]
    within = [c.knobs for c in ranked(cands, t, block)]
    chosen, price, tried = _first_that_counts(ad, block, within, n, dt, t)
    lo = min((r["eta"] for r in regular_rows), default=math.nan)
    hi = max((r["eta"] for r in regular_rows), default=math.nan)
    span = f"{len(rows)} settings searched: regular free rocking spans η = {lo:.4f}–{hi:.4f}"
    if chosen is not None:
        r = chosen
        m = measure_restitution(with_contact(ad, _chosen_settings(ad, r, n)), block, dt_s=dt)
        price["period_change"] = (m.first_quarter_s / price["rigid_first_quarter_s"] - 1.0) if m.first_quarter_s else None
        price["first_quarter_s"] = m.first_quarter_s
        note = (f"reached with {n} {ad.CONTACT_ROWS} along the base, {described(ad, r)}, {r['n']} impacts "
                f"measured; {pricing.price_line(price)}; {span}.")
    else:
        r = (within[0] if within else
             min(regular_rows or [x for x in rows if math.isfinite(x["eta"])] or rows,
                 key=lambda r: abs(r["eta"] - t) if math.isfinite(r["eta"]) else math.inf))
        note = f"not reached with {n} {ad.CONTACT_ROWS} along the base: {_why_not(ad, r, within, tried, t)}; {span}."
    res = CalibrationResult(eta_target=t, eta_measured=float(r["eta"]), eta_std=float(r["eta_std"]),
                            reached=chosen is not None, settings=_chosen_settings(ad, r, n), note=note,
                            evaluations=len(rows), price=price, sink_m=r.get("sink_m"), hop_m=r.get("hop_m"))
    return res, {"grid": rows, "price_tried": tried}


def _first_that_counts(ad, block: Block, within: list, n: int, dt: float,
                       t: float) -> tuple[dict | None, dict | None, list]:
    """The first of ``within`` (at most :data:`MAX_PRICE_TRIES`) whose contact counts, its price and
    what was tried. The static uplift threshold comes first: a candidate outside it cannot count, so
    its anti-slip cells are not run."""
    rest = Restitution("constant", value=t)
    tried = []
    for r in within[:MAX_PRICE_TRIES]:
        fixed = with_contact(ad, _chosen_settings(ad, r, n))
        up = pricing.uplift_threshold(fixed, block, rest, dt)
        tried.append({**r, "uplift_ratio": up.get("ratio", math.nan)})
        if not up.get("within"):
            continue
        pr = pricing.contact_price(fixed, block, rest, dt, uplift=up)
        tried[-1].update(n_slip=pr["anti_slip"]["n_slip"], n_jump=pr["anti_slip"]["n_jump"])
        if pr["counts"]:
            return r, pr, tried
    return None, None, tried


def _why_not(ad, r: dict, within: list, tried: list, t: float) -> str:
    """Why the search of a row along the base reached nothing, in words."""
    if not within:
        return f"the closest regular η is {r['eta']:.4f} ({100 * (r['eta'] - t) / t:+.2f} %)"
    return (f"{len(within)} settings give η within {100 * ETA_RESOLUTION:g} % with regular impacts, but none "
            "keeps the static uplift threshold within 2 % of g·tanα without rocking below it and the anti-slip "
            "cells free of slip (tried: " + "; ".join(
                f"{described(ad, x)}: uplift {x['uplift_ratio']:.3f}"
                + (f", {x['n_slip']} slip / {x['n_jump']} jump" if "n_slip" in x else "") for x in tried) + ")")


def first_reached(calibrate_n, counts, unit: str) -> CalibrationResult:
    """Calibrate a row of points along the base with each number of points in ``counts`` in turn
    (``calibrate_n(n)`` → :class:`CalibrationResult`) and return the first that reaches its target at
    an acceptable price; when none does, the closest (finite η first), its note listing every count
    tried (``"9 points: …"``, ``unit`` naming what the points are)."""
    tried = []
    for n in counts:
        c = calibrate_n(n)
        if c.reached:
            return c
        tried.append(c)
    if len(tried) == 1:
        return tried[0]
    best = min(tried, key=lambda c: abs(c.rel_error) if math.isfinite(c.rel_error) else math.inf)
    return dataclasses.replace(best, note=" | ".join(f"{c.settings['contact_points']} {unit}: {c.note}" for c in tried))
