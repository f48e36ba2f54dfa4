"""nnda's Python API: the few calls a script needs, each a front to the library's own functions.

    import nnda
    ds = nnda.generate("S3", seed=0, run=0)                  # a Dataset of a preset (or a Scenario)
    ds = nnda.read_dataset("data/plots")                     # or one on disk (`nnda import-detections`)
    tracks = nnda.track(ds, "mht", config={"n_scan": 3})    # pyarrow Table, one row per track per scan
    late = nnda.track(ds, "mht", lag=3)                      # the fixed-lag table: each scan revised 3 scans on
    result = nnda.run_study("studies/harbour.toml", "out/harbour")   # a study file, run and reported
    ss_tracks = nnda.to_stonesoup(tracks, ds)                # Stone Soup Tracks (the peers extra)
    ss_truth = nnda.truth_to_stonesoup(ds)                   # and GroundTruthPaths, for its metrics

``nnda`` itself imports this module only when one of these names is first
used, so ``import nnda`` stays light.
"""

from __future__ import annotations

import numbers
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from nnda.data import dataset as _dataset
from nnda.data.dataset import Dataset
from nnda.data.generator import generate as _generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Scenario
from nnda.errors import ConfigError, DatasetError

if TYPE_CHECKING:
    from stonesoup.types.groundtruth import GroundTruthPath
    from stonesoup.types.track import Track

__all__ = ["generate", "read_dataset", "run_study", "to_stonesoup", "track", "truth_to_stonesoup"]

#: what each kind of argument accepts, as the error message says it
_PATH = (str, os.PathLike)
_PATH_TEXT = "a path (str or pathlib.Path)"


def _argument(call: str, name: str, value: Any, types: tuple[type, ...], accepted: str) -> None:
    """ConfigError naming the call, the argument, the value and its type, and what is accepted, unless
    ``value`` is one of ``types`` (a bool is never taken for a number, nor an empty string for a name)."""
    if isinstance(value, str) and not value:
        raise ConfigError(f"nnda.{call}: argument {name!r} is an empty string; give {accepted}")
    if not isinstance(value, types) or (isinstance(value, bool) and bool not in types):
        shown = repr(value) if len(repr(value)) <= 60 else repr(value)[:57] + "..."
        raise ConfigError(f"nnda.{call}: argument {name!r} is {shown} of type {type(value).__name__}; give "
                          f"{accepted}")


def track(dataset: Dataset | str | Path, tracker: str, config: Mapping[str, Any] | str | Path | None = None,
          model: str | Path | None = None, lag: int = 0) -> pa.Table:
    """The track table (`nnda.study.track.TRACK_SCHEMA`) of ``tracker`` (a registered name) on ``dataset`` (a
    `Dataset` or a dataset directory), stepped exactly as a study job steps it; ``config``: the tracker's params
    (a mapping or a .toml/.json file), ``model``: the model file of ``nn``. With ``lag`` L > 0 the table of the
    fixed-lag output instead (`nnda.tracking.lag`: the same rows, each scan's tracks revised with the L scans
    after it: confirmations back-filled, states smoothed, MHT's decided contacts). A wrong argument is a
    ConfigError naming it; a config file's problems name the file."""
    from nnda.study.track import load, run_tracker, tracker_params  # the trackers load only when one runs
    from nnda.tracking.lag import checked_lag
    from nnda.tracking.registry import check_config

    _argument("track", "dataset", dataset, (Dataset, *_PATH), f"a Dataset or a dataset directory as {_PATH_TEXT}")
    _argument("track", "tracker", tracker, (str,), "a registered tracker's name (str), e.g. 'gnn'")
    _argument("track", "config", config, (Mapping, *_PATH, type(None)),
              f"a mapping of the tracker's options, a .toml or .json file as {_PATH_TEXT}, or None")
    _argument("track", "model", model, (*_PATH, type(None)), f"the nn tracker's model file as {_PATH_TEXT}, or None")
    _argument("track", "lag", lag, (numbers.Integral,), "a whole number of scans >= 0")
    lag = checked_lag(lag, "nnda.track: argument 'lag'")
    params = tracker_params(config, model)
    where = f"tracker config {os.fspath(config)}" if isinstance(config, _PATH) else "tracker config"
    dataset = load(dataset)
    check_config(tracker, params, where, dataset.scenario.sensors)  # with the class of target they declare
    if lag:
        return lagged_runs(dataset, tracker, params, lag, score=False)[1].table
    return run_tracker(dataset, tracker, params, score=False).table


