"""The paper's Figures 4–9 recomputed with the reference solver (paper §§2.4, 3.2, 3.3).

- Fig. 4 / 5: one sine wave, h/b = 2.25 / 4.5, Housner's η against the modified η with k = 0.75.
  The paper draws them for "any b" (normalised axes); we use B3M / B6M's geometry.
- Fig. 6 / 7: one sine wave, B3M and B3L / B6M and B6L with the modified η at Table 1's average k
  (0.8608 for M, 0.7306 for L), and Housner's η (the same for both sizes) for comparison.
- Fig. 8 / 9: the same blocks under one cosine wave.

Each map is a run directory under ``OUT/maps/`` (so a second call reuses it); each figure is
written as ``OUT/figN.png`` and ``OUT/figN.svg`` (or the formats asked for: png, svg, pdf).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rockbench.reference_solver.restitution import Restitution
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.benchmark.maps.grid import MapSpec, make_axis
from rockbench.benchmark.sweep import run_map
from rockbench.benchmark.report.plots.stability import plot_stability, save

#: The normalised ranges of the recomputed figures: ω/p and a0/(g·tanα).
W_RANGE = (0.5, 10.0)
A_RANGE = (0.5, 10.0)


@dataclass(frozen=True)
class Curve:
    block: str
    pulse: str
    restitution: str      # "housner", "k=0.75", "average" (short: they name the map folders)

    def law(self) -> Restitution:
        pre = get_preset(self.block)
        spelling = {"average": "modified-average"}.get(self.restitution, self.restitution.replace("k=", "modified:"))
        return pre.restitution(spelling)

    def label(self) -> str:
        """``B6M, η_H = 0.9294`` / ``B3M, η_M (k = 0.75) = 0.8532``."""
        r = self.law()
        eta = r.eta(get_preset(self.block).block().alpha_rad)
        name = "η_H" if r.kind == "housner" else f"η_M (k = {r.k:g})"
        return f"{self.block}, {name} = {eta:.4f}"


#: figure number → (title, curves)
FIGURES = {
    4: ("Fig. 4: one sine wave, h/b = 2.25", [Curve("B3M", "sine", "housner"), Curve("B3M", "sine", "k=0.75")]),
    5: ("Fig. 5: one sine wave, h/b = 4.5", [Curve("B6M", "sine", "housner"), Curve("B6M", "sine", "k=0.75")]),
    6: ("Fig. 6: one sine wave, B3M and B3L", [Curve("B3M", "sine", "average"), Curve("B3L", "sine", "average"),
                                               Curve("B3M", "sine", "housner")]),
    7: ("Fig. 7: one sine wave, B6M and B6L", [Curve("B6M", "sine", "average"), Curve("B6L", "sine", "average"),
                                               Curve("B6M", "sine", "housner")]),
    8: ("Fig. 8: one cosine wave, B3M and B3L", [Curve("B3M", "cosine", "average"),
                                                 Curve("B3L", "cosine", "average"), Curve("B3M", "cosine", "housner")]),
    9: ("Fig. 9: one cosine wave, B6M and B6L", [Curve("B6M", "cosine", "average"),
                                                 Curve("B6L", "cosine", "average"), Curve("B6M", "cosine", "housner")]),
}


def curve_spec(c: Curve, n: int) -> MapSpec:
    return MapSpec(get_preset(c.block).block(), c.pulse, c.law(),
                   make_axis("--w-ratio", "w_ratio", *W_RANGE, n), make_axis("--a-ratio", "a_ratio", *A_RANGE, n))


def make_figures(out_dir, *, resolution: int = 100, figures=None, jobs=None, serial: bool = False,
                 progress: bool = False, formats=("png", "svg")) -> dict:
    """Compute the maps and draw the figures; returns ``{figure: [paths, one per format]}`` and the map
    folders."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    done: dict = {}
    written: dict = {}
    for num in figures or sorted(FIGURES):
        title, curves = FIGURES[num]
        results = []
        for c in curves:
            key = f"{c.block}-{c.pulse}-{c.restitution.replace('=', '')}-{resolution}"
            if key not in done:
                done[key] = run_map(curve_spec(c, resolution), out / "maps" / key, jobs=jobs, serial=serial,
                                    progress=progress)
            results.append(done[key])
        drawn = plot_stability(results, [c.label() for c in curves], title=title + " (reference solver)")
        written[num] = [str(p) for p in save(drawn["ax"].figure, out / f"fig{num}", formats)]
    return {"figures": written, "maps": sorted(str(out / "maps" / k) for k in done)}
