"""The rigid block: geometry, mass and the derived rocking parameters (docs/physics.md §1).

A rectangular block of full width ``b`` (in the plane of excitation), full height ``h`` and depth
``d`` (default ``b``) rocks about one bottom corner at a time. Everything the equation of motion
needs follows from ``b`` and ``h``: the slenderness angle ``α = atan(b/h)`` (the paper prints
``tan⁻¹ h/b``, a misprint), the half-diagonal ``R = ½√(b² + h²)``, the frequency parameter
``p = √(3g/(4R))`` and the inertia about a corner ``I_A = 4/3·m·R²``. Mass only matters to the
engines (forces, contact stiffness), never to the reference solution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from rockbench.reference_solver.errors import ConfigError, check_positive

#: |θ| at which a block is taken to lie on its side [rad] (the classifier's rule 2)
FLAT_ANGLE_RAD = 0.5 * math.pi - 0.01

#: Gravitational acceleration used throughout the paper and this package [m/s^2].
G = 9.81

#: Density of the paper's aluminium blocks, consistent with Table 1's masses [kg/m^3].
ALUMINIUM_DENSITY = 2655.0


@dataclass(frozen=True)
class Block:
    """A homogeneous rectangular rigid block.

    Parameters
    ----------
    width_m : float
        Full width ``b`` in the plane of excitation [m].
    height_m : float
        Full height ``h`` [m].
    depth_m : float, optional
        Full depth out of the plane [m]; defaults to ``width_m`` (the paper's blocks).
    density_kg_m3 : float, optional
        Uniform density [kg/m^3]; defaults to aluminium (2655). Ignored when ``mass_kg`` is given.
    mass_kg : float, optional
        Mass [kg]; when given, the density is derived from it.
    name : str, optional
        A label (the preset's name, or ``"custom"``).
    """

    width_m: float
    height_m: float
    depth_m: float | None = None
    density_kg_m3: float | None = None
    mass_kg: float | None = None
    name: str = "custom"
    # derived, filled in __post_init__
    alpha_rad: float = field(init=False)
    half_diagonal_m: float = field(init=False)
    p_rad_s: float = field(init=False)

    def __post_init__(self):
        b = check_positive("--width", self.width_m, "m", "Give the block's full width in metres.")
        h = check_positive("--height", self.height_m, "m", "Give the block's full height in metres.")
        d = b if self.depth_m is None else check_positive("--depth", self.depth_m, "m")
        if self.mass_kg is not None:
            m = check_positive("mass", self.mass_kg, "kg")
            rho = m / (b * h * d)
        else:
            rho = ALUMINIUM_DENSITY if self.density_kg_m3 is None else check_positive(
                "--density", self.density_kg_m3, "kg/m^3")
            m = rho * b * h * d
        object.__setattr__(self, "width_m", b)
        object.__setattr__(self, "height_m", h)
        object.__setattr__(self, "depth_m", d)
        object.__setattr__(self, "density_kg_m3", rho)
        object.__setattr__(self, "mass_kg", m)
        if not (math.isfinite(m) and m > 0.0):
            raise ConfigError(f"the block's mass is {m:g} kg (width {b:g} m × height {h:g} m × depth {d:g} m × "
                              f"density {rho:g} kg/m^3); give sizes and a density whose product is a finite mass > 0.")
        alpha = math.atan2(b, h)
        if alpha >= FLAT_ANGLE_RAD:
            raise ConfigError(f"a block {b:g} m wide and {h:g} m high (b/h = {b / h:.4g}) lies flat: α = {alpha:.4f} rad, "
                              f"and rocking needs α < {FLAT_ANGLE_RAD:.4f} rad (b/h < {math.tan(FLAT_ANGLE_RAD):.4g}); "
                              "check --width and --height (full sizes in metres).")
        R = 0.5 * math.hypot(b, h)
        if not (math.isfinite(R) and R > 0.0):
            raise ConfigError(f"a block {b:g} m wide and {h:g} m high has no finite size; check --width and --height.")
        object.__setattr__(self, "alpha_rad", alpha)
        object.__setattr__(self, "half_diagonal_m", R)
        object.__setattr__(self, "p_rad_s", math.sqrt(3.0 * G / (4.0 * R)))

    @property
    def inertia_corner_kg_m2(self) -> float:
        """Moment of inertia about a bottom corner edge, ``I_A = 4/3·m·R²`` [kg m^2]."""
        return 4.0 / 3.0 * self.mass_kg * self.half_diagonal_m**2

    @property
    def inertia_cm_kg_m2(self) -> float:
        """Moment of inertia about the centre of mass, axis along the depth, ``m(b²+h²)/12`` [kg m^2]."""
        return self.mass_kg * (self.width_m**2 + self.height_m**2) / 12.0

    @property
    def slenderness(self) -> float:
        """Height over width ``h/b`` [-]."""
        return self.height_m / self.width_m

    def uplift_acceleration(self, linearized: bool = False) -> float:
        """Table acceleration at which rocking starts: ``g·tanα`` (``g·α`` linearised) [m/s^2]."""
        return G * (self.alpha_rad if linearized else math.tan(self.alpha_rad))

    def to_dict(self) -> dict:
        """Plain-data description (inputs and derived values) for JSON and run.json."""
        return {
            "name": self.name, "width_m": self.width_m, "height_m": self.height_m,
            "depth_m": self.depth_m, "density_kg_m3": self.density_kg_m3, "mass_kg": self.mass_kg,
            "alpha_rad": self.alpha_rad, "half_diagonal_m": self.half_diagonal_m,
            "p_rad_s": self.p_rad_s, "inertia_corner_kg_m2": self.inertia_corner_kg_m2,
        }

    @classmethod
    def from_dict(cls, d: dict) -> "Block":
        """Inverse of :meth:`to_dict` (derived values are recomputed, not trusted)."""
        return cls(d["width_m"], d["height_m"], d.get("depth_m"), mass_kg=d.get("mass_kg"),
                   density_kg_m3=None if d.get("mass_kg") is not None else d.get("density_kg_m3"),
                   name=d.get("name", "custom"))


def w_ratio_to_omega(block: Block, w_ratio: float) -> float:
    """Normalised frequency ω/p to the circular frequency ω [rad/s]."""
    return w_ratio * block.p_rad_s


def a_ratio_to_amplitude(block: Block, a_ratio: float) -> float:
    """Normalised amplitude a₀/(g·tanα) to the amplitude a₀ [m/s^2]."""
    return a_ratio * G * math.tan(block.alpha_rad)


def omega_to_w_ratio(block: Block, omega_rad_s: float) -> float:
    """Circular frequency ω [rad/s] to ω/p [-]."""
    return omega_rad_s / block.p_rad_s


def amplitude_to_a_ratio(block: Block, amplitude_mps2: float) -> float:
    """Amplitude a₀ [m/s^2] to a₀/(g·tanα) [-]."""
    return amplitude_mps2 / (G * math.tan(block.alpha_rad))
