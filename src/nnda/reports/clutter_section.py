"""The report's "Against clutter density" section: quality and cost as the clutter grows.

Present when the study holds a *sweep*: scenarios equal in everything but
their sensors' clutter count (and their names), at two or more counts, such
as `studies/clutter-sweep.toml`'s S1-S6 at 10, 100, 1,000 and 5,000 points
per scan. Per measure (GOSPA, false tracks, lost targets, time per scan) a
figure against clutter points per scan (log axes where the values allow),
one line per tracker: at each count the mean over the swept scenes of the
per-scene means, the bars the mean of the per-scene 95% bounds (the same
rule as the summary's over-all point), so every scene weighs the same. Then
a table of those numbers and one sentence per measure naming the best
tracker at the densest setting. Last, each tracker's measured time to
confirm beside the clairvoyant bound of its rule (`delay_bounds`: the least
mean delay of Wald's test fed only the targets' contacts,
`nnda.tracking.confirmation_bound`), from the scenarios' noise-free plans.
Reads ``study.json`` (the scenarios), ``summary.json`` and ``timing.json``.
"""

from __future__ import annotations

import json
from collections.abc import Callable

import matplotlib.pyplot as plt
import numpy as np

from nnda.data.checks import clutter_inside_fraction
from nnda.data.generator import Plan
from nnda.data.scenario import Scenario
from nnda.data.sensor import in_coverage
from nnda.reports.study_figures import _colours, _png
from nnda.reports.study_summary import stat
from nnda.reports.text_table import DASH, TextTable, interval
from nnda.study.measures import TIME, measure
from nnda.tracking.clutter_density import coverage_area
from nnda.tracking.confirmation_bound import clairvoyant_delay_s
from nnda.tracking.lifecycle import LifecycleConfig
from nnda.tracking.tracker import CLUTTER_RADIUS_M, SCORE_PD

#: the measures drawn against clutter density (registry keys), in panel order
MEASURES = tuple(measure(k) for k in ("gospa", "false_tracks", "lost_targets", TIME.key))


def clutter_count(scenario: dict) -> int:
    """Clutter points per sweep of a scenario dump (its sensors' counts must agree; 0 for law "none")."""
    counts = {0 if s.get("clutter", {}).get("law") == "none" else int(s.get("clutter", {}).get("count", 100))
              for s in scenario.get("sensors", [])}
    return counts.pop() if len(counts) == 1 else -1


def _without_clutter_count(scenario: dict) -> str:
    """The scenario dump with its name, description and clutter counts left out, as canonical JSON."""
    rest = {k: v for k, v in scenario.items() if k not in ("name", "description", "seed")}
    rest["sensors"] = [{**s, "clutter": {k: v for k, v in s.get("clutter", {}).items() if k != "count"}}
                       for s in scenario.get("sensors", [])]
    return json.dumps(rest, sort_keys=True)


def sweeps(manifest: dict) -> dict[str, dict[int, str]]:
    """The study's sweeps: for each group of scenarios that differ only in clutter count (at two or more
    counts), its first scenario's name -> {clutter per sweep: scenario name}."""
    groups: dict[str, dict[int, str]] = {}
    first: dict[str, str] = {}
    for sc in manifest["scenarios"]:
        count = clutter_count(sc["scenario"])
        if count < 0:
            continue
        key = _without_clutter_count(sc["scenario"])
        first.setdefault(key, sc["name"])
        groups.setdefault(key, {}).setdefault(count, sc["name"])
    return {first[k]: dict(sorted(g.items())) for k, g in groups.items() if len(g) >= 2}


def _mean(values: list) -> float | None:
    return None if not values or any(v is None for v in values) else float(np.mean(values))


def curves(manifest: dict, summary: dict, timing: dict, key: str) -> dict[str, dict[int, dict]]:
    """Per tracker, per clutter count: mean over the sweeps' scenes of the per-scene mean of ``key`` and the
    means of its interval bounds (None where a scene lacks one); counts some scene lacks are left out."""
    found = sweeps(manifest)
    counts = sorted({c for g in found.values() for c in g})
    by_name = {s["name"]: s for s in summary["scenarios"]}
    timing_by = {s["name"]: s for s in timing["scenarios"]}
    out: dict[str, dict[int, dict]] = {}
    for t in (t["label"] for t in summary["trackers"]):
        line = {}
        for c in counts:
            names = [g[c] for g in found.values() if c in g]
            stats = [stat(by_name[n], timing_by[n], t, key) or {} if t in by_name[n]["trackers"] else {}
                     for n in names]
            mean = _mean([s.get("mean") for s in stats])
            if mean is not None:
                line[c] = {"mean": mean, "ci_low": _mean([s.get("ci_low") for s in stats]),
                           "ci_high": _mean([s.get("ci_high") for s in stats]), "scenes": len(names)}
        if line:
            out[t] = line
    return out


