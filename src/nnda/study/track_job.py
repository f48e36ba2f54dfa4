"""One tracker job: a tracker over one run of one scenario, measured and scored.

`run_job` is what a worker process (local or on a Dask cluster) executes. It
builds the run's dataset (generated from scenario, seed and run, or read
from disk, so every tracker sees the same data), steps the tracker through
every scan with `time.perf_counter` around each `step` (single BLAS thread;
the first job of a tracker in a process runs it once untimed
before, `_warm_up`, so no scan's time holds the loading or compiling of
numba kernels), scores the outputs with `nnda.study.metrics.run_metrics` (every
run measure of `nnda.study.measures`), records the target count of every scan
(`nnda.study.cardinality`: true, confirmed tracks, and the filter's own
estimate when the tracker keeps a ``cardinality`` record) and returns a
JSON-ready record. The caller writes the record to the job's own file;
wall-clock timings are kept apart from the metrics (``timing``) so that
everything else is bit-identical for the same seed.

A contact tracker's record also holds ``track_management``: the confirmation
rule it used and its deletions of the run by reason
(`nnda.tracking.tracker.ContactTracker.track_management`).

A job with a lag L > 0 (the study file's ``lag`` of the tracker) steps the
tracker through `nnda.tracking.lag.FixedLag` and scores its lagged outputs
too: the record's ``lagged`` holds ``lag``, ``metrics`` and ``series``
(every run measure and series of the lagged outputs, as ``metrics`` and
``series`` hold the online ones), and ``timing`` also holds
``lag_time_per_scan_s``, the time of the fixed-lag revision of each scan
(the flush at the end of the run counted in the last scan's). Without a
lag the record is what it was before the option existed.
"""

from __future__ import annotations

import json
import time
import warnings
from typing import TYPE_CHECKING

import numpy as np
from threadpoolctl import threadpool_limits

from nnda.data.dataset import Dataset
from nnda.files import digest, finite_or_none
from nnda.study.cardinality import count_record, snapshot
from nnda.study.measures import RUN_MEASURES, SERIES_MEASURES
from nnda.study.metrics import RunMetrics, run_metrics
from nnda.tracking.lag import FixedLag
from nnda.tracking.output import TrackerOutput, TrackStatus
from nnda.tracking.protocol import Tracker
from nnda.tracking.registry import make_tracker

if TYPE_CHECKING:
    from nnda.study.kinds.track import TrackJob


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


def management_record(tracker: Tracker) -> dict | None:
    """The contact trackers' track management of the run so far (`ContactTracker.track_management`: the
    confirmation rule, deletions by reason, lines refused as too fast), None for a tracker without one."""
    management = getattr(tracker, "track_management", None)
    return None if management is None else management()


def step_run(tracker: Tracker, dataset: Dataset, lag: int = 0, on_scan=None
             ) -> tuple[list[TrackerOutput], list[TrackerOutput] | None, np.ndarray, np.ndarray | None, list]:
    """Step ``tracker`` through every scan of ``dataset``, ``time.perf_counter`` around each ``step``; with
    ``lag`` > 0 through `FixedLag`, its revision timed apart. Returns the online outputs, the lagged ones
    (None without a lag; one per scan, in scan order), the seconds of each step (n_scans,), those of each
    scan's lagged revision (None without a lag; the final flush in the last scan's) and the tracker's
    count snapshot after each scan (`nnda.study.cardinality.snapshot`). ``on_scan(done, total)`` is called
    after each scan."""
    n = dataset.n_scans
    outputs, seconds, counts = [], np.empty(n), []
    lagged, lag_seconds = (None, None) if lag == 0 else ([], np.zeros(n))
    fixed = None if lag == 0 else FixedLag(tracker, lag)
    for i, scan in enumerate(dataset.scans()):
        start = time.perf_counter()
        outputs.append(tracker.step(scan))
        seconds[i] = time.perf_counter() - start
        counts.append(snapshot(tracker, scan.index))
        if fixed is not None:
            start = time.perf_counter()
            late = fixed.revise(outputs[-1])
            if late is not None:
                lagged.append(late)
            lag_seconds[i] = time.perf_counter() - start
        if on_scan is not None:
            on_scan(i + 1, n)
    if fixed is not None:
        start = time.perf_counter()
        lagged += fixed.flush()
        if n:
            lag_seconds[-1] += time.perf_counter() - start
    return outputs, lagged, seconds, lag_seconds, counts


def run_job(job: TrackJob) -> dict:
    """Run one job and return its record (see the module docstring)."""
    with threadpool_limits(1):
        dataset = job.dataset()
        _warm_up(job, dataset)
        tracker = make_tracker(job.kind, dataset.scenario.sensors, job.params)
        outputs, lagged, seconds, lag_seconds, counts = step_run(tracker, dataset, job.lag)
        m = run_metrics(dataset, outputs, job.cutoff_m, job.ownership)
        late = None if lagged is None else run_metrics(dataset, lagged, job.cutoff_m, job.ownership)
    record = {
        "scenario": job.scenario, "tracker": job.tracker, "kind": job.kind, "run": job.run, "seed": job.seed,
        "dataset_digest": dataset_digest(dataset), "n_scans": dataset.n_scans,
        "n_targets": len(dataset.scenario.targets),
        "ownership": m.ownership, "metrics": scalars(m),
        "series": series(m),
        "cardinality": count_record(*m.counts, counts),
        "timing": {"time_per_scan_s": seconds.tolist()},
    }
    management = management_record(tracker)
    if management is not None:
        record["track_management"] = management
    if late is not None:
        record["lagged"] = {"lag": job.lag, "metrics": scalars(late), "series": series(late)}
        record["timing"]["lag_time_per_scan_s"] = lag_seconds.tolist()
    if job.keeps_tracks:
        record.update(_tracks(outputs, dataset))
    return record


#: the trackers (kind and params) this process has run untimed (`_warm_up`)
_WARM: set[str] = set()


def _warm_up(job: TrackJob, dataset: Dataset) -> None:
    """The first time this process runs the job's tracker (kind and params), step a copy of it through
    ``dataset`` untimed, its warnings silenced (the timed run gives them). The first call of each compiled
    kernel loads it from numba's cache (about 0.15 s for the neural tracker's) or, on a fresh install,
    compiles it (seconds): not a cost of the scan it falls in, and it would land on whichever scenario runs
    first in each process. A job with a lag warms its fixed-lag revision too (its lag is part of the key)."""
    key = json.dumps([job.kind, job.params] + ([job.lag] if job.lag else []), sort_keys=True, default=str)
    if key in _WARM:
        return
    tracker = make_tracker(job.kind, dataset.scenario.sensors, job.params)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        step_run(tracker, dataset, job.lag)  # with a lag, the revision's kernels too
    _WARM.add(key)
