"""The tracker jobs' aggregates: raw tables, means with confidence intervals, per-scan averages.

Rebuilt from the job records in plan order (scenario, tracker, run), so
they do not depend on the order jobs finished:

* ``results.parquet``: one row per job: scenario, tracker, kind, run, seed,
  dataset digest, the track ownership used ("contacts" or "position"), the
  value of every run measure of `nnda.study.measures` (columns in key
  order; counts as int64), the contact trackers' confirmation rule,
  deletions by reason and the lines of contacts refused as faster than
  ``lifecycle.v_max`` (``confirmation``, ``deleted_<reason>``,
  ``too_fast_lines``; null for other trackers, and ``too_fast_lines`` for
  records written before it was kept), with a tracker of track
  continuation (``continuation_gate`` above 0) the new tracks that
  continued a coasting one (``continued_tracks``; null for the trackers
  without it; a study without such a tracker has no such column), with a
  tracker that learns a sensor's P_D (``lifecycle.estimate_pd``) the
  values learnt by the run's end, per sensor (``learnt_pd``, a list; null
  for a tracker or sensor not learnt; likewise only when present), and the
  per-scan series as list columns
  (``<series name>_per_scan``). The series of
  ``false_tracks_per_scan`` is named ``false_tracks``, so its list column
  takes the name of the run value (its mean, which is left out): format
  version 1 keeps that layout. A study with a tracker of lag L > 0
  (`nnda.tracking.lag`) adds ``lag`` (int32: L, 0 for a tracker without)
  and the lagged output's measures and series, ``lag_<measure>`` and
  ``lag_<series name>_per_scan`` (null for a tracker without a lag); a
  study without lags has none of these columns;
* in ``summary.json``: per scenario and tracker, mean and t-interval over
  runs of every run measure (cut to the measure's ``bounds``), every
  per-scan series averaged over runs, and the ownership kinds its runs used;
  for a tracker with a lag also ``lagged``: ``lag``, and the ``metrics`` and
  ``series_mean`` of its lagged output (the online ones stay the headline);
* ``trajectories.parquet``: run 0's truth and every confirmed track's
  reports (the report's trajectory plot);
* ``cardinality.parquet``: one row per tracker job, the target count of every
  scan: true, confirmed tracks and the filter's own estimate
  (`nnda.study.cardinality`);
* ``timing.parquet`` and, in ``timing.json``, the wall-clock time per scan
  of every job and its aggregates (for a tracker with a lag, ``lagged``: the
  time of the fixed-lag revision alone, per scan);
* ``classifier.json``: what the study's model files say of themselves and
  their ROC (`nnda.study.classifier`), and ``ablation.json``: the feature
  ablation the study names (none without one).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa

from nnda.errors import DatasetError
from nnda.models.ablation import ABLATION_FILE
from nnda.study.cardinality import CARDINALITY_FILE, cardinality_table
from nnda.study.classifier import CLASSIFIER_FILE, evaluate_models
from nnda.study.measures import RUN_MEASURES, SERIES_MEASURES, TIME, time_summary
from nnda.study.stats import mean_ci, ragged_mean
from nnda.tracking.lifecycle import DELETION_REASONS
from nnda.tracking.output import TrackStatus

if TYPE_CHECKING:
    from nnda.study.kinds.track import TrackPlan

RESULTS_FILE = "results.parquet"
TRAJECTORIES_FILE = "trajectories.parquet"
TIMING_FILE = "timing.parquet"
#: GOSPA's fixed parameters (the cut-off is the study's)
GOSPA_P, GOSPA_ALPHA = 2, 2


def ordered(plan: TrackPlan, records: list[dict]) -> list[dict]:
    """The tracker records in (scenario, tracker, run) order; checks that every tracker of a run saw the same
    data."""
    order = {(s.name, t.label): (i, j) for i, s in enumerate(plan.scenarios) for j, t in enumerate(plan.trackers)}
    records = sorted(records, key=lambda r: (*order[r["scenario"], r["tracker"]], r["run"]))
    seen: dict[tuple[str, int], str] = {}
    for r in records:
        first = seen.setdefault((r["scenario"], r["run"]), r["dataset_digest"])
        if first != r["dataset_digest"]:
            raise DatasetError(f"the trackers of {r['scenario']} run {r['run']} did not see the same data "
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
    # the contact trackers' track management: confirmation rule and deletions by reason; null otherwise
    managed = [r.get("track_management") for r in records]
    cols["confirmation"] = _column([None if m is None else m["confirmation"] for m in managed], "str")
    for reason in DELETION_REASONS:
        cols[f"deleted_{reason}"] = _column([None if m is None else m["deletions"][reason] for m in managed], "int")
    cols["too_fast_lines"] = _column([None if m is None else m.get("too_fast_lines") for m in managed], "int")
    if any(m is not None and "continued" in m for m in managed):
        cols["continued_tracks"] = _column([None if m is None else m.get("continued") for m in managed], "int")
    if any(m is not None and "learnt_pd" in m for m in managed):
        cols["learnt_pd"] = pa.array([None if m is None else m.get("learnt_pd") for m in managed],
                                     type=pa.list_(pa.float64()))
    for m in SERIES_MEASURES:  # false_tracks -> false_tracks_per_scan replaces that run value (module docstring)
        kind = pa.int64() if m.integer else pa.float64()
        cols[f"{m.series_name}_per_scan"] = pa.array([r["series"][m.series_name] for r in records],
                                                     type=pa.list_(kind))
    if any("lagged" in r for r in records):
        cols.update(_lagged_columns(records))
    return pa.table(cols)


def _lagged_columns(records: list[dict]) -> dict[str, pa.Array]:
    """The lagged output's columns of `results_table` (module docstring): ``lag``, ``lag_<measure>``,
    ``lag_<series name>_per_scan``; null in the rows of trackers without a lag."""
    lagged = [r.get("lagged") for r in records]
    cols = {"lag": _column([0 if g is None else g["lag"] for g in lagged], "int32")}
    for m in sorted(RUN_MEASURES, key=lambda m: m.key):
        kind = "int" if m.integer and not m.per_scan else "float"
        cols[f"lag_{m.key}"] = _column([None if g is None else g["metrics"][m.key] for g in lagged], kind)
    for m in SERIES_MEASURES:
        kind = pa.int64() if m.integer else pa.float64()
        cols[f"lag_{m.series_name}_per_scan"] = pa.array(
            [None if g is None else g["series"][m.series_name] for g in lagged], type=pa.list_(kind))
    return cols


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


def summarise(plan: TrackPlan, records: list[dict]) -> dict:
    """The tracker entries of ``summary.json`` (deterministic: no timing, no paths)."""
    conf = plan.study.confidence
    scenarios = []
    for sc in plan.scenarios:
        trackers = {}
        for t in plan.trackers:
            mine = [r for r in records if r["scenario"] == sc.name and r["tracker"] == t.label]
            trackers[t.label] = {
                "kind": t.kind, "model": t.model, "runs": len(mine),
                "ownership": sorted({r["ownership"] for r in mine}),
                "metrics": {m.key: mean_ci([r["metrics"][m.key] for r in mine], conf, *m.bounds) for m in RUN_MEASURES},
                "series_mean": {m.series_name: ragged_mean([r["series"][m.series_name] for r in mine])
                                for m in SERIES_MEASURES},
            }
            if t.lag:
                late = [r["lagged"] for r in mine]
                trackers[t.label]["lagged"] = {
                    "lag": t.lag,
                    "metrics": {m.key: mean_ci([g["metrics"][m.key] for g in late], conf, *m.bounds)
                                for m in RUN_MEASURES},
                    "series_mean": {m.series_name: ragged_mean([g["series"][m.series_name] for g in late])
                                    for m in SERIES_MEASURES},
                }
        scenarios.append({"name": sc.name, "source": sc.description, "runs": sc.runs, "n_scans": sc.scenario.n_scans,
                          "targets": [tg.name for tg in sc.scenario.targets], "trackers": trackers})
    return {
        "gospa": {"cutoff_m": plan.study.gospa_cutoff_m, "p": GOSPA_P, "alpha": GOSPA_ALPHA},
        "ownership": plan.study.ownership,
        "trackers": [{"label": t.label, "kind": t.kind, "model": t.model} for t in plan.trackers],
        "scenarios": scenarios,
    }


def summarise_timing(plan: TrackPlan, records: list[dict]) -> dict:
    """The tracker entries of ``timing.json``: time per scan per scenario and tracker."""
    scenarios = []
    for sc in plan.scenarios:
        found = {}
        for t in plan.trackers:
            runs = [r["timing"]["time_per_scan_s"] for r in records if r["scenario"] == sc.name
                    and r["tracker"] == t.label]
            if runs:
                found[t.label] = time_summary(runs, plan.study.confidence)
            late = [r["timing"]["lag_time_per_scan_s"] for r in records if r["scenario"] == sc.name
                    and r["tracker"] == t.label and "lag_time_per_scan_s" in r["timing"]]
            if runs and late:  # the fixed-lag revision's own time per scan, beside the tracker's step
                found[t.label]["lagged"] = time_summary(late, plan.study.confidence)
        scenarios.append({"name": sc.name, "trackers": found})
    return {"method": "time.perf_counter around each Tracker.step, one BLAS thread per job",
            "scenarios": scenarios}


def aggregate(plan: TrackPlan, records: list[dict]) -> tuple[dict, dict, dict]:
    """The tracker jobs' entries of ``summary.json`` and ``timing.json`` and their files (module docstring):
    tables, classifier.json and ablation.json (None: the study names no ablation, a stale copy goes)."""
    records = ordered(plan, records)
    files = {RESULTS_FILE: results_table(records), TRAJECTORIES_FILE: trajectories_table(records),
             CARDINALITY_FILE: cardinality_table(records), TIMING_FILE: timing_table(records),
             CLASSIFIER_FILE: evaluate_models(plan.models),
             ABLATION_FILE: plan.ablation}
    return summarise(plan, records), summarise_timing(plan, records), files
