"""The reference solver as an engine: the paper's Newmark scheme behind the common contract.

One case goes through :func:`~rockbench.reference_solver.solver.solve` with its whole history; many
cases of harmonic pulses go through :func:`~rockbench.reference_solver.solver.solve_batch` in one
compiled parallel call (a whole stability map at once). Both paths give the same outcomes and
figures: the batch kernel applies the classifier's rule sample by sample (tested).

Validity: the rigid model is valid only where its own assumptions hold. Along every trajectory the
solver measures the contact demand (the smallest normal force over m·g and the largest |F|/N the
pivot must supply, :mod:`~rockbench.reference_solver.demand`); the one rule of
:func:`~rockbench.reference_solver.validity.contact_flags` turns a pull (N < 0) into
``lift-required`` and a friction demand above μ (the ``friction`` setting, 10 by default, the
engines' anti-slip friction) into ``slip-required``. Such a cell is not valid.

A planted difference: the setting ``planted_eta_factor`` (in (0, 1], default 1) multiplies the
restitution every case asks for, so the reference solver runs as an engine whose only error is an η
that much too small. Mapped and scored like any engine, such a variant measures how small a
difference a suite can resolve (its power); :func:`is_planted` tells such a map from the reference's own.
"""

from __future__ import annotations

import math
import time
import numpy as np

from rockbench.reference_solver.classify import OUTCOME_FROM_CODE, Outcome
from rockbench.reference_solver.errors import ConfigError, check_positive
from rockbench.reference_solver.pulses import MIN_STEPS_PER_WAVE
from rockbench.reference_solver.solver import MODES, PAPER_DT_S, solve, solve_batch
from rockbench.reference_solver.validity import DEFAULT_FRICTION, DOMAIN_FLAGS, contact_flag_bits, contact_flags
from rockbench.engines.contract import PLANTED, Case, CellColumns, CellResult, EngineAdapter, Trajectory

#: pulse kinds the batch kernel runs (records go case by case)
_BATCH_KINDS = ("sine", "cosine", "half-sine")


def is_planted(engine: str, settings) -> bool:
    """Whether a map of ``engine`` with ``settings`` (as given) is a planted variant of the reference
    solver (``planted_eta_factor`` given, even 1: the δ = 0 variant), scored as an engine, rather than
    a reference map."""
    return engine == ReferenceAdapter.name and PLANTED in (settings or {})


