"""Calibration knobs an adapter declares, and the candidates the shared search makes of them.

An adapter whose calibration is a grid over its contact knobs declares them
(:attr:`~rockbench.engines.contact.ContactEngine.KNOBS`, a tuple of :class:`Knob`); the one
calibration routine then runs the search (:mod:`rockbench.engines.calibration.routine`):
every combination of the knobs' ladders (:func:`grid`), then a finer grid around the pick
(:func:`around`) or, for one knob that asks for it, the one bisection between the ladder's
neighbours that bracket the target (or over its ``span``); each candidate measured in free rocking
and chosen by the one pick (:func:`~rockbench.engines.calibration.pick.pick`).

An adapter that keeps its starting contact when that is close enough
(:attr:`~rockbench.engines.contact.ContactEngine.START_KEEP_RTOL`) has it measured first
(every knob at its ``start`` value, by default the engine's shipped one); the knobs without ``when`` are
then searched, then those whose ``when`` names the side of the target the starting η lies on, every
candidate the starting contact with the searched knobs changed.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import math

from rockbench.reference_solver.model import Block
from rockbench.engines.calibration.pick import ETA_RESOLUTION, Candidate, pick, regular
from rockbench.engines.calibration.search import bisection, bracket

__all__ = ["Knob", "grid", "around", "candidate", "search"]


@dataclass(frozen=True)
class Knob:
    """One setting a calibration searches: its name, unit and values, and how they are searched.

    Attributes
    ----------
    name : str
        The setting it sets (the key in the candidate's settings): a contact setting of the engine's
        ``SHIPPED``, or a solver setting (PhysX's substeps).
    unit : str
        Its unit (``"s"``, ``"N/m"``, ``""``).
    values : tuple, callable or None
        The values tried first [unit]: a tuple, or ``values(block, dt_s) -> tuple`` where they depend
        on the block or the step (None: the knob has a ``span``).
    zeta : str or None
        What the knob's value says of the contact's damping ratio ζ (1: critical), which the pick's
        tie-break reads: ``"ratio"``, the value is ζ (MuJoCo's dampratio); ``"restitution"``, a
        restitution coefficient e, whose linear spring-dashpot has ζ = −ln e/√(π² + ln² e);
        None: nothing (a spring-dashpot's ``contact_stiffness_n_m`` and ``contact_damping_n_s_m`` give
        ζ = c/(2√(k·m)) whatever the knobs).
    start : float or None
        Where the search starts when that is not the engine's shipped value [unit] (Drake's stiff
        base contact); a contact given by hand takes it for a setting it leaves out.
    along : dict, callable or None
        Settings a candidate sets with the knob: a dict, or ``along(value, block, dt_s) -> dict`` (the
        damping of a critically damped spring, a contact-breaking threshold, a solver).
    refine : tuple of float
        Factors applied to the pick's value for a finer grid around it [-].
    minimum : callable or None
        ``minimum(block, dt_s)``: the smallest value a refined candidate may take [unit].
    bisect_steps : int
        For a calibration of this knob alone: instead of the finer grid, at most this many halvings
        between the first neighbours of ``values`` that bracket the target (0: the finer grid).
    bisect_rtol : float
        Relative distance to the target that ends that bisection [-].
    bisect_regular : bool
        Whether that bisection counts only regular runs (:func:`~rockbench.engines.calibration.pick.regular`):
        it brackets between regular values, is skipped when one is already within ``bisect_rtol``,
        and a midpoint that is not regular ends it; False: every finite η counts.
    span : callable or None
        ``span(block, dt_s) -> (lo, hi)``: instead of ``values``, the range bisected (``bisect_steps``
        halvings) [unit, or log10 of it with ``log10``].
    log10 : bool
        Whether ``values`` and ``span`` are log10 of the value (the bisection halves the logarithm).
    rising : bool
        Whether η rises with the knob over ``span``.
    no_eta_low_end : bool
        Whether a bisection's midpoint without an η replaces the range's low end (else its high end).
    when : str or None
        ``"above"`` (``"below"``): searched only when the starting contact's η lies more than
        ``when_rtol`` above (below, or has no η) the target; None: whatever it gives.
    when_rtol : float
        How far from the target, as a fraction of it, the starting η must lie for ``when`` to search
        the knob [-] (default: the reader's resolution).
    until : str or None
        The values measured one at a time (the stage's next knob searched at each), ending at the
        first after which ``"reached"``: the pick reaches the target; ``"close"``: a candidate lies
        within the last knob's ``bisect_rtol`` of it (the next knob's, else its own), regular where
        that knob's ``bisect_regular`` asks. None: the grid of the knobs' values.
    paired : bool
        Walked in step with the stage's first knob, which has ``until``: the i-th value of this
        knob goes with the i-th of that one's (a ladder of pairs, not a grid).
    note : str or None
        What the knob cannot do, in words: added to a calibration's note where the target is not
        reached (DART's restitution acts only above a bounce velocity).
    """

    name: str
    unit: str
    values: tuple | Callable[[Block, float], tuple] | None = None
    zeta: str | None = None
    start: float | None = None
    along: dict | Callable[[float, Block, float], dict] | None = None
    refine: tuple = (1.0,)
    minimum: Callable[[Block, float], float] | None = None
    bisect_steps: int = 0
    bisect_rtol: float = 0.0025
    bisect_regular: bool = True
    span: Callable[[Block, float], tuple] | None = None
    log10: bool = False
    rising: bool = True
    no_eta_low_end: bool = False
    when: str | None = None
    when_rtol: float = ETA_RESOLUTION
    until: str | None = None
    paired: bool = False
    note: str | None = None

    def __post_init__(self):
        # an adapter declares its knobs when its class is defined: a wrong field fails there, in one line
        for field_name, args in (("span", "(block, dt_s) -> (lo, hi)"), ("minimum", "(block, dt_s) -> value")):
            value = getattr(self, field_name)
            if value is not None and not callable(value):
                raise TypeError(f"Knob {self.name!r}: {field_name} must be a function {args}, not "
                                f"{type(value).__name__} {value!r}")
        if self.values is not None and not callable(self.values) and not isinstance(self.values, (tuple, list)):
            raise TypeError(f"Knob {self.name!r}: values must be a tuple or a function (block, dt_s) -> values, not "
                            f"{type(self.values).__name__} {self.values!r}")
        if self.along is not None and not callable(self.along) and not isinstance(self.along, dict):
            raise TypeError(f"Knob {self.name!r}: along must be a dict or a function (value, block, dt_s) -> settings")
        if self.zeta not in (None, "ratio", "restitution"):
            raise TypeError(f"Knob {self.name!r}: zeta must be None, 'ratio' or 'restitution', got {self.zeta!r}")

    def ladder(self, block: Block, dt_s: float) -> tuple:
        """The values tried first for ``block`` at step ``dt_s`` [s]."""
        return tuple(self.values(block, dt_s) if callable(self.values) else self.values)


def candidate(knob: Knob, value, block: Block, dt_s: float, start: dict | None = None) -> dict:
    """The contact settings of ``knob`` at ``value``: ``start`` (the shipped contact, or nothing)
    with the knob's ``along`` settings and the knob set."""
    along = knob.along(value, block, dt_s) if callable(knob.along) else (knob.along or {})
    return {**(start or {}), **along, knob.name: value}


def grid(knobs: tuple, block: Block, dt_s: float, start: dict | None = None) -> list[dict]:
    """Every combination of the knobs' ladders, the first knob varying slowest, each from ``start``
    (the shipped contact, or nothing) with the knobs' ``along`` settings."""
    out = []
    for values in itertools.product(*(k.ladder(block, dt_s) for k in knobs)):
        c = dict(start or {})
        for k, v in zip(knobs, values):
            c = candidate(k, v, block, dt_s, c)
        out.append(c)
    return out


def around(knobs: tuple, point: dict, block: Block, dt_s: float) -> list[dict]:
    """The finer grid around ``point``: every combination of each knob's ``refine`` factors times its
    value, the point itself and values below a knob's ``minimum`` left out."""
    out = []
    for factors in itertools.product(*(k.refine for k in knobs)):
        if all(f == 1.0 for f in factors):
            continue
        c = {k.name: point[k.name] * f for k, f in zip(knobs, factors)}
        if all(k.minimum is None or c[k.name] >= k.minimum(block, dt_s) for k in knobs):
            out.append(c)
    return out


def search(knobs: tuple, block: Block, target: float, dt_s: float, evaluate, keep_rtol: float | None = None,
           shipped: dict | None = None) -> list[dict]:
    """The one search of declared knobs: the measured candidates (``evaluate(candidates) -> rows``,
    each row a candidate with ``eta``, ``eta_std``, ``n`` and what else the pick reads), in order.

    With ``keep_rtol``: the starting contact first (every knob at its ``start``, else its value in
    ``shipped``, the engine's shipped contact), and nothing more when its η is within ``keep_rtol``
    of the target. Then the knobs
    without ``when`` (:func:`_stage`), then those whose ``when`` names the side of the target the
    starting η lies on (more than the knob's ``when_rtol`` away; no η counts as below), each
    candidate the starting contact with the searched knobs changed.
    """
    stages, start, rows = [[k for k in knobs if k.when is None]], None, []
    if keep_rtol is not None:
        first = {k.name: (shipped or {}).get(k.name) if k.start is None else k.start for k in knobs}
        start = {name: v for name, v in first.items() if v is not None}
        rows = evaluate([start])
        e0 = rows[0]["eta"]
        err = abs(e0 - target) / target
        if err <= keep_rtol:
            return rows
        side = "above" if e0 > target else "below"
        stages.append([k for k in knobs if k.when == side and not err <= k.when_rtol])
    for stage in stages:
        if stage:
            rows += _stage(tuple(stage), block, target, dt_s, evaluate, start)
    return rows


def _stage(knobs: tuple, block: Block, target: float, dt_s: float, evaluate, start: dict | None) -> list[dict]:
    """One stage of :func:`search`: a first knob with ``until`` measured value by value
    (:func:`_until`); else the grid of the knobs' ladders from ``start`` (the starting contact, left
    out: measured already), then the finer grid around its pick; or, for one knob with
    ``bisect_steps``, :func:`_bisected`."""
    k = knobs[0]
    if k.until is not None:
        return _until(knobs, block, target, dt_s, evaluate, start)
    if len(knobs) == 1 and k.bisect_steps:
        return _bisected(k, block, target, dt_s, evaluate, start)
    rows = evaluate([c for c in grid(knobs, block, dt_s, start) if c != start])
    if not any(math.isfinite(r["eta"]) for r in rows):
        return rows
    first = pick([Candidate.of_row(r) for r in rows], target, block).candidate.knobs
    return rows + evaluate(around(knobs, first, block, dt_s))


def _until(knobs: tuple, block: Block, target: float, dt_s: float, evaluate, start: dict | None) -> list[dict]:
    """The first knob's ladder value by value (with its ``paired`` knobs' values), the others
    searched at each (:func:`_stage`), until its ``until`` rule holds over the stage's candidates."""
    k, rows = knobs[0], []
    paired, rest = [x for x in knobs[1:] if x.paired], tuple(x for x in knobs[1:] if not x.paired)
    for values in zip(*(x.ladder(block, dt_s) for x in (k, *paired)), strict=True):
        c = start
        for x, v in zip((k, *paired), values):
            c = candidate(x, v, block, dt_s, c)
        rows += _stage(rest, block, target, dt_s, evaluate, c) if rest else evaluate([c])
        if k.until == "reached":
            done = pick([Candidate.of_row(r) for r in rows], target, block).reached
        else:
            last = rest[-1] if rest else k
            done = any(abs(r["eta"] - target) / target <= last.bisect_rtol for r in rows
                       if not last.bisect_regular or regular(Candidate.of_row(r), target, block))
        if done:
            break
    return rows


def _bisected(k: Knob, block: Block, target: float, dt_s: float, evaluate, start: dict | None) -> list[dict]:
    """One knob bisected (:func:`~rockbench.engines.calibration.search.bisection`, ``bisect_steps`` halvings, until
    within ``bisect_rtol``): over its ``span``, or after its ladder between the first neighbours that
    bracket the target (:func:`~rockbench.engines.calibration.search.bracket`)."""
    value = (lambda x: 10.0 ** x) if k.log10 else (lambda x: x)
    if k.span is not None:
        rows, (lo, hi), eta_lo = [], k.span(block, dt_s), -math.inf if k.rising else math.inf
    else:
        xs = [x for x in k.ladder(block, dt_s) if candidate(k, value(x), block, dt_s, start) != start]
        rows = evaluate([candidate(k, value(x), block, dt_s, start) for x in xs])
        ok = [(x, r) for x, r in zip(xs, rows) if not k.bisect_regular or regular(Candidate.of_row(r), target, block)]
        found = bracket([(x, r["eta"]) for x, r in ok], target)
        if found is None or (k.bisect_regular and any(abs(r["eta"] - target) <= k.bisect_rtol * target for _, r in ok)):
            return rows
        lo, eta_lo, hi = found

    def eta_at(x: float) -> float | None:
        rows.extend(evaluate([candidate(k, value(x), block, dt_s, start)]))
        return rows[-1]["eta"] if not k.bisect_regular or regular(Candidate.of_row(rows[-1]), target, block) else None

    bisection(eta_at, lo, hi, k.bisect_steps, target=target, eta_lo=eta_lo,
              done=lambda e: abs(e - target) <= k.bisect_rtol * target, nonfinite_low=k.no_eta_low_end)
    return rows
