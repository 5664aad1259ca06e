"""Block geometry and Table 1 of the paper (docs/physics.md §5)."""

import math

import pytest

from rockbench.benchmark.blocks.presets import PRESETS, get_preset
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import G, Block, a_ratio_to_amplitude, amplitude_to_a_ratio
from rockbench.reference_solver.restitution import housner_eta, modified_eta

# name: (m [g], b [mm], h [mm], alpha [rad], R [mm], p [rad/s], eta_H, eta_M(avg k), k exact, eta_M(exact k))
TABLE1 = {
    "B3M": (544.4, 45, 101.25, 0.4182, 55.4, 11.524, 0.7526, 0.8106, 0.7595, 0.8494),
    "B6M": (1089.6, 45, 202.5, 0.2187, 103.7, 8.423, 0.9294, 0.9472, 0.8241, 0.9515),
    "B3L": (1284.3, 60, 135, 0.4182, 73.9, 9.978, 0.7526, 0.8598, 0.7259, 0.8615),
    "B6L": (2569.2, 60, 270, 0.2187, 138.3, 7.294, 0.9294, 0.9617, 0.7214, 0.9626),
}


def _round_to(x, printed):
    decimals = len(str(printed).split(".")[1]) if "." in str(printed) else 0
    return round(x, decimals)


@pytest.mark.parametrize("name", list(TABLE1))
def test_table1_printed_digits(name):
    m, b, h, alpha, R, p, eta_h, eta_m, k_exact, eta_m_exact = TABLE1[name]
    pre = get_preset(name)
    blk = pre.block()
    assert _round_to(blk.mass_kg * 1e3, m) == m
    assert (blk.width_m, blk.height_m) == (b / 1e3, h / 1e3)
    assert _round_to(blk.alpha_rad, alpha) == alpha
    assert _round_to(blk.half_diagonal_m * 1e3, R) == R
    # The paper computed p from R rounded to 0.1 mm (B6M: 8.4232 from 103.7 mm, the exact R gives
    # 8.4224; B3L: 9.9780 from 73.9 mm vs 9.9803): reproduce that, and stay within 0.03 % exactly.
    p_from_printed_R = math.sqrt(3 * G / (4 * R / 1e3))
    assert _round_to(p_from_printed_R, p) == p
    assert blk.p_rad_s == pytest.approx(p, rel=3e-4)
    assert _round_to(housner_eta(blk.alpha_rad), eta_h) == eta_h
    assert _round_to(modified_eta(blk.alpha_rad, pre.k_average), eta_m) == eta_m
    assert pre.k_exact == k_exact
    assert _round_to(modified_eta(blk.alpha_rad, k_exact), eta_m_exact) == eta_m_exact


def test_density_consistent_with_aluminium():
    for pre in PRESETS.values():
        # Table 1 masses are weighed, not computed: within 0.5 % of 2655 kg/m³
        assert pre.block().density_kg_m3 == pytest.approx(2655, rel=5e-3)


def test_derived_quantities_custom_block():
    blk = Block(0.2, 0.6, density_kg_m3=2000)
    assert blk.depth_m == 0.2
    assert blk.mass_kg == pytest.approx(2000 * 0.2 * 0.6 * 0.2)
    assert blk.alpha_rad == pytest.approx(math.atan(1 / 3))
    assert blk.inertia_corner_kg_m2 == pytest.approx(
        blk.inertia_cm_kg_m2 + blk.mass_kg * blk.half_diagonal_m**2)  # parallel-axis theorem
    assert blk.uplift_acceleration() == pytest.approx(G / 3)
    assert blk.uplift_acceleration(linearized=True) == pytest.approx(G * math.atan(1 / 3))
    assert amplitude_to_a_ratio(blk, a_ratio_to_amplitude(blk, 3.7)) == pytest.approx(3.7)


def test_mass_overrides_density():
    blk = Block(0.045, 0.10125, mass_kg=0.5444)
    assert blk.density_kg_m3 == pytest.approx(0.5444 / (0.045**2 * 0.10125))


@pytest.mark.parametrize("kw", [dict(width_m=0, height_m=1), dict(width_m=-0.045, height_m=1),
                                dict(width_m=float("nan"), height_m=1), dict(width_m=1, height_m=float("inf")),
                                dict(width_m=1, height_m=1, depth_m=0), dict(width_m=1, height_m=1, density_kg_m3=-1),
                                dict(width_m="abc", height_m=1)])
def test_bad_blocks(kw):
    with pytest.raises(ConfigError):
        Block(**kw)


def test_bad_block_message_says_what_and_value():
    with pytest.raises(ConfigError, match=r"--width must be a finite number > 0 m, got -0.045"):
        Block(-0.045, 0.1)


def test_unknown_preset_suggests_nearest():
    with pytest.raises(ConfigError, match="Did you mean B3M"):
        get_preset("B3N")
    assert get_preset("b6l").name == "B6L"
