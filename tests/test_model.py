"""Block geometry, Table 1 of the paper (docs/physics.md §5) and the two presets from its measured range."""

import math

import pytest

from rockbench.benchmark.blocks.presets import MEAN_DENSITY_KG_M3, NOT_IN_TABLE_1, PRESETS, TABLE_1, get_preset
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


def test_table_1_is_the_four_printed_blocks():
    assert TABLE_1 == tuple(TABLE1) and all(PRESETS[n].in_table_1 for n in TABLE_1)
    assert sorted(set(PRESETS) - set(TABLE_1)) == ["B2M", "B4M", "B5M", "B7M", "B8M"]


# h/b: the slenderness of the medium blocks outside Table 1 (b = 45 mm, the size whose average k is 0.8608
# over h/b 1.5-9.75), Table 1's steps of 0.75
MEASURED_RANGE = {"B2M": 1.5, "B4M": 3.0, "B5M": 3.75, "B7M": 5.25, "B8M": 6.0}


@pytest.mark.parametrize("name", list(MEASURED_RANGE))
def test_measured_range_blocks_from_closed_forms(name):
    """With r = h/b: tan α = 1/r, so sin²α = 1/(1 + r²); R = (b/2)·√(1 + r²); p = √(3g/(4R));
    η_H = 1 − 1.5·sin²α; η_M from eq. (10) with the size's average k; the mass is the mean density of
    Table 1's printed blocks (m/(b²h), computed here from the printed digits) times b²h."""
    r, b, k = MEASURED_RANGE[name], 0.045, 0.8608
    pre = get_preset(name)
    blk = pre.block()
    s2 = 1.0 / (1.0 + r * r)
    R = 0.5 * b * math.sqrt(1.0 + r * r)
    assert (blk.width_m, blk.depth_m) == (b, b) and blk.height_m == pytest.approx(r * b, rel=1e-15)
    assert math.sin(blk.alpha_rad) ** 2 == pytest.approx(s2, rel=1e-12)
    assert blk.alpha_rad == pytest.approx(math.atan2(1.0, r), rel=1e-12)
    assert blk.half_diagonal_m == pytest.approx(R, rel=1e-12)
    assert blk.p_rad_s == pytest.approx(math.sqrt(3 * G / (4 * R)), rel=1e-12)
    row = pre.row()
    assert row["eta_housner"] == pytest.approx(1 - 1.5 * s2, rel=1e-12)
    assert row["eta_modified_average_k"] == pytest.approx((4 - 3 * s2 * (1 + k * k)) / (4 - 3 * s2 * (1 - k * k)),
                                                          rel=1e-12)
    density = sum(m / 1e3 / ((bb / 1e3) ** 2 * h / 1e3) for m, bb, h, *_ in TABLE1.values()) / 4
    assert MEAN_DENSITY_KG_M3 == pytest.approx(density, rel=1e-12) and round(density, 1) == 2649.5
    assert blk.mass_kg == pytest.approx(density * b * b * r * b, rel=1e-12)
    assert pre.k_average == k and pre.k_exact is None and not pre.in_table_1
    assert row["k_exact"] is None and row["eta_modified_exact_k"] is None and row["note"] == NOT_IN_TABLE_1
    # Table 1 numbers its blocks by h/b in steps of 0.75 (B3: 2.25, B6: 4.5); the new names follow it
    assert name == f"B{round(r / 0.75)}M" and [round(get_preset(n).h_over_b / 0.75) for n in ("B3M", "B6M")] == [3, 6]


def test_measured_range_values():
    """The numbers `rockbench blocks` prints for them (B2M: sin²α = 4/13, B8M: 1/37)."""
    assert get_preset("B2M").row()["eta_housner"] == pytest.approx(1 - 6 / 13)
    assert get_preset("B8M").row()["eta_housner"] == pytest.approx(1 - 1.5 / 37)
    assert round(get_preset("B2M").row()["eta_modified_average_k"], 4) == 0.6363
    assert round(get_preset("B8M").row()["eta_modified_average_k"], 4) == 0.9698
    assert round(get_preset("B2M").block().p_rad_s, 3) == 13.468 and round(get_preset("B8M").block().p_rad_s, 3) == 7.332
    # B4M: tan α = 1/3, sin²α = 1/10; B5M: 4/15, 16/241; B7M: 4/21, 16/457
    for name, s2 in (("B4M", 1 / 10), ("B5M", 16 / 241), ("B7M", 16 / 457)):
        assert get_preset(name).row()["eta_housner"] == pytest.approx(1 - 1.5 * s2, rel=1e-12)


def test_a_block_without_a_measured_k_has_no_exact_restitution():
    pre = get_preset("B8M")
    assert pre.restitution("housner").kind == "housner" and pre.restitution("modified-average").k == 0.8608
    assert pre.has_restitution("modified-average") and not pre.has_restitution("Modified-Exact")
    assert pre.which_k(0.8608) == "average" and pre.which_k(0.7595) is None
    with pytest.raises(ConfigError) as e:
        pre.restitution("modified-exact", option="--target")
    assert str(e.value) == ("--target modified-exact: block B8M is not in Table 1 (paper's measured range) and has no "
                            "measured k (only Table 1's B3M, B6M, B3L, B6L have one); use housner, modified-average "
                            "(k = 0.8608) or modified:K.")
    assert get_preset("B3M").restitution("modified-exact").k == 0.7595


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


def test_rockbench_blocks_lists_every_preset_and_marks_those_outside_table_1(capsys):
    import json

    from rockbench.benchmark.cli.main import main
    assert main(["blocks"]) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = {ln.split()[0]: ln for ln in lines[1:] if ln.split()[0] in PRESETS}
    assert list(rows) == ["B2M", "B3M", "B4M", "B5M", "B6M", "B7M", "B8M", "B3L", "B6L"]
    for name, line in rows.items():
        assert line.endswith(NOT_IN_TABLE_1) == (name not in TABLE_1)
    assert "0.5385" in rows["B2M"] and "0.9595" in rows["B8M"] and rows["B8M"].count("—") == 2
    assert lines[-1].startswith("B2M, B4M, B5M, B7M, B8M: medium blocks inside the h/b range 1.5–9.75")
    assert main(["blocks", "--json"]) == 0
    js = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    assert js["B2M"]["in_table_1"] is False and js["B2M"]["k_exact"] is None and js["B3M"]["note"] is None
    assert js["B8M"]["eta_modified_exact_k"] is None and js["B6L"]["eta_modified_exact_k"] == pytest.approx(0.9626, abs=5e-5)
