"""The report's "Kinematic vs extended features in the tracker" section.

Does better pair classification turn into better tracking, and at what cost
per scan? Present when the study runs neural trackers on both feature sets.
Each neural tracker whose model reads the IMM-extended features is set
against the kinematic-feature tracker (Vargas Avila (2015)'s three features)
whose model was trained by the same method (every kinematic-feature tracker
when none was), among those whose settings,
``feature_set`` aside, are its own (so a tracker with another association
rule or life cycle, such as the demo's ``nn-life``, is not set against one
with the default ones), scenario by scenario, on the
measures association changes: association losses, false tracks, track
breaks, lost targets, hit rate, GOSPA and time per scan, each ``mean [low,
high]`` over runs with a verdict that calls a difference clear only when the
two intervals are apart. Reads ``study.json``, ``classifier.json``,
``summary.json`` and ``timing.json``.
"""

from __future__ import annotations

from nnda.models.features import KINEMATIC
from nnda.reports.study_summary import apart, stat
from nnda.reports.text_table import DASH, TextTable, stat_cell
from nnda.study.measures import TIME, Measure, measure

#: the measures association changes (registry keys), in the table's order
COMPARED: tuple[Measure, ...] = tuple(measure(k) for k in (
    "losses", "false_tracks", "track_breaks", "lost_targets", "hit_rate", "gospa", TIME.key))


def feature_pairs(manifest: dict, classifier: dict) -> list[tuple[str, str]]:
    """(kinematic-feature tracker, extended-feature tracker) labels to compare (module docstring)."""
    models = {m["label"]: (m.get("features", KINEMATIC.name), m.get("method")) for m in classifier["models"]}
    nn = [(t["label"], *models[t["model"]], _settings(t)) for t in manifest["trackers"]
          if t["kind"] == "nn" and t.get("model") in models]
    pairs = []
    for label, features, method, settings in nn:
        if features != KINEMATIC.name:
            seed = [n for n in nn if n[1] == KINEMATIC.name and n[3] == settings]
            pairs += [(s[0], label) for s in ([s for s in seed if s[2] == method] or seed)]
    return pairs


def _settings(tracker: dict) -> dict:
    """A tracker's params without its ``feature_set``: what else sets it apart from another neural tracker."""
    return {k: v for k, v in (tracker.get("params") or {}).items() if k != "feature_set"}


def _verdict(seed: str, ext: str, a: dict | None, b: dict | None, sense: int) -> tuple[str, int]:
    """Words and outcome (+1 extended clearly better, -1 clearly worse, 0 otherwise) of one comparison."""
    if not a or not b or a.get("mean") is None or b.get("mean") is None:
        return DASH, 0
    if a["mean"] == b["mean"]:
        return "equal", 0
    better = ext if sense * (b["mean"] - a["mean"]) > 0 else seed
    if not apart(a, b):
        return f"{better} ahead, intervals overlap", 0
    return f"{better} better, intervals apart", 1 if better == ext else -1


def comparison(seed: str, ext: str, summary: dict, timing: dict) -> tuple[TextTable, dict[int, int]]:
    """The table of one (seed, extended) pair over every scenario, and the count of each outcome."""
    timing_by = {s["name"]: s for s in timing["scenarios"]}
    rows, counts = [], {1: 0, 0: 0, -1: 0}
    for sc in summary["scenarios"]:
        for m in COMPARED:
            a, b = (stat(sc, timing_by[sc["name"]], t, m.key) for t in (seed, ext))
            words, outcome = _verdict(seed, ext, a, b, m.sense)
            counts[outcome] += 1
            rows.append((sc["name"], m.title, stat_cell(a, m.fmt, m.scale), stat_cell(b, m.fmt, m.scale), words))
    note = (f"Mean [{summary['confidence']:.0%} interval] over runs; a difference is called only when the two "
            f"intervals are apart.")
    return TextTable(f"{seed} (kinematic features) against {ext} (extended features)",
                     ("Scenario", "Measure", seed, ext, "Verdict"), tuple(rows), note), counts


def tally(seed: str, ext: str, counts: dict[int, int]) -> str:
    """One sentence counting the clear outcomes of a comparison."""
    total = sum(counts.values())
    return (f"**{ext} against {seed}**: clearly better in {counts[1]} of {total} (scenario, measure) cells, clearly "
            f"worse in {counts[-1]}, not separable in {counts[0]}.")