def lagged_runs(dataset: Dataset | str | Path, tracker: str, params: Mapping[str, Any], lag: int,
                cutoff_m: float | None = None, ownership: str = "auto", on_scan=None, score: bool = True):
    """``tracker`` with ``params`` on ``dataset`` as a study job with a lag ``lag`` > 0 steps it
    (`nnda.study.track_job.step_run`): its online `TrackRun` and its fixed-lag one (the revision's own time
    per scan as ``step_seconds``), each scored where the dataset has truth and ``score`` is true."""
    from threadpoolctl import threadpool_limits

    from nnda.study.metrics import DEFAULT_CUTOFF_M, run_metrics
    from nnda.study.track import TrackRun, has_truth, load, run_records, track_table
    from nnda.study.track_job import step_run
    from nnda.tracking.registry import make_tracker

    dataset = load(dataset)
    cutoff_m = DEFAULT_CUTOFF_M if cutoff_m is None else cutoff_m
    with threadpool_limits(1):
        stepped = make_tracker(tracker, dataset.scenario.sensors, dict(params))
        outputs, lagged, seconds, lag_seconds, _ = step_run(stepped, dataset, lag, on_scan)
        scored = score and has_truth(dataset)
        records = run_records(stepped)
        runs = tuple(TrackRun(tracker, o, track_table(dataset, o), t,
                              run_metrics(dataset, o, cutoff_m, ownership) if scored else None, *records)
                     for o, t in ((outputs, seconds), (lagged, lag_seconds)))
    return runs


def generate(scenario: Scenario | str, seed: int = 0, run: int = 0) -> Dataset:
    """Run ``run`` of ``scenario`` (a `Scenario` or a preset name, see ``nnda presets``) drawn with ``seed``: the
    same dataset ``nnda generate`` writes and a study's job sees."""
    _argument("generate", "scenario", scenario, (Scenario, str), "a Scenario or a preset name (str), e.g. 'S3'")
    if isinstance(scenario, str):
        if scenario not in PRESETS:
            raise ConfigError(f"unknown preset {scenario!r}; presets: {', '.join(PRESETS)}")
        scenario = PRESETS[scenario]
    return _generate(scenario, seed, run)


def read_dataset(path: str | Path) -> Dataset:
    """The dataset directory at ``path`` (`nnda.data.dataset.read_dataset`: every file checked)."""
    _argument("read_dataset", "path", path, _PATH, f"a dataset directory as {_PATH_TEXT}")
    return _dataset.read_dataset(path)


def run_study(study: str | Path, out: str | Path, resume: bool = False, jobs: int = 2, dask: str | None = None,
              overwrite: bool = False, report: bool = True) -> Path:
    """Run the study file ``study`` into directory ``out`` as ``nnda compare`` does (every input checked first;
    ``resume``, ``jobs`` local processes or a ``dask`` scheduler address) and, with ``report``, write its report;
    returns ``out``."""
    from nnda.reports.study_report import write_report
    from nnda.study.compare import compare
    from nnda.study.config import load_study

    _argument("run_study", "study", study, _PATH, f"a study file (.toml or .json) as {_PATH_TEXT}")
    _argument("run_study", "out", out, _PATH, f"the output directory as {_PATH_TEXT}")
    for name, value in (("resume", resume), ("overwrite", overwrite), ("report", report)):
        _argument("run_study", name, value, (bool,), "True or False")
    _argument("run_study", "jobs", jobs, (numbers.Integral,), "a whole number of local processes >= 1")
    if jobs < 1:
        raise ConfigError(f"nnda.run_study: argument 'jobs' is {jobs}; give a whole number of local processes >= 1")
    _argument("run_study", "dask", dask, (str, type(None)), "a Dask scheduler address (str), or None")
    compare(load_study(study), out, resume=resume, workers=int(jobs), dask=dask, where=str(study), overwrite=overwrite)
    if report:
        write_report(out)
    return Path(out)


