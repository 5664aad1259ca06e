"""The Python API for notebooks, re-exported as ``rockbench.benchmark.simulate``, ``rockbench.benchmark.stability_map``
and ``rockbench.benchmark.load_run``.

Cases are described with the command line's words as keywords (``w_ratio=6`` for ``--w-ratio 6``):
both fill one :class:`~rockbench.benchmark.request.CaseRequest` and are checked by its code, so the API
and the CLI cannot drift apart; error messages name the keyword. Results are plain arrays
(:class:`Simulation`), labelled grids (``xarray.Dataset``) or tidy tables with categorical outcomes
(``pandas.DataFrame``); pandas and xarray come with ``pip install 'rockbench[notebook]'``.
"""

from __future__ import annotations

import json
import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import amplitude_to_a_ratio, omega_to_w_ratio
from rockbench.benchmark.blocks.presets import PRESETS
from rockbench.benchmark.engine_info.adapters import build_adapter
from rockbench.benchmark.maps.grid import MAP_PULSES, make_axis, parse_range
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.report.histories import impact_times, picture_span_s
from rockbench.benchmark.report.plots.trajectories import plot_theta
from rockbench.benchmark.request import CaseRequest
from rockbench.benchmark.scoring.metrics import METRICS
from rockbench.benchmark.scoring.score_runs import load_score
from rockbench.benchmark.report.tables import ranked_summary, short_verdict_text, summary, verdict_text
from rockbench.benchmark.scoring.scores import Scores
from rockbench.benchmark.simulation import run_case, trajectory_for_picture
from rockbench.benchmark.store.frames import need, rows_to_dataframe, rows_to_dataset
from rockbench.benchmark.store.loading import MapEntry as RunMap, full_grid_rows, load_entries

__all__ = ["simulate", "stability_map", "load_run", "Simulation", "Run", "RunMap"]


def _keywords(message: str) -> str:
    """A CLI message in the API's words: ``--w-ratio`` → ``w_ratio=``."""
    return re.sub(r"--([a-z][a-z0-9-]*)", lambda m: m.group(1).replace("-", "_") + "=", message)


def request_of(block, *, width=None, height=None, depth=None, density=None, restitution="housner", k=None,
               pulse="sine", w_ratio=None, omega=None, period=None, a_ratio=None, amplitude=None, amplitude_g=None,
               engine="reference", dt=None, linearized=False, settings=None, drive=None, friction=None,
               **engine_settings) -> CaseRequest:
    """The :class:`CaseRequest` of the API's keywords: any keyword the command line has no option for is
    an engine setting (as ``--set KEY=VALUE``)."""
    if block is not None and not isinstance(block, str):
        raise ConfigError(f"block must be a preset name ({', '.join(PRESETS)}), got {block!r}; for a custom block "
                          "give width= and height= [m].")
    return CaseRequest(
        block=block, width=width, height=height, depth=depth, density=density, restitution=str(restitution),
        k=None if k is None else str(k), pulse=str(pulse), w_ratio=w_ratio, omega=omega, period=period,
        a_ratio=a_ratio, amplitude=amplitude, amplitude_g=amplitude_g, engine=str(engine),
        dt=None if dt is None else str(dt), linearized=bool(linearized), settings=settings, drive=drive,
        friction=None if friction is None else str(friction),
        set=tuple(f"{key}={json.dumps(v) if isinstance(v, (list, tuple)) else v}"
                  for key, v in engine_settings.items()))


def _checked(fn, *args, **kw):
    try:
        return fn(*args, **kw)
    except ConfigError as e:
        raise type(e)(_keywords(str(e))) from None


