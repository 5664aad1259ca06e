"""Restitution laws (docs/physics.md §3, paper eq. (10))."""

import math

import pytest
from hypothesis import given, strategies as st

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.restitution import Restitution, housner_eta, modified_eta

alphas = st.floats(0.01, 1.2)


@given(alphas)
def test_modified_limits(alpha):
    assert modified_eta(alpha, 1.0) == pytest.approx(housner_eta(alpha), abs=1e-14)
    assert modified_eta(alpha, 0.0) == pytest.approx(1.0, abs=1e-14)


@given(alphas, st.floats(0, 1), st.floats(0, 1))
def test_modified_decreases_with_k(alpha, k1, k2):
    lo, hi = sorted((k1, k2))
    assert modified_eta(alpha, hi) <= modified_eta(alpha, lo) + 1e-15


def test_housner_from_angular_momentum():
    # Independent derivation from first principles: at impact the angular momentum about the new
    # pivot is conserved, I_A·θ̇⁺ = I_cm·θ̇⁻ + m·(r_new × v_cm), with v_cm from rotation about the old pivot.
    b, h, m = 0.045, 0.10125, 1.0
    R = 0.5 * math.hypot(b, h)
    I_A = 4 / 3 * m * R**2
    I_cm = m * (b**2 + h**2) / 12
    w = 1.0
    r_old = (b / 2, h / 2)   # from the old pivot (−b/2, 0) to the centre
    v_cm = (-w * r_old[1], w * r_old[0])
    r_new = (-b / 2, h / 2)  # from the new pivot (+b/2, 0) to the centre
    L = I_cm * w + m * (r_new[0] * v_cm[1] - r_new[1] * v_cm[0])
    eta = L / I_A
    alpha = math.atan(b / h)
    assert eta == pytest.approx(housner_eta(alpha), rel=1e-12)


def test_parse_and_labels():
    assert Restitution.parse("Housner").eta(0.3) == housner_eta(0.3)
    assert Restitution.parse("modified", k=0.5).label == "modified(k=0.5)"
    assert Restitution.parse("0.9").eta(0.3) == 0.9
    assert Restitution.parse("1").eta(0.3) == 1.0


@pytest.mark.parametrize("text,k", [("0", None), ("1.2", None), ("-0.5", None), ("nan", None), ("soft", None),
                                    ("modified", 1.5), ("modified", -0.1), ("modified", None)])
def test_bad_restitution(text, k):
    with pytest.raises(ConfigError):
        Restitution.parse(text, k=k)


@pytest.mark.parametrize("alpha", [0.05, 0.2187, 0.4182, 0.9])
@pytest.mark.parametrize("k", [0.0, 0.25, 0.7306, 0.8608, 1.0])
def test_effective_k_inverts_eq_10(alpha, k):
    from rockbench.reference_solver.restitution import effective_k
    assert effective_k(alpha, modified_eta(alpha, k)) == pytest.approx(k, abs=1e-12)


def test_effective_k_edges():
    import math
    from rockbench.reference_solver.restitution import effective_k
    a = 0.4182
    assert effective_k(a, housner_eta(a)) == pytest.approx(1.0, abs=1e-14)
    assert effective_k(a, 1.0) == 0.0
    assert effective_k(a, 0.7) > 1.0          # more loss than Housner: impulse "outside" the base
    assert math.isnan(effective_k(a, 0.0)) and math.isnan(effective_k(a, 1.2))


@pytest.mark.parametrize("text,k,want", [
    ("housner", None, Restitution()),
    (" Housner ", None, Restitution()),
    ("modified", 0.5, Restitution("modified", k=0.5)),
    ("modified", None, Restitution("modified", k=0.8608)),          # the preset's average k
    ("modified-average", None, Restitution("modified", k=0.8608)),
    ("modified-exact", None, Restitution("modified", k=0.7595)),
    ("modified:0.25", None, Restitution("modified", k=0.25)),
    ("modified(k=0.8608)", None, Restitution("modified", k=0.8608)),   # a run folder's label
    ("0.9", None, Restitution("constant", value=0.9)),
    (0.9, None, Restitution("constant", value=0.9)),
])
def test_parse_reads_every_spelling(text, k, want):
    assert Restitution.parse(text, k, k_average=0.8608, k_exact=0.7595) == want


def test_parse_reads_back_every_label():
    for law in (Restitution(), Restitution("modified", k=0.7306), Restitution("constant", value=0.75)):
        assert Restitution.parse(law.label) == law


@pytest.mark.parametrize("text,k,kw,match", [
    ("housner", 0.5, {}, "--k applies to --restitution modified only"),
    ("modified", None, {}, "--restitution modified on a custom block needs --k"),
    ("modified-exact", None, {"option": "--target"}, "--target modified-exact needs a preset block"),
    ("modified:2", None, {}, "--k must be in"),
    ("bouncy", None, {}, "must be housner, modified or a number"),
    ("1.5", None, {}, r"constant restitution must be in \(0, 1\]"),
])
def test_parse_refuses_with_one_line(text, k, kw, match):
    with pytest.raises(ConfigError, match=match):
        Restitution.parse(text, k, **kw)
