"""A conformance suite for engine adapters, in the spirit of Gymnasium's env checker.

Each check is a public function ``check_<name>(adapter, block, dt_s=None)`` that returns what it saw
or raises :class:`CheckFailed` (testable alone); :data:`CHECKS` lists them and ``check_adapter(adapter_or_name)``
runs them all: first that the adapter is written to this rockbench's engine contract and implements
every hook, then a dozen short simulations that check what the contract (:mod:`rockbench.engines.contract`)
promises: the shape and units of the trajectory, the sign
convention, mirror symmetry, no uplift below the threshold ``g·tanα``, determinism, batches equal
to single runs, a clean :class:`~rockbench.reference_solver.errors.ConfigError` for a bad case or
setting, an overturn where any faithful engine must overturn, and measurements the one validity
rule can judge (both bottom corners in the table's frame, no verdicts of the adapter's own), and the
same rocking case under each other ``drive`` and ``planar`` value the adapter supports (a check of a
mode it does not support is skipped, :class:`CheckSkipped`). Third-party adapters can call it
in their own CI::

    from rockbench.engines.checker import check_adapter
    report = check_adapter(MyAdapter())
    assert report.passed, report.text()

``rockbench check-adapter NAME`` prints the same report (exit 0 passed, 1 a check failed).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import Block, a_ratio_to_amplitude, w_ratio_to_omega
from rockbench.reference_solver.pulses import make_pulse
from rockbench.reference_solver.restitution import Restitution
from rockbench.reference_solver.validity import Measurement
from rockbench.engines.contact import MODES, ContactEngine
from rockbench.engines.contract import Case, EngineAdapter
from rockbench.engines.registry import contract_refusal, get_adapter

#: The block the checks use by default: B6M of Table 1 (h/b = 4.5).
DEFAULT_BLOCK = Block(0.045, 0.2025, mass_kg=1.0896, name="B6M")


@dataclass
class CheckResult:
    """One check: its name, whether it passed, and what was seen."""

    name: str
    passed: bool
    detail: str = ""
    wall_s: float = 0.0
    #: not run: the adapter does not support what it checks (passed stays True)
    skipped: bool = False


@dataclass
class CheckReport:
    """All checks of one adapter."""

    engine: str
    version: str | None
    checks: list = field(default_factory=list)
    #: the checks not run because a hook is missing
    not_run: list = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def failed(self) -> list:
        return [c for c in self.checks if not c.passed]

    def to_dict(self) -> dict:
        return {"engine": self.engine, "version": self.version, "passed": self.passed,
                "n_checks": len(self.checks), "n_failed": len(self.failed),
                "checks": [{"name": c.name, "passed": c.passed, "detail": c.detail, "wall_s": c.wall_s,
                            "skipped": c.skipped} for c in self.checks], "not_run": list(self.not_run)}

    def text(self) -> str:
        lines = [f"check-adapter {self.engine} (version {self.version}):"]
        for c in self.checks:
            first, *more = c.detail.split("\n")
            lines.append(f"  {'SKIP' if c.skipped else 'PASS' if c.passed else 'FAIL'}  {c.name:28} {first}")
            lines.extend(f"  {'':4}  {'':28} {m}" for m in more)
        n, k = len(self.failed), sum(c.skipped for c in self.checks)
        lines.append(f"{len(self.checks) - n - k} of {len(self.checks) - k} checks passed"
                     + (f"; {n} failed" if n else "") + (f"; {k} skipped." if k else "."))
        if self.not_run:
            lines.append(f"{len(self.not_run)} checks not run: they run once every hook is implemented.")
        return "\n".join(lines)


def _case(block: Block, kind: str, w_ratio: float, a_ratio: float, dt_s=None) -> Case:
    amp = a_ratio_to_amplitude(block, a_ratio)
    return Case(block, make_pulse(kind, amp, w_ratio_to_omega(block, w_ratio)), Restitution(), dt_s)


def _mirror(case: Case) -> Case:
    p = case.pulse
    return replace(case, pulse=make_pulse(p.kind, -p.amplitude_mps2, p.omega_rad_s))


class CheckFailed(Exception):
    """A check's clear failure message (what was wrong, what the contract asks)."""


