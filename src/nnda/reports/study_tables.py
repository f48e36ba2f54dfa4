"""The per-scenario tables of a study report: every measure, beside the thesis's values.

Per-scenario tables follow the layout of the thesis's Tables 6.4-6.9 (rows:
the measures of `nnda.study.measures.MEASURES`, the thesis's seven first; a
column per tracker) and add the thesis's classical and proposed columns
when the scenario is the preset the thesis ran. A cell reads ``mean [low,
high]``: the mean over runs and its Student-t confidence interval. A tracker
with a fixed lag L has a second column, "<label> lag L", of its lagged output.
The association network's tables are `nnda.reports.classifier_tables`.
"""

from __future__ import annotations

from nnda.data.presets import PRESETS
from nnda.reports.published_tracking import PUBLISHED_COLUMN_TITLES, PUBLISHED_TRACKING
from nnda.reports.study_summary import stat
from nnda.reports.text_table import DASH, TextTable, stat_cell
from nnda.study.measures import TIME, TRACK_MEASURES


def is_thesis_scenario(name: str, scenario: dict) -> bool:
    """True when the scenario is the thesis's own (a preset S1-S6 with its config unchanged)."""
    return name in PUBLISHED_TRACKING and name in PRESETS and PRESETS[name].model_dump(mode="json") == scenario


def scenario_table(scenario: dict, timing: dict, thesis: bool, confidence: float) -> TextTable:
    """The per-scenario table of one ``summary.json`` scenario and its ``timing.json`` entry: a row per
    measure of the registry, a column per tracker (and the thesis's columns)."""
    trackers = scenario["trackers"]
    # (column title, tracker, lagged?): a tracker with a lag L has a column "<label> lag L" after its own
    columns = [c for name, t in trackers.items()
               for c in ((name, name, False), *(((f"{name} lag {t['lagged']['lag']}", name, True),)
                                                 if "lagged" in t else ()))]
    header = ("Measure", *(title for title, _, _ in columns))
    spec = PUBLISHED_TRACKING.get(scenario["name"]) if thesis else None
    if spec:
        header += tuple(PUBLISHED_COLUMN_TITLES[c] for c in spec)
    rows = []
    for m in TRACK_MEASURES:
        row = [m.title, *(stat_cell(_cell(scenario, timing, name, m.key, lagged), m.fmt, m.scale)
                          for _, name, lagged in columns)]
        if spec:
            for column in spec.values():
                value = column.get(m.key)
                row.append(DASH if value is None else m.fmt.format(value * m.scale))
        rows.append(tuple(row))
    runs = max(t["runs"] for t in trackers.values())
    note = (f"Mean over {runs} run(s) [{confidence:.0%} t-interval, cut to the measure's possible range]; "
            f"a value without an interval was the same in every run. GOSPA parts are in m² per scan; "
            f"each missed target or false track adds c²/2. OSPA and its localisation and cardinality parts "
            f"are in m, OSPA² = localisation² + cardinality² in each scan.")
    if any(lagged for _, _, lagged in columns):
        note += (" A column \"lag L\" is the tracker's fixed-lag output: each scan's tracks revised with the L "
                 "scans after it (confirmations back-filled, states smoothed); its time per scan is the "
                 "revision's alone, added to the tracker's.")
    if spec:
        note += " Thesis columns: one run, MATLAB timings on an i5-2450M (compare ratios, not milliseconds)."
    title = (f"{scenario['name']}: {len(scenario['targets'])} targets, {scenario['n_scans']} scans, "
             f"{scenario['source']}")
    return TextTable(title, header, tuple(rows), note)


def _cell(scenario: dict, timing: dict, tracker: str, key: str, lagged: bool) -> dict | None:
    """`stat` of the tracker's online output, or with ``lagged`` of its fixed-lag output (time per scan: the
    lag's revision, `timing.json`'s ``lagged``)."""
    if not lagged:
        return stat(scenario, timing, tracker, key)
    if key == TIME.key:
        return timing["trackers"].get(tracker, {}).get("lagged", {}).get(TIME.key)
    return scenario["trackers"][tracker]["lagged"]["metrics"].get(key)
