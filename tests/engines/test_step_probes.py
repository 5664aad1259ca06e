"""The time-step rule's probe cells straddle the reference's overturning boundary."""

from rockbench.engines.contract import Case
from rockbench.engines.adapters.reference import ReferenceAdapter
from rockbench.engines.calibration.step_rule import PROBE_DEEP, PROBE_MARGIN, probe_cases
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.reference_solver.model import a_ratio_to_amplitude, w_ratio_to_omega
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution, housner_eta


def test_probes_straddle_the_reference_boundary_and_one_lies_well_above_it():
    block = get_preset("B6L").block()
    eta = housner_eta(block.alpha_rad)
    probes = probe_cases(block, eta)
    assert len(probes) >= 12 and len(probes) % 3 == 0
    ref = ReferenceAdapter()
    for (p, w, a_lo), (p2, w2, a_hi), (p3, w3, a_deep) in zip(probes[::3], probes[1::3], probes[2::3]):
        assert (p, w) == (p2, w2) == (p3, w3) and a_hi - a_lo <= 2 * PROBE_MARGIN + 1e-9
        assert a_deep == a_hi - PROBE_MARGIN + PROBE_DEEP
        out = [ref.run(Case(block, make_pulse(p, a_ratio_to_amplitude(block, a), w_ratio_to_omega(block, w)),
                            Restitution("constant", value=eta))).outcome for a in (a_lo, a_hi)]
        assert out[0] != "overturn" and out[1] == "overturn", (p, w, a_lo, a_hi, out)
