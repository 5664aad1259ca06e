"""The one validity rule and the rigid model's contact demand (docs/physics.md §9), against independent results."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rockbench.benchmark.blocks.presets import get_preset
from rockbench.engines.contract import Case, EngineAdapter, Trajectory
from rockbench.reference_solver.demand import contact_demand, impact_friction_ratio
from rockbench.reference_solver.model import G, a_ratio_to_amplitude
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution
from rockbench.reference_solver.solver import solve, solve_batch
from rockbench.reference_solver.validity import (Measurement, contact_flags, judge_measurement, jump_tol_m,
                                                 rigid_energy_j_kg, slip_tol_m)

# (block, pulse, ω/p, a0/(g·tanα)) -> min N/(m·g) of an independent computation, or None where it is < 0
VALID = [("B3M", "sine", 3.0, 2.5, 0.60), ("B3M", "sine", 7.44, 5.27, 0.49), ("B6M", "cosine", 3.0, 4.27, 0.72)]
LIFT = [("B3M", "sine", 2.22, 4.27), ("B3M", "sine", 1.78, 9.36), ("B3L", "sine", 2.6, 6.0)]


def _case(name, kind, wr, ar):
    b = get_preset(name).block()
    return b, make_pulse(kind, a_ratio_to_amplitude(b, ar), wr * b.p_rad_s)


def _housner(b):
    return 1.0 - 1.5 * math.sin(b.alpha_rad) ** 2


# -- the formulas ------------------------------------------------------------------------------------

def test_demand_at_the_uplift_threshold_is_the_static_one():
    """At θ = 0 with ü = g·tanα the block balances on its corner (θ̈ = 0): N = m·g, F = m·g·tanα."""
    b = get_preset("B3M").block()
    n, f = contact_demand([0.0], [0.0], [0.0], [-G * math.tan(b.alpha_rad)], b.alpha_rad, b.p_rad_s, side=[1.0])
    assert n[0] == pytest.approx(1.0)
    assert abs(f[0]) == pytest.approx(math.tan(b.alpha_rad))


def test_demand_of_a_free_fall_from_the_balance_point():
    """Falling freely from rest at |θ| = α, energy gives θ̇² = 2p²(1 − cos φ) and the equation of motion
    θ̈ = −p² sin φ (φ = α − θ); Newton's law then gives N/(m·g) = (3 cos φ − 1)²/4 and
    F/(m·g) = ¾ sin φ (2 − 3 cos φ): the corner unloads completely at cos φ = 1/3."""
    b = get_preset("B6M").block()
    p = b.p_rad_s
    phi = -np.linspace(0.0, 1.3, 50)
    th = b.alpha_rad - phi
    thd = np.sqrt(2 * p * p * (1 - np.cos(phi)))
    thdd = -p * p * np.sin(phi)
    n, f = contact_demand(th, thd, thdd, np.zeros_like(th), b.alpha_rad, p)
    np.testing.assert_allclose(n, (3 * np.cos(phi) - 1) ** 2 / 4, atol=1e-12)
    np.testing.assert_allclose(f, 0.75 * np.sin(phi) * (2 - 3 * np.cos(phi)), atol=1e-12)


def test_housner_impact_impulse_needs_little_friction():
    # the impulse at the new corner: |Jx|/Jz = (h/b)(1 − η)/(1 + η), far below μ = 10
    for name in ("B3M", "B6M", "B3L", "B6L"):
        b = get_preset(name).block()
        assert impact_friction_ratio(b.width_m, b.height_m, _housner(b)) < 0.35


# -- the kernel against an independent event-driven computation ---------------------------------------

def _independent_min_normal(b, pulse, eta):
    """Smallest N/(m·g) from an event-driven solution (solve_ivp, impacts as events) and Newton's law
    applied to the centre of mass's position differentiated numerically: nothing shared with the
    solver's kernel or with :func:`contact_demand`.

    Window: from uplift to the classifier's decision (overturn certain: flat, or |θ| > α moving
    outward after the pulse), else the pulse's end.
    """
    al, p, R = b.alpha_rad, b.p_rad_s, b.half_diagonal_m
    t_end = pulse.duration_s
    thr = G * math.tan(al)
    ts = np.linspace(0.0, t_end, 200001)
    up = np.nonzero(np.abs(pulse.accel(ts)) > thr)[0]
    t0 = float(ts[up[0]])
    s = -math.copysign(1.0, float(pulse.accel(t0)))
    y = [0.0, 0.0]
    segs = []
    t = t0
    while t < t_end - 1e-12:
        def rhs(tt, yy, s=s):
            u = float(pulse.accel(tt)) / G
            z = al * s - yy[0]
            return [yy[1], -p * p * (math.sin(z) + u * math.cos(z))]

        def hit(tt, yy):
            return yy[0]
        hit.terminal, hit.direction = True, (-s)

        def flat(tt, yy):
            return abs(yy[0]) - (0.5 * math.pi - 0.01)
        flat.terminal = True
        sol = solve_ivp(rhs, (t, t_end), y, events=(hit, flat), dense_output=True, rtol=1e-10, atol=1e-12,
                        max_step=1e-3)
        segs.append((t, sol.t[-1], s, sol.sol))
        if sol.status == 1 and sol.t_events[1].size:
            break
        if sol.status == 1 and sol.t_events[0].size:
            t = float(sol.t_events[0][0])
            y = [0.0, eta * float(sol.y_events[0][0][1])]
            s = -s
            continue
        break
    n_min = 1.0
    for a, bnd, s, f in segs:
        if bnd - a < 1e-6:
            continue
        tt = np.linspace(a, bnd, 4001)[1:-1]
        h = 1e-6
        th = [f(tt + k * h)[0] for k in (-1, 0, 1)]
        # the centre of mass relative to the pivot, differentiated twice numerically
        z = [R * np.cos(al * s - x) for x in th]
        zdd = (z[0] - 2 * z[1] + z[2]) / (h * h)
        n_min = min(n_min, float(np.min(1.0 + zdd / G)))
    return n_min


@pytest.mark.parametrize("name,kind,wr,ar,expected", VALID)
def test_contact_demand_matches_an_independent_computation(name, kind, wr, ar, expected):
    b, pulse = _case(name, kind, wr, ar)
    eta = _housner(b)
    sol = solve(b, pulse, eta, dt_s=1e-3, history=False)
    indep = _independent_min_normal(b, pulse, eta)
    assert sol.min_normal_mg == pytest.approx(indep, abs=0.05)
    assert sol.min_normal_mg == pytest.approx(expected, abs=0.05)   # docs/physics.md §9
    assert contact_flags(sol.min_normal_mg, sol.max_friction_ratio) == []


@pytest.mark.parametrize("name,kind,wr,ar", LIFT)
def test_lift_required_cells(name, kind, wr, ar):
    b, pulse = _case(name, kind, wr, ar)
    sol = solve(b, pulse, _housner(b), dt_s=1e-3, history=False)
    assert sol.min_normal_mg < 0 and _independent_min_normal(b, pulse, _housner(b)) < 0
    assert "lift-required" in contact_flags(sol.min_normal_mg, sol.max_friction_ratio)


def test_batch_and_single_solve_give_the_same_demand_in_both_modes():
    for name, kind, wr, ar, _ in VALID:
        b, pulse = _case(name, kind, wr, ar)
        one = [solve(b, pulse, _housner(b), mode=m, history=False) for m in ("energy", "to-rest")]
        r = solve_batch(b.alpha_rad, b.p_rad_s, _housner(b), kind, pulse.omega_rad_s, pulse.amplitude_mps2)
        assert float(r.min_normal_mg) == one[0].min_normal_mg == pytest.approx(one[1].min_normal_mg, abs=1e-9)
        assert float(r.max_friction_ratio) == one[0].max_friction_ratio


def test_demand_of_a_block_that_never_lifts():
    b, pulse = _case("B3M", "sine", 4.0, 0.9)
    sol = solve(b, pulse, 0.8, history=False)
    assert sol.outcome.value == "rest" and sol.min_normal_mg == 1.0 and sol.max_friction_ratio == 0.0


def test_reference_adapter_flags_and_friction_setting():
    from rockbench.engines.adapters.reference import ReferenceAdapter
    b, pulse = _case("B3M", "sine", 3.0, 2.5)
    case = Case(b, pulse, Restitution())
    assert ReferenceAdapter().run(case).valid
    tight = ReferenceAdapter(friction=0.5).run(case)           # needs |F|/N = 0.57 > 0.5
    assert tight.flags == ["slip-required"] and not tight.valid
    # the batch path and the per-case path give the same verdict
    assert ReferenceAdapter(friction=0.5).run_many([case, case])[0].flags == ["slip-required"]


# -- the one rule on what an engine measured ---------------------------------------------------------

def _clean_record(name="B3M", kind="sine", wr=3.0, ar=2.5, dt=2e-4):
    """An ideal rocking record: the reference's θ(t) with the corners placed kinematically (the pivot
    never moves), sampled every ``dt`` from t = 0 to the end of the run."""
    b, pulse = _case(name, kind, wr, ar)
    sol = solve(b, pulse, _housner(b), dt_s=1e-3, mode="to-rest", t_max_s=pulse.duration_s + 0.6)
    t = np.arange(0.0, sol.t_s[-1], dt)
    th = np.interp(t, sol.t_s, sol.theta_rad)
    thd = np.interp(t, sol.t_s, sol.theta_dot_rad_s)
    bw, h = b.width_m, b.height_m
    cx, cz = [], []
    for sx in (1.0, -1.0):
        # the pivot on side s stays at x = s·b/2, z = 0; the other corner swings about it
        s = np.where(th > 0, 1.0, np.where(th < 0, -1.0, sx))
        px = s * bw / 2
        dx, dz = sx * bw / 2 - px, 0.0
        c, si = np.cos(th), np.sin(th)
        cx.append(px + dx * c + dz * si)
        cz.append(-dx * si + dz * c)
    return b, pulse, Measurement(t, th, thd, np.stack(cx, 1), np.stack(cz, 1))


def test_a_clean_record_is_not_flagged():
    b, pulse, m = _clean_record()
    v = judge_measurement(m, b, pulse.duration_s)
    # a corner just lifting off (within the jump tolerance) moves by b·(1 − cos θ): sub-micrometre
    assert v.flags == () and v.max_slip_m < 2e-3 * slip_tol_m(b) and v.max_jump_m < 1e-12


def test_injected_slip_jump_and_energy_gain_are_flagged():
    b, pulse, m = _clean_record()
    t = m.t_s
    # slip: the corners slide 2 % of b along the table after 0.1 s
    slid = Measurement(t, m.theta_rad, m.theta_dot_rad_s, m.corner_x_m + np.where(t > 0.1, 0.02 * b.width_m, 0.0)[:, None],
                       m.corner_z_m)
    assert judge_measurement(slid, b, pulse.duration_s).flags == ("slip",)
    # jump: both corners 1 % of b above the table for 5 ms
    hop = ((t > 0.05) & (t < 0.055))[:, None] * 0.01 * b.width_m
    jumped = Measurement(t, m.theta_rad, m.theta_dot_rad_s, m.corner_x_m, m.corner_z_m + hop)
    assert judge_measurement(jumped, b, pulse.duration_s).flags == ("jump",)
    # energy gain after the pulse, away from θ = 0
    E = rigid_energy_j_kg(m.theta_rad, m.theta_dot_rad_s, b)
    late = np.nonzero((t > pulse.duration_s) & (np.abs(m.theta_rad) > 0.5 * b.alpha_rad))[0]
    assert late.size
    E2 = E.copy()
    E2[late[len(late) // 2]:] += 0.2 * G * b.half_diagonal_m * (1 - math.cos(b.alpha_rad))
    gained = Measurement(t, m.theta_rad, m.theta_dot_rad_s, m.corner_x_m, m.corner_z_m, E2)
    assert judge_measurement(gained, b, pulse.duration_s).flags == ("energy-gain",)
    # ... but not when the rise lives only where |θ| ≤ 0.1α (a soft contact's spring at rest)
    E3 = E.copy()
    near = (t > pulse.duration_s) & (np.abs(m.theta_rad) <= 0.1 * b.alpha_rad)
    E3[near] += 1.0
    assert judge_measurement(Measurement(t, m.theta_rad, m.theta_dot_rad_s, m.corner_x_m, m.corner_z_m, E3),
                             b, pulse.duration_s).flags == ()


def test_tolerances_are_the_documented_fractions_of_b():
    b = get_preset("B6L").block()
    assert slip_tol_m(b) == pytest.approx(0.01 * 0.06) and jump_tol_m(b) == pytest.approx(0.005 * 0.06)


def test_the_falling_block_after_a_certain_overturn_is_not_judged():
    """After the pulse, once |θ| > α moving outward, the block falls onto its side: what its corner
    does then (any contact unloads) is outside the window."""
    b, pulse, m = _clean_record(wr=3.0, ar=2.5)           # overturns after the pulse
    t, th, thd = m.t_s, m.theta_rad, m.theta_dot_rad_s
    over = (t >= pulse.duration_s) & (np.abs(th) > b.alpha_rad) & (th * thd > 0)
    assert over.any()
    after = np.arange(t.size) > np.argmax(over)
    fallen = Measurement(t, th, thd, m.corner_x_m + after[:, None] * 0.05, m.corner_z_m + after[:, None] * 0.05)
    assert judge_measurement(fallen, b, pulse.duration_s).flags == ()


class _Recorded(EngineAdapter):
    """An adapter that replays a fixed trajectory (no engine): what each engine's judge sees."""

    name = "recorded"
    own_dt_s = 1e-3

    def __init__(self, tr, **kw):
        super().__init__(**kw)
        self._tr = tr

    def _simulate(self, case):
        return self._tr


