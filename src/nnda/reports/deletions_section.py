"""The report's "Track deletions" section: why each contact tracker ended its tracks.

Read from ``results.parquet`` (its ``confirmation`` and ``deleted_<reason>``
columns, `nnda.study.track_results`): per tracker, its confirmation rule and the
mean number of tracks deleted per run for each reason of
`nnda.tracking.lifecycle.DELETION_REASONS` (the life cycle's: unconfirmed,
misses, score, capped; the sanity rules': speed, coverage, covariance,
quality), with the mean over every run of every scenario. Trackers without a
life cycle (the PHD family, the peers) are not listed; a study directory
written before the deletions were recorded has no such columns and no
section, and one written before a reason was added (quality) shows the
reasons it recorded.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

from nnda.reports.text_table import TextTable
from nnda.study.checksums import read_checked, read_table
from nnda.study.track_results import RESULTS_FILE
from nnda.tracking.lifecycle import DELETION_REASONS

#: how the table names each confirmation rule
RULES = {"adaptive": "adaptive score", "mn": "M/N", "score": "track score", "existence": "existence"}


def deletions(out: Path) -> dict[str, tuple[str, dict[str, float]]]:
    """Per contact tracker of the study in ``out``: (its rule, mean deletions per run by reason), for the
    reasons of `DELETION_REASONS` the study recorded (an older study lacks the newer ones)."""
    names = set(pq.read_schema(read_checked(out, RESULTS_FILE)).names)
    reasons = [r for r in DELETION_REASONS if f"deleted_{r}" in names]
    if not reasons or not {"tracker", "confirmation"} <= names:
        return {}
    t = read_table(out, RESULTS_FILE, ["tracker", "confirmation", *(f"deleted_{r}" for r in reasons)]).to_pydict()
    found: dict[str, tuple[str, dict[str, float]]] = {}
    for label in dict.fromkeys(t["tracker"]):
        rows = [i for i, name in enumerate(t["tracker"]) if name == label and t["confirmation"][i] is not None]
        if rows:
            found[label] = (t["confirmation"][rows[0]],
                            {r: float(np.mean([t[f"deleted_{r}"][i] for i in rows])) for r in reasons})
    return found


def deletions_section(section, out: Path):
    """Fill ``section`` (a `nnda.reports.pages.Section`) with the deletions table; None without one."""
    found = deletions(out)
    if not found:
        return None
    section.text("Tracks each contact tracker deleted, mean per run over every run of every scenario, by reason: "
                 "its life cycle's (unconfirmed preliminary tracks, too many misses, a low track score, the cap on "
                 "preliminary tracks) and the sanity rules' (an impossible speed, outside every sensor's coverage, "
                 "a position covariance beyond its bound, a confirmed track whose gate holds too much clutter to "
                 "tell its target's contact apart; `nnda.tracking.lifecycle`).")
    reasons = list(next(iter(found.values()))[1])  # those the study recorded
    section.table(TextTable("Track deletions per run, by reason", ("tracker", "rule", *reasons), tuple(
        (label, RULES.get(rule, rule), *(f"{per[r]:.1f}" for r in reasons))
        for label, (rule, per) in found.items())), "deletions")
    return section