@dataclass
class Simulation:
    """One simulated case (what :func:`rockbench.benchmark.simulate` returns).

    Attributes
    ----------
    outcome : str or None
        ``rest`` (never lifted off), ``rocking`` (lifted off, came back to rest), ``overturn``;
        None when the engine failed.
    valid : bool
        False when the run broke the rigid model's assumptions (see ``flags``).
    flags : list of str
        ``slip``, ``jump``, ``energy-gain``, ``lift-required``, ``slip-required``, ``engine-error``, ...
    n_impacts : int
        Impacts up to the decision [-].
    t_s, theta_rad, theta_dot_rad_s : ndarray
        The history: time [s], rotation [rad] (positive about +y; a positive table acceleration
        starts a negative θ) and angular velocity [rad/s].
    impacts_s : ndarray
        Impact times [s].
    t_pulse_end_s : float
        End of the table pulse [s].
    t_overturn_s, t_uplift_s : float or None
        When |θ| passed α (overturn only) and when the block first lifted off [s].
    max_abs_theta_rad : float
        Largest |θ| [rad].
    eta, alpha_rad, p_rad_s : float
        Restitution coefficient [-], slenderness angle [rad], frequency parameter [rad/s].
    w_ratio, a_ratio : float or None
        ω/p and a₀/(g·tanα) [-] (ω/p is None for a record).
    engine : str
        The engine's registry name.
    min_normal_mg, max_friction_ratio : float or None
        The rigid model's contact demand (reference only) [-].
    case : Case
        What was simulated (block, pulse, restitution, time step).
    settings : dict
        The engine settings given.
    wall_s : float
        Wall time of the simulation [s].
    """

    outcome: str | None
    valid: bool
    flags: list
    n_impacts: int
    t_s: np.ndarray
    theta_rad: np.ndarray
    theta_dot_rad_s: np.ndarray
    impacts_s: np.ndarray
    t_pulse_end_s: float
    t_overturn_s: float | None
    t_uplift_s: float | None
    max_abs_theta_rad: float
    eta: float
    alpha_rad: float
    p_rad_s: float
    w_ratio: float | None
    a_ratio: float
    engine: str
    min_normal_mg: float | None
    max_friction_ratio: float | None
    case: object = field(repr=False)
    settings: dict = field(default_factory=dict, repr=False)
    wall_s: float = 0.0
    _trajectory: object = field(default=None, repr=False)

    def plot(self, ax=None, **kw) -> dict:
        """θ(t) with its impacts and the pulse beneath, over the span the case needs (integrated on
        past the pulse's end where the reference stopped early). Returns what was drawn."""
        tr, _ = trajectory_for_picture(self.engine, self.settings, self.case, self._trajectory)
        span = picture_span_s(self.case.pulse, self.t_overturn_s)
        run = {"label": kw.pop("label", f"{self.engine} (η = {self.eta:.4f}): {self.outcome}"), "t_s": tr.t_s,
               "theta_rad": tr.theta_rad, "impacts_s": impact_times(tr), "reference": self.engine == "reference",
               "outcome": self.outcome}
        return plot_theta([run], alpha_rad=self.alpha_rad, pulse=self.case.pulse, t_end_s=span, ax=ax, **kw)

    def to_dataframe(self):
        """The history as a ``pandas.DataFrame`` (columns ``t_s``, ``theta_rad``, ``theta_dot_rad_s``)."""
        pd = need("pandas")
        return pd.DataFrame({"t_s": self.t_s, "theta_rad": self.theta_rad, "theta_dot_rad_s": self.theta_dot_rad_s})


def simulate(block: str | None = "B3M", **case) -> Simulation:
    """Simulate one case with any engine; the history comes back as arrays.

    Parameters
    ----------
    block : str
        A preset (``B3M``, ``B6M``, ``B3L``, ``B6L``); None with ``width=`` and ``height=`` [m]
        (and optionally ``depth=``, ``density=``) for a custom block.
    **case
        The command line's case options as keywords: ``restitution`` (``"housner"``,
        ``"modified"``, or a number), ``k``; ``pulse`` (``"sine"``, ``"cosine"``, ``"half-sine"`` or a
        CSV path); one of ``w_ratio`` (ω/p), ``omega`` [rad/s], ``period`` [s]; one of ``a_ratio``
        (a₀/(g·tanα)), ``amplitude`` [m/s^2], ``amplitude_g`` [g]; ``engine`` (default
        ``"reference"``), ``dt`` [s], ``linearized``; engine settings ``settings``
        (``"calibrated"``/``"shipped"``), ``drive``, ``friction`` and any other setting by name
        (the reference takes ``mode="energy"`` or ``"to-rest"``).

    Returns
    -------
    Simulation

    Raises
    ------
    ConfigError
        A bad or missing value (the message names the keyword).
    EngineUnavailableError
        The engine is not installed.

    Examples
    --------
    >>> sim = rb.simulate("B3M", w_ratio=6, a_ratio=6.1, restitution="modified", k=0.7595)
    >>> sim.outcome
    'overturn'
    """
    request = _checked(request_of, block, **case)
    c, _ = _checked(request.case)
    settings = _checked(request.engine_settings)
    adapter = _checked(build_adapter, request.engine, **settings)
    tr, res = run_case(adapter, c)
    empty = np.zeros(0)
    b, p = c.block, c.pulse
    return Simulation(
        outcome=res.outcome, valid=bool(res.valid), flags=list(res.flags), n_impacts=int(res.n_impacts),
        t_s=np.asarray(tr.t_s) if tr is not None else empty,
        theta_rad=np.asarray(tr.theta_rad) if tr is not None else empty,
        theta_dot_rad_s=np.asarray(tr.theta_dot_rad_s) if tr is not None else empty,
        impacts_s=np.asarray(impact_times(tr) if tr is not None else [], float), t_pulse_end_s=float(p.duration_s),
        t_overturn_s=res.t_overturn_s if res.outcome == "overturn" else None, t_uplift_s=res.t_uplift_s,
        max_abs_theta_rad=float(res.max_abs_theta_rad) if res.max_abs_theta_rad is not None else float("nan"),
        eta=float(c.eta), alpha_rad=float(b.alpha_rad), p_rad_s=float(b.p_rad_s),
        w_ratio=None if p.omega_rad_s is None else float(omega_to_w_ratio(b, p.omega_rad_s)),
        a_ratio=float(amplitude_to_a_ratio(b, p.amplitude_mps2)), engine=adapter.name,
        min_normal_mg=res.min_normal_mg, max_friction_ratio=res.max_friction_ratio, case=c, settings=settings,
        wall_s=float(res.wall_s), _trajectory=tr)


