"""Tables of a study report: per-scenario results beside the thesis's, the classifier, the setup.

Per-scenario tables follow the layout of the thesis's Tables 6.4-6.9 (rows:
the spec's seven measures, then nnda's additional ones; a column per
tracker) and add the thesis's classical and proposed columns when the
scenario is the preset the thesis ran. A cell reads ``mean [low, high]``:
the mean over runs and its Student-t confidence interval.
"""

from __future__ import annotations

import html

from nnda.data.presets import PRESETS
from nnda.models.features import KINEMATIC
from nnda.models.metrics import SPEC_TABLE_6_3
from nnda.models.tables import MEASURES, METHOD_NAMES, TextTable
from nnda.reports.spec_values import SPEC_COLUMN_TITLES, SPEC_TRACKING

#: (metric key, row label, number format, scale applied to the value); time comes from timing.json
ROWS = (
    ("target_contacts", "Target contacts", "{:.1f}", 1.0),
    ("hits", "Hits", "{:.1f}", 1.0),
    ("losses", "Association losses", "{:.1f}", 1.0),
    ("clutter_associated", "Clutter associated with tracks", "{:.2f}", 1.0),
    ("hit_rate", "Hit rate (%)", "{:.2f}", 1.0),
    ("mean_time_per_scan_s", "Mean time per scan (ms)", "{:.4g}", 1e3),
    ("confirmed_tracks", "Confirmed tracks", "{:.2f}", 1.0),
    ("false_tracks", "False tracks", "{:.2f}", 1.0),
    ("track_breaks", "Track breaks", "{:.2f}", 1.0),
    ("lost_targets", "Lost targets", "{:.2f}", 1.0),
    ("mean_time_to_confirm_s", "Time to confirm (s)", "{:.1f}", 1.0),
    ("position_rmse_m", "Position RMSE (m)", "{:.1f}", 1.0),
    ("gospa", "GOSPA, mean over scans (m)", "{:.1f}", 1.0),
    ("gospa_localisation", "  localisation part (m², per scan)", "{:,.0f}", 1.0),
    ("gospa_missed", "  missed-target part (m², per scan)", "{:,.0f}", 1.0),
    ("gospa_false", "  false-track part (m², per scan)", "{:,.0f}", 1.0),
    ("ospa", "OSPA, mean over scans (m)", "{:.1f}", 1.0),
    ("false_tracks_per_scan", "False tracks per scan", "{:.3f}", 1.0),
)
TIME_KEY = "mean_time_per_scan_s"
DASH = "—"


def cell(stat: dict | None, fmt: str, scale: float = 1.0) -> str:
    """``mean [low, high]`` of a mean_ci record: the mean alone with one run or when every run
    gave the same value, a dash when undefined."""
    if not stat or stat.get("mean") is None:
        return DASH
    text = fmt.format(stat["mean"] * scale)
    if stat.get("ci_low") is not None and stat["ci_low"] != stat["ci_high"]:
        text += f" [{fmt.format(stat['ci_low'] * scale)}, {fmt.format(stat['ci_high'] * scale)}]"
    return text


def is_thesis_scenario(name: str, scenario: dict) -> bool:
    """True when the scenario is the thesis's own (a preset S1-S6 with its config unchanged)."""
    return name in SPEC_TRACKING and name in PRESETS and PRESETS[name].model_dump(mode="json") == scenario


def scenario_table(scenario: dict, timing: dict, thesis: bool, confidence: float) -> TextTable:
    """The per-scenario table of one ``summary.json`` scenario and its ``timing.json`` entry."""
    trackers = scenario["trackers"]
    header = ("Measure", *trackers)
    spec = SPEC_TRACKING.get(scenario["name"]) if thesis else None
    if spec:
        header += tuple(SPEC_COLUMN_TITLES[c] for c in spec)
    rows = []
    for key, label, fmt, scale in ROWS:
        row = [label]
        for name, t in trackers.items():
            stat = timing["trackers"][name][key] if key == TIME_KEY else t["metrics"].get(key)
            row.append(cell(stat, fmt, scale))
        if spec:
            for column in spec.values():
                value = column.get(key)
                row.append(DASH if value is None else fmt.format(value * scale))
        rows.append(tuple(row))
    runs = max(t["runs"] for t in trackers.values())
    note = (f"Mean over {runs} run(s) [{confidence:.0%} t-interval, cut to the measure's possible range]; "
            f"a value without an interval was the same in every run. GOSPA parts are in m² per scan; "
            f"each missed target or false track adds c²/2.")
    if spec:
        note += " Thesis columns: one run, MATLAB timings on an i5-2450M (compare ratios, not milliseconds)."
    title = (f"{scenario['name']}: {len(scenario['targets'])} targets, {scenario['n_scans']} scans, "
             f"{scenario['source']}")
    return TextTable(title, header, tuple(rows), note)


