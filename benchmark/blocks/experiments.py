"""Experimental data: the blocks' free-rocking restitution and shaking-table outcome sets.

Two kinds of data, both documented in docs/data.md:

1. ``data/restitution.json`` (shipped): each Table 1 block's impulse position ``k`` measured in
   free rocking ([24] of the paper) and the restitution it implies, ``η_M(k)`` (paper eq. (10)),
   plus the size averages k = 0.8608 (b = 45 mm) and 0.7306 (b = 60 mm). An engine's measured η is
   scored against them with :func:`restitution_errors`.
2. Shaking-table outcomes (a user's CSV; none shipped, because the paper's Figs 13–16 points were
   published only as figure markers): one row per tested point with the block, the pulse, the
   frequency and amplitude in physical units, the outcome T (translation: no uplift), R (rocking,
   then rest) or O (overturn), the number of repetitions and the source. :func:`load_outcomes`
   validates such a file; :func:`~rockbench.benchmark.scoring.experiments.score_outcomes` scores a
   stability map against it.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from rockbench.reference_solver.classify import OUTCOME_CODES, Outcome
from rockbench.reference_solver.errors import ConfigError
from rockbench.reference_solver.model import G, amplitude_to_a_ratio
from rockbench.reference_solver.restitution import housner_eta, modified_eta
from rockbench.benchmark.blocks.presets import PRESETS, TABLE_1

#: Largest table acceleration the Quanser ST-III still performed as one sine wave (paper §5.1,
#: "ST limit" in Figs 13–16) [m/s^2].
SHAKING_TABLE_LIMIT_MPS2 = 25.0

#: Experimental outcome letters and the classifier's outcome code each one corresponds to.
OUTCOME_LETTERS = {"T": OUTCOME_CODES[Outcome.REST], "R": OUTCOME_CODES[Outcome.ROCKING],
                   "O": OUTCOME_CODES[Outcome.OVERTURN]}
LETTER_OF_CODE = {v: k for k, v in OUTCOME_LETTERS.items()}

PULSES = ("sine", "cosine", "half-sine")

#: The outcomes CSV format in one line, for help texts and messages (the full description is in
#: the project's docs/data.md, which an installed copy does not carry).
FORMAT_HINT = ("a CSV with the header block,pulse,f_hz,amplitude_mps2,outcome,repetitions,source (or omega_rad_s or "
               "period_s for the frequency, amplitude_g for the amplitude); outcome T, R or O; '#' lines are comments")
FREQUENCY_COLUMNS = {"f_hz": "Hz", "omega_rad_s": "rad/s", "period_s": "s"}
AMPLITUDE_COLUMNS = {"amplitude_mps2": "m/s^2", "amplitude_g": "g"}
REQUIRED_COLUMNS = ("block", "pulse", "outcome", "source")


# -- restitution -----------------------------------------------------------------------------------

def load_restitution() -> dict:
    """The shipped free-rocking restitution data (``data/restitution.json``) as a dict."""
    text = resources.files("rockbench.benchmark.blocks").joinpath("data/restitution.json").read_text()
    return json.loads(text)


def experimental_eta(block: str) -> float:
    """η_M with the block's own measured k (paper eq. (10), k from [24]) [-].

    Raises
    ------
    ConfigError
        ``block`` is not one of the paper's blocks.
    """
    rec = _restitution_record(block)
    return modified_eta(_alpha(rec), rec["k_exact"])


def restitution_targets(block: str) -> dict:
    """The three restitution coefficients a block is compared with [-].

    Returns
    -------
    dict
        ``housner`` (η_H), ``modified_average_k`` (η_M with the size's average k) and
        ``experiment`` (η_M with the block's exact k, i.e. its free-rocking measurement).
    """
    rec = _restitution_record(block)
    alpha = _alpha(rec)
    k_avg = {s["size"]: s["k_average"] for s in load_restitution()["size_averages"]}[rec["size"]]
    return {"housner": housner_eta(alpha), "modified_average_k": modified_eta(alpha, k_avg),
            "experiment": modified_eta(alpha, rec["k_exact"])}


def restitution_errors(eta_measured: float, block: str) -> dict:
    """Relative error of an engine's measured η against each target of :func:`restitution_targets`.

    ``(eta_measured − target)/target`` [-] for each key, plus ``eta_measured`` itself.
    """
    t = restitution_targets(block)
    return {"eta_measured": float(eta_measured), **{f"{k}_eta": v for k, v in t.items()},
            **{f"{k}_rel_error": (float(eta_measured) - v) / v for k, v in t.items()}}


def _restitution_record(block: str) -> dict:
    for rec in load_restitution()["blocks"]:
        if rec["block"].upper() == str(block).upper():
            return rec
    raise ConfigError(f"no free-rocking restitution data for block {block!r}; the data covers Table 1's "
                      f"blocks {', '.join(TABLE_1)}.")


def _alpha(rec: dict) -> float:
    return math.atan(rec["width_m"] / rec["height_m"])


# -- shaking-table outcomes ------------------------------------------------------------------------

@dataclass(frozen=True)
class OutcomePoint:
    """One tested point of a shaking-table campaign.

    Attributes
    ----------
    block : str
        A Table 1 preset (B3M, B6M, B3L, B6L).
    pulse : str
        ``sine``, ``cosine`` or ``half-sine``.
    omega_rad_s : float
        Angular frequency of the wave [rad/s].
    amplitude_mps2 : float
        Acceleration amplitude a₀ [m/s^2].
    outcome : str
        ``T`` (no uplift), ``R`` (rocked, came to rest) or ``O`` (overturned).
    repetitions : int
        How many runs gave this outcome at this point [-].
    source : str
        Where the point comes from (paper, figure, lab book).
    line : int
        Line in the file (for messages).
    """

    block: str
    pulse: str
    omega_rad_s: float
    amplitude_mps2: float
    outcome: str
    repetitions: int
    source: str
    line: int = 0

    @property
    def w_ratio(self) -> float:
        """ω/p of the point for its block [-]."""
        return self.omega_rad_s / PRESETS[self.block].block().p_rad_s

    @property
    def a_ratio(self) -> float:
        """a₀/(g·tanα) of the point for its block [-]."""
        return amplitude_to_a_ratio(PRESETS[self.block].block(), self.amplitude_mps2)


def load_outcomes(path) -> list[OutcomePoint]:
    """Read and validate a shaking-table outcomes CSV (format in docs/data.md).

    Raises
    ------
    ConfigError
        Missing file, missing or duplicate column, unknown block, pulse or outcome, a non-positive
        or non-numeric frequency or amplitude, a bad repetition count, or no data rows: one line
        naming the file, the line and what to fix.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ConfigError(f"experiments file {str(p)!r} does not exist; give the path of an outcomes CSV "
                          f"({FORMAT_HINT}).") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ConfigError(f"cannot read experiments file {str(p)!r}: {e}.") from None
    return parse_outcomes(text, name=str(p))


def parse_outcomes(text: str, name: str = "<outcomes>") -> list[OutcomePoint]:
    """Validate outcomes CSV ``text`` (see :func:`load_outcomes`)."""
    lines = text.splitlines()
    # comment lines (provenance) start with '#'; keep line numbers for messages
    body = [(n, ln) for n, ln in enumerate(lines, 1) if ln.strip() and not ln.lstrip().startswith("#")]
    if not body:
        raise ConfigError(f"{name}: no header and no data; the first non-comment line must be the header "
                          f"{','.join(REQUIRED_COLUMNS[:2])},f_hz,amplitude_mps2,outcome,repetitions,source.")
    rows = list(csv.reader(io.StringIO("\n".join(ln for _, ln in body))))
    header = [h.strip().lower() for h in rows[0]]
    where = f"{name}:{body[0][0]}"
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise ConfigError(f"{where}: column {dup[0]!r} appears twice in the header; keep one.")
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise ConfigError(f"{where}: missing column {missing[0]!r}; the header needs "
                          f"{', '.join(REQUIRED_COLUMNS)}, one of {', '.join(FREQUENCY_COLUMNS)} and one of "
                          f"{', '.join(AMPLITUDE_COLUMNS)} (repetitions optional), got {','.join(header)}.")
    fcol = [c for c in FREQUENCY_COLUMNS if c in header]
    acol = [c for c in AMPLITUDE_COLUMNS if c in header]
    for cols, kind in ((fcol, FREQUENCY_COLUMNS), (acol, AMPLITUDE_COLUMNS)):
        if len(cols) != 1:
            what = "frequency" if kind is FREQUENCY_COLUMNS else "amplitude"
            got = f"got {', '.join(cols)}" if cols else "got none"
            raise ConfigError(f"{where}: give exactly one {what} column of {', '.join(kind)}, {got}.")
    known = set(REQUIRED_COLUMNS) | set(FREQUENCY_COLUMNS) | set(AMPLITUDE_COLUMNS) | {"repetitions", "note"}
    extra = [h for h in header if h not in known]
    if extra:
        raise ConfigError(f"{where}: unknown column {extra[0]!r}; allowed: {', '.join(sorted(known))}.")
    out = []
    for (lineno, _), row in zip(body[1:], rows[1:]):
        w = f"{name}:{lineno}"
        if len(row) != len(header):
            raise ConfigError(f"{w}: {len(row)} fields, the header has {len(header)}; fix the row.")
        r = {h: v.strip() for h, v in zip(header, row)}
        block = r["block"].upper()
        if block not in TABLE_1:
            raise ConfigError(f"{w}: block {r['block']!r} is not one of the experiments' blocks; use one of "
                              f"{', '.join(TABLE_1)} (Table 1).")
        pulse = r["pulse"].lower()
        if pulse not in PULSES:
            raise ConfigError(f"{w}: unknown pulse {r['pulse']!r}; use one of {', '.join(PULSES)}.")
        f = _positive(r[fcol[0]], fcol[0], FREQUENCY_COLUMNS[fcol[0]], w)
        omega = {"f_hz": 2 * math.pi * f, "omega_rad_s": f, "period_s": 2 * math.pi / f}[fcol[0]]
        a = _positive(r[acol[0]], acol[0], AMPLITUDE_COLUMNS[acol[0]], w)
        amp = a * G if acol[0] == "amplitude_g" else a
        letter = r["outcome"].upper()
        if letter not in OUTCOME_LETTERS:
            raise ConfigError(f"{w}: outcome must be T (translation, no uplift), R (rocking) or O (overturn), "
                              f"got {r['outcome']!r}.")
        reps_text = r.get("repetitions", "") or "1"
        try:
            reps = int(reps_text)
        except ValueError:
            reps = 0
        if reps < 1:
            raise ConfigError(f"{w}: repetitions must be a whole number >= 1, got {reps_text!r}.")
        if not r["source"]:
            raise ConfigError(f"{w}: empty source; say where the point comes from (paper and figure, lab book).")
        out.append(OutcomePoint(block, pulse, omega, amp, letter, reps, r["source"], lineno))
    if not out:
        raise ConfigError(f"{name}: the header is there but there are no data rows.")
    return out


def _positive(text: str, col: str, unit: str, where: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ConfigError(f"{where}: {col} must be a number [{unit}], got {text!r}.") from None
    if not math.isfinite(v) or v <= 0:
        raise ConfigError(f"{where}: {col} must be a finite number > 0 [{unit}], got {text!r}.")
    return v


def st_limit_a_ratio(block, st_limit_mps2: float = SHAKING_TABLE_LIMIT_MPS2) -> float:
    """The shaking-table limit in a₀/(g·tanα) for a block [-].

    Parameters
    ----------
    block : str or Block
        A preset's name (paper Table 1) or the block itself.
    st_limit_mps2 : float
        The table's largest acceleration [m/s^2] (default :data:`SHAKING_TABLE_LIMIT_MPS2`).
    """
    b = PRESETS[block.upper()].block() if isinstance(block, str) else block
    return amplitude_to_a_ratio(b, st_limit_mps2)
