"""One tracker on one dataset: its track table and, where the dataset has truth, the study's scores.

Usage sketch::

    run = run_tracker(read_dataset("data/S3"), "mht", config={"n_scan": 3})   # TrackRun
    run.table            # pyarrow Table, one row per reported track per scan (TRACK_SCHEMA)
    run.scores           # RunMetrics of nnda.study.metrics.run_metrics, or None without truth

The tracker is built and stepped exactly as a study job does
(`nnda.study.track_job.run_job`: `make_tracker` with the config, the model path in
its ``model`` field, one BLAS thread, ``time.perf_counter`` around each
``step``), so the table and scores equal that job's for the same tracker,
config and dataset.

The table (`TRACK_SCHEMA`) has plain Arrow columns (no extension or
dictionary types, so pandas and polars read it as is): ``scan`` (int32,
1-based), ``time`` (s), ``track_id`` (int64), ``status`` (text: "tentative",
"preliminary", "confirmed" or "deleted"; a deleted track is reported once
more in the scan that deletes it), ``x``, ``vx``, ``y``, ``vy`` (m, m/s,
scenario frame), the 10 unique entries of the symmetric 4x4 covariance of
[x, vx, y, vy] as ``cov_<a>_<b>`` (upper triangle, row by row:
cov_x_x, cov_x_vx, cov_x_y, cov_x_vy, cov_vx_vx, ...; m^2, m^2/s, m^2/s^2),
``contact`` (int64: the row of the scan's measurements the track used, or
-1, `NO_CONTACT`, when it used none or the tracker reports no contacts) and
``detection`` (int64: that contact's row in the dataset's
``detections.parquet``, -1 likewise). Rows are in scan order, then as the
tracker reported them.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from threadpoolctl import threadpool_limits

from nnda.data.dataset import Dataset, is_collection, read_dataset
from nnda.errors import ConfigError, DatasetError
from nnda.files import read_config
from nnda.study.kinds.track import MODEL_PARAM
from nnda.study.metrics import DEFAULT_CUTOFF_M, Ownership, RunMetrics, run_metrics
from nnda.study.track_job import dataset_digest, management_record, scalars
from nnda.tracking.detection_probability import DetectionProbabilities
from nnda.tracking.output import NO_CONTACT, TrackerOutput, TrackStatus
from nnda.tracking.protocol import Tracker
from nnda.tracking.registry import make_tracker
from nnda.tracking.target_classes import TargetClassUse

STATE = ("x", "vx", "y", "vy")
#: (row, column) of the covariance's unique entries, upper triangle row by row
COV_ENTRIES = tuple((i, j) for i in range(4) for j in range(i, 4))
COV_COLUMNS = tuple(f"cov_{STATE[i]}_{STATE[j]}" for i, j in COV_ENTRIES)
STATUS_NAMES = tuple(s.name.lower() for s in TrackStatus)
TRACK_SCHEMA = pa.schema(
    [("scan", pa.int32()), ("time", pa.float64()), ("track_id", pa.int64()), ("status", pa.string())]
    + [(c, pa.float64()) for c in STATE] + [(c, pa.float64()) for c in COV_COLUMNS]
    + [("contact", pa.int64()), ("detection", pa.int64())])


@dataclass(frozen=True)
class TrackRun:
    """A tracker's run on one dataset: its per-scan outputs, their table, the time of each ``step`` (s), the
    scores (None when the dataset has no truth), a contact tracker's track management (the confirmation
    rule, deletions by reason, lines refused as too fast: `nnda.study.track_job.management_record`; None for
    other trackers), the P_D each sensor's scans were tracked with and its source (`detection_record`; None
    for a tracker that assumes none) and the class of target the sensors declare, with what the tracker took
    from it (`targets_record`; None when none is declared)."""

    tracker: str
    outputs: list[TrackerOutput]
    table: pa.Table
    step_seconds: np.ndarray
    scores: RunMetrics | None
    management: dict | None = None
    detection: DetectionProbabilities | None = None
    targets: TargetClassUse | None = None


def tracker_params(config: Mapping[str, Any] | str | Path | None, model: str | Path | None) -> dict:
    """The tracker's params: ``config`` (a mapping, or a .toml/.json file of one) with the model path in its
    ``model`` field, as a study passes it."""
    params = dict(read_config(config, "tracker config") if isinstance(config, (str, Path)) else (config or {}))
    if model is not None:
        if MODEL_PARAM in params:
            raise ConfigError(f"give the model either as --model or as the config's field {MODEL_PARAM!r}, not both")
        params[MODEL_PARAM] = str(model)
    return params


def load(dataset: Dataset | str | Path) -> Dataset:
    """A dataset, or the one dataset directory at a path (a collection is refused: name one member)."""
    if isinstance(dataset, Dataset):
        return dataset
    if is_collection(dataset):
        raise DatasetError(f"{dataset}: a collection of datasets; give one of its member directories")
    return read_dataset(dataset)


def has_truth(dataset: Dataset) -> bool:
    return dataset.truth.scan.size > 0


def _cat(parts: list[np.ndarray], empty: np.ndarray) -> np.ndarray:
    return np.concatenate(parts) if parts else empty


def track_table(dataset: Dataset, outputs: list[TrackerOutput]) -> pa.Table:
    """The `TRACK_SCHEMA` table of per-scan ``outputs`` on ``dataset``."""
    n = [len(o) for o in outputs]
    scan = np.repeat(np.array([o.scan for o in outputs], dtype=np.int32), n)
    when = np.repeat(np.array([o.time for o in outputs], dtype=np.float64), n)
    tid = _cat([o.track_id for o in outputs], np.empty(0, np.int64)).astype(np.int64)
    status = _cat([o.status for o in outputs], np.empty(0, np.int8)).astype(np.int64)
    state = _cat([o.state for o in outputs], np.empty((0, 4))).reshape(-1, 4)
    cov = _cat([o.covariance for o in outputs], np.empty((0, 4, 4))).reshape(-1, 4, 4)
    contact = _cat([o.contact for o in outputs], np.empty(0, np.int64)).astype(np.int64)
    bounds = dataset.scan_bounds()
    detection = np.where(contact == NO_CONTACT, NO_CONTACT, bounds[np.maximum(scan, 1) - 1] + contact)
    columns = {"scan": scan, "time": when, "track_id": tid,
               "status": pa.array(np.asarray(STATUS_NAMES, dtype=object)[status].tolist(), pa.string())}
    columns.update({c: state[:, i] for i, c in enumerate(STATE)})
    columns.update({c: cov[:, i, j] for c, (i, j) in zip(COV_COLUMNS, COV_ENTRIES)})
    columns.update({"contact": contact, "detection": detection.astype(np.int64)})
    return pa.Table.from_arrays([pa.array(columns[f.name], f.type) if not isinstance(columns[f.name], pa.Array)
                                 else columns[f.name] for f in TRACK_SCHEMA], schema=TRACK_SCHEMA)


def track_covariances(table: pa.Table) -> np.ndarray:
    """(R, 4, 4) the covariances of a `TRACK_SCHEMA` table's rows, from its upper-triangle columns."""
    cov = np.empty((table.num_rows, 4, 4))
    for c, (i, j) in zip(COV_COLUMNS, COV_ENTRIES):
        cov[:, i, j] = cov[:, j, i] = table[c].to_numpy()
    return cov


