"""A PhysX cell's answer does not depend on its batch-mates (marked ``engine``; skipped without sapien).

PhysX runs a batch of cells as worlds of one scene (every block at the origin, colliding only with
its own table) and reuses the scene from one batch to the next. Each cell here runs alone, on an
adapter of its own (a fresh scene), and then in batches of other compositions on one adapter (other
pulses beside it, other sizes, the reverse order, the scene reused): its answer must be the same to
the last digit. Measured: bit-identical with PGS (the calibrated solver), so the test asserts
identity; with TGS (as shipped) the adapter runs one world at a time, since TGS's answer moves with
the other worlds in the scene (docs/physx.md), and the reused scene must still give identity.
"""

from __future__ import annotations

import pytest

from cells import cell_case

pytest.importorskip("sapien", reason="sapien is not installed (pip install 'rockbench[physx]')")

from rockbench.engines.registry import get_adapter  # noqa: E402

pytestmark = pytest.mark.engine

#: the step every cell runs at (one step: the cells of a call form one batch)
DT_S = 5e-4

#: the cells compared (block B3M, pulse, ω/p, a₀/(g·tanα)): rocking with impacts, overturn after an
#: impact, overturn at once
CELLS = [("B3M", "sine", 6.0, 3.0), ("B3M", "sine", 10.0, 6.0), ("B3M", "sine", 2.0, 1.5), ("B3M", "sine", 6.0, 10.0)]

#: the batch-mates: other pulses, shorter and longer runs
OTHERS = [("B3M", "cosine", 8.0, 3.0), ("B3M", "sine", 2.0, 3.0), ("B3M", "cosine", 16.0, 12.0)]

#: the fields compared, floats to the last digit
FIELDS = ("outcome", "n_impacts", "max_abs_theta_rad", "t_overturn_s", "t_uplift_s", "valid", "flags")


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ROCKBENCH_CACHE", str(tmp_path / "cache"))


def _answer(result) -> dict:
    out = {k: getattr(result, k) for k in FIELDS}
    out["steps"] = (result.diagnostics or {}).get("steps")
    return out


def _cases(cells: list) -> list:
    return [cell_case(*c, dt_s=DT_S) for c in cells]


@pytest.mark.parametrize("settings", [{}, {"drive": "table"}, {"settings": "shipped"}],
                         ids=["calibrated", "calibrated-table", "shipped"])
def test_a_cell_answers_the_same_alone_and_in_any_batch(settings):
    alone = [_answer(get_adapter("physx", **settings).run(c)) for c in _cases(CELLS)]
    ad = get_adapter("physx", **settings)
    batches = [CELLS + OTHERS, OTHERS[::-1] + CELLS[::-1], [CELLS[2], OTHERS[0], CELLS[0]], [CELLS[3], CELLS[1]]]
    for batch in batches:
        got = {c: _answer(r) for c, r in zip(batch, ad.run_many(_cases(batch)))}
        for c, a in zip(CELLS, alone):
            if c in got:
                assert got[c] == a, (c, batch)
    assert {a["outcome"] for a in alone} >= {"overturn", "rocking"}   # both kinds of run are compared
