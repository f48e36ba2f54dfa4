"""A reference work's claim, nnda's number with its interval, and the verdict the interval gives.

    claim = Claim("Vargas Avila (2015)", "radar", "IMM/TOMHT hit rate in S1", hit_rate("S1", "mht"),
                  reference=99.63, unit="%")
    claim.verdict(study_files)       # "agrees": 99.63 lies inside nnda's 95% interval

Two kinds of claim:

* a **number** (``reference`` given): the verdict is *agrees* when the
  reference's number lies inside nnda's interval, *nnda higher* or *nnda
  lower* when the whole interval lies on one side of it;
* a **comparison** (``sign`` +1 or -1, no reference number): nnda's
  quantities are differences (one or several: "A beats B in x and in y");
  the verdict is *holds* when every interval lies on the claimed side of
  0, *reversed* when one lies wholly on the other side, *not shown* when an
  interval holds 0.

Either is *not measured* when nnda's interval is undefined (too few runs).
A statistic is a mapping with ``mean``, ``ci_low`` and ``ci_high``
(`nnda.study.stats.mean_ci`'s result and the like).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from nnda.reports.pages import StudyFiles
from nnda.reports.text_table import DASH, stat_cell

Stat = Mapping[str, float | None]

AGREES, HIGHER, LOWER = "agrees", "nnda higher", "nnda lower"
HOLDS, REVERSED, NOT_SHOWN, NOT_MEASURED = "holds", "reversed", "not shown", "not measured"


def _defined(stat: Stat) -> bool:
    return stat.get("ci_low") is not None and stat.get("ci_high") is not None


def number_verdict(reference: float, stat: Stat) -> str:
    """Where the reference's number lies against nnda's interval."""
    if not _defined(stat):
        return NOT_MEASURED
    if stat["ci_low"] > reference:
        return HIGHER
    if stat["ci_high"] < reference:
        return LOWER
    return AGREES


def sign_verdict(stats: Sequence[Stat], sign: int) -> str:
    """A comparison read from the intervals of its differences (module docstring)."""
    if not stats or not all(_defined(s) for s in stats):
        return NOT_MEASURED
    side = [1 if s["ci_low"] > 0 else -1 if s["ci_high"] < 0 else 0 for s in stats]
    if all(x == sign for x in side):
        return HOLDS
    if any(x == -sign for x in side):
        return REVERSED
    return NOT_SHOWN


def difference(a: Stat, b: Stat) -> Stat:
    """a - b from two independent summaries: the means' difference and the widest interval their intervals
    allow (conservative: it excludes 0 only when the two intervals do not overlap)."""
    if not (_defined(a) and _defined(b)) or a.get("mean") is None or b.get("mean") is None:
        return {"mean": None, "ci_low": None, "ci_high": None}
    return {"mean": a["mean"] - b["mean"], "ci_low": a["ci_low"] - b["ci_high"], "ci_high": a["ci_high"] - b["ci_low"]}


@dataclass(frozen=True)
class Claim:
    """A claim of ``work`` that study ``study`` (a directory of the reproduction) checks: ``measured`` gives
    nnda's statistic (a number claim) or statistics (a comparison: differences claimed to have ``sign``)."""

    work: str
    study: str
    text: str
    measured: Callable[[StudyFiles], Stat | Sequence[Stat]]
    reference: float | None = None
    sign: int = 0
    unit: str = ""
    fmt: str = "{:.2f}"
    scale: float = 1.0

    def __post_init__(self) -> None:
        if (self.reference is None) == (self.sign == 0):
            raise ValueError(f"{self.text}: give a reference number or a sign, not both and not neither")

    def stats(self, study: StudyFiles) -> list[Stat]:
        got = self.measured(study)
        return [got] if isinstance(got, Mapping) else list(got)

    def verdict(self, study: StudyFiles) -> str:
        stats = self.stats(study)
        if self.reference is not None:
            return number_verdict(self.reference, stats[0])
        return sign_verdict(stats, self.sign)

    def reference_cell(self) -> str:
        if self.reference is None:
            return "higher" if self.sign > 0 else "lower"
        return f"{self.fmt.format(self.reference * self.scale)}{(' ' + self.unit) if self.unit else ''}"

    def nnda_cell(self, study: StudyFiles) -> str:
        return "; ".join(stat_cell(s, self.fmt, self.scale) if s.get("mean") is not None else DASH
                         for s in self.stats(study))
