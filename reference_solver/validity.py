"""The one validity rule: what an engine measured, turned into flags by one rule for every engine.

The rigid rocking model assumes that the pivot corner neither slides nor lifts and that energy only
leaves the block (at impacts). An adapter reports what its engine measured along a run (a
:class:`Measurement`: θ, θ̇, both bottom corners' positions in the table's frame and, where the engine
gives it, the block's own mechanical energy); :func:`judge_measurement` turns that into flags. No
adapter computes a flag itself, so ``invalid`` means the same thing for every engine.

The rule
--------
**Window.** Every check looks at the samples from ``t = 0`` up to the classifier's decision
(:func:`~rockbench.reference_solver.classify.decision_index`: the first sample at which an overturn
is certain, else the last sample). The rigid model's own contact demand (:mod:`.demand`) is judged
over the same stretch, so an engine and the reference are held to the same motion.

**slip**: a bottom corner that touches the table (its clearance above the rest level is at most
:func:`jump_tol_m`) has moved horizontally, relative to the table, by more than :func:`slip_tol_m`
(1 % of b) from where it stood at ``t = 0``. An ideal rocking block puts each corner back on its
own spot, so drift accumulated over several contact episodes (a walking block) counts too.

**jump**: every bottom corner is above the rest level by more than :func:`jump_tol_m` (0.5 % of b)
at once. The rest level is the clearance of the lowest corner at ``t = 0`` (a block starts at rest,
on its base or, in free rocking, on one corner): a soft contact lets a settled block sink into the
table, and that is not a jump.

**energy-gain**: after the excitation has ended, the block's mechanical energy (per unit mass, in
the table's frame) rises above its running minimum by more than :data:`ENERGY_GAIN_TOL` (5 %) of
the barrier ``g·R·(1 − cos α)`` (the energy a block at rest needs to overturn). Samples with
``|θ| ≤`` :data:`NEAR_UPRIGHT_FRAC` ``·α`` are left out: there both corners may touch, and a soft
contact stores and gives back energy within each impact and tilts a resting block slightly; a gain
that lives only there is the contact's spring, not a gain of the rocking motion. The engine's own
energy is used where it reports one (it sees hops and sinking that θ alone misses); otherwise the
rigid model's ``(I_A/m)·(½θ̇² + p²·cos(α − |θ|))``.

**diverged** (non-finite samples) and the failures ``engine-error``, ``timeout``, ``crashed`` are
not judged here: they are recorded where they happen.

The rigid model's own domain (:func:`contact_flags`): a reference cell whose trajectory needs the
table to pull the block down (``min N/(m·g) < 0``) is ``lift-required``; one that needs
``|F|/N > μ`` is ``slip-required``. There the rigid model's assumptions fail, so the reference is
not valid, and an engine that flags ``jump`` or ``slip`` is right.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rockbench.reference_solver.classify import UPLIFT_TOL_FRAC, decision_index, uplift_tol  # noqa: F401 - the one uplift tolerance
from rockbench.reference_solver.energy import ENERGY_GAIN_TOL  # noqa: F401 - the rule's tolerance, defined with the energy
from rockbench.reference_solver.model import G, Block

#: Flags that the one rule raises from what an engine measured.
MEASURED_FLAGS = ("slip", "jump", "energy-gain")
#: Flags for a reference trajectory outside the rigid model's own domain.
DOMAIN_FLAGS = ("lift-required", "slip-required")
#: Every flag a cell can carry.
FLAGS = MEASURED_FLAGS + ("diverged", "engine-error", "timeout", "crashed") + DOMAIN_FLAGS
#: Flags by which a run says it left the rigid model through its contact: an engine's slip or jump,
#: the reference's need of either (docs/physics.md §9).
LEFT_MODEL_FLAGS = frozenset({"slip", "jump", "lift-required", "slip-required"})

#: Slip tolerance as a fraction of the block's width b [-].
SLIP_TOL_FRAC = 0.01
#: Jump tolerance as a fraction of the block's width b [-].
JUMP_TOL_FRAC = 0.005
#: |θ| at or below this fraction of α is left out of the energy check [-].
NEAR_UPRIGHT_FRAC = 0.1
#: Default friction coefficient of the contact-demand test: the engines' anti-slip friction [-].
DEFAULT_FRICTION = 10.0


def slip_tol_m(block: Block) -> float:
    """Horizontal motion of a touching corner on the table beyond which a run slipped [m]: 1 % of b."""
    return SLIP_TOL_FRAC * block.width_m


def jump_tol_m(block: Block) -> float:
    """Height of both bottom corners above the rest level beyond which the block jumped [m]: 0.5 % of b."""
    return JUMP_TOL_FRAC * block.width_m


def uplift_tol_rad(block: Block) -> float:
    """|θ| at or below which a block counts as not lifted [rad]: the classifier's one uplift tolerance
    (:data:`~rockbench.reference_solver.classify.UPLIFT_TOL_FRAC` of α), the same for every engine and
    the reference."""
    return uplift_tol(block.alpha_rad)


def barrier_energy_j_kg(block: Block) -> float:
    """Energy per unit mass a block at rest needs to overturn, ``g·R·(1 − cos α)`` [J/kg]."""
    return G * block.half_diagonal_m * (1.0 - math.cos(block.alpha_rad))


def rigid_energy_j_kg(theta_rad, theta_dot_rad_s, block: Block):
    """The rigid model's energy per unit mass, ``(I_A/m)·(½θ̇² + p²·cos(α − |θ|))`` [J/kg] (vectorised).

    With ``I_A/m = 4R²/3`` and ``p² = 3g/(4R)`` this is ``(2/3)R²θ̇² + g·R·cos(α − |θ|)``.
    """
    R = block.half_diagonal_m
    th = np.abs(np.asarray(theta_rad, dtype=float))
    return 2.0 / 3.0 * R * R * np.asarray(theta_dot_rad_s, dtype=float) ** 2 + G * R * np.cos(block.alpha_rad - th)


@dataclass
class Measurement:
    """What an engine measured along one run, in the table's frame.

    Attributes
    ----------
    t_s : ndarray, shape (n,)
        Sample times [s], increasing, from 0.
    theta_rad, theta_dot_rad_s : ndarray, shape (n,)
        Rotation about +y [rad] and angular velocity [rad/s].
    corner_x_m : ndarray, shape (n, k)
        Horizontal position of the block's ``k ≥ 2`` bottom corners (or corner edges) relative to
        the table [m]: the two edges of a planar model, the four corners of a 3-D one.
    corner_z_m : ndarray, shape (n, k)
        Clearance of the same corners' contact geometry above the table top [m] (negative: sunk
        into a soft contact). An offset common to every sample does not matter: the rule measures
        from the rest level.
    energy_j_kg : ndarray, shape (n,), or None
        The block's mechanical energy per unit mass in the table's frame,
        ``½|v_cm|² + ½(I_cm/m)·θ̇² + g·z_cm`` [J/kg], where the engine gives the body's state; None
        falls back to the rigid model's energy (:func:`rigid_energy_j_kg`). Only its rises matter.
    """

    t_s: np.ndarray
    theta_rad: np.ndarray
    theta_dot_rad_s: np.ndarray
    corner_x_m: np.ndarray
    corner_z_m: np.ndarray
    energy_j_kg: np.ndarray | None = None

    def __post_init__(self):
        n = np.asarray(self.t_s).shape[0]
        for name in ("corner_x_m", "corner_z_m"):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.ndim != 2 or a.shape[0] != n or a.shape[1] < 2 or a.shape != np.shape(self.corner_x_m):
                raise ValueError(f"Measurement.{name} must have shape ({n}, k) with k >= 2 like corner_x_m, "
                                 f"got {a.shape}")
            setattr(self, name, a)


@dataclass(frozen=True)
class Verdict:
    """The rule's answer on one measurement.

    Attributes
    ----------
    flags : tuple of str
        The raised :data:`MEASURED_FLAGS`, sorted.
    max_slip_m : float
        Largest drift of a touching corner from its place at t = 0, relative to the table [m].
    max_jump_m : float
        Largest clearance of the lower corner above the rest level [m] (0 if it never rose).
    energy_gain_rel : float
        Largest rise of the energy after the pulse over its running minimum, relative to the
        barrier [-].
    window_end_s : float
        The last judged sample's time [s].
    """

    flags: tuple
    max_slip_m: float
    max_jump_m: float
    energy_gain_rel: float
    window_end_s: float

    def diagnostics(self) -> dict:
        return {"max_slip_m": self.max_slip_m, "max_jump_m": self.max_jump_m,
                "energy_gain_rel": self.energy_gain_rel, "judged_until_s": self.window_end_s}


def judge_measurement(m: Measurement, block: Block, t_pulse_end_s: float) -> Verdict:
    """Apply the one validity rule (module docstring) to what an engine measured."""
    t = np.asarray(m.t_s, dtype=float)
    th = np.asarray(m.theta_rad, dtype=float)
    thd = np.asarray(m.theta_dot_rad_s, dtype=float)
    if t.size == 0:
        return Verdict((), 0.0, 0.0, 0.0, 0.0)
    i_end, _ = decision_index(t, th, thd, alpha_rad=block.alpha_rad, t_pulse_end_s=t_pulse_end_s)
    w = slice(0, i_end + 1)
    x = m.corner_x_m[w]
    z = m.corner_z_m[w]
    z_rel = z - float(np.min(z[0]))

    touching = z_rel <= jump_tol_m(block)
    drift = np.abs(x - x[0][None, :])
    max_slip = float(np.max(np.where(touching, drift, 0.0)))
    # the lower corner's clearance a sample: the least down the columns of a contiguous copy of z_rel.T,
    # the same numbers as along z_rel's short rows, which numpy takes five times longer over
    max_jump = max(float(np.max(np.min(np.ascontiguousarray(z_rel.T), axis=0))), 0.0)

    E = rigid_energy_j_kg(th, thd, block) if m.energy_j_kg is None else np.asarray(m.energy_j_kg, dtype=float)
    keep = (t[w] >= t_pulse_end_s) & (np.abs(th[w]) > NEAR_UPRIGHT_FRAC * block.alpha_rad)
    e = E[w][keep]
    gain = float(np.max(e - np.minimum.accumulate(e))) / barrier_energy_j_kg(block) if e.size >= 2 else 0.0

    flags = []
    if max_slip > slip_tol_m(block):
        flags.append("slip")
    if max_jump > jump_tol_m(block):
        flags.append("jump")
    if gain > ENERGY_GAIN_TOL:
        flags.append("energy-gain")
    return Verdict(tuple(sorted(flags)), max_slip, max_jump, gain, float(t[i_end]))


def _lift_required(min_normal_mg):
    """The table must pull the block down (floats or arrays)."""
    return min_normal_mg < 0.0


def _slip_required(max_friction_ratio, friction):
    """The pivot needs more friction than μ gives (floats or arrays)."""
    return max_friction_ratio > friction


def contact_flags(min_normal_mg: float, max_friction_ratio: float, friction: float = DEFAULT_FRICTION) -> list[str]:
    """Flags of a rigid-model trajectory outside its own domain (module docstring).

    Parameters
    ----------
    min_normal_mg : float
        Smallest normal force the pivot must supply, over m·g [-].
    max_friction_ratio : float
        Largest |F|/N it must supply while N > 0 [-].
    friction : float
        The friction coefficient μ the contact can give [-].
    """
    flags = []
    if _lift_required(min_normal_mg):
        flags.append("lift-required")
    if _slip_required(max_friction_ratio, friction):
        flags.append("slip-required")
    return flags


def contact_flag_bits(min_normal_mg, max_friction_ratio, friction: float = DEFAULT_FRICTION) -> np.ndarray:
    """:func:`contact_flags` for arrays of cases, as bits: 1 ``lift-required``, 2 ``slip-required``
    (``DOMAIN_FLAGS[k]`` where bit ``2**k`` is set; 0: valid) [-]."""
    lift = _lift_required(np.asarray(min_normal_mg, dtype=float))
    slip = _slip_required(np.asarray(max_friction_ratio, dtype=float), friction)
    return lift.astype(np.int8) | (slip.astype(np.int8) << 1)