def classifier_table(models: list[dict]) -> TextTable:
    """Table 6.3 layout: each model over all its training pairs, beside the thesis's GD and LM columns."""
    header = ("Measure", *(f"{m['label']} (all pairs)" for m in models), "thesis GD", "thesis LM")
    rows = []
    for label, key, fmt in MEASURES:
        row = [label]
        for m in models:
            value = m["evaluation"]["metrics"].get(key)
            row.append(DASH if value is None else fmt.format(value))
        for method in ("gd", "lm"):
            value = SPEC_TABLE_6_3[method].get(key)
            row.append(DASH if value is None else fmt.format(value))
        rows.append(tuple(row))
    extra = (("Method", lambda m: METHOD_NAMES.get(m["method"], str(m["method"] or DASH))),
             ("Features", lambda m: str(m.get("features", KINEMATIC.name))),
             ("Hidden units", lambda m: str(m["n_hidden"])),
             ("Epochs (best)", lambda m: f"{m['epochs']} ({m['best_epoch']})" if m["epochs"] is not None else DASH),
             ("Stopped by", lambda m: str(m["stop_reason"] or DASH)),
             ("Pairs (own contact)", lambda m: f"{m['evaluation']['n_pairs']} ({m['evaluation']['n_positive']})"))
    spec_extra = {"Method": ("Gradient descent", "Levenberg-Marquardt"),
                  "Features": (KINEMATIC.name, KINEMATIC.name), "Hidden units": ("5", "5"),
                  "Epochs (best)": ("1000", "35"), "Stopped by": (DASH, DASH),
                  "Pairs (own contact)": ("2766 (831)", "2766 (831)")}
    for label, get in extra:
        rows.append((label, *(get(m) for m in models), *spec_extra[label]))
    sources = "; ".join(f"{m['label']}: {m['evaluation']['pairs_from']}" for m in models)
    note = f"Scores of every pair of the models' training data. Pairs: {sources}."
    return TextTable("Association network (layout of the thesis's Table 6.3)", header, tuple(rows), note)


def model_test_table(models: list[dict]) -> TextTable:
    """The test-split metrics each model file records about itself."""
    header = ("Measure", *(f"{m['label']} (test split)" for m in models))
    rows = []
    for label, key, fmt in MEASURES:
        row = [label]
        for m in models:
            value = (m.get("test_metrics") or {}).get(key)
            row.append(DASH if value is None else fmt.format(value))
        rows.append(tuple(row))
    return TextTable("As recorded in the model files (test split)", header, tuple(rows))


#: a column with a cell longer than this many characters is prose (set-up tables): it wraps, left-aligned
TEXT_CELL = 40
_TEXT = ' class="text"'


def table_html(table: TextTable, table_id: str = "") -> str:
    """The table as an HTML <table> with its title as caption and its note below."""
    ident = f' id="{html.escape(table_id)}"' if table_id else ""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in table.header)
    prose = {j for row in table.rows for j, c in enumerate(row) if len(c) > TEXT_CELL}
    body = "".join("<tr>" + "".join(f"<td{_TEXT if j in prose else ''}>{html.escape(c)}</td>"
                                    for j, c in enumerate(row)) + "</tr>" for row in table.rows)
    note = f'<p class="note">{html.escape(table.note)}</p>' if table.note else ""
    return (f'<div class="table"><table{ident}><caption>{html.escape(table.title)}</caption><thead><tr>{head}</tr>'
            f"</thead><tbody>{body}</tbody></table></div>{note}")
