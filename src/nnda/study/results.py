"""Aggregates of a finished study: raw tables, means with confidence intervals, per-scan averages.

Written next to the job files, always rebuilt from them in plan order
(scenario, tracker, run), so they do not depend on the order jobs finished:

* ``results.parquet``: one row per job: scenario, tracker, kind, run, seed,
  dataset digest, the track ownership used ("contacts" or "position"), the
  value of every run measure of `nnda.study.measures` (columns in key
  order; counts as int64), the contact trackers' confirmation rule and
  deletions by reason (``confirmation``, ``deleted_<reason>``; null for
  other trackers), and the per-scan series as list columns
  (``<series name>_per_scan``). The series of
  ``false_tracks_per_scan`` is named ``false_tracks``, so its list column
  takes the name of the run value (its mean, which is left out): format
  version 1 keeps that layout;
* ``summary.json``: per scenario and tracker, mean and t-interval over runs
  of every run measure (cut to the measure's ``bounds``), every per-scan
  series averaged over runs, and the ownership kinds its runs used;
* ``trajectories.parquet``: run 0's truth and every confirmed track's
  reports (the report's trajectory plot);
* ``cardinality.parquet``: one row per tracker job, the target count of every
  scan: true, confirmed tracks and the filter's own estimate
  (`nnda.study.cardinality`);
* ``timing.parquet`` and ``timing.json``: the wall-clock time per scan of
  every job and its aggregates, plus how the study was executed;
* with filter jobs (``[filters.<label>]``): ``filter_results.parquet``, one
  row per filter job with every measure of `nnda.study.filter_measures`,
  and in ``summary.json`` a ``filters`` list (per single-target scenario
  and filter, mean and t-interval of each measure, per-scan means) and the
  filters' time per scan in ``timing.json``; a study without filters
  writes neither.

Timing is the only thing that changes between two runs of the same study,
so it lives in its own two files: ``results.parquet``, ``summary.json``,
``trajectories.parquet`` and ``cardinality.parquet`` are byte-identical for the same study and seed,
whether run at once, resumed, locally or on Dask.
"""

from __future__ import annotations

import os
import platform
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from nnda.errors import DatasetError
from nnda.files import atomic_file, finite_or_none, read_json, write_json
from nnda.study.cardinality import CARDINALITY_FILE, cardinality_table
from nnda.study.filter_measures import FILTER_MEASURES, FILTER_SERIES
from nnda.study.measures import RUN_MEASURES, SERIES_MEASURES, TIME
from nnda.study.plan import StudyPlan
from nnda.study.runner import Execution, read_job
from nnda.study.stats import mean_ci
from nnda.tracking.lifecycle import DELETION_REASONS
from nnda.tracking.output import TrackStatus
from nnda.version import __version__

SUMMARY_FORMAT = "nnda.study-summary"
TIMING_FORMAT = "nnda.study-timing"
FORMAT_VERSION = 1
RESULTS_FILE = "results.parquet"
FILTER_RESULTS_FILE = "filter_results.parquet"
SUMMARY_FILE = "summary.json"
TRAJECTORIES_FILE = "trajectories.parquet"
TIMING_FILE = "timing.parquet"
TIMING_SUMMARY_FILE = "timing.json"
#: GOSPA's fixed parameters (the cut-off is the study's)
GOSPA_P, GOSPA_ALPHA = 2, 2


def _nanmean_rows(rows: list[list[float]]) -> list[float | None]:
    """Element-wise mean of series of possibly different lengths (shorter ones padded with NaN)."""
    width = max(len(r) for r in rows)
    a = np.full((len(rows), width), np.nan)
    for i, r in enumerate(rows):
        a[i, :len(r)] = r
    counts = np.isfinite(a).sum(axis=0)
    sums = np.nansum(a, axis=0)
    return [finite_or_none(float(s / c)) if c else None for s, c in zip(sums, counts)]


