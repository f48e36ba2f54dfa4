"""The report's "Track deletions" section: why each contact tracker ended its tracks.

Read from ``results.parquet`` (its ``confirmation`` and ``deleted_<reason>``
columns, `nnda.study.track_results`): per tracker, its confirmation rule and the
mean number of tracks deleted per run for each reason of
`nnda.tracking.lifecycle.DELETION_REASONS` (the life cycle's: unconfirmed,
misses, score, capped; the sanity rules': speed, coverage, covariance),
with the mean over every run of every scenario. Trackers without a life
cycle (the PHD family, the peers) are not listed; a study directory written
before the deletions were recorded has no such columns and no section.
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
RULES = {"mn": "M/N", "score": "track score", "existence": "existence"}


def deletions(out: Path) -> dict[str, tuple[str, dict[str, float]]]:
    """Per contact tracker of the study in ``out``: (its rule, mean deletions per run by reason)."""
    columns = ["tracker", "confirmation", *(f"deleted_{r}" for r in DELETION_REASONS)]
    if not set(columns) <= set(pq.read_schema(read_checked(out, RESULTS_FILE)).names):
        return {}
    t = read_table(out, RESULTS_FILE, columns).to_pydict()
    found: dict[str, tuple[str, dict[str, float]]] = {}
    for label in dict.fromkeys(t["tracker"]):
        rows = [i for i, name in enumerate(t["tracker"]) if name == label and t["confirmation"][i] is not None]
        if rows:
            found[label] = (t["confirmation"][rows[0]],
                            {r: float(np.mean([t[f"deleted_{r}"][i] for i in rows])) for r in DELETION_REASONS})
    return found


def deletions_section(section, out: Path):
    """Fill ``section`` (a `nnda.reports.pages.Section`) with the deletions table; None without one."""
    found = deletions(out)
    if not found:
        return None
    section.text("Tracks each contact tracker deleted, mean per run over every run of every scenario, by reason: "
                 "its life cycle's (unconfirmed preliminary tracks, too many misses, a low track score, the cap on "
                 "preliminary tracks) and the sanity rules' (an impossible speed, outside every sensor's coverage, "
                 "a position covariance beyond its bound; `nnda.tracking.lifecycle`).")
    section.table(TextTable("Track deletions per run, by reason", ("tracker", "rule", *DELETION_REASONS), tuple(
        (label, RULES.get(rule, rule), *(f"{per[r]:.1f}" for r in DELETION_REASONS))
        for label, (rule, per) in found.items())), "deletions")
    return section
