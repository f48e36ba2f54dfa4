"""The automatically written summary of a study: who wins where, with the intervals.

For each scenario and headline measure the tracker with the best mean is
named with its confidence interval and the runner-up's. A win is *clear*
when the two intervals do not overlap; otherwise the text says the two are
not separable at the study's confidence level (with a single run there is
no interval and no win is called clear). Time per scan is compared as
ratios, and against the thesis's ratio when the study holds both an ``nn``
and an ``mht`` tracker on the thesis's scenarios.
"""

from __future__ import annotations

from dataclasses import dataclass

from nnda.reports.spec_values import SPEC_TRACKING
from nnda.reports.text_table import stat_cell
from nnda.study.measures import TIME, Measure, measure

#: the measures the summary ranks (keys of `nnda.study.measures`; each has a better direction)
HEADLINES: tuple[Measure, ...] = tuple(measure(k) for k in (
    "hit_rate", "false_tracks", "lost_targets", "gospa", "position_rmse_m", "mota", TIME.key))


def stat(scenario: dict, timing: dict, tracker: str, key: str) -> dict | None:
    """A tracker's mean/interval record of ``key`` in one scenario (time per scan from ``timing``)."""
    if key == TIME.key:
        return timing["trackers"][tracker][TIME.key]
    return scenario["trackers"][tracker]["metrics"].get(key)


def _fmt(m: Measure, stat: dict) -> str:
    return stat_cell(stat, m.fmt, m.scale) + (f" {m.unit}" if m.unit else "")


def apart(a: dict, b: dict) -> bool:
    """True when the two intervals exist and do not overlap."""
    if a.get("ci_low") is None or b.get("ci_low") is None:
        return False
    return a["ci_high"] < b["ci_low"] or b["ci_high"] < a["ci_low"]


@dataclass(frozen=True)
class Verdict:
    """The outcome of one measure in one scenario."""

    scenario: str
    headline: Measure
    best: str | None  # None: a tie for best
    second: str | None
    clear: bool
    text: str


def verdicts(summary: dict, timing: dict) -> list[Verdict]:
    """One verdict per scenario and headline measure that at least two trackers define."""
    out = []
    timing_by_name = {s["name"]: s for s in timing["scenarios"]}
    level = f"{summary['confidence']:.0%}"
    for sc in summary["scenarios"]:
        tsc = timing_by_name[sc["name"]]
        for h in HEADLINES:
            stats = {t: s for t in sc["trackers"] if (s := stat(sc, tsc, t, h.key)) and s["mean"] is not None}
            if len(stats) < 2:
                continue
            ranked = sorted(stats, key=lambda t: -h.sense * stats[t]["mean"])
            best, second = ranked[0], ranked[1]
            tied = [t for t in ranked if stats[t]["mean"] == stats[best]["mean"]]
            if len(tied) == len(ranked):
                text = f"{h.label}: all trackers equal ({_fmt(h, stats[best])})"
                out.append(Verdict(sc["name"], h, None, None, False, text))
                continue
            if len(tied) > 1:
                text = f"{h.label}: {', '.join(f'**{t}**' for t in tied)} tie for best at {_fmt(h, stats[best])}"
                out.append(Verdict(sc["name"], h, None, None, False, text))
                continue
            clear = apart(stats[best], stats[second])
            relation = "clearly ahead of" if clear else f"not separable at {level} from"
            text = (f"{h.label}: **{best}** {_fmt(h, stats[best])}, {relation} {second} "
                    f"{_fmt(h, stats[second])}")
            out.append(Verdict(sc["name"], h, best, second, clear, text))
    return out


def _time_ratios(summary: dict, timing: dict) -> list[str]:
    """Per thesis scenario, each neural tracker's time per scan over each MHT tracker's, beside the thesis's."""
    kinds = {t["label"]: t["kind"] for t in summary["trackers"]}
    nn = [t for t, k in kinds.items() if k == "nn"]
    mht = [t for t, k in kinds.items() if k == "mht"]
    lines = []
    for tsc in timing["scenarios"]:
        spec = SPEC_TRACKING.get(tsc["name"])
        for a in nn:
            for b in mht:
                ta, tb = tsc["trackers"][a][TIME.key]["mean"], tsc["trackers"][b][TIME.key]["mean"]
                if ta is None or not tb:
                    continue
                line = f"{tsc['name']}: {a} / {b} time per scan = {ta / tb:.3f}"
                if spec:
                    ratio = spec["proposed"][TIME.key] / spec["classical"][TIME.key]
                    line += f" (thesis, proposed / classical: {ratio:.3f})"
                lines.append(line)
    return lines


def summary_markdown(summary: dict, timing: dict) -> str:
    """The summary as Markdown: an overall tally, then the verdicts per scenario."""
    vs = verdicts(summary, timing)
    trackers = [t["label"] for t in summary["trackers"]]
    clear = {t: sum(v.clear and v.best == t for v in vs) for t in trackers}
    best = {t: sum(v.best == t for v in vs) for t in trackers}
    level = f"{summary['confidence']:.0%}"
    lines = [f"Across {len(summary['scenarios'])} scenario(s) and {len(HEADLINES)} headline measures "
             f"({', '.join(h.label for h in HEADLINES)}), best means, ties left out (clear wins: "
             f"{level} intervals apart): "
             + ", ".join(f"{t} {best[t]} ({clear[t]})"
                         for t in sorted(trackers, key=lambda t: (-clear[t], -best[t], t)))
             + ".", ""]
    ratios = _time_ratios(summary, timing)
    if ratios:
        lines += ["Time per scan, neural over MHT (the thesis reports under 0.1):", ""]
        lines += [f"* {r}" for r in ratios] + [""]
    for sc in summary["scenarios"]:
        mine = [v for v in vs if v.scenario == sc["name"]]
        if not mine:
            continue
        lines += [f"**{sc['name']}**", ""] + [f"* {v.text}" for v in mine] + [""]
    if len(trackers) < 2:
        lines.append("Only one tracker in this study: nothing to compare.")
    return "\n".join(lines).rstrip() + "\n"