def collect(plan: StudyPlan, out: str | Path) -> list[dict]:
    """Every job record in (scenario, tracker or filter, run) order; checks that all saw the same data."""
    out = Path(out)
    labels = [t.label for t in plan.trackers] + [f.label for f in plan.filters]
    order = {(s.name, label): (i, j) for i, s in enumerate(plan.scenarios) for j, label in enumerate(labels)}
    jobs = sorted(plan.jobs, key=lambda j: (*order[j.scenario, j.tracker], j.run))
    records = [read_job(job, out) for job in jobs]
    seen: dict[tuple[str, int], str] = {}
    for r in records:
        first = seen.setdefault((r["scenario"], r["run"]), r["dataset_digest"])
        if first != r["dataset_digest"]:
            raise DatasetError(f"{out}: the trackers of {r['scenario']} run {r['run']} did not see the same data "
                               f"(dataset digests differ); rerun the study in a fresh directory")
    return records


def _column(values: list, kind: str) -> pa.Array:
    types = {"int": pa.int64(), "float": pa.float64(), "str": pa.string(), "int32": pa.int32()}
    return pa.array(values, type=types[kind])


def results_table(records: list[dict]) -> pa.Table:
    """One row per job (see the module docstring); counts stay integers."""
    cols: dict[str, pa.Array] = {
        "scenario": _column([r["scenario"] for r in records], "str"),
        "tracker": _column([r["tracker"] for r in records], "str"),
        "kind": _column([r["kind"] for r in records], "str"),
        "run": _column([r["run"] for r in records], "int32"),
        "seed": _column([r["seed"] for r in records], "int"),
        "dataset_digest": _column([r["dataset_digest"] for r in records], "str"),
        "n_scans": _column([r["n_scans"] for r in records], "int32"),
        "n_targets": _column([r["n_targets"] for r in records], "int32"),
        "ownership": _column([r["ownership"] for r in records], "str"),
    }
    for m in sorted(RUN_MEASURES, key=lambda m: m.key):
        kind = "int" if m.integer and not m.per_scan else "float"
        cols[m.key] = _column([r["metrics"][m.key] for r in records], kind)
    # the contact trackers' track management (issue 21): confirmation rule and deletions by reason; null otherwise
    managed = [r.get("track_management") for r in records]
    cols["confirmation"] = _column([None if m is None else m["confirmation"] for m in managed], "str")
    for reason in DELETION_REASONS:
        cols[f"deleted_{reason}"] = _column([None if m is None else m["deletions"][reason] for m in managed], "int")
    for m in SERIES_MEASURES:  # false_tracks -> false_tracks_per_scan replaces that run value (module docstring)
        kind = pa.int64() if m.integer else pa.float64()
        cols[f"{m.series_name}_per_scan"] = pa.array([r["series"][m.series_name] for r in records],
                                                     type=pa.list_(kind))
    return pa.table(cols)


def timing_table(records: list[dict]) -> pa.Table:
    """Per job: mean and every per-scan wall-clock time (s) of the tracker's step."""
    times = [r["timing"]["time_per_scan_s"] for r in records]
    return pa.table({
        "scenario": _column([r["scenario"] for r in records], "str"),
        "tracker": _column([r["tracker"] for r in records], "str"),
        "run": _column([r["run"] for r in records], "int32"),
        TIME.key: _column([float(np.mean(t)) for t in times], "float"),
        "time_per_scan_s": pa.array(times, type=pa.list_(pa.float64())),
    })


_STATUS = {int(s): s.name.lower() for s in TrackStatus}


