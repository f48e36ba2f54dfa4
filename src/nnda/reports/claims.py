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

Every verdict comes with a one-sentence **reason** computed from the
numbers: a claim's own ``reason`` (a function of the study's files, for a
claim whose reading needs more than its interval, such as the reference
work's own figures beside nnda's) or `generic_reason` (which side of the
reference and by how much; how many differences lie on which side).
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


def _mean(stat: Stat, fmt: str, scale: float) -> str:
    return "-" if stat.get("mean") is None else fmt.format(stat["mean"] * scale)


def generic_reason(verdict: str, stats: Sequence[Stat], reference: float | None, sign: int, fmt: str = "{:.2f}",
                   scale: float = 1.0, unit: str = "") -> str:
    """The sentence that says why ``verdict`` follows from ``stats``: for a number, which side of the reference
    nnda's interval lies on and how far its mean is from it; for a comparison, how many differences lie on the
    claimed side, how many on the other and how many hold 0."""
    u = f" {unit}" if unit else ""
    if verdict == NOT_MEASURED or not stats:
        return "nnda has no interval here (a single run, or the entry is missing)."
    if reference is not None:
        s = stats[0]
        ref = fmt.format(reference * scale)
        low, high = fmt.format(s["ci_low"] * scale), fmt.format(s["ci_high"] * scale)
        if verdict == AGREES:
            return f"the reference's {ref}{u} lies inside nnda's interval [{low}, {high}]."
        gap = (s["mean"] - reference) * scale
        side = "above" if verdict == HIGHER else "below"
        return (f"nnda's mean is {fmt.format(abs(gap))}{u} {side} the reference's {ref}{u}, and its whole interval "
                f"[{low}, {high}] lies {side} it.")
    side = [1 if s["ci_low"] > 0 else -1 if s["ci_high"] < 0 else 0 for s in stats]
    claimed, other, zero = side.count(sign), side.count(-sign), side.count(0)
    want = "above 0" if sign > 0 else "below 0"
    means = ", ".join(_mean(s, fmt.replace("{:", "{:+") if "+" not in fmt else fmt, scale) for s in stats)
    return (f"{claimed} of {len(stats)} differences lie wholly {want} as claimed, {other} wholly on the other side, "
            f"{zero} hold 0 (means {means}{u}).")


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
    reason: Callable[[StudyFiles], str] | None = None

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

    def reason_text(self, study: StudyFiles) -> str:
        """One sentence: why the verdict is what it is, from the measured values (the claim's own ``reason``,
        or `generic_reason`)."""
        if self.reason is not None:
            return self.reason(study)
        return generic_reason(self.verdict(study), self.stats(study), self.reference, self.sign, self.fmt,
                              self.scale, self.unit)

    def reference_cell(self) -> str:
        if self.reference is None:
            return "higher" if self.sign > 0 else "lower"
        return f"{self.fmt.format(self.reference * self.scale)}{(' ' + self.unit) if self.unit else ''}"

    def nnda_cell(self, study: StudyFiles) -> str:
        return "; ".join(stat_cell(s, self.fmt, self.scale) if s.get("mean") is not None else DASH
                         for s in self.stats(study))
