"""The report's "Against Stone Soup" section: our trackers beside the Stone Soup peers.

Present only when the study ran a peer (a tracker kind of
`nnda.tracking.registry.PEERS`). Per scenario, one row per tracker: mean
time per scan, GOSPA and false tracks, each ``mean [low, high]`` over runs,
and for our trackers the speed ratio peer time / our time against the
nearest Stone Soup equivalent (`nnda.peers.parameters.EQUIVALENT`; the
fastest peer of the study when there is none). Then the geometric mean of
those ratios over scenarios, and the table of how the peers are set up.
Reads only ``summary.json`` and ``timing.json``; Stone Soup is not needed.
"""

from __future__ import annotations

import math

from nnda.peers.parameters import EQUIVALENT, MATCHING
from nnda.reports.text_table import DASH, TextTable, stat_cell
from nnda.study.measures import TIME, measure
from nnda.tracking.registry import PEERS

#: the measures beside the time per scan (registry keys)
COLUMNS = tuple(measure(k) for k in ("gospa", "false_tracks"))


def peer_labels(summary: dict) -> list[str]:
    """Labels of the study's trackers that are Stone Soup peers."""
    return [t["label"] for t in summary["trackers"] if t["kind"] in PEERS]


def _reference(kind: str, peers: dict[str, str], times: dict[str, float]) -> str | None:
    """Label of the peer an our-tracker of ``kind`` is compared with (peers: label -> kind)."""
    same = [label for label, k in peers.items() if k == EQUIVALENT.get(kind)]
    if same:
        return same[0]
    timed = [label for label in peers if times.get(label)]
    return min(timed, key=times.__getitem__) if timed else None


def _ratios(summary: dict, timing: dict) -> dict[str, dict[str, tuple[str, float]]]:
    """Per scenario, per our tracker: (reference peer, peer time / our time)."""
    kinds = {t["label"]: t["kind"] for t in summary["trackers"]}
    peers = {label: kinds[label] for label in peer_labels(summary)}
    out = {}
    for sc in timing["scenarios"]:
        times = {label: t[TIME.key]["mean"] for label, t in sc["trackers"].items()}
        row = {}
        for label, kind in kinds.items():
            ref = None if label in peers else _reference(kind, peers, times)
            if ref is not None and times.get(label) and times.get(ref):
                row[label] = (ref, times[ref] / times[label])
        out[sc["name"]] = row
    return out


def against_stonesoup(section, summary: dict, timing: dict):
    """Fill ``section`` (a study_report Section: ``text`` and ``table``) and return it."""
    peers = peer_labels(summary)
    conf = summary["confidence"]
    ratios = _ratios(summary, timing)
    section.text(f"Stone Soup's trackers ({', '.join(peers)}) ran as trackers of this study on the same data, "
                 f"scored by the same metrics; their parameters are matched to ours as the last table says. "
                 f"Speed ratio = the peer's mean time per scan / ours (how many times faster ours is), in the "
                 f"same study on the same machine.")
    timing_by = {s["name"]: s for s in timing["scenarios"]}
    for sc in summary["scenarios"]:
        rows = []
        for label, t in sc["trackers"].items():
            ref = ratios[sc["name"]].get(label)
            rows.append((label + (" (Stone Soup)" if label in peers else ""),
                         stat_cell(timing_by[sc["name"]]["trackers"][label][TIME.key], TIME.fmt, TIME.scale),
                         *(stat_cell(t["metrics"].get(m.key), m.fmt, m.scale) for m in COLUMNS),
                         f"{ref[1]:.3g}x vs {ref[0]}" if ref else DASH))
        sec_note = (f"Mean over {max(t['runs'] for t in sc['trackers'].values())} run(s) "
                    f"[{conf:.0%} t-interval].")
        section.table(TextTable(f"{sc['name']}: ours against Stone Soup",
                                ("Tracker", TIME.title, *(m.title for m in COLUMNS), "Speed ratio"),
                                tuple(rows), sec_note), f"peers-{sc['name']}")
    overall = {}
    for row in ratios.values():
        for label, (ref, r) in row.items():
            overall.setdefault((label, ref), []).append(r)
    if overall:
        section.table(TextTable("Speed ratio over scenarios", ("Tracker", "Against", "Geometric mean", "Range"),
                                tuple((label, ref, f"{math.exp(sum(map(math.log, rs)) / len(rs)):.3g}x",
                                       f"{min(rs):.3g}x - {max(rs):.3g}x")
                                      for (label, ref), rs in overall.items())))
    section.table(TextTable("How the peers are set up", ("Part", "Stone Soup", "Matched to (nnda)"), MATCHING))
    return section
