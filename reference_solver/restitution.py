"""Coefficients of restitution for the rocking impact (docs/physics.md §3, paper §2.3 and eq. (10)).

The coefficient ``η`` multiplies the angular velocity at every impact, ``θ̇⁺ = η·θ̇⁻``, so the
kinetic energy at ``θ = 0`` drops by ``η²``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rockbench.reference_solver.errors import ConfigError


def housner_eta(alpha_rad: float) -> float:
    """Housner's coefficient ``η_H = 1 − 1.5·sin²α`` [-] (conservation of angular momentum
    about the new pivot for a rectangular block)."""
    return 1.0 - 1.5 * math.sin(alpha_rad) ** 2


def modified_eta(alpha_rad: float, k: float) -> float:
    """Modified coefficient (Kalliontzis et al. 2016; Chatzis et al. 2017; paper eq. (10)).

    ``η_M = (4 − 3·sin²α·(1 + k²)) / (4 − 3·sin²α·(1 − k²))``

    Parameters
    ----------
    alpha_rad : float
        Slenderness angle α [rad].
    k : float
        Position of the impact impulse as a fraction of the half width, ``k = b̄/(b/2)`` in
        [0, 1] [-]. ``k = 1`` gives Housner's η, ``k = 0`` gives 1.
    """
    k = check_k(k)
    s2 = math.sin(alpha_rad) ** 2
    return (4.0 - 3.0 * s2 * (1.0 + k * k)) / (4.0 - 3.0 * s2 * (1.0 - k * k))


def effective_k(alpha_rad: float, eta: float) -> float:
    """The impulse position ``k`` for which eq. (10) gives ``eta`` (its inverse) [-].

    ``k = √[(4 − 3·sin²α)(1 − η) / (3·sin²α·(1 + η))]``: 1 at Housner's η_H, 0 at η = 1, above 1
    for η below η_H (an impulse outside the base: more loss than a plastic corner impact). Used to
    read an engine's measured free-rocking η as the position of its impact impulse.
    """
    s2 = math.sin(alpha_rad) ** 2
    e = float(eta)
    if not (0.0 < e <= 1.0) or s2 == 0.0:
        return math.nan
    return math.sqrt((4.0 - 3.0 * s2) * (1.0 - e) / (3.0 * s2 * (1.0 + e)))


def check_k(k) -> float:
    """Validate the impulse position ``k`` in [0, 1]."""
    try:
        kf = float(k)
    except (TypeError, ValueError):
        raise ConfigError(f"--k must be a number in [0, 1], got {k!r}.") from None
    if not (0.0 <= kf <= 1.0) or math.isnan(kf):
        raise ConfigError(f"--k must be in [0, 1] (the impulse position as a fraction of b/2), got {k!r}.")
    return kf


def check_eta(eta) -> float:
    """Validate a constant coefficient of restitution in (0, 1]."""
    try:
        e = float(eta)
    except (TypeError, ValueError):
        raise ConfigError(f"--restitution must be housner, modified or a number in (0, 1], got {eta!r}.") from None
    if not (0.0 < e <= 1.0):
        raise ConfigError(f"a constant restitution must be in (0, 1], got {eta!r}; "
                          "use 1 for no energy loss at impact.")
    return e


@dataclass(frozen=True)
class Restitution:
    """A restitution law: ``housner``, ``modified`` (with ``k``) or ``constant`` (with ``value``).

    Parameters
    ----------
    kind : str
        ``"housner"``, ``"modified"`` or ``"constant"``.
    k : float, optional
        Impulse position for ``modified`` [-], in [0, 1].
    value : float, optional
        The coefficient for ``constant`` [-], in (0, 1].
    """

    kind: str = "housner"
    k: float | None = None
    value: float | None = None

    def __post_init__(self):
        if self.kind == "housner":
            return
        if self.kind == "modified":
            if self.k is None:
                raise ConfigError("--restitution modified needs --k (the impulse position in [0, 1]); "
                                  "presets supply their average k.")
            object.__setattr__(self, "k", check_k(self.k))
        elif self.kind == "constant":
            object.__setattr__(self, "value", check_eta(self.value))
        else:
            raise ConfigError(f"--restitution must be housner, modified or a number in (0, 1], got {self.kind!r}.")

    def eta(self, alpha_rad: float) -> float:
        """The coefficient for a block of slenderness angle ``alpha_rad`` [-]."""
        if self.kind == "housner":
            return housner_eta(alpha_rad)
        if self.kind == "modified":
            return modified_eta(alpha_rad, self.k)
        return self.value

    def eta_for(self, alpha_rad: float) -> float:
        """:meth:`eta`, checked: a ConfigError when the law gives no coefficient in (0, 1] for a block
        of slenderness ``alpha_rad`` [rad] (Housner's η is ≤ 0 for α ≥ asin(√(2/3)) ≈ 0.9553 rad,
        blocks wider than √2 times their height)."""
        eta = self.eta(alpha_rad)
        if not 0.0 < eta <= 1.0:
            law = ("Housner's law" if self.kind == "housner" else
                   f"the modified law (k = {self.k:g})" if self.kind == "modified" else "it")
            raise ConfigError(f"{law} gives η = {eta:.4g} for a block with α = {alpha_rad:.4f} rad "
                              f"(b/h = {math.tan(alpha_rad):.4g}); η must be in (0, 1]: use a more slender block "
                              "or give --restitution a number in (0, 1].")
        return eta

    @property
    def label(self) -> str:
        """Short text: ``housner``, ``modified(k=0.8608)`` or ``0.9``."""
        if self.kind == "housner":
            return "housner"
        if self.kind == "modified":
            return f"modified(k={self.k:g})"
        return f"{self.value:g}"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "k": self.k, "value": self.value}

    @classmethod
    def from_dict(cls, d: dict) -> "Restitution":
        return cls(d["kind"], d.get("k"), d.get("value"))

    @classmethod
    def parse(cls, text, k: float | None = None, *, k_average: float | None = None,
              k_exact: float | None = None, option: str = "--restitution") -> "Restitution":
        """A restitution law from any of its spellings; the one parser of them all.

        Parameters
        ----------
        text : str or float
            ``housner``; ``modified`` (with ``k``, else ``k_average``); ``modified-average`` or
            ``modified-exact`` (a preset's average or exact k, as suite files write them);
            ``modified:K``; ``modified(k=K)`` (:attr:`label`, as run folders record it); or a number
            in (0, 1] (a constant coefficient).
        k : float, optional
            The impulse position given apart (the CLI's ``--k``) [-]; only with ``modified``.
        k_average, k_exact : float, optional
            The block's average and exact k [-] (a preset's; None for a custom block).
        option : str
            The option that gave ``text``, named in error messages.

        Raises
        ------
        ConfigError
            An unknown spelling, ``k`` with another law, a k the block has not got, or a value out
            of range; the message names ``option``.
        """
        t = str(text).strip().lower()
        if k is not None and t != "modified":
            raise ConfigError(f"--k applies to {option} modified only, got {option} {text}.")
        if t == "housner":
            return cls()
        if t in ("modified", "modified-average", "modified-exact"):
            kk = k if k is not None else k_exact if t == "modified-exact" else k_average
            if kk is None:
                which = "exact" if t == "modified-exact" else "average"
                raise ConfigError(f"{option} {t} on a custom block needs --k (the impulse position in [0, 1])."
                                  if t == "modified" else
                                  f"{option} {t} needs a preset block (it takes the preset's {which} k); give "
                                  "modified:K for another block.")
            return cls("modified", k=kk)
        if t.startswith("modified:"):
            return cls("modified", k=t[len("modified:"):])
        if t.startswith("modified(k=") and t.endswith(")"):
            return cls("modified", k=t[len("modified(k="):-1])
        return cls("constant", value=check_eta(text))