def to_stonesoup(tracks: pa.Table | str | Path, dataset: Dataset | str | Path | None = None,
                 statuses: str | Iterable[str] = "confirmed") -> list[Track]:
    """A track table as Stone Soup tracks (the ``peers`` extra), for Stone Soup's metrics and plotters: one
    ``stonesoup.types.track.Track`` per track id, its ``id`` the id as text, in increasing id order; each
    kept row a ``GaussianState`` of [x, vx, y, vy] (Stone Soup's order for a 2-D constant-velocity target)
    and the 4x4 covariance, with the row's status, scan, contact and detection in the track's ``metadatas``
    (`nnda.peers.export`, which says why plain Gaussian states).

    ``tracks``: the table of `track` (`nnda.study.track.TRACK_SCHEMA`), or the ``tracks.parquet`` (or
    ``.csv``) that ``nnda track`` writes; further columns (``lat``, ``lon``) are ignored. ``statuses``: the
    statuses whose rows are kept, "confirmed" (the default: the tracks a Stone Soup tracker outputs, and the
    ones nnda's GOSPA and OSPA score) and/or "preliminary". A row of status "deleted" is a track's report in
    the scan that deletes it, not an estimate: never kept. ``dataset`` (a `Dataset` or its directory): the
    tracks' dataset; its ``time_origin_utc`` (an import of absolute times) dates the states, and each row's
    time is checked against the dataset's scan times. Without one, or without an origin, second t is
    `nnda.peers.adapter.EPOCH` + t, as the truth of `truth_to_stonesoup`. A table that is not a track table
    (a column missing, a value of the wrong kind) is a ConfigError or DatasetError naming the file, the row
    and the column."""
    from nnda.peers import require_stonesoup
    from nnda.study.track import STATE, load, track_covariances

    _argument("to_stonesoup", "tracks", tracks, (pa.Table, *_PATH),
              f"the track table of nnda.track (a pyarrow Table), or the tracks.parquet of nnda track as {_PATH_TEXT}")
    _argument("to_stonesoup", "dataset", dataset, (Dataset, *_PATH, type(None)),
              f"a Dataset or a dataset directory as {_PATH_TEXT}, or None")
    kept = _statuses(statuses)
    require_stonesoup("nnda.to_stonesoup")
    from nnda.peers.export import to_tracks

    label, table = _track_table(tracks)
    if dataset is not None:
        dataset = load(dataset)
        _check_times(label, table, dataset)
    table = table.filter(pc.is_in(table["status"], pa.array(kept)))
    state = np.column_stack([table[c].to_numpy() for c in STATE]).reshape(-1, 4)
    metadata = {c: table[c].to_numpy(zero_copy_only=False) for c in ("status", "scan", "contact", "detection")}
    return to_tracks(table["track_id"].to_numpy(), table["time"].to_numpy(), state, track_covariances(table), metadata,
                     None if dataset is None else dataset.time_origin_utc)


def truth_to_stonesoup(dataset: Dataset | str | Path) -> list[GroundTruthPath]:
    """The truth of ``dataset`` (a `Dataset` or its directory) as Stone Soup ground truth (the ``peers``
    extra): one ``stonesoup.types.groundtruth.GroundTruthPath`` per target with truth rows, its ``id`` the
    target's name, each scan it exists in a ``GroundTruthState`` [x, vx, y, vy] (m, m/s) with the target's
    index and whether it was detected in its ``metadata``; timestamps as `to_stonesoup` dates the tracks of
    the same dataset. No truth: an empty list.

    With `to_stonesoup`, Stone Soup's metric managers score nnda's tracks against nnda's truth: its
    ``GOSPAMetric(p=2, c=c, measure=Euclidean((0, 2)))`` on the confirmed tracks equals nnda's per-scan GOSPA
    of cut-off c (`nnda.study.metrics`) at each time Stone Soup reports (times with tracks or targets;
    nnda's are 0 at the others), and likewise ``OSPAMetric``. The mapping (0, 2) measures positions only, as
    nnda does: without it Stone Soup's distance takes in the velocities."""
    from nnda.peers import require_stonesoup
    from nnda.study.track import load

    _argument("truth_to_stonesoup", "dataset", dataset, (Dataset, *_PATH),
              f"a Dataset or a dataset directory as {_PATH_TEXT}")
    require_stonesoup("nnda.truth_to_stonesoup")
    from nnda.peers.export import to_truth_paths

    return to_truth_paths(load(dataset))


