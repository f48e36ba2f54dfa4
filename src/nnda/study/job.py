"""One job of a study: a tracker over one run of one scenario (or a single-target filter), measured and scored.

`run_job` is what a worker process (local or on a Dask cluster) executes. It
builds the run's dataset (generated from scenario, seed and run, or read
from disk, so every tracker sees the same data), steps the tracker through
every scan with `time.perf_counter` around each `step` (single BLAS thread,
spec A29; the first job of a tracker in a process runs it once untimed
before, `_warm_up`, so no scan's time holds the loading or compiling of
numba kernels), scores the outputs with `nnda.study.metrics.run_metrics` (every
run measure of `nnda.study.measures`), records the target count of every scan
(`nnda.study.cardinality`: true, confirmed tracks, and the filter's own
estimate when the tracker keeps a ``cardinality`` record) and returns a
JSON-ready record. The caller writes the record to the job's own file;
wall-clock timings are kept apart from the metrics (``timing``) so that
everything else is bit-identical for the same seed.

A "filter" job (`JobSpec.task`) runs a single-target filter
(`nnda.filters.single_target`) through the target's own contacts (the
generator's labels pick them: no association) and scores its estimates
against the truth with `nnda.study.filter_measures`; its record has the
same layout, with those measures.

A contact tracker's record also holds ``track_management``: the confirmation
rule it used and its deletions of the run by reason
(`nnda.tracking.tracker.ContactTracker.track_management`).
"""

from __future__ import annotations

import json
import time
import warnings

import numpy as np
from threadpoolctl import threadpool_limits

from nnda.data.dataset import Dataset, read_dataset
from nnda.data.generator import generate
from nnda.files import digest, finite_or_none
from nnda.filters.single_target import make_filter
from nnda.study.cardinality import count_record, snapshot
from nnda.study.filter_measures import FILTER_MEASURES, FILTER_SERIES, FilterRun
from nnda.study.measures import RUN_MEASURES, SERIES_MEASURES
from nnda.study.metrics import RunMetrics, run_metrics
from nnda.study.plan import JobSpec
from nnda.tracking.output import TrackStatus
from nnda.tracking.registry import make_tracker

JOB_FORMAT = "nnda.study-job"
#: 2: CLEAR-MOT measures and the ownership kind used; 3: the record's own SHA-256; 4: the OSPA parts and the
#: per-scan target counts (``cardinality``, `nnda.study.cardinality`). Older records are run again on resume
#: (`nnda.study.runner.is_done`) and refused by `nnda.study.runner.read_job`, naming the version.
JOB_FORMAT_VERSION = 4

def dataset_digest(dataset: Dataset) -> str:
    """SHA-256 of a dataset's contacts: equal digests mean the trackers saw the same data."""
    d = dataset.detections
    return digest(*(np.ascontiguousarray(a).tobytes() for a in (d.scan, d.range, d.azimuth, d.target_id)))


def scalars(m: RunMetrics) -> dict[str, float | int | None]:
    """The run's single numbers, one per run measure (a per-scan measure's mean over scans): counts
    as ints, other values as floats, undefined ones (NaN, or no contacts to count) as None."""
    return {k: (v if isinstance(v, int) or v is None else finite_or_none(float(v)))
            for k, v in ((ms.key, m.values[ms.key]) for ms in RUN_MEASURES)}


def series(m: RunMetrics) -> dict[str, list]:
    """The per-scan series of the run, by their record names (`Measure.series_name`)."""
    return {ms.series_name: m.series[ms.key].tolist() for ms in SERIES_MEASURES}


def _tracks(outputs, dataset: Dataset) -> dict:
    """Rows of every track that was ever confirmed (all its reports), and the truth, as lists."""
    scan = np.concatenate([np.full(len(o), o.scan) for o in outputs])
    tid = np.concatenate([o.track_id for o in outputs])
    status = np.concatenate([o.status for o in outputs])
    state = np.concatenate([o.state for o in outputs]).reshape(-1, 4)
    keep = np.isin(tid, np.unique(tid[status == TrackStatus.CONFIRMED]))
    order = np.lexsort((scan[keep], tid[keep]))
    t = dataset.truth
    return {
        "tracks": {"scan": scan[keep][order].tolist(), "time": dataset.scan_time[scan[keep][order] - 1].tolist(),
                   "track_id": tid[keep][order].tolist(), "status": status[keep][order].tolist(),
                   "x": state[keep, 0][order].tolist(), "y": state[keep, 2][order].tolist()},
        "truth": {"scan": t.scan.tolist(), "time": t.time.tolist(), "target_id": t.target_id.tolist(),
                  "x": t.x.tolist(), "y": t.y.tolist(), "detected": t.detected.tolist(),
                  "target_names": [tg.name for tg in dataset.scenario.targets]},
    }