def trajectories_table(records: list[dict]) -> pa.Table:
    """Run 0 of each scenario: truth rows (source "truth") and each tracker's confirmed tracks."""
    rows: dict[str, list] = {k: [] for k in ("scenario", "source", "scan", "time", "id", "name", "status", "x", "y")}

    def add(scenario, source, block, ids, names, status):
        n = len(block["scan"])
        rows["scenario"] += [scenario] * n
        rows["source"] += [source] * n
        rows["scan"] += block["scan"]
        rows["time"] += block["time"]
        rows["id"] += ids
        rows["name"] += names
        rows["status"] += status
        rows["x"] += block["x"]
        rows["y"] += block["y"]

    truth_done = set()
    for r in records:
        if "tracks" not in r:
            continue
        if r["scenario"] not in truth_done:
            t = r["truth"]
            add(r["scenario"], "truth", t, t["target_id"], [t["target_names"][i] for i in t["target_id"]],
                ["detected" if d else "missed" for d in t["detected"]])
            truth_done.add(r["scenario"])
        tr = r["tracks"]
        add(r["scenario"], r["tracker"], tr, tr["track_id"], [""] * len(tr["scan"]), [_STATUS[s] for s in tr["status"]])
    types = {"scenario": pa.string(), "source": pa.string(), "scan": pa.int32(), "time": pa.float64(),
             "id": pa.int64(), "name": pa.string(), "status": pa.string(), "x": pa.float64(), "y": pa.float64()}
    return pa.table({k: pa.array(v, type=types[k]) for k, v in rows.items()})


def _tracking(records: list[dict]) -> list[dict]:
    """The records of the tracker jobs (the filter jobs' have ``task`` "filter")."""
    return [r for r in records if r.get("task", "track") == "track"]


def filter_results_table(records: list[dict]) -> pa.Table:
    """One row per filter job: scenario, filter, kind, run, seed, dataset digest, every filter measure."""
    cols: dict[str, pa.Array] = {
        "scenario": _column([r["scenario"] for r in records], "str"),
        "filter": _column([r["tracker"] for r in records], "str"),
        "kind": _column([r["kind"] for r in records], "str"),
        "run": _column([r["run"] for r in records], "int32"),
        "seed": _column([r["seed"] for r in records], "int"),
        "dataset_digest": _column([r["dataset_digest"] for r in records], "str"),
    }
    for m in FILTER_MEASURES:
        cols[m.key] = _column([r["metrics"][m.key] for r in records], "float")
    for m in FILTER_SERIES:
        cols[f"{m.series_name}_per_scan"] = pa.array([r["series"][m.series_name] for r in records],
                                                     type=pa.list_(pa.float64()))
    return pa.table(cols)


def _filter_summary(plan: StudyPlan, records: list[dict]) -> list[dict]:
    conf, out = plan.study.confidence, []
    for sc in plan.scenarios:
        filters = {}
        for f in plan.filters:
            mine = [r for r in records if r["scenario"] == sc.name and r["tracker"] == f.label]
            if not mine:
                continue
            filters[f.label] = {
                "kind": f.kind, "runs": len(mine),
                "metrics": {m.key: mean_ci([r["metrics"][m.key] for r in mine], conf, *m.bounds)
                            for m in FILTER_MEASURES},
                "series_mean": {m.series_name: _nanmean_rows([r["series"][m.series_name] for r in mine])
                                for m in FILTER_SERIES},
            }
        if filters:
            out.append({"name": sc.name, "runs": sc.runs, "filters": filters})
    return out


def summarise(plan: StudyPlan, records: list[dict]) -> dict:
    """The ``summary.json`` content (deterministic: no timing, no paths)."""
    conf = plan.study.confidence
    filter_records = [r for r in records if r.get("task") == "filter"]
    records = _tracking(records)
    scenarios = []
    for sc in plan.scenarios:
        trackers = {}
        for t in plan.trackers:
            mine = [r for r in records if r["scenario"] == sc.name and r["tracker"] == t.label]
            trackers[t.label] = {
                "kind": t.kind, "model": t.model, "runs": len(mine),
                "ownership": sorted({r["ownership"] for r in mine}),
                "metrics": {m.key: mean_ci([r["metrics"][m.key] for r in mine], conf, *m.bounds) for m in RUN_MEASURES},
                "series_mean": {m.series_name: _nanmean_rows([r["series"][m.series_name] for r in mine])
                                for m in SERIES_MEASURES},
            }
        scenarios.append({"name": sc.name, "source": sc.source, "runs": sc.runs, "n_scans": sc.scenario.n_scans,
                          "targets": [tg.name for tg in sc.scenario.targets], "trackers": trackers})
    return {
        "format": SUMMARY_FORMAT, "format_version": FORMAT_VERSION, "study": plan.study.name,
        "fingerprint": plan.fingerprint, "seed": plan.study.seed, "confidence": conf,
        "gospa": {"cutoff_m": plan.study.gospa_cutoff_m, "p": GOSPA_P, "alpha": GOSPA_ALPHA},
        "ownership": plan.study.ownership,
        "trackers": [{"label": t.label, "kind": t.kind, "model": t.model} for t in plan.trackers],
        "scenarios": scenarios,
        **({"filters": _filter_summary(plan, filter_records)} if plan.filters else {}),
    }


