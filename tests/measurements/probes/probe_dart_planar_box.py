"""Why DART's planar block touches the table through two corner spheres, not its box, nor a row of
spheres along its base.

A planar block whose collision shape is its box touches the table with two points per bottom edge
(y = ±d/2) whose constraint rows are identical for a planar joint. This probe runs the mirror pair
(ü and −ü) of 20 cells with three models, the box in the plane, the corner spheres in the plane (the
adapter's planar model) and the free box (the adapter's ``planar=false``), and prints how far the
mirrored run's max |θ| is from the run's, and whether the outcomes agree.

``--row`` instead measures free rocking (η of the first four impacts, DART as shipped) with rows of
3, 5, 9 and 17 spheres along the base (the corner spheres and evenly spaced ones between them), at
Δt = 0.5 and 0.25 ms, for B3M and B6M: whether a contact along the base could raise η towards η_M.

Run from the repository root: ``python tests/measurements/probes/probe_dart_planar_box.py [--row]``.
"""

from __future__ import annotations

import math
import sys

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.adapters import dart as da
from rockbench.engines.contract import Case
from rockbench.engines.registry import get_adapter
from rockbench.reference_solver.model import G
from rockbench.reference_solver.pulses import make_pulse
from rockbench.engines.calibration.free_rocking import measure_restitution

CELLS = [(name, kind, w, a) for name in ("B3M", "B6M") for kind in ("sine", "cosine")
         for w, a in ((2, 1.5), (4, 1.6), (4, 3), (6, 2), (8, 4))]


class _BoxScene(da._Scene):
    """The planar scene with the block's box as its collision shape instead of the corner spheres."""

    def __init__(self, block, s, dt):
        super().__init__(block, s, dt)
        import dartpy as dart

        node = self.block.getBodyNode(0)
        node.removeAllShapeNodes()
        da._contact_aspects(node.createShapeNode(dart.dynamics.BoxShape([block.width_m, block.depth_m, block.height_m])),
                            float(s["friction"]), float(s["contact_restitution"]))


def _row_scene(planar_scene, n: int):
    """The planar scene with ``n`` spheres along the base (the two corner spheres among them)."""

    class _Row(planar_scene):
        def __init__(self, block, s, dt):
            super().__init__(block, s, dt)
            import dartpy as dart

            node, r = self.block.getBodyNode(0), float(s["corner_radius_m"])
            for i in range(1, n - 1):
                x = -(block.width_m / 2 - r) + i * (block.width_m - 2 * r) / (n - 1)
                sphere = node.createShapeNode(dart.dynamics.SphereShape(r))
                sphere.setRelativeTranslation([x, 0.0, -block.height_m / 2 + r])
                da._contact_aspects(sphere, float(s["friction"]), float(s["contact_restitution"]))

    return _Row


def row() -> None:
    print("| block | spheres along the base | Δt [s] | η measured (per-impact spread) | η of each impact |")
    print("|---|---|---|---|---|")
    planar_scene = da._Scene
    for name in ("B3M", "B6M"):
        for n in (3, 5, 9, 17):
            for dt in (5e-4, 2.5e-4):
                da._scene.cache_clear()
                da._Scene = _row_scene(planar_scene, n)
                m = measure_restitution(get_adapter("dart", settings="shipped"), get_preset(name).block(), dt_s=dt)
                print(f"| {name} | {n} | {dt:g} | {m.eta_mean:.4f} ± {m.eta_std:.4f} | "
                      f"{', '.join(f'{e:.4f}' for e in m.etas)} |")
    da._Scene = planar_scene


def _case(name, kind, w, a, sign):
    b = get_preset(name).block()
    return Case(b, make_pulse(kind, sign * a * G * math.tan(b.alpha_rad), w * b.p_rad_s))


def main() -> None:
    print("| model | cells whose mirror differs (> 1e-9) | by more than 2 % | outcome differs | worst cell |")
    print("|---|---|---|---|---|")
    planar_scene = da._Scene
    for label, planar, box in (("box in the plane", True, True), ("corner spheres in the plane (adapter)", True, False),
                               ("free box (adapter, planar=false)", False, False)):
        da._scene.cache_clear()  # worlds are cached per process: build this model's
        da._Scene = _BoxScene if box else planar_scene
        ad = get_adapter("dart", planar=planar, settings="shipped")
        rows = []
        for c in CELLS:
            r1, r2 = ad.run(_case(*c, 1.0)), ad.run(_case(*c, -1.0))
            rel = abs(r1.max_abs_theta_rad / r2.max_abs_theta_rad - 1.0) if r1.outcome != "overturn" else 0.0
            rows.append((rel, r1.outcome != r2.outcome, c, r1.max_abs_theta_rad, r2.max_abs_theta_rad))
        worst = max(rows)
        print(f"| {label} | {sum(r[0] > 1e-9 for r in rows)} | {sum(r[0] > 0.02 for r in rows)} | "
              f"{sum(r[1] for r in rows)} | {' '.join(map(str, worst[2]))}: {worst[3]:.4f} / {worst[4]:.4f} rad |")
    da._Scene = planar_scene


if __name__ == "__main__":
    row() if "--row" in sys.argv[1:] else main()