def run_job(job: JobSpec) -> dict:
    """Run one job and return its record (see the module docstring)."""
    with threadpool_limits(1):
        dataset = read_dataset(job.dataset) if job.dataset is not None else generate(job.generate, job.seed, job.run)
        if job.task == "filter":
            return _run_filter(job, dataset)
        _warm_up(job, dataset)
        tracker = make_tracker(job.kind, dataset.scenario.sensors, job.params)
        outputs, seconds, counts = [], np.empty(dataset.n_scans), []
        for i, scan in enumerate(dataset.scans()):
            start = time.perf_counter()
            outputs.append(tracker.step(scan))
            seconds[i] = time.perf_counter() - start
            counts.append(snapshot(tracker, scan.index))
        m = run_metrics(dataset, outputs, job.cutoff_m, job.ownership)
    record = {
        "format": JOB_FORMAT, "format_version": JOB_FORMAT_VERSION, "key": job.key,
        "scenario": job.scenario, "tracker": job.tracker, "kind": job.kind, "run": job.run, "seed": job.seed,
        "dataset_digest": dataset_digest(dataset), "n_scans": dataset.n_scans,
        "n_targets": len(dataset.scenario.targets),
        "ownership": m.ownership, "metrics": scalars(m),
        "series": series(m),
        "cardinality": count_record(*m.counts, counts),
        "timing": {"time_per_scan_s": seconds.tolist()},
    }
    management = getattr(tracker, "track_management", None)  # the contact trackers' (issue 21)
    if management is not None:
        record["track_management"] = management()
    if job.keeps_tracks:
        record.update(_tracks(outputs, dataset))
    return record


#: the trackers (kind and params) this process has run untimed (`_warm_up`)
_WARM: set[str] = set()


def _warm_up(job: JobSpec, dataset: Dataset) -> None:
    """The first time this process runs the job's tracker (kind and params), step a copy of it through
    ``dataset`` untimed, its warnings silenced (the timed run gives them). The first call of each compiled
    kernel loads it from numba's cache (about 0.15 s for the neural tracker's) or, on a fresh install,
    compiles it (seconds): not a cost of the scan it falls in, and it would land on whichever scenario runs
    first in each process."""
    key = json.dumps([job.kind, job.params], sort_keys=True, default=str)
    if key in _WARM:
        return
    tracker = make_tracker(job.kind, dataset.scenario.sensors, job.params)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for scan in dataset.scans():
            tracker.step(scan)
    _WARM.add(key)


def _run_value(series: np.ndarray) -> float:
    """A per-scan filter measure's run value: its mean over the scans where it is defined (NaN if none)."""
    finite = series[np.isfinite(series)]
    return float(finite.mean()) if finite.size else float("nan")


def _run_filter(job: JobSpec, dataset: Dataset) -> dict:
    """A filter job's record: the filter through the target's own contacts, scored against the truth."""
    f = make_filter(job.kind, dataset.scenario.sensors, job.params)
    truth, bounds = dataset.truth, dataset.scan_bounds()
    own = dataset.detections.target_id == 0
    rows = np.flatnonzero(truth.target_id == 0)  # the scans where the target exists, in scan order
    alive = set(truth.scan[rows].tolist())
    x, P = np.full((len(rows), 4), np.nan), np.full((len(rows), 4, 4), np.nan)
    seconds = np.empty(len(rows))
    i = 0
    for scan in dataset.scans():
        if scan.index not in alive:
            continue
        mine = np.flatnonzero(own[bounds[scan.index - 1]:bounds[scan.index]])  # at most one contact per scan
        start = time.perf_counter()
        est = f.step(float(scan.time), scan.sensor, scan.measurements[mine[0]] if mine.size else None)
        seconds[i] = time.perf_counter() - start
        if est is not None:
            x[i], P[i] = est.x, est.P
        i += 1
    run = FilterRun(dataset.scan_time[truth.scan[rows] - 1], x, P,
                    np.column_stack([truth.x[rows], truth.vx[rows], truth.y[rows], truth.vy[rows]]))
    values = {m.key: m.compute(run) for m in FILTER_MEASURES}
    return {
        "format": JOB_FORMAT, "format_version": JOB_FORMAT_VERSION, "key": job.key, "task": "filter",
        "scenario": job.scenario, "tracker": job.tracker, "kind": job.kind, "run": job.run, "seed": job.seed,
        "dataset_digest": dataset_digest(dataset), "n_scans": dataset.n_scans, "n_targets": 1,
        "metrics": {m.key: finite_or_none(_run_value(values[m.key]) if m.per_scan else values[m.key])
                    for m in FILTER_MEASURES},
        "series": {m.series_name: [finite_or_none(float(v)) for v in values[m.key]] for m in FILTER_SERIES},
        "timing": {"time_per_scan_s": seconds.tolist()},
    }
