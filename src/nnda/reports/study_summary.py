"""The automatically written summary of a study: who wins where, with the intervals.

For each scenario and headline measure the tracker with the best mean is
named with its confidence interval and the runner-up's. A win is *clear*
when the two intervals do not overlap; otherwise the text says the two are
not separable at the study's confidence level (with a single run there is
no interval and no win is called clear). Time per scan is compared as
ratios, and against the thesis's ratio when the study holds both an ``nn``
and an ``mht`` tracker on the thesis's scenarios. The report gives all of
it as one table (`verdict_table`, a row per scenario) with the `tally`
above, below its headline (`nnda.reports.headline`). When the study holds
trackers of two association families or more (`nnda.tracking.registry.FAMILIES`),
`family_table` answers "which family, where, at what cost" from the same
verdicts.
"""

from __future__ import annotations

from dataclasses import dataclass

from nnda.reports.published_tracking import PUBLISHED_TRACKING
from nnda.reports.text_table import DASH, TextTable, stat_cell
from nnda.study.measures import TIME, Measure, measure
from nnda.tracking.registry import FAMILIES

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
    text: str  # the cell of `verdict_table`


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
                out.append(Verdict(sc["name"], h, None, None, False, f"all equal ({_fmt(h, stats[best])})"))
                continue
            if len(tied) > 1:
                text = f"tie: {', '.join(tied)} ({_fmt(h, stats[best])})"
                out.append(Verdict(sc["name"], h, None, None, False, text))
                continue
            clear = apart(stats[best], stats[second])
            relation = "clear of" if clear else f"not separable at {level} from"
            text = (f"{best} {_fmt(h, stats[best])}, {relation} {second} "
                    f"({h.fmt.format(stats[second]['mean'] * h.scale)})")
            out.append(Verdict(sc["name"], h, best, second, clear, text))
    return out


def _time_ratios(summary: dict, timing: dict) -> list[tuple[str, str]]:
    """(scenario, text) per scenario, neural tracker and MHT tracker: the first's time per scan over the second's,
    beside the thesis's proposed / classical ratio on its own scenarios."""
    kinds = {t["label"]: t["kind"] for t in summary["trackers"]}
    nn = [t for t, k in kinds.items() if k == "nn"]
    mht = [t for t, k in kinds.items() if k == "mht"]
    lines = []
    for tsc in timing["scenarios"]:
        spec = PUBLISHED_TRACKING.get(tsc["name"])
        for a in nn:
            for b in mht:
                ta, tb = tsc["trackers"][a][TIME.key]["mean"], tsc["trackers"][b][TIME.key]["mean"]
                if ta is None or not tb:
                    continue
                line = f"{a} / {b} = {ta / tb:.3f}"
                if spec:
                    ratio = spec["proposed"][TIME.key] / spec["classical"][TIME.key]
                    line += f" (thesis: {ratio:.3f})"
                lines.append((tsc["name"], line))
    return lines


def tally(summary: dict, timing: dict) -> str:
    """One sentence: per tracker, the number of best means (and clear wins) over scenarios and headline measures."""
    vs = verdicts(summary, timing)
    trackers = [t["label"] for t in summary["trackers"]]
    clear = {t: sum(v.clear and v.best == t for v in vs) for t in trackers}
    best = {t: sum(v.best == t for v in vs) for t in trackers}
    level = f"{summary['confidence']:.0%}"
    return (f"Across {len(summary['scenarios'])} scenario(s) and {len(HEADLINES)} headline measures "
            f"({', '.join(h.label for h in HEADLINES)}), best means, ties left out (clear wins: "
            f"{level} intervals apart): "
            + ", ".join(f"{t} {best[t]} ({clear[t]})" for t in sorted(trackers, key=lambda t: (-clear[t], -best[t], t)))
            + ".")


def verdict_table(summary: dict, timing: dict) -> TextTable:
    """Scenario x headline measure: the best tracker, its mean [interval], and whether it is clear of the
    runner-up; a last column of the neural over MHT time-per-scan ratios (`_time_ratios`) when there are any."""
    vs = {(v.scenario, v.headline.key): v for v in verdicts(summary, timing)}
    ratios = _time_ratios(summary, timing)
    header = ("Scenario", *(h.title for h in HEADLINES)) + (("Time per scan, neural / MHT",) if ratios else ())
    rows = []
    for sc in summary["scenarios"]:
        row = [sc["name"], *(vs[sc["name"], h.key].text if (sc["name"], h.key) in vs else DASH for h in HEADLINES)]
        if ratios:
            row.append("; ".join(r for name, r in ratios if name == sc["name"]) or DASH)
        rows.append(tuple(row))
    level = f"{summary['confidence']:.0%}"
    note = (f"Per scenario and measure the tracker with the best mean over runs [{level} t-interval]; clear: its "
            f"interval and the runner-up's (its mean in brackets) do not overlap; not separable: they do (with one "
            f"run there is no interval and no win is clear).")
    if ratios:
        note += (" Time ratios: each neural tracker's mean time per scan over each MHT tracker's (the thesis reports "
                 "under 0.1).")
    return TextTable("Best per scenario", header, tuple(rows), note)


#: the measures of `family_table`'s "where it wins" columns
FAMILY_MEASURES: tuple[Measure, ...] = tuple(measure(k) for k in ("gospa", "hit_rate", "false_tracks", "lost_targets"))


def family_of(kind: str) -> str:
    """The association family of a tracker kind (`FAMILIES`; a kind not listed is its own family)."""
    return FAMILIES.get(kind, kind)


def _wins(names: list[str]) -> str:
    return f"{len(names)}: {', '.join(names)}" if names else "0"


def family_table(summary: dict, timing: dict) -> TextTable | None:
    """Association family x (its trackers, the scenarios where one of them has the best mean of each measure
    of `FAMILY_MEASURES`, its members' time per scan): None when the study holds one family only."""
    kinds = {t["label"]: t["kind"] for t in summary["trackers"]}
    families: dict[str, list[str]] = {}
    for label, kind in kinds.items():
        families.setdefault(family_of(kind), []).append(label)
    if len(families) < 2:
        return None
    vs = verdicts(summary, timing)
    timing_by = {s["name"]: s for s in timing["scenarios"]}
    rows = []
    for family, members in families.items():
        row = [family, ", ".join(members)]
        for m in FAMILY_MEASURES:
            row.append(_wins([v.scenario for v in vs if v.headline.key == m.key and v.best in members]))
        times = [stat(sc, timing_by[sc["name"]], t, TIME.key) for sc in summary["scenarios"] for t in members
                 if t in sc["trackers"] and t in timing_by[sc["name"]]["trackers"]]
        means = [s["mean"] * TIME.scale for s in times if s and s.get("mean") is not None]
        row.append(f"{TIME.fmt.format(min(means))}-{TIME.fmt.format(max(means))}" if means else DASH)
        rows.append(tuple(row))
    n = len(summary["scenarios"])
    header = ("Family", "Trackers", *(f"Best {m.label.lower() if not m.label[:2].isupper() else m.label} in"
                                      for m in FAMILY_MEASURES), f"Time per scan ({TIME.unit})")
    note = (f"Which family of association methods wins where, and what it costs: per family, the scenarios (of "
            f"{n}) in which one of its trackers has the best mean of the measure (ties count for none; whether "
            f"the win is clear is in the table above), and the lowest and highest mean time per scan of its "
            f"trackers over the scenarios.")
    return TextTable("Which family, where", header, tuple(rows), note)