def _axis(option: str, name: str, value):
    if isinstance(value, str):
        return parse_range(option, value, name)
    try:
        lo, hi, n = value
    except (TypeError, ValueError):
        raise ConfigError(f"{option} takes (LO, HI, N) or 'LO:HI:N', got {value!r}.") from None
    return make_axis(option, name, float(lo), float(hi), int(n))


def stability_map(block: str | None = "B3M", *, w_ratio=(1.0, 12.0, 50), a_ratio=(1.0, 10.0, 50),
                  output: str = "dataset", adaptive: bool = False, jobs: int | None = None, out=None, **case):
    """A stability map in memory: every cell of an ω/p × a₀/(g·tanα) grid simulated (or, with
    ``adaptive=True``, inferred where its neighbours agree; such cells are marked ``filled``).

    Parameters
    ----------
    block : str
        A preset, or None with ``width=``/``height=`` for a custom block (as :func:`simulate`).
    w_ratio, a_ratio : (lo, hi, n) or "LO:HI:N"
        The axes: n values from lo to hi inclusive, ω/p and a₀/(g·tanα) [-].
    output : {"dataset", "dataframe"}
        An ``xarray.Dataset`` on dims ``(a_ratio, w_ratio)`` or a tidy ``pandas.DataFrame`` (one row
        per cell, ``outcome`` categorical: rest, rocking, overturn, failed).
    adaptive : bool
        Simulate a coarse grid and refine where neighbours disagree (engines; the reference is fast
        enough to simulate every cell).
    jobs : int, optional
        Worker processes for an engine (default: all cores); the reference runs in this process.
    out : path, optional
        Keep the run directory there (cells.csv, run.json; rerunning resumes); by default it lives
        in a temporary folder that is removed.
    **case
        ``pulse``, ``restitution``, ``k``, ``engine``, ``dt``, engine settings: as :func:`simulate`.

    Returns
    -------
    xarray.Dataset or pandas.DataFrame
    """
    if output not in ("dataset", "dataframe"):
        raise ConfigError(f"output must be 'dataset' or 'dataframe', got {output!r}.")
    if output == "dataset":
        need("xarray")
    bad = sorted(set(case) & {"w_ratio", "a_ratio", "omega", "period", "amplitude", "amplitude_g"})
    if bad:
        raise ConfigError(f"a map takes its axes as w_ratio=(LO, HI, N) and a_ratio=(LO, HI, N), not {bad[0]}=.")
    request = _checked(request_of, block, **case)
    kind = request.pulse.strip().lower()
    if kind not in MAP_PULSES:
        raise ConfigError(f"a map needs a harmonic pulse ({', '.join(MAP_PULSES)}), got pulse={request.pulse!r}.")
    spec = _checked(request.map_spec, kind, lambda: (_axis("w_ratio", "w_ratio", w_ratio),
                                                    _axis("a_ratio", "a_ratio", a_ratio)))
    ref = spec.engine == "reference"

    def compute(d):
        run_map(spec, d, jobs=jobs, serial=ref, adaptive=adaptive and not ref, progress=False)
        return full_grid_rows(d)

    if out is not None:
        rows = compute(Path(out))
    else:
        with tempfile.TemporaryDirectory(prefix="rockbench-map-") as tmp:
            rows = compute(Path(tmp) / "map")
    return rows_to_dataset(rows) if output == "dataset" else rows_to_dataframe(rows)