def summarise_timing(plan: StudyPlan, records: list[dict], execution: Execution) -> dict:
    """The ``timing.json`` content: time per scan per scenario and tracker (and filter), and the execution."""
    def times(labels: list[str], task: str) -> list[dict]:
        scenarios = []
        for sc in plan.scenarios:
            found = {}
            for label in labels:
                runs = [np.asarray(r["timing"]["time_per_scan_s"]) for r in records if r["scenario"] == sc.name
                        and r["tracker"] == label and r.get("task", "track") == task]
                if not runs:
                    continue
                every = np.concatenate(runs)
                found[label] = {
                    TIME.key: mean_ci([float(x.mean()) for x in runs], plan.study.confidence, *TIME.bounds),
                    "median_s": float(np.median(every)), "p95_s": float(np.percentile(every, 95)),
                    "max_s": float(every.max()),
                }
            if found or task == "track":
                scenarios.append({"name": sc.name, "trackers" if task == "track" else "filters": found})
        return scenarios

    filters = {"filters": times([f.label for f in plan.filters], "filter")} if plan.filters else {}
    return {
        "format": TIMING_FORMAT, "format_version": FORMAT_VERSION, "fingerprint": plan.fingerprint,
        "execution": {"executor": execution.executor, "workers": execution.workers, "jobs_run": execution.jobs_run,
                      "jobs_skipped": execution.jobs_skipped, "seconds": execution.seconds},
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "processor": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
                    "nnda_version": __version__},
        "method": "time.perf_counter around each Tracker.step, one BLAS thread per job (spec A29)",
        "scenarios": times([t.label for t in plan.trackers], "track"),
        **filters,
    }


def _write_parquet(table: pa.Table, path: Path) -> None:
    with atomic_file(path) as tmp:
        pq.write_table(table, tmp)


def write_results(plan: StudyPlan, out: str | Path, execution: Execution) -> dict:
    """Aggregate every job of ``out`` into the files of the module docstring; returns the summary."""
    out = Path(out)
    records = collect(plan, out)
    summary = summarise(plan, records)
    tracking = _tracking(records)
    _write_parquet(results_table(tracking), out / RESULTS_FILE)
    _write_parquet(trajectories_table(tracking), out / TRAJECTORIES_FILE)
    _write_parquet(cardinality_table(tracking), out / CARDINALITY_FILE)
    _write_parquet(timing_table(tracking), out / TIMING_FILE)
    if plan.filters:
        _write_parquet(filter_results_table([r for r in records if r.get("task") == "filter"]),
                       out / FILTER_RESULTS_FILE)
    else:
        (out / FILTER_RESULTS_FILE).unlink(missing_ok=True)  # a study rerun without filters keeps no stale file
    write_json(out / SUMMARY_FILE, summary)
    write_json(out / TIMING_SUMMARY_FILE, summarise_timing(plan, records, execution))
    return summary


def read_summary(out: str | Path) -> tuple[dict, dict]:
    """The saved ``summary.json`` and ``timing.json`` of a study directory, with every per-tracker
    mapping back in the study's tracker order (the files sort their keys)."""
    out = Path(out)
    summary = read_json(out / SUMMARY_FILE, SUMMARY_FORMAT, FORMAT_VERSION)
    timing = read_json(out / TIMING_SUMMARY_FILE, TIMING_FORMAT, FORMAT_VERSION)
    order = [t["label"] for t in summary["trackers"]]
    for sc in summary["scenarios"] + timing["scenarios"]:
        sc["trackers"] = {label: sc["trackers"][label] for label in order}
    return summary, timing