@pytest.mark.parametrize("inject", ["none", "slip", "jump"])
def test_one_record_gives_the_same_flags_in_every_adapters_format(inject):
    """Two corner edges (MuJoCo, PyBullet, planar Exudyn) or four corners (Exudyn's 3-D block, each
    edge twice), with the body's energy or without it: the same record, the same verdict, whichever
    adapter class judges it."""
    b, pulse, m = _clean_record()
    x, z = m.corner_x_m.copy(), m.corner_z_m.copy()
    if inject == "slip":
        x = x + np.where(m.t_s > 0.1, 0.02 * b.width_m, 0.0)[:, None]
    elif inject == "jump":
        z = z + ((m.t_s > 0.05) & (m.t_s < 0.055))[:, None] * 0.01 * b.width_m
    E = rigid_energy_j_kg(m.theta_rad, m.theta_dot_rad_s, b)
    formats = [(x, z, None), (x, z, E), (np.repeat(x, 2, axis=1), np.repeat(z, 2, axis=1), E)]
    case = Case(b, pulse, Restitution())
    from rockbench.engines.registry import BUILTIN, adapter_class
    verdicts = set()
    for cx, cz, e in formats:
        tr = Trajectory(m.t_s, m.theta_rad, m.theta_dot_rad_s, pulse.duration_s, corner_x_m=cx, corner_z_m=cz,
                        energy_j_kg=e, uplift_tol_rad=0.02 * b.alpha_rad)
        verdicts.add(tuple(_Recorded(tr).run(case).flags))
        for name in BUILTIN:
            if name != "reference":
                verdicts.add(tuple(adapter_class(name).judge(_Recorded(tr), case, tr).flags))
    expected = {"none": (), "slip": ("slip",), "jump": ("jump",)}[inject]
    assert verdicts == {expected}


def test_adapters_flags_other_than_diverged_are_ignored():
    """An adapter reports measurements; only the judge raises slip, jump, energy-gain."""
    b, pulse, m = _clean_record()
    tr = Trajectory(m.t_s, m.theta_rad, m.theta_dot_rad_s, pulse.duration_s, flags=["slip"],
                    corner_x_m=m.corner_x_m, corner_z_m=m.corner_z_m)
    assert _Recorded(tr).run(Case(b, pulse, Restitution())).flags == []