@dataclass
class Run:
    """A finished ``rockbench run`` (or ``map``) folder, as :func:`load_run` reads it.

    Attributes
    ----------
    path : Path
        The folder.
    maps : list of RunMap
        Every map found in or below it (``RunMap`` is :class:`~rockbench.benchmark.store.loading.MapEntry`: its folder,
        engine, variant, block, pulse, restitution, η, outcome grid; ``to_dataframe()``, ``to_dataset()``).
    score : Scores or None
        score.json read back (:class:`~rockbench.benchmark.scoring.scores.Scores`: metric definitions, every
        scored pair by variant and scenario, the verdict, the speed stage), when the folder has one.
    """

    path: Path
    maps: list
    score: Scores | None = None

    def cells(self):
        """All maps' cells on their full grids in one tidy ``pandas.DataFrame`` (``variant``,
        ``block``, ``pulse`` and ``restitution`` keep them apart)."""
        pd = need("pandas")
        frames = [rows_to_dataframe(full_grid_rows(m.path)) for m in self.maps]
        df = pd.concat(frames, ignore_index=True)
        for c in ("engine", "variant", "block", "pulse", "restitution"):
            df[c] = df[c].astype(str).astype("category")
        return df

    def scores(self):
        """Every scored pair of score.json, one row each, one column per metric (``pandas.DataFrame``)."""
        pd = need("pandas")
        if not self.score:
            raise ConfigError(f"{str(self.path)!r} has no score.json; run `rockbench score {self.path}` first.")
        rows = [{"variant": p["variant"], "block": p["block"], "pulse": p["pulse"], "restitution": p["restitution"],
                 "reference": p["reference"]["restitution"], "like_for_like": p["like_for_like"],
                 **{k: (np.nan if v is None else v) for k, v in p["scores"].items()}} for p in self.score.pairs]
        return pd.DataFrame(rows)

    def summary(self):
        """Per engine variant, the mean of each metric over its like-for-like pairs (counts summed),
        as the report's summary table shows it (``pandas.DataFrame`` indexed by variant)."""
        pd = need("pandas")
        if not self.score:
            raise ConfigError(f"{str(self.path)!r} has no score.json; run `rockbench score {self.path}` first.")
        return pd.DataFrame.from_dict(summary(self.score), orient="index")

    def verdict(self):
        """The verdict of score.json, one row per variant in the verdict's order (``pandas.DataFrame``
        indexed by variant: label, settings, group, the primary value, ``ci95_lo``, ``ci95_hi``, rank (1
        may be the best of its class, 2 resolved behind it), pairs, fails, reasons); its sentences are
        :meth:`verdict_text`."""
        pd = need("pandas")
        if not self.score:
            raise ConfigError(f"{str(self.path)!r} has no score.json; run `rockbench score {self.path}` first.")
        keep = ("label", "settings", "group", "value", "rank", "pairs", "fails", "reasons", "cells_missing")
        rows = {r["variant"]: {**{k: r[k] for k in keep}, "ci95_lo": (r["ci95"] or [np.nan, np.nan])[0],
                               "ci95_hi": (r["ci95"] or [np.nan, np.nan])[1]} for r, _ in ranked_summary(self.score)}
        return pd.DataFrame.from_dict(rows, orient="index")

    def verdict_text(self, short: bool = False) -> list[str]:
        """The verdict's sentences (``short``: the verdict in at most 120 words), written by the report's words
        (:mod:`~rockbench.benchmark.report.verdict_words`) from score.json's numbers."""
        if not self.score:
            raise ConfigError(f"{str(self.path)!r} has no score.json; run `rockbench score {self.path}` first.")
        return short_verdict_text(self.score) if short else verdict_text(self.score)

    def metrics(self) -> dict:
        """Metric name → its definition in words (from score.json, else from this rockbench)."""
        if self.score and self.score.metrics:
            return {m["name"]: m["definition"] for m in self.score.metrics}
        return {k: m.definition for k, m in METRICS.items()}


def load_run(path) -> Run:
    """Read a finished ``rockbench run`` folder (or one ``rockbench map`` folder, or a folder of maps).

    Raises
    ------
    ConfigError
        Nothing there, or no map in it.
    """
    p = Path(path)
    maps = load_entries([p])
    score = None
    if (p / "score.json").is_file():
        score = load_score(p / "score.json")
    return Run(p, maps, score)
