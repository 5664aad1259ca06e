"""The run stage of the report's θ(t) comparisons: each case simulated with the reference (each
restitution the case needs) and every engine variant of the run, stored in ``trajectories/``
(:mod:`rockbench.benchmark.store.trajectories`) for the report to draw.

``rockbench run`` records the suite's ``[report] cases`` into its output folder; ``rockbench report``
records the ``--case`` cases into its ``--out`` folder. A case already stored for the same runs is
not simulated again.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from rockbench.engines.contract import Case
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import a_ratio_to_amplitude
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.engine_info.adapters import build_adapter
from rockbench.benchmark.report.histories import impact_times
from rockbench.benchmark.scoring.labels import restitution_symbol, variant_labels
from rockbench.benchmark.scoring.score_runs import load_runs
from rockbench.benchmark.simulation import trajectory_for_picture
from rockbench.benchmark.store import trajectories as stored
from rockbench.benchmark.store.atomic import write_bytes_atomic


def record_for_report(cases, run_dirs, out_dir, *, against=None, log=None, entries=None) -> None:
    """Store in ``out_dir/trajectories`` the θ(t) runs of ``cases`` for the report of the maps under
    ``run_dirs`` (its engine maps: every map when scored ``against`` other references, else those that
    are not the reference's), as :func:`~rockbench.benchmark.report.build.build_report` draws them. A
    case some run directory already stored for the same runs is copied from there, not simulated.
    ``entries``: those maps when already read (:func:`~rockbench.benchmark.scoring.score_runs.load_runs`)."""
    log = log or (lambda msg: print(f"rockbench: {msg}", file=sys.stderr))
    if entries is None:
        entries, _ = load_runs(run_dirs)
    if not entries:
        return   # no map: the report refuses the run directories and says why
    cands = [e for e in entries if (against or not e.is_reference) and not e.is_planted]
    folder = trajectory_folder(out_dir)
    for d in run_dirs:
        for case in cases:
            _copy_if_current(trajectory_folder(d), folder, case, cands)
    record_trajectories(cases, cands, variant_labels(cands), folder, log)


def _copy_if_current(src: Path, dst: Path, case, cands: list) -> None:
    """Copy a case's stored θ(t) runs from ``src`` to ``dst`` when they are of the runs ``cands`` need
    and those in ``dst`` (if any) are not."""
    plan = _plan(_runs(case, cands)[0])
    here = stored.read_case(dst, case)
    if src.resolve() == dst.resolve() or (here is not None and here["runs"] == plan):
        return
    have = stored.read_case(src, case)
    if have is not None and have["runs"] == plan:
        dst.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(stored.case_path(dst, case), stored.case_path(src, case).read_bytes())


def _plan(runs: list) -> list:
    """What :func:`_runs` lists, as the stored file records it (JSON values)."""
    return [[name, list(how) if how else [], rest.label] for name, how, rest in runs]


def record_trajectories(cases, cands: list, labels: dict, folder, log) -> None:
    """Simulate and store each case of ``cases`` whose file in ``folder`` is missing or was made for
    other runs.

    Parameters
    ----------
    cases : sequence of TrajectoryCase
    cands : list of MapEntry
        The engine maps of the run: one curve per engine variant and restitution among them.
    labels : dict
        ``variant`` → its label in words (:func:`~rockbench.benchmark.scoring.labels.variant_labels`).
    folder : path
        The ``trajectories`` folder.
    log : callable
        Receives a line per curve simulated.
    """
    for case in cases:
        block = get_preset(case.block).block()
        runs, notes = _runs(case, cands)
        plan = _plan(runs)
        have = stored.read_case(folder, case)
        if have is not None and have["runs"] == plan:
            continue
        pulse = make_pulse(case.pulse, a_ratio_to_amplitude(block, case.a_ratio), case.w_ratio * block.p_rad_s)
        curves = []
        for name, how, rest in runs:
            engine, settings = ("reference", {}) if name == "reference" else how
            law = f"{restitution_symbol(rest.label, case.block)} = {rest.eta(block.alpha_rad):.4f}"
            label = f"reference, {law}" if name == "reference" else labels.get(name, name)
            try:
                log(f"θ(t): {label}")
                curves.append(_curve(engine, settings, Case(block, pulse, rest), label, name == "reference"))
            except Exception as ex:  # noqa: BLE001 - one engine failing must not sink the others' curves
                notes.append(f"θ(t) {label}: {type(ex).__name__}: {ex}")
        stored.write_case(folder, case, plan, curves, notes)


def _runs(case, cands: list) -> tuple[list, list[str]]:
    """``([(name, (engine, settings) or None, Restitution)], notes)``: the reference at each k of the case
    and at each restitution of an engine variant, then each variant that has a map of the case's block
    (a held-out variant mapped on other blocks draws no curve here)."""
    notes = []
    runs = [("reference", None, Restitution("modified", k=k)) for k in case.reference_k]
    variants = {}
    for e in (e for e in cands if e.block == case.block):   # the variants the maps compare on the case's block
        settings = dict(e.settings or {})   # the map's settings given, under today's names
        variants.setdefault((e.variant, e.restitution), (e.engine, settings))
    for (variant, rest_label), (engine, settings) in sorted(variants.items()):
        try:
            rest = Restitution.parse(rest_label)
        except ConfigError:
            notes.append(f"θ(t): restitution {rest_label!r} of {variant} not understood; skipped")
            continue
        if not any(r[0] == "reference" and r[2] == rest for r in runs):
            runs.append(("reference", None, rest))
        runs.append((variant, (engine, settings), rest))
    return runs, notes


def _curve(engine: str, settings: dict, case, label: str, reference: bool) -> dict:
    """One θ(t) curve of ``case``, judged by the one judge."""
    tr, mode = trajectory_for_picture(engine, settings, case)
    res = build_adapter(engine, **({**settings, "mode": mode} if mode else settings)).judge(case, tr)
    return {"label": f"{label}: {res.outcome or 'failed'}", "reference": reference, "outcome": res.outcome,
            "t_overturn_s": float(res.t_overturn_s) if res.outcome == "overturn" and res.t_overturn_s is not None
            else None,
            "t_s": np.asarray(tr.t_s, float), "theta_rad": np.asarray(tr.theta_rad, float),
            "impacts_s": impact_times(tr)}


def trajectory_folder(out_dir) -> Path:
    """The ``trajectories`` folder of a run or report directory."""
    return Path(out_dir) / stored.FOLDER
