"""The report's pictures drawn over the machine's cores.

Each picture is a :class:`Drawing`: a plot function of plain data (maps, scores, curves) and the
file name of its PNG. :class:`Drawings` gathers them while the report is assembled and draws them
all at once, in helper processes (one per core, :func:`~rockbench.benchmark.maps.cores.cpu_count`),
each picture leaving as the bytes of its files (:func:`~.output.figure_bytes`). The same function
on the same data gives the same bytes in any process, so the pictures are the same byte for byte
however many helpers draw them (in this process where there is one core or one picture, or where
no helper can start).

The helpers are forked where that is safe (:func:`~rockbench.benchmark.maps.cores.can_fork_helper`:
they share what is imported already), else started fresh (they import matplotlib, under a second
each), as the suite's preparation of the engines starts its helpers.
"""

from __future__ import annotations

import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Callable

from rockbench.benchmark.maps.cores import can_fork_helper, cpu_count
from rockbench.benchmark.report.plots.output import figure_bytes


@dataclass
class Drawing:
    """One picture: ``plot(*args, **kwargs)["figure"]`` saved as ``name`` (a ``.png`` name) and in the
    other formats asked for; ``cost`` its drawing cost relative to the others (the costliest start first)."""

    name: str
    plot: Callable
    args: tuple = ()
    kwargs: dict = field(default_factory=dict)
    cost: float = 1.0


def draw(d: Drawing, formats=("png",)) -> tuple[dict[str, bytes], float]:
    """``({file name: bytes}, figure width [in])`` of one picture: its PNG first, then ``formats``."""
    fig = d.plot(*d.args, **d.kwargs)["figure"]
    stem = d.name[: -len(".png")]
    files = {f"{stem}.{fmt}": figure_bytes(fig, fmt) for fmt in dict.fromkeys(("png", *formats))}
    return files, fig.get_figwidth()


class Drawings:
    """The pictures of one report, drawn together by :meth:`draw_all`."""

    def __init__(self, formats=("png",)):
        self.formats = tuple(formats)
        self.todo: list[Drawing] = []

    def add(self, name: str, plot: Callable, *args, cost: float = 1.0, **kwargs) -> str:
        """Queue ``plot(*args, **kwargs)`` as the picture ``name``; returns ``name``."""
        self.todo.append(Drawing(name, plot, args, kwargs, cost))
        return name

    def draw_all(self) -> tuple[dict[str, bytes], dict[str, float]]:
        """``(images, widths)``: every file's bytes by file name, in the order the pictures were
        added, and each picture's width [in] by its PNG's name."""
        images: dict[str, bytes] = {}
        widths: dict[str, float] = {}
        for d, (files, width) in zip(self.todo, _draw_each(self.todo, self.formats)):
            images.update(files)
            widths[d.name] = width
        return images, widths


def _draw_each(todo: list[Drawing], formats) -> list:
    """:func:`draw` of each of ``todo``, in its order; in helper processes where there are two cores
    and two pictures, else (or when the helpers cannot start or die) here."""
    workers = min(cpu_count(), len(todo))
    if workers < 2:
        return [draw(d, formats) for d in todo]
    ctx = multiprocessing.get_context("fork" if can_fork_helper() else "spawn")
    try:
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
            order = sorted(range(len(todo)), key=lambda i: -todo[i].cost)   # the costliest first
            futs = {i: pool.submit(draw, todo[i], formats) for i in order}
            return [futs[i].result() for i in range(len(todo))]
    except (OSError, BrokenProcessPool):
        return [draw(d, formats) for d in todo]