def run_tracker(dataset: Dataset | str | Path, tracker: str, config: Mapping[str, Any] | str | Path | None = None,
                model: str | Path | None = None, cutoff_m: float = DEFAULT_CUTOFF_M, ownership: Ownership = "auto",
                on_scan: Callable[[int, int], None] | None = None, score: bool = True) -> TrackRun:
    """Run ``tracker`` (a registered name) on every scan of ``dataset``, as a study job does; score it by
    `run_metrics` when the dataset has truth and ``score`` is true. ``on_scan(done, total)`` is called after
    each scan."""
    dataset = load(dataset)
    params = tracker_params(config, model)
    with threadpool_limits(1):
        t = make_tracker(tracker, dataset.scenario.sensors, params)
        outputs, seconds = [], np.empty(dataset.n_scans)
        for i, scan in enumerate(dataset.scans()):
            start = time.perf_counter()
            outputs.append(t.step(scan))
            seconds[i] = time.perf_counter() - start
            if on_scan is not None:
                on_scan(i + 1, dataset.n_scans)
        scores = run_metrics(dataset, outputs, cutoff_m, ownership) if score and has_truth(dataset) else None
    return TrackRun(tracker, outputs, track_table(dataset, outputs), seconds, scores, *run_records(t))


def run_records(tracker: Tracker) -> tuple[dict | None, DetectionProbabilities | None, TargetClassUse | None]:
    """What a `TrackRun` records of the tracker that made it, in its field order: ``management``
    (`nnda.study.track_job.management_record`), ``detection`` (`detection_record`), ``targets``
    (`targets_record`)."""
    return management_record(tracker), detection_record(tracker), targets_record(tracker)


def detection_record(tracker: Tracker) -> DetectionProbabilities | None:
    """The P_D per sensor a built tracker assumes and where each came from (its ``detection``,
    `nnda.tracking.detection_probability`), None for a tracker that assumes none."""
    found = getattr(tracker, "detection", None)
    return found if isinstance(found, DetectionProbabilities) else None


def targets_record(tracker: Tracker) -> TargetClassUse | None:
    """The class of target a built tracker's sensors declare and what it took from it (its ``targets``,
    `nnda.tracking.target_classes`), None when none is declared or the tracker takes none."""
    found = getattr(tracker, "targets", None)
    return found if isinstance(found, TargetClassUse) else None


SCORES_FORMAT = "nnda.track-scores"
SCORES_FORMAT_VERSION = 1


def scores_record(run: TrackRun, dataset: Dataset, params: Mapping[str, Any], cutoff_m: float) -> dict:
    """``scores.json``: what was run on what, the ownership used, every run measure (`scalars`: a per-scan
    measure's mean over scans, undefined ones null; ``metrics`` and ``ownership`` null for a dataset without
    truth, whose run is recorded all the same) and, for a contact tracker, its ``track_management``
    (the confirmation rule, deletions by reason, lines refused as too fast) and, for a tracker that assumes a
    P_D, ``detection_probability``: per sensor its P_D and where it came from (`TrackRun.detection`), and
    where the sensors declare a class of target, ``target_class``: the class, its sensors, the window and the
    values taken (`TrackRun.targets`). No
    wall-clock time: the same inputs give the same bytes."""
    scored = run.scores is not None
    return {
        "format": SCORES_FORMAT, "format_version": SCORES_FORMAT_VERSION, "tracker": run.tracker,
        "params": dict(params), "scenario": dataset.scenario.name, "dataset_digest": dataset_digest(dataset),
        "n_scans": dataset.n_scans, "n_targets": len(dataset.scenario.targets), "cutoff_m": cutoff_m,
        "ownership": run.scores.ownership if scored else None, "metrics": scalars(run.scores) if scored else None,
    } | ({} if run.management is None else {"track_management": run.management}) | (
        {} if run.detection is None else {"detection_probability": run.detection.record()}) | (
        {} if run.targets is None else {"target_class": run.targets.record()})
