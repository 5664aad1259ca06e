"""What scoring a run yields, typed: :class:`Scores` (variants → scenarios → pairs, the verdict, the speed
stage), and score.json as its serialisation (:meth:`Scores.to_json`, :meth:`Scores.from_json`).

One function makes it (:func:`rockbench.benchmark.scoring.score_runs.score_run`); the report, the console
summary, ``rockbench compare`` and the notebook API read it. It holds numbers only: the words and tables
are the report's (:mod:`rockbench.benchmark.report.verdict_words`, :mod:`rockbench.benchmark.report.tables`).

score.json keeps its flat layout: ``pairs`` is one list sorted by pair key (:func:`pair_key`), which
:class:`Scores` groups by variant and scenario (block × pulse) and flattens back. A pair, a verdict row
and the speed stage keep every field of their stored object (``record``), so a score.json written by an
older or newer rockbench of the same schema reads back to the document it was; :meth:`Scores.to_json`
gives copies, so whoever edits the document it returns changes nothing in the scores.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

#: score.json's ``kind``.
SCORE_KIND = "rockbench-score"

#: Version of score.json's layout (2: the verdict, pairs' completeness, labels and settings classes).
SCORE_SCHEMA_VERSION = 2


def pair_key(p: dict) -> str:
    """A stable text key of a scored pair: what compare matches baseline and current by."""
    return f"{p['variant']} | {p['block']} | {p['pulse']} | {p['restitution']} | vs {p['reference']['restitution']}"


@dataclass(frozen=True)
class Pair:
    """One scored pair: an engine map against one reference map of its block and pulse; ``record`` is its
    object in score.json (the maps, their cells, ``scores``, the facts the verdict reads)."""

    key: str
    variant: str
    block: str
    pulse: str
    record: dict

    @classmethod
    def from_json(cls, p: dict) -> "Pair":
        return cls(p["key"], p["variant"], p["block"], p["pulse"], copy.deepcopy(p))

    def to_json(self) -> dict:
        return copy.deepcopy(self.record)


@dataclass(frozen=True)
class Scenario:
    """A variant's pairs of one block and pulse (one per reference it was judged against)."""

    block: str
    pulse: str
    pairs: tuple[Pair, ...]


@dataclass(frozen=True)
class VariantScores:
    """An engine variant's scenarios, in the order their pairs first come in score.json."""

    variant: str
    scenarios: tuple[Scenario, ...]


def nest(pairs: list[Pair]) -> tuple[VariantScores, ...]:
    """``pairs`` grouped by variant, then by scenario (block × pulse), each group in first-come order."""
    by: dict = {}
    for p in pairs:
        by.setdefault(p.variant, {}).setdefault((p.block, p.pulse), []).append(p)
    return tuple(VariantScores(v, tuple(Scenario(b, u, tuple(ps)) for (b, u), ps in sc.items()))
                 for v, sc in by.items())


#: The verdict's fields in score.json's order (:func:`rockbench.benchmark.scoring.verdict.verdict`).
_VERDICT_FIELDS = ("metric", "direction", "unit", "confidence", "declared", "fail_distance", "mcb", "power",
                   "general", "equivalence", "variants")


@dataclass(frozen=True)
class Verdict:
    """score.json's ``verdict`` (docs/scores.md, "The verdict in score.json"): the primary metric, the
    suite's declarations, each class's comparisons (``mcb``), the suite's power, the general-problem scope,
    equivalence, and one row per variant (``variants``, in the verdict's order); ``more`` holds fields this
    rockbench does not name (an older file's words among them), kept as they were."""

    metric: str
    direction: str
    unit: str
    confidence: float
    declared: dict
    fail_distance: float
    mcb: dict
    power: dict | None
    general: dict | None
    equivalence: dict
    variants: tuple[dict, ...]
    more: dict = field(default_factory=dict)

    @classmethod
    def from_json(cls, v: dict) -> "Verdict":
        v = copy.deepcopy(v)
        known = {k: v.pop(k, None) for k in _VERDICT_FIELDS}
        return cls(**{**known, "variants": tuple(known["variants"] or ())}, more=v)

    def to_json(self) -> dict:
        out = {k: copy.deepcopy(getattr(self, k)) for k in _VERDICT_FIELDS}
        out["variants"] = list(out["variants"])
        return {**out, **copy.deepcopy(self.more)}