class CheckSkipped(Exception):
    """Why a check does not apply to the adapter (a mode it does not support), in one line."""


def _rocking(block: Block, dt_s: float | None = None) -> Case:
    """The plain rocking case most checks use: one sine wave at ω/p = 4, a0 = 1.6·g·tanα (at step
    ``dt_s`` [s], None: the adapter's own)."""
    return _case(block, "sine", 4.0, 1.6, dt_s)


def check_contract(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                   dt_s: float | None = None) -> str:
    """The adapter is written to this rockbench's engine contract (the ``CONTRACT_VERSION`` it
    declares; :func:`~rockbench.engines.registry.contract_refusal`)."""
    refusal = contract_refusal(type(adapter))
    if refusal:
        raise CheckFailed(refusal)
    return f"written to engine contract {type(adapter).CONTRACT_VERSION}"


def check_hooks(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                dt_s: float | None = None) -> str:
    """Every hook the base class calls is implemented (:mod:`rockbench.engines.hooks`); one line per
    missing hook saying what to implement."""
    missing = adapter.missing_hooks()
    if missing:
        raise CheckFailed("\n".join(missing))
    return "every hook the base class calls is implemented"


def check_describe(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                   dt_s: float | None = None) -> str:
    """describe() and resolve() are JSON-ready and the version is known."""
    ad, b = adapter, block
    try:
        version = str(ad.version())
    except Exception as e:  # noqa: BLE001 - a failed check
        raise CheckFailed(f"version() raised {type(e).__name__}: {e}") from None
    d = ad.describe()
    json.dumps(d)
    s = ad.resolve(b, Restitution())
    json.dumps(s)
    if not isinstance(d, dict) or "engine" not in d or "version" not in d:
        raise CheckFailed(f"describe() must return a dict with engine and version, got {d!r}")
    return f"describe() and resolve() are JSON-ready; version {version}"


def check_unknown_setting(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                          dt_s: float | None = None) -> str:
    """An unknown setting raises ConfigError (contract item 2)."""
    ad = adapter
    try:
        type(ad)(__no_such_setting__=1)
    except ConfigError:
        return "an unknown setting raises ConfigError"
    raise CheckFailed("an unknown setting was accepted; it must raise ConfigError (contract item 2)")


