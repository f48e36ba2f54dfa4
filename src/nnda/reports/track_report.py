"""The tracker jobs' sections of a study report (and the single-target filters' beside them).

Built only from the files a study directory keeps (``study.json``,
``summary.json``, ``timing.json``, ``classifier.json``, ``timing.parquet``,
``trajectories.parquet``, ``cardinality.parquet``), each checked against
``checksums.json``. Sections, in order (their HTML ids in brackets):
summary [summary] (the answer first: quality against cost, a table over
all scenarios and a reading, `nnda.reports.headline`; then the best
tracker per scenario and measure, `nnda.reports.study_summary`), setup
[setup], association network [classifier], results per scenario
[scenarios], kinematic vs extended features in the tracker
[features-in-tracker] (when neural trackers run on both feature sets),
feature ablation [ablation] (when the study names one, from
``ablation.json``), against Stone Soup [peers] (when the study ran a
Stone Soup peer), single-target filters [filters], time per scan
[timing], false tracks and GOSPA over time [over-time], target count over
time [cardinality] (`nnda.reports.cardinality_section`), trajectories
[trajectories].
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from nnda.data.scenario import scenario_from_dict
from nnda.files import read_json
from nnda.models.ablation import ABLATION_FILE
from nnda.reports import (
    ablation_section,
    association_section,
    cardinality_section,
    features_section,
    headline,
    study_figures,
)
from nnda.reports.classifier_tables import classifier_table, model_test_table
from nnda.reports.clutter_section import clutter_section
from nnda.reports.deletions_section import deletions_section
from nnda.reports.filters_section import filters_section
from nnda.reports.fusion_section import fusion_section
from nnda.reports.pages import Figure, Section, StudyFiles
from nnda.reports.peers_section import against_stonesoup, peer_labels
from nnda.reports.study_tables import is_thesis_scenario, scenario_table
from nnda.reports.text_table import DASH, TextTable
from nnda.reports.trajectory_plot import figure_div, trajectory_figure
from nnda.study.checksums import read_checked, read_table
from nnda.study.classifier import CLASSIFIER_FILE, CLASSIFIER_FORMAT, read_ablation
from nnda.study.classifier import FORMAT_VERSION as CLASSIFIER_VERSION
from nnda.study.track_results import TIMING_FILE, TRAJECTORIES_FILE
from nnda.tracking.registry import confirmation_rule


def _columns(out: Path, name: str) -> dict[str, np.ndarray]:
    table = read_table(out, name)
    return {c: table.column(c).to_numpy(zero_copy_only=False) for c in table.column_names}


def _times(out: Path) -> dict[tuple[str, str], np.ndarray]:
    """Every per-scan time (s) of each (scenario, tracker), all runs together."""
    table = read_table(out, TIMING_FILE).to_pydict()
    grouped: dict[tuple[str, str], list] = {}
    for s, t, times in zip(table["scenario"], table["tracker"], table["time_per_scan_s"]):
        grouped.setdefault((s, t), []).extend(times)
    return {k: np.asarray(v) for k, v in grouped.items()}


def _json_compact(value) -> str:
    return json.dumps(value, sort_keys=True, separators=(", ", ": "))


def _per_sensor(value: int | list[int]) -> str:
    """A number of the study manifest given per sensor for several sensors: "2 / 2"."""
    return " / ".join(map(str, value)) if isinstance(value, list) else str(value)


#: how the report names a contact tracker's confirmation rule (`nnda.tracking.registry.confirmation_rule`)
_RULES = {"adaptive": "track score (SPRT), clutter-adaptive threshold", "mn": "M/N counts",
          "score": "track score (SPRT)", "existence": "probability of existence (IPDA/JIPDA)"}


def _setup(manifest: dict, summary: dict, timing: dict) -> Section:
    study = manifest["study"]
    sec = Section("setup", "Setup", [], [])
    gospa = summary["gospa"]
    sec.text(f"Study **{study['name']}**{': ' + study['description'] if study['description'] else ''}. "
             f"Seed {study['seed']}; generated scenarios run {study['runs']} time(s), run r of scenario s drawn "
             f"from `nnda.data.generator.generate(s, seed, r)`, the same data for every tracker. GOSPA with c = "
             f"{gospa['cutoff_m']:g} m, p = {gospa['p']}, alpha = {gospa['alpha']} (localisation, missed and "
             f"false parts); OSPA with the same c and p (localisation and cardinality parts). "
             f"Intervals: {summary['confidence']:.0%} Student-t over runs.")
    sec.table(TextTable("Trackers", ("Label", "Kind", "Model", "Parameters"), tuple(
        (t["label"], t["kind"], t["model"] or DASH, _json_compact(t["params"]) if t["params"] else "defaults")
        for t in manifest["trackers"])))
    rules = [(t["label"], confirmation_rule(t["kind"], t["params"])) for t in manifest["trackers"]]
    if any(rule is not None for _, rule in rules):  # which rule confirmed and deleted each one's tracks
        sec.text("Track confirmation and deletion: " + "; ".join(
            f"{label}: {_RULES[rule]}" for label, rule in rules if rule is not None)
            + ". Every contact tracker also deletes impossible tracks (speed, coverage, covariance; "
            "`nnda.tracking.lifecycle`) and records its deletions by reason in results.parquet.")
    sec.table(TextTable("Scenarios", ("Name", "Source", "Targets", "Scans", "Clutter per scan", "Runs"), tuple(
        (s["name"], s["source"], ", ".join(s["targets"]), str(s["n_scans"]), _per_sensor(s["clutter_per_scan"]),
         str(s["runs"]))
        for s in manifest["scenarios"])))
    if manifest["models"]:
        sec.table(TextTable("Model files", ("Label", "File", "SHA-256"), tuple(
            (m["label"], m["path"], m["sha256"][:16]) for m in manifest["models"])))
    ex, machine = timing["execution"], timing["machine"]
    remote = ex["executor"].startswith("dask ") and ex["executor"] != "dask local"
    where = (f"the Dask cluster at {ex['executor'][5:]}" if remote
             else f"{ex['executor']} with {ex['workers']} worker(s)")
    sec.text(f"Executed on {where}: {ex['jobs_run']} job(s) run and "
             f"{ex['jobs_skipped']} resumed from earlier in {ex['seconds']:.1f} s (last invocation). Machine: "
             f"{machine['processor']}, {machine['cpus']} CPU(s), {machine['platform']}, Python {machine['python']}, "
             f"nnda {machine['nnda_version']}. Timing: {timing['method']}.")
    # summaries written before track ownership had two kinds hold no "ownership": theirs was by contacts
    kinds = {t: ", ".join(v.get("ownership", ["contacts"])) for sc in summary["scenarios"]
             for t, v in sc["trackers"].items()}
    by = "; ".join(f"{t}: by {k}" for t, k in kinds.items())
    option = summary.get("ownership", "auto")
    sec.text(f"Bookkeeping (`nnda.study.metrics`): a track belongs to a target by contacts (the target that "
             f"produced most of its contacts) or, for outputs without contacts, by position (the target it was "
             f"matched to in most of its confirmed scans); study option ownership = {option!r} "
             f"({by}). Only tracks confirmed at some scan count. Hits are target contacts used by a track of "
             "their own target; association losses are target contacts after the target's first track exists "
             "that no track of that target used; hit rate = hits / (hits + losses + clutter associated). A false "
             "track is a confirmed track owned by no target (mostly clutter, or mostly unmatched); a track break "
             "is a further confirmed track of an already tracked target; a lost target had its track deleted "
             "while it still produced contacts. GOSPA and OSPA compare the confirmed tracks' positions with the "
             f"true positions per scan. MOTA, MOTP and identity switches are CLEAR-MOT (Bernardin & Stiefelhagen "
             f"2008) over the per-scan matching of confirmed tracks to targets closer than {gospa['cutoff_m']:g} m "
             f"(the GOSPA cut-off), which also gives ownership by position.")
    return sec


def _classifier(classifier: dict, figures: list[Figure]) -> Section:
    sec = Section("classifier", "Association network", [], [])
    models = classifier["models"]
    if not models:
        sec.text("This study has no model file (no neural tracker), so there is no classifier to report.")
        return sec
    sec.table(classifier_table(models), "classifier-table")
    sec.table(model_test_table(models))
    fig = Figure("roc.png", "ROC of each model over all its training pairs", study_figures.roc_curves, (models,))
    figures.append(fig)
    sec.figure(fig)
    return sec


def _features_in_tracker(pairs: list[tuple[str, str]], summary: dict, timing: dict) -> Section:
    sec = Section("features-in-tracker", "Kinematic vs extended features in the tracker", [], [])
    sec.text("Does better pair classification make better tracks, and at what cost per scan? Each neural "
             "tracker on the IMM-extended features beside the kinematic-feature tracker trained by the same method.")
    for seed, ext in pairs:
        table, counts = features_section.comparison(seed, ext, summary, timing)
        sec.text(features_section.tally(seed, ext, counts))
        sec.table(table)
    return sec


def _ablation(doc: dict, figures: list[Figure]) -> Section:
    sec = Section("ablation", "Feature ablation", [], [])
    sec.text("Which pair features buy how much classification: Vargas Avila (2015)'s three kinematic features "
             "(variant 'seed'), the IMM-extended nine, the three plus each IMM feature, and the IMM features "
             "alone, every variant trained on the same pairs and splits, under the thesis's data model (measured "
             "track history) and the error-free one (true positions).")
    for table in ablation_section.tables(doc):
        sec.table(table)
    sec.text(ablation_section.reading(doc))
    fig = Figure("ablation_roc.png", "Feature ablation: mean test ROC over seeds", study_figures.ablation_roc,
                 (doc["results"],))
    figures.append(fig)
    sec.figure(fig)
    return sec


def _scenarios(manifest: dict, summary: dict, timing: dict) -> Section:
    sec = Section("scenarios", "Results per scenario", [], [])
    sec.text("Layout of the thesis's Tables 6.4-6.9, extended by nnda's measures. Where the scenario is the "
             "thesis's own, its classical (IMM/TOMHT) and proposed (neural) columns stand beside ours.")
    configs = {s["name"]: s["scenario"] for s in manifest["scenarios"]}
    timing_by = {s["name"]: s for s in timing["scenarios"]}
    for sc in summary["scenarios"]:
        thesis = is_thesis_scenario(sc["name"], configs[sc["name"]])
        sec.table(scenario_table(sc, timing_by[sc["name"]], thesis, summary["confidence"]), f"table-{sc['name']}")
    return sec


def _tracker_figures(out: Path, summary: dict, scenarios: list[str], trackers: list[str],
                     scan_times: dict[str, np.ndarray], figures: list[Figure]) -> list[Section]:
    """The sections of figures over the trackers: time per scan, per-scan means over time, trajectories."""
    sections = []
    timing_sec = Section("timing", "Time per scan", [], [])
    fig = Figure("time_per_scan.png", "Time per scan of every scan and run (log scale)",
                 study_figures.time_per_scan, (_times(out), scenarios, trackers))
    figures.append(fig)
    timing_sec.figure(fig)
    timing_sec.text("Wall-clock time of `Tracker.step` only (data generation and metrics excluded), one BLAS "
                    "thread per job. Absolute times depend on the machine; compare ratios.")
    sections.append(timing_sec)

    over = Section("over-time", "False tracks and GOSPA over time", [], [])
    for sc in summary["scenarios"]:
        fig = Figure(f"over_time_{sc['name']}.png", f"{sc['name']}: per-scan means over runs",
                     study_figures.over_time, (sc, scan_times[sc["name"]], summary["gospa"]["cutoff_m"]))
        figures.append(fig)
        over.figure(fig)
    sections.append(over)

    traj = Section("trajectories", "Trajectories and tracks", [], [])
    traj.md += ["Run 0 of each scenario, the truth and every tracker's confirmed tracks, is drawn in report.html "
                "(interactive: zoom, hover a track for its id and status); trajectories.parquet holds its points.",
                ""]
    traj.html.append("<p>Run 0 of each scenario. Zoom with the mouse, hover a track point for the tracker, track "
                     "id and status, click a legend entry to hide or show it.</p>")
    rows = _columns(out, TRAJECTORIES_FILE)
    for name in scenarios:
        mine = {k: v[rows["scenario"] == name] for k, v in rows.items()}
        div = figure_div(trajectory_figure(name, mine, trackers), f"trajectories-{name}")
        traj.html.append(f'<div class="plot">{div}</div>')
    sections.append(traj)

    return sections


def _kept(fig: Figure, figures: list[Figure]) -> Figure:
    figures.append(fig)
    return fig


def track_sections(study: StudyFiles, figures: list[Figure]) -> list[Section]:
    """The sections of the tracker jobs (and the filter jobs on the same scenarios), in report order."""
    out, manifest, summary, timing = study.out, study.manifest, study.summary, study.timing
    classifier = read_json(read_checked(out, CLASSIFIER_FILE), CLASSIFIER_FORMAT, CLASSIFIER_VERSION)
    scenarios = [s["name"] for s in summary["scenarios"]]
    trackers = [t["label"] for t in summary["trackers"]]
    scan_times = {s["name"]: scenario_from_dict(s["scenario"]).scan_schedule()[0] for s in manifest["scenarios"]}

    top = headline.headline_section(Section("summary", "Summary", [], []), summary, timing,
                                    lambda *made: _kept(Figure(*made), figures))
    sections = [top, _setup(manifest, summary, timing), _classifier(classifier, figures)]
    if trackers:
        sections.append(_scenarios(manifest, summary, timing))
        pairs = features_section.feature_pairs(manifest, classifier)
        if pairs:
            sections.append(_features_in_tracker(pairs, summary, timing))
        association = association_section.tables(manifest, classifier, summary, timing)
        if association:
            sec = Section("association-ablation", "Neural association ablation", [], [])
            sec.text("The neural association's options, each on or off: the context features, multi-target "
                     "encounter scenes and DAgger rounds in the training data, the global assignment; "
                     "the classifier's figures first, then the tracking measures per scenario.")
            for table in association:
                sec.table(table)
            sections.append(sec)
        if (out / ABLATION_FILE).is_file():
            sections.append(_ablation(read_ablation(read_checked(out, ABLATION_FILE)), figures))
        if peer_labels(summary):
            sections.append(against_stonesoup(Section("peers", "Against Stone Soup", [], []), summary, timing))
        fused = fusion_section(Section("fusion", "Fusion against single sensors", [], []), manifest, summary)
        if fused is not None:
            sections.append(fused)
        swept = clutter_section(Section("clutter", "Against clutter density", [], []), manifest, summary, timing,
                                lambda *made: _kept(Figure(*made), figures))
        if swept is not None:
            sections.append(swept)
        deleted = deletions_section(Section("deletions", "Track deletions", [], []), out)
        if deleted is not None:
            sections.append(deleted)
    if summary.get("filters"):
        sections.append(filters_section(Section("filters", "Single-target filters", [], []), summary, timing))
    if trackers:
        sections += _tracker_figures(out, summary, scenarios, trackers, scan_times, figures)
        sections.insert(-1, cardinality_section.target_counts(  # before the trajectories
            Section("cardinality", "Target count over time", [], []), out, summary, scan_times,
            lambda *made: _kept(Figure(*made), figures)))
    return sections
