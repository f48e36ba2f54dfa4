"""The report's "Single-target filters" section: each filter job's measures against the truth, per scenario.

Rows come from `nnda.study.measures.FILTER_MEASURES` plus the time
per scan of `timing.json`; one column per filter, mean [t-interval] over runs.
"""

from __future__ import annotations

from nnda.reports.text_table import TextTable, stat_cell
from nnda.study.filter_run import NEES_BOUND
from nnda.study.measures import FILTER_MEASURES, TIME


def filters_section(section, summary: dict, timing: dict):
    """Fill ``section`` (a `nnda.reports.pages.Section`) from the study's ``filters`` summaries."""
    conf = summary["confidence"]
    section.text("Single-target filters run on the study's single-target scenarios with the target's own "
                 "contacts (the generator's labels: no association), from the two-point start onwards, and are "
                 f"scored against the true state at every scan. NEES is 4 on average for a consistent filter; "
                 f"a scan counts as divergent when its NEES exceeds {NEES_BOUND:g} (chi-square 99.9%, 4 dof).")
    times = {s["name"]: s["filters"] for s in timing.get("filters", [])}
    for sc in summary["filters"]:
        labels = list(sc["filters"])
        rows = [(m.title, *(stat_cell(sc["filters"][f]["metrics"].get(m.key), m.fmt, m.scale) for f in labels))
                for m in FILTER_MEASURES]
        rows.append((TIME.title, *(stat_cell(times.get(sc["name"], {}).get(f, {}).get(TIME.key), TIME.fmt,
                                             TIME.scale) for f in labels)))
        runs = max(f["runs"] for f in sc["filters"].values())
        section.table(TextTable(f"{sc['name']}: single-target filters", ("Measure", *labels), tuple(rows),
                                f"Mean over {runs} run(s) [{conf:.0%} t-interval]."), f"filters-{sc['name']}")
    return section