def check_trajectory_shape(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                           dt_s: float | None = None) -> str:
    """The trajectory of a rocking case: 1-D samples from t = 0 over the pulse, only the diverged flag (items 3, 4)."""
    ad, b = adapter, block
    rocking = _rocking(block, dt_s)
    tr = ad.simulate(rocking)
    t, th, thd = (np.asarray(x) for x in (tr.t_s, tr.theta_rad, tr.theta_dot_rad_s))
    if not (t.ndim == th.ndim == thd.ndim == 1 and t.shape == th.shape == thd.shape and t.size >= 2):
        raise CheckFailed(f"t_s, theta_rad, theta_dot_rad_s must be 1-D of one length >= 2, got {t.shape}, "
                    f"{th.shape}, {thd.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(th)) and np.all(np.isfinite(thd))):
        raise CheckFailed("non-finite samples in a plain rocking case")
    if abs(t[0]) > 1e-9:
        raise CheckFailed(f"samples must start at t = 0 s, got {t[0]:g} s")
    if not np.all(np.diff(t) > 0):
        raise CheckFailed("sample times must increase strictly")
    T = rocking.pulse.duration_s
    dt = ad.posed(replace(rocking, dt_s=dt_s)).dt_s
    if not math.isclose(tr.t_pulse_end_s, T, rel_tol=0.01, abs_tol=2 * dt):
        raise CheckFailed(f"t_pulse_end_s = {tr.t_pulse_end_s:g} but the pulse lasts {T:g} s (seconds expected)")
    if t[-1] < T - 2 * dt:
        raise CheckFailed(f"the samples end at {t[-1]:g} s, before the pulse does ({T:g} s) (contract item 3)")
    bad = sorted(set(tr.flags) - {"diverged"})
    if bad:
        raise CheckFailed(f"the adapter set the flags {bad} itself; an adapter reports measurements and may only "
                    "set 'diverged': slip, jump and energy-gain come from the one validity rule (contract item 4)")
    json.dumps(tr.diagnostics)
    if not (0.0 <= tr.uplift_tol_rad < b.alpha_rad):
        raise CheckFailed(f"uplift_tol_rad = {tr.uplift_tol_rad:g} must be in [0, α = {b.alpha_rad:.4f}) rad")
    return f"{t.size} samples over {t[-1]:.3f} s, pulse {T:.3f} s"


def check_units(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                dt_s: float | None = None) -> str:
    """Radians and rad/s: max |θ| plausible and θ̇ the derivative of θ."""
    ad = adapter
    rocking = _rocking(block, dt_s)
    tr = ad.simulate(rocking)
    t, th, thd = (np.asarray(x, float) for x in (tr.t_s, tr.theta_rad, tr.theta_dot_rad_s))
    m = float(np.max(np.abs(th)))
    if m > 0.5 * math.pi + 0.2:
        raise CheckFailed(f"max |θ| = {m:.3g} in a rocking case: degrees instead of radians?")
    if m <= tr.uplift_tol_rad:
        raise CheckFailed(f"the block did not rock at a0/(g·tanα) = 1.6, ω/p = 4 (max |θ| = {m:.3g} rad)")
    grad = np.gradient(th, t)
    moving = np.abs(thd) > 0.1 * np.max(np.abs(thd))
    err = np.median(np.abs(grad[moving] - thd[moving])) / np.median(np.abs(thd[moving]))
    if not err < 0.2:
        raise CheckFailed(f"theta_dot_rad_s is not the derivative of theta_rad (median relative mismatch {err:.2f})")
    return f"max |θ| = {m:.4f} rad, θ̇ matches dθ/dt (median mismatch {100 * err:.1f} %)"


def check_sign_convention(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                          dt_s: float | None = None) -> str:
    """A positive table acceleration starts a negative θ (item 3)."""
    ad = adapter
    rocking = _rocking(block, dt_s)
    tr = ad.simulate(rocking)
    th = np.asarray(tr.theta_rad, float)
    lifted = np.nonzero(np.abs(th) > max(tr.uplift_tol_rad, 1e-12))[0]
    if lifted.size == 0:
        raise CheckFailed("the block never lifted off in the rocking case")
    if th[lifted[0]] >= 0:
        raise CheckFailed("a positive table acceleration started a positive θ; the contract's convention is the "
                    "opposite (θ about +y, x along the excitation, z up) (contract item 3)")
    return "a positive table acceleration starts a negative θ"


def check_mirror_symmetry(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                          dt_s: float | None = None) -> str:
    """−ü gives the mirrored motion: same outcome, impacts and max |θ|, θ on the other side."""
    ad, b = adapter, block
    msgs = []
    for kind in ("sine", "cosine"):
        c = _case(b, kind, 4.0, 1.6, dt_s)
        r1, r2 = ad.run(c), ad.run(_mirror(c))
        if (r1.outcome, r1.n_impacts) != (r2.outcome, r2.n_impacts):
            raise CheckFailed(f"{kind}: ü gives {r1.outcome} with {r1.n_impacts} impacts, −ü gives {r2.outcome} with "
                        f"{r2.n_impacts} impacts")
        if not math.isclose(r1.max_abs_theta_rad, r2.max_abs_theta_rad, rel_tol=0.02, abs_tol=1e-9):
            raise CheckFailed(f"{kind}: max |θ| {r1.max_abs_theta_rad:.5g} for ü, {r2.max_abs_theta_rad:.5g} for −ü")
        t1 = ad.simulate(c)
        t2 = ad.simulate(_mirror(c))
        i1 = np.argmax(np.abs(t1.theta_rad) > max(t1.uplift_tol_rad, 1e-12))
        i2 = np.argmax(np.abs(t2.theta_rad) > max(t2.uplift_tol_rad, 1e-12))
        if np.sign(t1.theta_rad[i1]) == np.sign(t2.theta_rad[i2]):
            raise CheckFailed(f"{kind}: ü and −ü start θ on the same side")
        msgs.append(f"{kind} {r1.outcome}/{r1.n_impacts}")
    return "−ü gives −θ (" + ", ".join(msgs) + ")"


def check_no_uplift_below_threshold(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                                    dt_s: float | None = None) -> str:
    """No uplift below a0 = g·tanα (sine and cosine, ω/p = 1 and 6)."""
    ad, b = adapter, block
    for kind in ("sine", "cosine"):
        for w in (1.0, 6.0):
            r = ad.run(_case(b, kind, w, 0.9, dt_s))
            if r.outcome != "rest":
                raise CheckFailed(f"{kind}, ω/p = {w:g}, a0 = 0.9·g·tanα: {r.outcome} (max |θ| = "
                            f"{r.max_abs_theta_rad:.3g} rad); no uplift is possible below g·tanα")
    return "rest at a0 = 0.9·g·tanα (sine and cosine, ω/p = 1 and 6)"


def check_determinism(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                      dt_s: float | None = None) -> str:
    """Two runs of one case are bit-identical."""
    ad = adapter
    rocking = _rocking(block, dt_s)
    t1, t2 = ad.simulate(rocking), ad.simulate(rocking)
    if not (np.array_equal(t1.t_s, t2.t_s) and np.array_equal(t1.theta_rad, t2.theta_rad)):
        n = min(len(t1.theta_rad), len(t2.theta_rad))
        d = float(np.max(np.abs(np.asarray(t1.theta_rad[:n]) - np.asarray(t2.theta_rad[:n])))) if n else math.nan
        raise CheckFailed(f"two runs of one case differ (max |Δθ| = {d:.3g} rad); results must be reproducible")
    return "two runs are bit-identical"


def check_batch_equals_single(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                              dt_s: float | None = None) -> str:
    """run_many equals run case by case (item 6)."""
    ad, b = adapter, block
    cases = [_case(b, "sine", 4.0, 1.6, dt_s), _case(b, "cosine", 2.0, 3.0, dt_s), _case(b, "sine", 1.0, 0.9, dt_s)]
    many = ad.run_many(cases)
    one = [ad.run(c) for c in cases]
    for k, (m, o) in enumerate(zip(many, one)):
        if (m.outcome, m.n_impacts, m.status) != (o.outcome, o.n_impacts, o.status) or not math.isclose(
                m.max_abs_theta_rad, o.max_abs_theta_rad, rel_tol=1e-9, abs_tol=1e-12):
            raise CheckFailed(f"case {k}: run_many gives {m.outcome}/{m.n_impacts}, run gives {o.outcome}/{o.n_impacts} "
                        "(contract item 6)")
    return "run_many equals run case by case"


def check_bad_case_config_error(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                                dt_s: float | None = None) -> str:
    """A negative or too coarse time step raises ConfigError."""
    ad = adapter
    rocking = _rocking(block, dt_s)
    for dt in (-1e-3, 10.0):
        bad = replace(rocking, dt_s=dt)
        try:
            ad.run(bad)
        except ConfigError:
            continue
        except Exception as e:  # noqa: BLE001
            raise CheckFailed(f"dt_s = {dt:g} s raised {type(e).__name__}, not ConfigError: {e}") from None
        raise CheckFailed(f"dt_s = {dt:g} s was accepted; a bad case must raise ConfigError (the step is the case's "
                          "dt_s, which run_many poses once)")
    return "a negative or too coarse time step raises ConfigError"


def check_overturns_when_it_must(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                                 dt_s: float | None = None) -> str:
    """A long, strong sine wave (ω/p = 1, a0 = 5·g·tanα) overturns the block."""
    ad, b = adapter, block
    r = ad.run(_case(b, "sine", 1.0, 5.0, dt_s))
    if r.outcome != "overturn":
        raise CheckFailed(f"one sine wave at ω/p = 1, a0 = 5·g·tanα gave {r.outcome}; every faithful model overturns")
    return "overturns under a long, strong sine wave (ω/p = 1, a0 = 5·g·tanα)"


def check_measurements(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                       dt_s: float | None = None) -> str:
    """Measurements the one validity rule can judge; the mild rocking case is valid (item 4)."""
    ad = adapter
    rocking = _rocking(block, dt_s)
    tr = ad.simulate(rocking)
    if tr.min_normal_mg is not None:
        if not (math.isfinite(tr.min_normal_mg) and math.isfinite(tr.max_friction_ratio or 0.0)):
            raise CheckFailed("the rigid model's contact demand must be finite")
        return (f"rigid-model contact demand reported (min N/(m·g) = {tr.min_normal_mg:.3f}, "
                f"max |F|/N = {tr.max_friction_ratio:.3f})")
    m = tr.measurement()
    if m is None:
        raise CheckFailed("no corner_x_m/corner_z_m: a contact engine must report both bottom corners relative to the "
                    "table so that the one validity rule can judge slip and jump (contract item 4)")
    try:
        Measurement(m.t_s, m.theta_rad, m.theta_dot_rad_s, m.corner_x_m, m.corner_z_m, m.energy_j_kg)
    except ValueError as e:
        raise CheckFailed(str(e)) from None
    if not (np.all(np.isfinite(m.corner_x_m)) and np.all(np.isfinite(m.corner_z_m))):
        raise CheckFailed("non-finite corner positions in a plain rocking case")
    if m.energy_j_kg is not None and np.shape(m.energy_j_kg) != np.shape(m.t_s):
        raise CheckFailed(f"energy_j_kg must have one value per sample, got shape {np.shape(m.energy_j_kg)}")
    r = ad.judge(rocking, tr)
    if not r.valid:
        raise CheckFailed(f"a mild rocking case (a0/(g·tanα) = 1.6, ω/p = 4) was judged {r.flags}: the corner "
                    "measurements are in the wrong frame or units, or the contact slides")
    return (f"{m.corner_x_m.shape[1]} corners and {'the body energy' if m.energy_j_kg is not None else 'no energy'}"
            " reported; the mild rocking case is valid by the one rule")


def _check_mode(adapter: EngineAdapter, block: Block, key: str, dt_s: float | None = None) -> str:
    """The rocking case under every value of the setting ``key`` (``drive``, ``planar``) the adapter
    supports besides its own, at its own step: it lifts on the contract's side, the one validity rule
    finds it valid, and its outcome and max |θ| (within 10 %) are those of the adapter's own value."""
    own = adapter.settings.get(key)
    if own is None or not isinstance(adapter, ContactEngine):
        raise CheckSkipped(f"no {key!r} setting (not a contact engine)")
    supported = adapter.supported_modes(key)
    others = [v for v in supported if v != own]
    if not others:
        left = ", ".join(f"{key} = {str(v).lower()}" for v in MODES[key] if v not in supported)
        raise CheckSkipped(f"the adapter supports {key} = {str(own).lower()} only (SUPPORTED_MODES): {left} not checked")
    rocking = _rocking(block, dt_s)
    # the step of its own runs
    case = adapter.posed(replace(rocking, dt_s=dt_s))
    r0, seen = adapter.run(case), []
    for v in others:
        tr = type(adapter)(**{**adapter.settings, key: v}).simulate(case)
        r = adapter.judge(case, tr)
        th = np.asarray(tr.theta_rad, float)
        lifted = np.nonzero(np.abs(th) > max(tr.uplift_tol_rad, 1e-12))[0]
        mode = f"{key} = {str(v).lower()}"
        if lifted.size == 0 or th[lifted[0]] >= 0:
            raise CheckFailed(f"{mode}: a positive table acceleration did not start a negative θ (contract item 3)")
        if not r.valid:
            raise CheckFailed(f"{mode}: the rocking case was judged {r.flags}: the corners are not in the table's frame "
                              "(table drive: relative to the moving table), or the mode poses another problem")
        if r.outcome != r0.outcome or not math.isclose(r.max_abs_theta_rad, r0.max_abs_theta_rad, rel_tol=0.1):
            raise CheckFailed(f"{mode}: {r.outcome}, max |θ| {r.max_abs_theta_rad:.4g} rad; {key} = {str(own).lower()}: "
                              f"{r0.outcome}, {r0.max_abs_theta_rad:.4g} rad (the same problem posed another way)")
        seen.append(f"{mode}: {r.outcome}, max |θ| {r.max_abs_theta_rad:.4f} rad")
    return "; ".join(seen) + f" ({str(own).lower()}: {r0.max_abs_theta_rad:.4f} rad)"


def check_drive(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                dt_s: float | None = None) -> str:
    """The rocking case under each other drive the adapter supports poses the same problem."""
    return _check_mode(adapter, block, "drive", dt_s)


def check_planar(adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
                 dt_s: float | None = None) -> str:
    """The rocking case with the other ``planar`` value, where the adapter supports it, poses the same problem."""
    return _check_mode(adapter, block, "planar", dt_s)


#: every check, by the name the report gives it, in the order check_adapter runs them
CHECKS: dict[str, Callable[..., str]] = {
    "contract": check_contract,
    "hooks": check_hooks,
    "describe": check_describe,
    "unknown-setting": check_unknown_setting,
    "trajectory-shape": check_trajectory_shape,
    "units": check_units,
    "sign-convention": check_sign_convention,
    "mirror-symmetry": check_mirror_symmetry,
    "no-uplift-below-threshold": check_no_uplift_below_threshold,
    "determinism": check_determinism,
    "batch-equals-single": check_batch_equals_single,
    "bad-case-config-error": check_bad_case_config_error,
    "overturns-when-it-must": check_overturns_when_it_must,
    "measurements": check_measurements,
    "drive": check_drive,
    "planar": check_planar,
}


def check_adapter(adapter_or_name, *, block: Block | None = None, dt_s: float | None = None) -> CheckReport:
    """Run every check of :data:`CHECKS` on an adapter instance or a registered engine name.

    Parameters
    ----------
    adapter_or_name : EngineAdapter or str
        The adapter, or its registry name (instantiated with default settings).
    block : Block, optional
        The block to use (default :data:`DEFAULT_BLOCK`, B6M).
    dt_s : float, optional
        The time step of every case [s]; default: the adapter's own (``posed``: for a calibrated
        contact engine the time-step rule's step, whose calibrations at each step of the ladder are
        what a slow engine's checks spend most of their time on).

    Returns
    -------
    CheckReport

    Raises
    ------
    ConfigError
        An unknown engine name.
    EngineUnavailableError
        The engine is not installed.
    """
    ad: EngineAdapter = get_adapter(adapter_or_name) if isinstance(adapter_or_name, str) else adapter_or_name
    b = block or DEFAULT_BLOCK
    try:
        version = str(ad.version())
    except Exception:  # noqa: BLE001 - the describe check reports it
        version = None
    rep = CheckReport(ad.name or type(ad).__name__, version)
    for name, check in CHECKS.items():
        rep.checks.append(run_check(name, check, ad, b, dt_s))
        if name in ("contract", "hooks") and not rep.checks[-1].passed:
            # the others would only fail on the contract or the missing hooks
            rep.not_run = list(CHECKS)[list(CHECKS).index(name) + 1:]
            break
    return rep


def run_check(name: str, check: Callable[..., str], adapter: EngineAdapter, block: Block = DEFAULT_BLOCK,
              dt_s: float | None = None) -> CheckResult:
    """Run one check: passed with its detail, or failed with the :class:`CheckFailed` message or
    the exception it raised."""
    t0 = time.perf_counter()
    skipped = False
    try:
        detail, ok = check(adapter, block, dt_s), True
    except CheckSkipped as e:
        ok, detail, skipped = True, str(e), True
    except CheckFailed as e:
        ok, detail = False, str(e)
    except Exception as e:  # noqa: BLE001 - any exception is a failed check, reported
        ok, detail = False, f"raised {type(e).__name__}: {e}"
    return CheckResult(name, ok, detail, time.perf_counter() - t0, skipped)