def _statuses(statuses: str | Iterable[str]) -> list[str]:
    """The statuses `to_stonesoup` keeps: "confirmed" and/or "preliminary" (a name or several); ConfigError
    for another, naming the argument."""
    from nnda.study.track import STATUS_NAMES
    from nnda.tracking.output import TrackStatus

    deleted = STATUS_NAMES[TrackStatus.DELETED]
    names = [statuses] if isinstance(statuses, str) else list(statuses) if isinstance(statuses, Iterable) else []
    if not names or not all(isinstance(n, str) for n in names):
        raise ConfigError(f"nnda.to_stonesoup: argument 'statuses' is {statuses!r}; give a status or a list of "
                          f"them: 'confirmed' and/or 'preliminary'")
    for name in names:
        if name == deleted:
            raise ConfigError("nnda.to_stonesoup: argument 'statuses' names 'deleted': a deleted track's row is its "
                              "report in the scan that deletes it, not an estimate, and is never exported; give "
                              "'confirmed' and/or 'preliminary'")
        if name not in STATUS_NAMES:
            raise ConfigError(f"nnda.to_stonesoup: argument 'statuses' names {name!r}, not a track status; give "
                              f"'confirmed' and/or 'preliminary'")
    return names


def _track_table(tracks: pa.Table | str | Path) -> tuple[Any, pa.Table]:
    """The label (its path, or "the track table") and the rows of a track table or file as
    `nnda.study.track.TRACK_SCHEMA` (further columns dropped), every value checked: numbers finite, integer
    columns whole, statuses named; ConfigError or DatasetError naming the file, row and column otherwise."""
    from nnda.data.table_reading import numbers_of, read_source, texts_of, where_in
    from nnda.study.track import STATUS_NAMES, TRACK_SCHEMA

    if isinstance(tracks, _PATH) and Path(tracks).is_dir():
        raise ConfigError(f"{os.fspath(tracks)}: a directory; give the track file in it, e.g. "
                          f"{Path(tracks) / 'tracks.parquet'}")
    label, table = read_source(tracks if isinstance(tracks, pa.Table) else Path(tracks), "track")
    missing = [n for n in TRACK_SCHEMA.names if n not in table.column_names]
    if missing:
        raise ConfigError(f"{label}: not a track table of nnda: column(s) {', '.join(missing)} missing; a track "
                          f"table (nnda.track, nnda track's tracks.parquet) has {', '.join(TRACK_SCHEMA.names)}")
    columns = []
    for f in TRACK_SCHEMA:
        if f.name == "status":
            values = np.array(texts_of(table, label, f.name), dtype=object)
            bad = ~np.isin(values, np.array(STATUS_NAMES, dtype=object))
        else:
            values = numbers_of(table, label, f.name, f.name)
            bad = values != np.round(values) if pa.types.is_integer(f.type) else np.zeros(values.size, bool)
        if bad.any():
            row = int(np.argmax(bad))
            wanted = f"one of {', '.join(STATUS_NAMES)}" if f.name == "status" else "a whole number"
            raise DatasetError(f"{where_in(label, row, f.name)}: {values[row]!r}, not {wanted}")
        columns.append(pa.array(values.tolist() if f.name == "status" else values.astype(f.type.to_pandas_dtype()),
                                f.type))
    return label, pa.Table.from_arrays(columns, schema=TRACK_SCHEMA)


def _check_times(label: Any, table: pa.Table, dataset: Dataset) -> None:
    """DatasetError naming the first row of the track ``table`` whose scan is not one of ``dataset``'s or whose
    time is not that scan's (to `nnda.data.dataset.TIME_RTOL`): tracks of another dataset."""

    scan, time = table["scan"].to_numpy(), table["time"].to_numpy()
    outside = (scan < 1) | (scan > dataset.n_scans)
    expected = dataset.scan_time[np.clip(scan, 1, dataset.n_scans) - 1]
    bad = outside | (np.abs(time - expected) > _dataset.TIME_RTOL * np.maximum(1.0, np.abs(expected)))
    if bad.any():
        row = int(np.argmax(bad))
        k, t, want = int(scan[row]), float(time[row]), float(expected[row])
        said = (f"scan {k}, but the dataset has scans 1-{dataset.n_scans}" if outside[row] else
                f"scan {k} at {t!r} s, but the dataset's scan {k} is at {want!r} s")
        raise DatasetError(f"{label}: row {row + 1} (1-based): {said}: tracks of another dataset?")