@dataclass(frozen=True)
class SpeedStage:
    """score.json's ``speed``: the speed stage's maps scored, their cost at matched accuracy
    (:mod:`rockbench.benchmark.scoring.speed_runs`); ``record`` is that object."""

    record: dict

    def to_json(self) -> dict:
        return copy.deepcopy(self.record)


#: Top-level fields of score.json that :class:`Scores` names.
_TOP = ("kind", "schema_version", "metrics_version", "rules_version", "created_utc", "metrics", "pairs", "skipped",
        "reference_gaps", "experiments", "verdict", "speed", "pairing", "gate")


@dataclass(frozen=True)
class Scores:
    """A run's scores: every engine variant's pairs by scenario (``variants``), the verdict, the speed stage,
    and what they rest on (the metrics' definitions and version, the pairs skipped for their grids, the
    η_H–η_M reference gaps, how maps were paired, the experiments' scores and ``rockbench score``'s gate
    where there are some)."""

    metrics_version: str
    rules_version: str | None
    created_utc: str
    metrics: tuple[dict, ...]
    variants: tuple[VariantScores, ...]
    skipped: tuple[dict, ...]
    reference_gaps: tuple[dict, ...]
    verdict: Verdict
    experiments: tuple[dict, ...] | None = None
    speed: SpeedStage | None = None
    pairing: dict | None = None
    gate: dict | None = None
    schema_version: int = SCORE_SCHEMA_VERSION
    more: dict = field(default_factory=dict)

    @property
    def pairs(self) -> list[dict]:
        """Every scored pair's object, sorted by key (score.json's ``pairs``); copies."""
        return [p.to_json() for p in self.pair_list()]

    def pair_list(self) -> list[Pair]:
        """Every :class:`Pair`, sorted by key (a stable sort: pairs of one key keep their order)."""
        return sorted((p for v in self.variants for s in v.scenarios for p in s.pairs), key=lambda p: p.key)

    @classmethod
    def from_json(cls, doc: dict) -> "Scores":
        """The scores a score.json document holds (as :meth:`to_json` writes it)."""
        d = copy.deepcopy(doc)
        exp, speed = d.get("experiments"), d.get("speed")
        return cls(metrics_version=d.get("metrics_version"), rules_version=d.get("rules_version"),
                   created_utc=d.get("created_utc"), metrics=tuple(d.get("metrics") or ()),
                   variants=nest([Pair.from_json(p) for p in d.get("pairs") or ()]),
                   skipped=tuple(d.get("skipped") or ()), reference_gaps=tuple(d.get("reference_gaps") or ()),
                   verdict=Verdict.from_json(d["verdict"]), experiments=None if exp is None else tuple(exp),
                   speed=None if speed is None else SpeedStage(speed), pairing=d.get("pairing"), gate=d.get("gate"),
                   schema_version=d.get("schema_version"), more={k: v for k, v in d.items() if k not in _TOP})

    def to_json(self) -> dict:
        """score.json's document: its fields in their order, optional ones only where present."""
        out = {"kind": SCORE_KIND, "schema_version": self.schema_version, "metrics_version": self.metrics_version}
        if self.rules_version is not None:
            out["rules_version"] = self.rules_version
        out.update(created_utc=self.created_utc, metrics=copy.deepcopy(list(self.metrics)), pairs=self.pairs,
                   skipped=copy.deepcopy(list(self.skipped)), reference_gaps=copy.deepcopy(list(self.reference_gaps)))
        if self.experiments is not None:
            out["experiments"] = copy.deepcopy(list(self.experiments))
        out["verdict"] = self.verdict.to_json()
        for name in ("speed", "pairing", "gate"):
            part = getattr(self, name)
            if part is not None:
                out[name] = part.to_json() if isinstance(part, SpeedStage) else copy.deepcopy(part)
        return {**out, **copy.deepcopy(self.more)}