class ReferenceAdapter(EngineAdapter):
    """The reference solution (paper §2.2) as an adapter.

    Settings
    --------
    mode : {"energy", "to-rest"}
        How a run ends: at the pulse's end with the exact energy decision (default), or integrated
        on until rest or overturn (see :mod:`rockbench.reference_solver.solver`).
    friction : float
        The friction coefficient μ the table can give [-]: a trajectory that needs ``|F|/N > μ``
        at the pivot is ``slip-required`` (default 10, the engines' anti-slip friction).
    planted_eta_factor : float
        The factor in (0, 1] on the restitution every case asks for [-] (default 1: none): η·(1 − δ)
        with factor 1 − δ, a planted difference (module docstring).
    """

    name = "reference"
    module = None
    install_hint = "part of rockbench; nothing to install."
    SETTINGS = {"mode": "energy", "friction": DEFAULT_FRICTION, PLANTED: 1.0}
    #: the paper's step (§2.2)
    own_dt_s = PAPER_DT_S
    #: solve_batch runs the cases in parallel on all cores: maps call it once, in-process
    batching = "parallel"

    def validate(self, settings: dict) -> None:
        if settings["mode"] not in MODES:
            raise ConfigError(f"the reference engine's mode must be energy or to-rest, got {settings['mode']!r}.")
        self.number_setting(settings, "friction", allow_none=False)
        self.number_setting(settings, PLANTED, allow_none=False)
        if settings[PLANTED] > 1.0:
            raise ConfigError(f"the reference engine's {PLANTED} must be in (0, 1] (the planted η is the case's "
                              f"η times it), got {settings[PLANTED]!r}.")

    def _eta(self, eta: float) -> float:
        """The η a run uses: the case's ``eta`` times the planted factor [-]."""
        return eta * self.settings[PLANTED]

    @property
    def _energy(self) -> bool:
        return self.settings["mode"] == "energy"

    def _simulate(self, case: Case) -> Trajectory:
        dt = case.dt_s
        eta = self._eta(case.eta)
        sol = solve(case.block, case.pulse, eta, dt_s=dt, linearized=case.linearized,
                    mode=self.settings["mode"], history=True)
        diag = {"mode": sol.mode, "dt_s": sol.dt_s, "n_steps": sol.n_steps, "n_newton": sol.n_newton,
                "impacts": sol.impact_list(), "uplifts_s": [float(x) for x in sol.uplifts]}
        return Trajectory(t_s=sol.t_s, theta_rad=sol.theta_rad, theta_dot_rad_s=sol.theta_dot_rad_s,
                          t_pulse_end_s=sol.t_pulse_end_s, flags=[], diagnostics=diag,
                          eta_for_tail=eta if self._energy else None, uplift_tol_rad=0.0,
                          theta_ddot_rad_s2=sol.theta_ddot_rad_s2, min_normal_mg=sol.min_normal_mg,
                          max_friction_ratio=sol.max_friction_ratio)

    def solve_grid(self, block, pulse_kind: str, restitution, omega_rad_s, amplitude_mps2, *,
                 dt_s: float | None = None, linearized: bool = False) -> CellColumns:
        """The verdicts on many cases of one block, harmonic pulse kind and restitution as arrays
        (contract item 6): one :func:`solve_batch` call, no object per case.

        Parameters
        ----------
        block : Block
            The block.
        pulse_kind : {"sine", "cosine", "half-sine"}
            The pulse.
        restitution : Restitution
            The restitution law.
        omega_rad_s, amplitude_mps2 : array_like
            ω [rad/s] and a₀ [m/s^2] of each case.
        dt_s : float, optional
            Time step [s] (default :attr:`own_dt_s`, the paper's).
        linearized : bool
            Linearised equation of motion.

        Returns
        -------
        CellColumns
            Equal, case by case, to what :meth:`run_many` gives for the same cases.

        Raises
        ------
        ConfigError
            A pulse kind the batch does not run, or a step too coarse for a case's wave.
        """
        if pulse_kind not in _BATCH_KINDS:
            raise ConfigError(f"solve_grid takes the pulses {', '.join(_BATCH_KINDS)}, got {pulse_kind!r}.")
        dt = check_positive("--dt", self.own_dt_s if dt_s is None else dt_s, "s")
        # the per-case path's rule (Pulse.check_dt: MIN_STEPS_PER_WAVE steps over the pulse's duration)
        duration = (math.pi if pulse_kind == "half-sine" else 2.0 * math.pi) / np.asarray(omega_rad_s, dtype=float)
        if np.size(duration) and dt > float(np.min(duration)) / MIN_STEPS_PER_WAVE:
            raise ConfigError(f"--dt {dt:g} s is too coarse for the shortest {pulse_kind} pulse of the grid: "
                              f"use --dt <= {float(np.min(duration)) / MIN_STEPS_PER_WAVE:.3g} s.")
        t0 = time.perf_counter()
        eta = self._eta(restitution.eta(block.alpha_rad))
        r = solve_batch(block.alpha_rad, block.p_rad_s, eta, pulse_kind, omega_rad_s, amplitude_mps2, dt_s=dt,
                        linearized=linearized, mode=self.settings["mode"])
        n = max(int(np.size(r.outcome)), 1)
        return CellColumns(outcome=r.outcome, n_impacts=r.n_impacts, max_abs_theta_rad=r.max_abs_theta_rad,
                           t_overturn_s=r.t_overturn_s, t_uplift_s=r.t_uplift_s,
                           flag_bits=contact_flag_bits(r.min_normal_mg, r.max_friction_ratio, self.friction),
                           flag_names=DOMAIN_FLAGS, min_normal_mg=r.min_normal_mg,
                           max_friction_ratio=r.max_friction_ratio, wall_s=(time.perf_counter() - t0) / n)

    def _native_verdicts(self, cases: list[Case]) -> list[CellResult | None]:
        """Harmonic pulses of one kind and model run in one :func:`solve_batch` call, whose kernel
        applies the classifier's rule sample by sample; the contact demand goes through the one
        rule :func:`contact_flags`. Records are left to the per-case path (None).

        The results equal those of the per-case path (:meth:`run`) in outcome, impacts, max |θ|,
        uplift and overturn times; their diagnostics hold the step counts but no impact list.
        """
        out: list[CellResult | None] = [None] * len(cases)
        groups: dict[tuple, list[int]] = {}
        for i, c in enumerate(cases):
            if c.pulse.kind in _BATCH_KINDS:
                groups.setdefault((c.pulse.kind, bool(c.linearized)), []).append(i)
        for (kind, lin), idx in groups.items():
            sel = [cases[i] for i in idx]
            dts = np.array([c.dt_s for c in sel])   # posed by run_many (a step too coarse: a ConfigError there)
            t0 = time.perf_counter()
            r = solve_batch(np.array([c.block.alpha_rad for c in sel]), np.array([c.block.p_rad_s for c in sel]),
                            np.array([self._eta(c.eta) for c in sel]), kind,
                            np.array([c.pulse.omega_rad_s for c in sel]),
                            np.array([c.pulse.amplitude_mps2 for c in sel]), dt_s=dts, linearized=lin,
                            mode=self.settings["mode"])
            wall = (time.perf_counter() - t0) / len(sel)
            mu = self.friction
            for j, i in enumerate(idx):
                outcome = OUTCOME_FROM_CODE[int(r.outcome[j])]
                t_up = float(r.t_uplift_s[j])
                n_min, f_max = float(r.min_normal_mg[j]), float(r.max_friction_ratio[j])
                flags = contact_flags(n_min, f_max, mu)
                out[i] = CellResult(
                    outcome=outcome.value, n_impacts=int(r.n_impacts[j]),
                    max_abs_theta_rad=float(r.max_abs_theta_rad[j]),
                    t_overturn_s=float(r.t_overturn_s[j]) if outcome is Outcome.OVERTURN else None,
                    t_uplift_s=None if math.isnan(t_up) else t_up, valid=not flags, flags=flags, status="ok",
                    wall_s=wall, diagnostics={"mode": self.settings["mode"], "dt_s": float(dts[j]),
                                              "n_steps": int(r.n_steps[j]), "n_newton": int(r.n_newton[j])},
                    min_normal_mg=n_min, max_friction_ratio=f_max)
        return out
