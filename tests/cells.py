"""One cell of a stability map as an engine test case: a preset block, a pulse and the cell's
normalised frequency ω/p and amplitude a₀/(g·tanα) (the engine tests' shared way of naming a cell)."""

from rockbench.engines.contract import Case
from rockbench.benchmark.blocks.presets import get_preset
from rockbench.reference_solver.model import a_ratio_to_amplitude, w_ratio_to_omega
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution


def cell_case(block_name: str, pulse: str, w_ratio: float, a_ratio: float, *, sign: float = 1.0,
              restitution: Restitution | None = None, dt_s: float | None = None) -> Case:
    """The case of the cell (ω/p = ``w_ratio``, a₀/(g·tanα) = ``a_ratio``) of ``block_name`` under
    ``pulse``; ``sign`` −1 mirrors the table motion; Housner's restitution unless given."""
    b = get_preset(block_name).block()
    p = make_pulse(pulse, sign * a_ratio_to_amplitude(b, a_ratio), w_ratio_to_omega(b, w_ratio))
    return Case(b, p, Restitution() if restitution is None else restitution, dt_s)