def _bounded_rule(params: dict) -> str | None:
    """The rule of a tracker's params whose clairvoyant bound the section gives: "adaptive", "score" or
    "existence"; None for M/N and for false tracks at a rate (its threshold needs the scans' initiator
    counts)."""
    lifecycle = params.get("lifecycle", {})
    rule = lifecycle.get("confirmation", LifecycleConfig().confirmation)
    bounded = ("adaptive", "score", "existence")
    return rule if rule in bounded and lifecycle.get("false_tracks_per_scan") is None else None


def scene_delay_bound(scenario: dict, params: dict) -> float | None:
    """Mean over a scenario dump's targets of the clairvoyant confirmation delay (s) of a tracker of ``params``
    (`clairvoyant_delay_s`, the target at its first noise-free position inside the coverage, the clutter's
    area density there from its law: uniform over the square's covered part, or the Gaussian's); None for
    other rules, sensors or clutter laws, or a scene without a target in the coverage."""
    rule = _bounded_rule(params)
    sc = Scenario.model_validate(scenario)
    if rule is None or len(sc.sensors) != 1 or sc.sensors[0].kind != "polar" or sc.sensors[0].clutter.law not in (
            "square", "gaussian"):
        return None
    sensor, plan = sc.sensors[0], Plan.of(sc)
    clutter, centre = sensor.clutter, plan.clutter_centre[0]
    inside = in_coverage(sensor, plan.x, plan.y)
    lifecycle = LifecycleConfig.model_validate(params.get("lifecycle", {}))
    delays = []
    for t in np.unique(plan.target_id[inside]):
        i = np.flatnonzero(inside & (plan.target_id == t))[0]
        off = np.array([plan.x[i], plan.y[i]]) - centre
        if clutter.law == "square":
            mass = float(np.all(np.abs(off) <= 0.5 * clutter.side_m)) / clutter.side_m**2
        else:
            mass = np.exp(-0.5 * off @ off / clutter.sigma_m**2) / (2 * np.pi * clutter.sigma_m**2)
        # the local estimate never falls below one contact in its square
        density = max(clutter.count * mass / clutter_inside_fraction(clutter, sensor, centre),
                      1.0 / (2.0 * params.get("clutter_radius_m", CLUTTER_RADIUS_M)) ** 2)
        delays.append(clairvoyant_delay_s(
            rule, lifecycle, density, float(np.hypot(*(np.array([plan.x[i], plan.y[i]]) - sensor.position))),
            sensor.sigma_range_m, sensor.sigma_azimuth_rad, sensor.scan_period_s, params.get("pd", SCORE_PD),
            params.get("gate", 9.21), plan.pd[i], coverage_area(sensor)))
    return float(np.mean(delays)) if delays else None


def delay_bounds(manifest: dict) -> dict[str, dict[int, float]]:
    """Per tracker whose rule has a bound (`scene_delay_bound`), per clutter count of the sweeps: the mean of
    its scenes' bounds (s)."""
    found = sweeps(manifest)
    dumps = {s["name"]: s["scenario"] for s in manifest["scenarios"]}
    out = {}
    for t in manifest["trackers"]:
        if _bounded_rule(t.get("params", {})) is None:
            continue
        by_count = {}
        for c in sorted({c for g in found.values() for c in g}):
            values = [scene_delay_bound(dumps[g[c]], t.get("params", {})) for g in found.values() if c in g]
            if values and all(v is not None for v in values):
                by_count[c] = float(np.mean(values))
        out[t["label"]] = by_count
    return out


def figure(lines: dict[str, dict[str, dict[int, dict]]], trackers: list[str]) -> bytes:
    """One panel per measure (``lines``: measure key -> `curves`), clutter per scan on a log x axis."""
    colours = _colours(trackers)
    fig, axes = plt.subplots(1, len(lines), figsize=(4.2 * len(lines), 3.8), constrained_layout=True, squeeze=False)
    for ax, (key, per_tracker) in zip(axes[0], lines.items()):
        m = measure(key)
        positive = True
        for t in trackers:
            line = per_tracker.get(t)
            if not line:
                continue
            x = np.array(sorted(line), dtype=float)
            y = np.array([line[c]["mean"] for c in sorted(line)]) * m.scale
            lo = np.array([line[c]["ci_low"] if line[c]["ci_low"] is not None else line[c]["mean"]
                           for c in sorted(line)]) * m.scale
            hi = np.array([line[c]["ci_high"] if line[c]["ci_high"] is not None else line[c]["mean"]
                           for c in sorted(line)]) * m.scale
            positive &= bool((y > 0).all())
            ax.errorbar(np.maximum(x, 1.0), y, yerr=[y - lo, hi - y], marker="o", ms=4, capsize=2,
                        color=colours[t], label=t)
        ax.set_xscale("log")
        if positive and key in ("gospa", TIME.key):
            ax.set_yscale("log")
        ax.set_xlabel("clutter points per scan")
        ax.set_title(m.title, fontsize=9)
        ax.grid(alpha=0.3, which="both")
    axes[0][0].legend(fontsize=7)
    return _png(fig)


