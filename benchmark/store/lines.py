"""One line of cells.csv as text: the per-cell path's format (:func:`plain_row`), which the
columnar writer (:mod:`rockbench.benchmark.store.columnar`) reproduces byte for byte.
"""

from __future__ import annotations




def exact_text(x) -> str:
    """A cell's value as cells.csv writes it: a float as its ``repr`` (it reads back exactly), None empty."""
    t = type(x)
    if t is float:
        return repr(x)   # round-trips exactly
    if t is str:
        return x
    if x is None:
        return ""
    if t is bool:
        return "true" if x else "false"
    return str(x)


def plain_row(head: str, wr: str, ar: str, om: str, am: str, i: int, j: int, outcome: str, n_impacts: int,
              theta: float, valid: bool, flags: str, wall_s: str, t_overturn_s, t_uplift_s, min_normal_mg,
              max_friction_ratio, cpu_s=None, simulated_s=None) -> str:
    """One cells.csv line of a successful cell without a message, every float as ``repr`` writes it
    (``head``: the first five fields and their commas; ``wr``..``am``: the axis texts; ``wall_s`` as
    text; the last six None where empty). The text :mod:`.columnar`'s compiled writer reproduces (its
    cells have no cost: ``cpu_s`` and ``simulated_s`` empty)."""
    def opt(x):
        return "" if x is None else repr(float(x))

    return (f"{head}{wr},{ar},{om},{am},{outcome},{int(n_impacts)},{float(theta)!r},"
            f"{'true' if valid else 'false'},{flags},ok,,{wall_s},{opt(cpu_s)},{opt(simulated_s)},{opt(t_overturn_s)},"
            f"{opt(t_uplift_s)},{opt(min_normal_mg)},{opt(max_friction_ratio)},{i},{j}\n")
