"""The speed stage in words and a table (score.json's ``speed``, :mod:`.speed`), for the report and the
console: what the curves rest on, and each engine's cost at matched accuracy, the GPU rows included
(timed on a CUDA device, or saying why not).
"""

from __future__ import annotations

from rockbench.benchmark.scoring.labels import engine_name
from rockbench.benchmark.report.tables import render

#: The section's words where a run has no speed stage.
NO_STAGE = ("No accuracy–cost curves: this run has no speed stage (`rockbench run speed` runs it alone, the full "
            "suite with its maps; docs/speed.md). The table gives each variant's time at the step it ran.")

#: The lead of a report whose run is the accuracy–cost stage alone.
STAGE_ALONE = ("This run is the accuracy–cost stage alone (`rockbench run speed`): it has no verdict, no summary "
               "and no stability graphs, since none of its maps is a verdict variant's; its maps are scored against "
               "the reference in the speed section below. The default and full suites give the verdict.")


def _g(x, spec: str = ".3g") -> str:
    return "–" if x is None else format(x, spec)


def _at(p: dict | None, unit_words: str = "") -> str:
    """``0.5 ms: 0.041 at 0.12`` (step, distance, cost) or "not reached"."""
    if not p:
        return "not reached"
    return f"{p['dt_s'] * 1e3:g} ms: {_g(p['value'], '.3f')} at {_g(p['cost'])}{unit_words}"


def _unmapped(r: dict) -> str:
    """The declared steps an engine's curve lacks (a run stopped before them), said beside its finest."""
    gone = r.get("unmapped") or []
    if not gone:
        return ""
    words = [f"{u['dt_s'] * 1e3:g} ms" + (f" (only {', '.join(u['blocks'])})" if u["blocks"] else "") for u in gone]
    return f"; not mapped: {', '.join(words)}"


def _device(r: dict) -> str:
    d = r.get("device") or {}
    if d.get("runs_on") == "gpu":
        return "GPU (the device's wall time)"
    # the adapter's device note says where the engine runs on this machine (``device_note``: "" for an
    # engine that runs on the CPU by design, "CPU only (...)" for a GPU-first one without a GPU)
    return d.get("note") or "CPU"


def _rule(rule: dict | None) -> str:
    """The time-step rule's choice: each step with its blocks, and the distance and cost they make."""
    if not rule:
        return "not known (no rule's record in the maps)"
    by: dict = {}
    for block, dt in rule["per_block"].items():
        by.setdefault(dt, []).append(block)
    steps = "; ".join(f"{dt * 1e3:g} ms ({', '.join(bs)})" for dt, bs in sorted(by.items(), reverse=True))
    if rule.get("outside"):
        return f"{steps}: not among the steps mapped on every problem"
    return f"{steps}: {_g(rule['value'], '.3f')} at {_g(rule['cost'])}"


def _band(b: dict | None) -> str:
    """The detectable difference of criterion (a) and whose it is."""
    if not b:
        return "–"
    return f"{b['value']:.3f} ({'the verdict' if b['source'] == 'verdict' else 'the stage'})"


def matched_table(speed: dict) -> tuple[list[str], list[list[str]]]:
    """Head and rows: per engine its finest step, the detectable difference, the cheapest step of each
    criterion, and the time-step rule's choice (distance at cost, cost in CPU seconds per simulated second,
    a GPU row in the device's wall seconds); then a row per engine meant for a GPU that has no GPU row."""
    d = float((speed.get("declared") or {}).get("matched_distance") or 0.0)
    head = ["engine", "runs on", "finest step: distance at cost", "detectable difference",
            "(a) cheapest within it of the finest", f"(b) cheapest within {d:g} of the reference",
            "time-step rule's choice: distance at cost"]
    body = []
    for r in speed.get("engines", []):
        m = r.get("matched") or {}
        a = m.get("within_mdd")
        if a and a.get("dt_s") == (m.get("finest") or {}).get("dt_s"):
            speedup = " (the finest itself)"
        else:
            speedup = f" ({a['speedup_vs_finest']:.3g}× cheaper)" if a and a.get("speedup_vs_finest") else ""
        body.append([r["label"], _device(r), _at(m.get("finest")) + _unmapped(r), _band(r.get("band")),
                     _at(a) + speedup, _at(m.get("within_distance")), _rule(r.get("rule"))])
    for x in speed.get("absent", []):
        body.append([engine_name(x["engine"]), "GPU: no row", f"absent: {x['why']}", "–", "–", "–", "–"])
    return head, body


def stage_words(speed: dict) -> str:
    """What the curves and the table rest on: the problems, the steps, the machine, the unit, the
    detectable difference, and the rule for each criterion."""
    dec = speed.get("declared") or {}
    steps = ", ".join(f"{dt * 1e3:g}" for dt in dec.get("steps_s", []))
    problems = f"{', '.join(dec.get('blocks', []))} under {' and '.join(dec.get('pulses', []))}"
    m = speed.get("machine")
    where = (f"on {m.get('cpu_model')} ({m.get('cores_usable')} cores usable, {m.get('threads_per_worker')} thread(s) "
             "a worker)" if m else "on several machines (their costs are not comparable: rerun on one)")
    mdd = speed.get("mdd")
    vm = speed.get("verdict_mdd")
    within = (f"the verdict's between calibrated variants, {vm:.3f}" if vm is not None else
              f"the stage's own, from 95 % comparisons of each step with the finest on these problems ({_g(mdd, '.3f')} "
              "typically; this run has no calibrated variants in its verdict)")
    return (f"Each engine calibrated to its target at each step ({steps} ms; calibrated at that step and mapped at "
            f"it) on one problem per slenderness ({problems}), scored against the reference like any map and timed "
            f"{where}. Cost: CPU seconds per simulated second of block motion (the CPU time of every simulation of "
            f"the maps, cells and bisection samples, over the time they simulated; a GPU row: the device's wall "
            f"seconds). Accuracy: the boundary distance's mean over the problems. Matched accuracy: (a) the "
            f"cheapest step whose distance lies within the detectable difference (80 % power) of the engine's "
            f"finest step's: {within}; (b) the cheapest within the declared {_g(dec.get('matched_distance'))} "
            f"of the reference; \"not reached\" where none is. These maps are not in the verdict.")


#: The title of the matched-accuracy table on the console.
MATCHED_TITLE = "Speed: cost at matched accuracy (CPU seconds per simulated second)"


def speed_block(speed: dict | None, markdown: bool = False) -> str:
    """The matched-accuracy table under its title (``rockbench run`` and ``score``); "" without a stage."""
    if not speed:
        return ""
    title = f"### {MATCHED_TITLE}\n\n" if markdown else MATCHED_TITLE + "\n"
    return title + render(*matched_table(speed), markdown)