def clutter_section(section, manifest: dict, summary: dict, timing: dict,
                    made: Callable[..., object]):
    """Fill ``section`` (a `nnda.reports.pages.Section`) when the study holds a sweep; else None.
    ``made(name, caption, draw, args)`` registers a figure and returns it for ``section.figure``."""
    found = sweeps(manifest)
    if not found:
        return None
    trackers = [t["label"] for t in summary["trackers"]]
    lines = {m.key: curves(manifest, summary, timing, m.key) for m in MEASURES}
    scenes = ", ".join(found)
    counts = sorted({c for g in found.values() for c in g})
    section.text(f"The study sweeps the clutter over {len(found)} scene(s) ({scenes}) at "
                 f"{', '.join(f'{c:,}' for c in counts)} points per scan. Each point is the mean over those scenes "
                 f"of the per-scene means; its bars are the means of the per-scene 95% intervals.")
    section.figure(made("clutter_sweep.png", "Quality and cost against clutter points per scan, mean over the "
                        f"swept scenes ({scenes}).", figure, (lines, trackers)))
    rows = []
    for t in trackers:
        for c in counts:
            cells = []
            for m in MEASURES:
                s = lines[m.key].get(t, {}).get(c)
                cells.append(DASH if s is None else interval(s["mean"], s["ci_low"], s["ci_high"], m.fmt, m.scale))
            rows.append((t, f"{c:,}", *cells))
    section.table(TextTable("Against clutter density (mean over the swept scenes)",
                            ("tracker", "clutter per scan", *(m.title for m in MEASURES)), tuple(rows)),
                  "clutter-sweep")
    densest = counts[-1]
    said = []
    for m in MEASURES:
        at = {t: line[densest]["mean"] for t, line in lines[m.key].items() if densest in line}
        if len(at) < 2:
            continue
        best = sorted(at, key=lambda t: -m.sense * at[t])[0]
        tied = [t for t in at if at[t] == at[best]]
        low = {t: line[counts[0]]["mean"] for t, line in lines[m.key].items() if counts[0] in line}
        growth = (f", {at[best] / low[best]:.1f}x its value at {counts[0]:,}"
                  if len(tied) == 1 and low.get(best) else "")
        who = f"**{best}** is" if len(tied) == 1 else ", ".join(f"**{t}**" for t in tied) + " tie for"
        said.append(f"{m.label}: {who} best at {densest:,} clutter per scan "
                    f"({m.fmt.format(at[best] * m.scale)}{(' ' + m.unit) if m.unit else ''}{growth}).")
    if said:
        section.text(" ".join(said))
    _delay_table(section, manifest, summary, timing, trackers, counts)
    return section


def _delay_table(section, manifest: dict, summary: dict, timing: dict, trackers: list[str], counts: list[int]
                 ) -> None:
    """The measured time to confirm beside the clairvoyant bound of each tracker's rule, per clutter count."""
    measured = curves(manifest, summary, timing, "mean_time_to_confirm_s")
    bounds = delay_bounds(manifest)
    fmt = measure("mean_time_to_confirm_s").fmt
    rows = [(t, f"{c:,}", interval(s["mean"], s["ci_low"], s["ci_high"], fmt) if s else DASH,
             fmt.format(bounds[t][c]) if c in bounds.get(t, {}) else DASH)
            for t in trackers for c in counts for s in [measured.get(t, {}).get(c)]]
    section.table(TextTable("Confirmation delay: measured against the clairvoyant bound (s)",
                            ("tracker", "clutter per scan", "time to confirm", "bound of its rule"), tuple(rows)),
                  "clutter-delay")
    section.text("The bound is the least mean delay from a target's first detection to its confirmation that "
                 "Wald's test of the tracker's rule can have when it sees only that target's contacts, each "
                 "predicted with no error but the measurement noise (`nnda.tracking.confirmation_bound`); "
                 "the M/N rule and false tracks at a rate have none here.")
