"""A case (or a map) as a user asks for it: :class:`CaseRequest`, one definition for the command line
(each field is an option, ``w_ratio`` for ``--w-ratio``) and the notebook API (each field is a keyword),
read into a block, a restitution law, a pulse, a time step, engine settings and a map's spec by the one
set of rules below.

Values are kept as given (text from the command line, numbers or text from Python) and checked when
read; a message names the option (``--w-ratio``), which the API rewrites into its keyword.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path

from rockbench.engines.contract import SETTINGS_MODES, Case
from rockbench.reference_solver.errors import ConfigError, check_positive
from rockbench.reference_solver.model import Block, G, a_ratio_to_amplitude
from rockbench.reference_solver.pulses import Pulse, RecordPulse, make_pulse
from rockbench.reference_solver.restitution import Restitution
from rockbench.benchmark.blocks.presets import PRESETS, get_preset
from rockbench.benchmark.maps.grid import MapSpec


@dataclass(frozen=True)
class CaseRequest:
    """A block, restitution, pulse and engine, as asked for (docs/cli.md, "Describing a case").

    Attributes
    ----------
    block : str or None
        A preset (``B3M``, ...), or None for a custom block of ``width`` × ``height`` [m] (and
        optionally ``depth`` [m], ``density`` [kg/m^3]).
    restitution, k :
        ``housner``, ``modified`` (with the impulse position ``k``, default the preset's average) or a
        number in (0, 1].
    pulse : str
        ``sine``, ``cosine``, ``half-sine`` or the path of a record (CSV).
    w_ratio, omega, period :
        The frequency, one of them: ω/p [-], ω [rad/s] or the period 2π/ω [s].
    a_ratio, amplitude, amplitude_g :
        The amplitude, one of them: a₀/(g·tanα) [-], a₀ [m/s^2] or a₀ [g].
    engine, dt, linearized :
        The engine's registry name, its time step [s] (None: the engine's) and the linearised
        equation of motion (reference only).
    settings, drive, friction, set :
        Engine settings: ``calibrated``/``shipped``, ``inertial``/``table``, μ [-], and any other as
        ``KEY=VALUE`` texts (an old name or value of a setting is read under the new one, with a note).
    """

    block: str | None = None
    width: object = None
    height: object = None
    depth: object = None
    density: object = None
    restitution: str = "housner"
    k: object = None
    pulse: str = "sine"
    w_ratio: object = None
    omega: object = None
    period: object = None
    a_ratio: object = None
    amplitude: object = None
    amplitude_g: object = None
    engine: str = "reference"
    dt: object = None
    linearized: bool = False
    settings: str | None = None
    drive: str | None = None
    friction: object = None
    set: tuple = ()

    @classmethod
    def from_args(cls, args) -> "CaseRequest":
        """The request of parsed command-line options (those a subcommand does not take keep their
        defaults)."""
        given = {f.name: getattr(args, f.name) for f in fields(cls) if hasattr(args, f.name)}
        given["set"] = tuple(given.get("set") or ())
        return cls(**given)

    def block_and_preset(self) -> tuple[Block, object]:
        """The block and its preset (None for a custom block)."""
        if self.block and (self.width is not None or self.height is not None):
            raise ConfigError(f"give either --block or --width/--height, not both (got --block {self.block}).")
        if self.block:
            pre = get_preset(self.block)
            if self.depth is not None or self.density is not None:
                raise ConfigError("--depth and --density apply to custom blocks only; drop them or use "
                                  "--width/--height.")
            return pre.block(), pre
        if self.width is None or self.height is None:
            raise ConfigError(f"no block given: use --block NAME ({', '.join(PRESETS)}) or --width W --height H [m].")
        return Block(_num("--width", self.width), _num("--height", self.height),
                     None if self.depth is None else _num("--depth", self.depth),
                     density_kg_m3=None if self.density is None else _num("--density", self.density)), None

    def restitution_law(self, preset, token=None, option: str = "--restitution") -> Restitution:
        """``restitution`` (or ``token``, given as ``option``) and ``k`` into a Restitution
        (:meth:`Restitution.parse`; a preset supplies its average and exact k)."""
        k = None if self.k is None else _num("--k", self.k)
        text = self.restitution if token is None else token
        if preset is not None:
            return preset.restitution(text, k, option=option)
        return Restitution.parse(text, k, option=option)

    def omega_rad_s(self, block: Block) -> float:
        """ω [rad/s] from ``w_ratio``, ``omega`` or ``period``."""
        name, v = self._one_of(["--w-ratio", "--omega", "--period"], "frequency")
        x = check_positive(name, _num(name, v), {"--omega": "rad/s", "--period": "s"}.get(name, ""))
        if name == "--w-ratio":
            return x * block.p_rad_s
        if name == "--period":
            return 2.0 * math.pi / x
        return x

    def amplitude_mps2(self, block: Block) -> float:
        """a0 [m/s^2] from ``a_ratio``, ``amplitude`` or ``amplitude_g``."""
        name, v = self._one_of(["--a-ratio", "--amplitude", "--amplitude-g"], "amplitude")
        x = check_positive(name, _num(name, v), {"--amplitude": "m/s^2", "--amplitude-g": "g"}.get(name, ""))
        if name == "--a-ratio":
            return a_ratio_to_amplitude(block, x)
        if name == "--amplitude-g":
            return x * G
        return x

    def ground_motion(self, block: Block) -> Pulse:
        """The pulse: a harmonic one of the frequency and amplitude, or a record (scaled to the
        amplitude when one is given)."""
        kind = str(self.pulse)
        if Path(kind).is_dir():
            raise ConfigError(f"--pulse names a directory ({kind!r}); give sine, cosine, half-sine or the path of a "
                              "PATH.csv record with columns t_s,accel_mps2.")
        if kind.lower().endswith(".csv") or Path(kind).suffix:
            if any(v is not None for v in (self.w_ratio, self.omega, self.period)):
                raise ConfigError(f"a record ({kind}) has its own time scale: drop --w-ratio/--omega/--period.")
            rec = RecordPulse.from_csv(kind)
            if any(v is not None for v in (self.a_ratio, self.amplitude, self.amplitude_g)):
                scale = self.amplitude_mps2(block) / rec.amplitude_mps2 if rec.amplitude_mps2 > 0 else 1.0
                rec = RecordPulse.from_csv(kind, scale=scale)
            return rec
        return make_pulse(kind.lower(), self.amplitude_mps2(block), self.omega_rad_s(block))

    def dt_s(self) -> float | None:
        """The time step [s], or None (the engine's)."""
        return None if self.dt is None else check_positive("--dt", _num("--dt", self.dt), "s")

    def engine_settings(self) -> dict:
        """Engine settings given (only those the user set)."""
        s = {}
        if self.settings is not None:
            s["settings"] = self.settings
            if s["settings"] not in SETTINGS_MODES:
                raise ConfigError(f"--settings must be {' or '.join(SETTINGS_MODES)}, got {self.settings!r}.")
        if self.drive is not None:
            if self.drive not in ("inertial", "table"):
                raise ConfigError(f"--drive must be inertial or table, got {self.drive!r}.")
            s["drive"] = self.drive
        if self.friction is not None:
            s["friction"] = check_positive("--friction", _num("--friction", self.friction))
        for item in self.set:
            key, eq, val = item.partition("=")
            if not eq or not key:
                raise ConfigError(f"--set takes KEY=VALUE, got {item!r}.")
            s[key.strip()] = _auto(val.strip())
        return s

    def case(self) -> tuple[Case, object]:
        """A full single case (for ``simulate``) and the preset (or None)."""
        block, preset = self.block_and_preset()
        rest = self.restitution_law(preset)
        rest.eta_for(block.alpha_rad)   # a law that gives no η for this block is refused here, not by the engine
        pulse = self.ground_motion(block)
        dt = self.dt_s()
        if dt is not None:
            pulse.check_dt(dt)
        return Case(block, pulse, rest, dt, bool(self.linearized)), preset

    def map_spec(self, kind: str, axes) -> MapSpec:
        """The :class:`MapSpec` of a map of this block, restitution and engine: ``kind`` a harmonic pulse,
        ``axes()`` its ``(x, y)`` axes (read after the block and the restitution, so that a message
        names the first problem in the order the options are described)."""
        block, preset = self.block_and_preset()
        rest = self.restitution_law(preset)
        x, y = axes()
        return MapSpec(block, kind, rest, x, y, engine=self.engine, engine_settings=self.engine_settings(),
                       dt_s=self.dt_s(), linearized=bool(self.linearized))

    def _one_of(self, names: list[str], what: str):
        given = [(n, getattr(self, n.lstrip("-").replace("-", "_"))) for n in names]
        given = [(n, v) for n, v in given if v is not None]
        if len(given) > 1:
            raise ConfigError(f"the {what} is given twice ({' and '.join(n for n, _ in given)}); give exactly one of "
                              f"{', '.join(names)}.")
        if not given:
            raise ConfigError(f"no {what} given: use one of {', '.join(names)}.")
        return given[0]


def _num(name: str, v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} must be a number, got {v!r}.") from None


def _auto(v: str):
    """A ``--set`` value: a boolean, a whole number, a number, a comma-separated list, else the text."""
    low = v.lower()
    if low in ("true", "false"):
        return low == "true"
    try:
        return int(v)
    except ValueError:
        pass
    try:
        return float(v)
    except ValueError:
        pass
    if "," in v:
        return [_auto(x) for x in v.split(",")]
    return v
