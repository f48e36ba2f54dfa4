"""The report's opening [summary]: quality against cost, a compact table and a reading of the numbers.

Read only from ``summary.json`` and ``timing.json``:

* a figure per quality measure of `QUALITY` (GOSPA; hit rate when some
  tracker defines it: the PHD trackers have none) against the time per scan
  (ms, log scale): one point per tracker with its t-interval over runs on
  both axes, the Pareto front (`pareto_front`: no other tracker is at least
  as good on both axes and better on one) drawn as a dashed line through
  filled markers, dominated trackers hollow; a panel over all scenarios,
  then one per scenario. Over all scenarios a tracker's point is the mean
  over scenarios of its per-scenario means, and its interval the mean of
  the per-scenario bounds (not an interval of the overall mean itself: a
  guide to the spread only); a tracker missing a value in some scenario has
  no overall point. `headline_points` gives the plotted numbers;
* a table of the trackers against the headline measures of
  `nnda.reports.study_summary.HEADLINES` over all scenarios (the same mean of
  means), the best of each column in bold, with the number of scenarios in
  which the tracker has the best mean (ties count for none);
* two or three sentences computed from those numbers;

then `nnda.reports.study_summary`'s tally, its table of the best tracker
per scenario and headline measure, and its table by association family. A tracker that did not run on a scenario
has no point there and none over all scenarios.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D
from matplotlib.ticker import FuncFormatter, LogFormatter

from nnda.reports.study_figures import _colours, _png
from nnda.reports.study_summary import HEADLINES, family_table, stat, tally, verdict_table, verdicts
from nnda.reports.text_table import DASH, TextTable
from nnda.study.measures import TIME, Measure, measure

#: the quality measures drawn against the time per scan (registry keys)
QUALITY: tuple[Measure, ...] = tuple(measure(k) for k in ("gospa", "hit_rate"))
#: the panel over all scenarios
OVERALL = "all scenarios"


def pareto_front(points, senses) -> np.ndarray:
    """Boolean mask of the non-dominated rows of ``points`` (n, d). ``senses[j]`` is +1 when higher is
    better on axis j, -1 when lower is. A row is dominated when another row is at least as good on every
    axis and better on one; equal rows (duplicates) do not dominate each other, so both stay on the front.
    Rows holding NaN are never on the front and dominate nothing."""
    senses = np.asarray(senses, dtype=float)
    p = np.asarray(points, dtype=float).reshape(len(points), senses.size) * senses
    ok = ~np.isnan(p).any(axis=1)
    mask = np.zeros(len(p), dtype=bool)
    for i in np.flatnonzero(ok):
        others = p[ok]
        dominated = np.any(np.all(others >= p[i], axis=1) & np.any(others > p[i], axis=1))
        mask[i] = not dominated
    return mask


@dataclass(frozen=True)
class Point:
    """One tracker in one panel: time per scan (ms) and the quality measure, each mean and interval (the
    bounds None when undefined: one run)."""

    tracker: str
    time_ms: float
    time_low: float | None
    time_high: float | None
    value: float
    low: float | None
    high: float | None


def _mean(values: list[float | None]) -> float | None:
    return None if not values or any(v is None for v in values) else float(np.mean(values))


def _scaled(v: float | None, scale: float) -> float | None:
    return None if v is None else v * scale


def _ran(tracker: str, scenario: dict, timing: dict) -> bool:
    """True when the tracker ran on the scenario (``summary.json`` and ``timing.json`` both hold it)."""
    return tracker in scenario["trackers"] and tracker in timing["trackers"]


def overall(summary: dict, timing: dict, key: str) -> dict[str, dict]:
    """Per tracker, the mean over scenarios of its per-scenario mean of ``key`` and the means of the
    per-scenario interval bounds (None where some scenario lacks one); trackers lacking a mean in some
    scenario are left out."""
    timing_by = {s["name"]: s for s in timing["scenarios"]}
    out = {}
    for t in (t["label"] for t in summary["trackers"]):
        stats = [stat(sc, timing_by[sc["name"]], t, key) or {} if _ran(t, sc, timing_by[sc["name"]]) else {}
                 for sc in summary["scenarios"]]
        mean = _mean([s.get("mean") for s in stats])
        if mean is not None:
            out[t] = {"mean": mean, "ci_low": _mean([s.get("ci_low") for s in stats]),
                      "ci_high": _mean([s.get("ci_high") for s in stats]), "n": len(stats)}
    return out


def headline_points(summary: dict, timing: dict, key: str) -> dict[str, list[Point]]:
    """The points of the quality-against-cost figure of measure ``key``: panel title (`OVERALL`, then each
    scenario's name) -> one `Point` per tracker defining both numbers there, in the study's order."""
    m = measure(key)
    panels = {OVERALL: (overall(summary, timing, TIME.key), overall(summary, timing, key))}
    timing_by = {s["name"]: s for s in timing["scenarios"]}
    for sc in summary["scenarios"]:
        tsc = timing_by[sc["name"]]
        ran = [t for t in sc["trackers"] if _ran(t, sc, tsc)]
        panels[sc["name"]] = ({t: stat(sc, tsc, t, TIME.key) for t in ran}, {t: stat(sc, tsc, t, key) for t in ran})
    out = {}
    for title, (times, values) in panels.items():
        points = []
        for t in (t["label"] for t in summary["trackers"]):
            x, y = times.get(t) or {}, values.get(t) or {}
            if x.get("mean") is None or y.get("mean") is None or x["mean"] <= 0:
                continue
            points.append(Point(t, x["mean"] * TIME.scale, _scaled(x.get("ci_low"), TIME.scale),
                                _scaled(x.get("ci_high"), TIME.scale), y["mean"] * m.scale,
                                _scaled(y.get("ci_low"), m.scale), _scaled(y.get("ci_high"), m.scale)))
        out[title] = points
    return out


def front(points: list[Point], m: Measure) -> np.ndarray:
    """`pareto_front` of the points: lower time better, ``m``'s own sense on the other axis."""
    return pareto_front([(p.time_ms, p.value) for p in points], (TIME.sense, m.sense))


def _err(mean: float, low: float | None, high: float | None) -> list[list[float]]:
    if low is None or high is None:
        return [[0.0], [0.0]]
    return [[max(mean - low, 0.0)], [max(high - mean, 0.0)]]


def quality_cost(panels: dict[str, list[Point]], key: str, trackers: list[str]) -> bytes:
    """PNG of measure ``key`` against the time per scan, one panel per entry of ``panels`` (`headline_points`)."""
    m = measure(key)
    colours = _colours(trackers)
    n = len(panels)
    cols = min(n, 4)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.1 * cols + 1.8, 2.7 * rows + 0.4), squeeze=False,
                             constrained_layout=True)
    better = "lower" if m.sense < 0 else "higher"
    for ax, (title, points) in zip(axes.ravel(), panels.items()):
        on = front(points, m)
        # a log axis has no 0: an interval reaching 0 ms runs to the panel's left edge
        positive = [v for p in points for v in (p.time_ms, p.time_low) if v is not None and v > 0]
        edge = 0.5 * min(positive) if positive else None
        for p, f in zip(points, on):
            c = colours[p.tracker]
            low = p.time_low if p.time_low is None or p.time_low > 0 else edge
            ax.errorbar(p.time_ms, p.value, xerr=_err(p.time_ms, low, p.time_high),
                        yerr=_err(p.value, p.low, p.high), fmt="o", ms=7, color=c, mfc=c if f else "white",
                        mec=c, mew=1.5, elinewidth=1, capsize=2, zorder=3)
        best = sorted((p for p, f in zip(points, on) if f), key=lambda p: (p.time_ms, -m.sense * p.value))
        if len(best) > 1:
            ax.plot([p.time_ms for p in best], [p.value for p in best], ls="--", color="0.35", lw=1, zorder=2,
                    drawstyle="steps-post")  # the front's attainment line: a step down (up) at each front point
        ax.set_xscale("log")
        if edge is not None:
            ax.set_xlim(left=edge)
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(LogFormatter(minor_thresholds=(1.2, 0.5)))
        ax.set_title(title, fontweight="bold" if title == OVERALL else "normal", fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.tick_params(labelsize=8, which="both")
    for ax in axes.ravel()[n:]:
        ax.set_axis_off()
    for ax in axes[-1]:
        ax.set_xlabel(f"{TIME.label.lower()} ({TIME.unit}, log)", fontsize=9)
    for ax in axes[:, 0]:
        ax.set_ylabel(f"{m.label} ({m.unit}), {better} is better" if m.unit else m.label, fontsize=9)
    drawn = {p.tracker for points in panels.values() for p in points}
    handles = [Line2D([], [], marker="o", ls="", color=colours[t], label=t if t in drawn else f"{t} (undefined)")
               for t in trackers]
    handles += [Line2D([], [], marker="o", ls="--", color="0.35", label="Pareto front"),
                Line2D([], [], marker="o", ls="", color="0.35", mfc="white", label="dominated")]
    fig.legend(handles=handles, loc="outside right upper", fontsize=8, frameon=False)
    return _png(fig)


def _bold(text: str) -> str:
    return f"**{text}**"


def compact_table(summary: dict, timing: dict) -> TextTable:
    """Trackers x `HEADLINES` over all scenarios: mean of the per-scenario means, best of each column in
    bold, and in brackets the number of scenarios in which the tracker has the best mean."""
    trackers = [t["label"] for t in summary["trackers"]]
    wins = Counter((v.best, v.headline.key) for v in verdicts(summary, timing) if v.best is not None)
    columns = []
    for h in HEADLINES:
        means = {t: s["mean"] for t, s in overall(summary, timing, h.key).items()}
        top = max((h.sense * v for v in means.values()), default=None)
        cells = []
        for t in trackers:
            if t not in means:
                cells.append(DASH)
                continue
            text = h.fmt.format(means[t] * h.scale)
            text = _bold(text) if h.sense and len(means) > 1 and h.sense * means[t] == top else text
            cells.append(f"{text} ({wins[t, h.key]})")
        columns.append(cells)
    rows = tuple((t, *(col[i] for col in columns)) for i, t in enumerate(trackers))
    n = len(summary["scenarios"])
    note = (f"Mean over the {n} scenario(s) of each tracker's mean over runs ({DASH}: undefined in some "
            f"scenario); bold: the best of the column. In brackets: in how many of the {n} scenario(s) the "
            f"tracker has the best mean of that measure (ties count for none).")
    return TextTable("Over all scenarios", ("Tracker", *(h.title for h in HEADLINES)), rows, note)


def _ratio_text(a: str, times: dict[str, dict]) -> str:
    """``a``'s time per scan against the fastest tracker's, over all scenarios."""
    fastest = min(times, key=lambda t: times[t]["mean"])
    if fastest == a or times[fastest]["mean"] <= 0:
        return "and is also the fastest"
    return f"at {times[a]['mean'] / times[fastest]['mean']:.2g}x the time per scan of {fastest}, the fastest"


def reading(summary: dict, timing: dict) -> str:
    """Two or three sentences from the numbers: who is best on the first quality measure in how many
    scenarios and at what cost, and which trackers are on the Pareto fronts over all scenarios."""
    trackers = [t["label"] for t in summary["trackers"]]
    if len(trackers) < 2:
        return "Only one tracker in this study: nothing to compare."
    n = len(summary["scenarios"])
    vs = verdicts(summary, timing)
    times = overall(summary, timing, TIME.key)
    sentences, named = [], None
    for m in QUALITY:
        mine = [v for v in vs if v.headline.key == m.key and v.best is not None]
        if not mine:
            continue
        counts = {t: sum(v.best == t for v in mine) for t in trackers}
        top = max(trackers, key=lambda t: (counts[t], -trackers.index(t)))
        clear = sum(v.clear for v in mine if v.best == top)
        word = "lowest" if m.sense < 0 else "highest"
        label = m.label if m.label[:2].isupper() else m.label.lower()
        text = (f"**{top}** has the {word} {label} in {counts[top]} of {n} scenario(s) (intervals apart in "
                f"{clear})")
        if top in times and len(times) > 1 and top != named:
            text += " " + _ratio_text(top, times)
        named = top
        sentences.append(text + ".")
    fronts = []
    for m in QUALITY:
        points = headline_points(summary, timing, m.key)[OVERALL]
        if len(points) > 1:
            on = [p.tracker for p, f in zip(points, front(points, m)) if f]
            fronts.append(f"{m.label} against time: {', '.join(on)}")
    if fronts:
        sentences.append("On the Pareto front over all scenarios (no tracker both faster and better), "
                         + "; ".join(fronts) + ".")
    return " ".join(sentences)


def headline_section(section, summary: dict, timing: dict, figure: Callable[..., object]):
    """Fill ``section`` (a `nnda.reports.pages.Section`) with the figures, the compact table and the reading,
    then the best tracker per scenario and measure (`nnda.reports.study_summary.verdict_table`), and return it;
    ``figure(name, caption, draw, args)`` makes a report figure and registers it for drawing."""
    trackers = [t["label"] for t in summary["trackers"]]
    if not trackers:
        section.text("No tracker ran in this study (single-target filters only: see their section).")
        return section
    level = f"{summary['confidence']:.0%}"
    for m in QUALITY:
        panels = headline_points(summary, timing, m.key)
        if not any(panels.values()):
            continue
        lacking = [t for t in trackers if not any(p.tracker == t for ps in panels.values() for p in ps)]
        caption = (f"{m.label} against time per scan, one point per tracker with {level} intervals over runs on "
                   f"both axes; Pareto front dashed, dominated trackers hollow. Over all scenarios: mean of the "
                   f"per-scenario means, interval = mean of the per-scenario bounds; an interval reaching 0 ms "
                   f"runs to the left edge (log axis)")
        if lacking:
            caption += f"; {', '.join(lacking)}: no {m.label.lower()}"
        section.figure(figure(f"quality_cost_{m.key}.png", caption, quality_cost, (panels, m.key, trackers)))
    table = compact_table(summary, timing)
    section.md.append(table.markdown())  # the bold cells: ** in Markdown, <strong> in HTML
    section.html.append(re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", table.html("headline-table")))
    section.text(reading(summary, timing))
    section.text(tally(summary, timing))
    section.table(verdict_table(summary, timing), "best-per-scenario")
    if (families := family_table(summary, timing)) is not None:
        section.table(families, "family-table")
    return section
