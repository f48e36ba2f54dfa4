"""nnda's tracks and truth as Stone Soup objects, for Stone Soup's metrics, plotters and tools.

Usage sketch (``nnda.to_stonesoup`` and ``nnda.truth_to_stonesoup`` read a track table and a dataset into
these arguments)::

    tracks = to_tracks(track_id, time, state, covariance, metadata, time_origin_utc)  # R report rows
    tracks[0].states[0].state_vector        # StateVector (4, 1): [x, vx, y, vy], m and m/s
    tracks[0].metadatas[0]["status"]        # "confirmed": the row's status, scan, contact, detection
    paths = to_truth_paths(dataset)         # one GroundTruthPath per target, id = the target's name

* **States**: Stone Soup's state of a 2-D constant-velocity target is
  [x, vx, y, vy] (its ``CombinedLinearGaussianTransitionModel`` of two
  ``ConstantVelocity`` models, one per axis), nnda's order too, so a row's
  state and 4x4 covariance are copied as they are. Each state is a plain
  ``GaussianState``, not a ``GaussianStateUpdate`` or
  ``GaussianStatePrediction``: those carry the prior x_{k|k-1}, P_{k|k-1}
  (an update its hypothesis's prediction), which a track table does not
  keep, and a tracker that reports no contacts (the PHD family) reports
  updated states all the same. Stone Soup's Kalman smoothers read those
  priors, so they refuse these tracks (TypeError) rather than smooth with
  wrong ones; nnda's own fixed-lag output (``nnda.track(..., lag=L)``)
  smooths with the tracker's model.
* **Metadata**: a ``GaussianState`` has none, so each state's row is in the
  track's ``metadatas`` (one dict per state, Stone Soup's per-state
  metadata list; ``track.metadata`` is the last one): ``nnda.to_stonesoup``
  puts there its ``status``, ``scan``, ``contact`` and ``detection``.
* **Times**: second t of a run is ``origin + t`` as a naive ``datetime``
  in UTC, as Stone Soup's readers stamp theirs (they parse with
  ``ignoretz`` or drop the zone of a UTC time), rounded to the microsecond
  (``timedelta``). ``origin`` is the dataset's ``time_origin_utc`` (an
  import of absolute times; sub-microsecond digits dropped) or, without
  one, `nnda.peers.adapter.EPOCH` (`nnda.peers.adapter.to_datetime`). Two
  scans at the same time (two sensors) share a timestamp, so Stone Soup's
  metrics, which group states by timestamp, see them as one.

Requires Stone Soup (``pip install 'nnda[peers]'``).
"""

from __future__ import annotations

from collections.abc import Mapping
from datetime import datetime, timedelta, timezone

import numpy as np
from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState
from stonesoup.types.state import GaussianState
from stonesoup.types.track import Track

from nnda.data.dataset import Dataset
from nnda.errors import ConfigError
from nnda.peers.adapter import to_datetime


def origin_datetime(time_origin_utc: str) -> datetime:
    """A dataset's ``time_origin_utc`` (ISO 8601 text in UTC, e.g. 2016-01-12T13:02:10Z) as a naive UTC
    datetime, digits beyond the microsecond dropped; ConfigError for text that is not such a time."""
    try:
        when = datetime.fromisoformat(time_origin_utc)
    except (TypeError, ValueError):
        raise ConfigError(f"time_origin_utc {time_origin_utc!r}: not an ISO 8601 time such as "
                          f"2016-01-12T13:02:10Z") from None
    return when if when.tzinfo is None else when.astimezone(timezone.utc).replace(tzinfo=None)


def timestamps(time: np.ndarray, time_origin_utc: str | None = None) -> np.ndarray:
    """Times (R,) s after the start of the run as Stone Soup timestamps, (R,) object array of datetimes:
    ``time_origin_utc`` + t, or `to_datetime` (EPOCH + t) without an origin. One datetime per distinct time,
    shared by the rows at that time."""
    distinct, inverse = np.unique(np.asarray(time, np.float64), return_inverse=True)
    if time_origin_utc is None:
        stamps = [to_datetime(t) for t in distinct.tolist()]
    else:
        origin = origin_datetime(time_origin_utc)
        stamps = [origin + timedelta(seconds=t) for t in distinct.tolist()]
    out = np.empty(distinct.size, dtype=object)
    out[:] = stamps
    return out[inverse.reshape(-1)]


def _groups(key: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """The distinct values of ``key`` (R,) in increasing order and, for each, its rows in their given order."""
    distinct, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    order = np.argsort(inverse.reshape(-1), kind="stable")
    return distinct, np.split(order, np.cumsum(counts)[:-1])


def to_tracks(track_id: np.ndarray, time: np.ndarray, state: np.ndarray, covariance: np.ndarray,
              metadata: Mapping[str, np.ndarray], time_origin_utc: str | None = None) -> list[Track]:
    """Report rows as Stone Soup tracks: one `Track` per distinct ``track_id`` (R,) int, its ``id`` the id as
    text, in increasing id order; each row a ``GaussianState`` of ``state`` (R, 4) [x, vx, y, vy] (m, m/s) and
    ``covariance`` (R, 4, 4) at time ``time`` (R,) s (`timestamps`), in row order within its track (rows come
    in scan order). ``metadata``: columns (R,) each, whose values at a row make that state's entry of the
    track's ``metadatas``. Every row given becomes a state: the caller leaves out the rows it does not want
    (``nnda.to_stonesoup`` leaves out deleted tracks' last reports and, by default, every status but
    confirmed). A list, not a set: Stone Soup's metric managers and plotters take any collection of tracks (a
    manager makes a set of it), and a list keeps the order, so the plotters' colours follow the ids."""
    when = timestamps(time, time_origin_utc)
    keys = list(metadata)
    values = [np.asarray(metadata[k]).tolist() for k in keys]
    rows_meta = [dict(zip(keys, row)) for row in zip(*values)] if keys else [{} for _ in range(len(when))]
    ids, groups = _groups(np.asarray(track_id, np.int64))
    tracks = []
    for tid, rows in zip(ids.tolist(), groups):
        track = Track([GaussianState(state[i], covariance[i], timestamp=when[i]) for i in rows.tolist()],
                      id=str(tid))
        track.metadatas = [rows_meta[i] for i in rows.tolist()]
        tracks.append(track)
    return tracks


def to_truth_paths(dataset: Dataset) -> list[GroundTruthPath]:
    """The dataset's truth as Stone Soup ground truth: one `GroundTruthPath` per target with truth rows, its
    ``id`` the target's name (the scenario's), in target order; each row (a scan the target exists in) a
    ``GroundTruthState`` [x, vx, y, vy] (m, m/s) at the row's time (`timestamps`, the dataset's time origin),
    its ``metadata`` the target's index (``target_id``) and whether it was detected that scan
    (``detected``). A dataset without truth gives an empty list."""
    t = dataset.truth
    when = timestamps(t.time, dataset.time_origin_utc)
    state = np.column_stack([t.x, t.vx, t.y, t.vy]).astype(np.float64)
    detected = np.asarray(t.detected, bool).tolist()
    names = [target.name for target in dataset.scenario.targets]
    ids, groups = _groups(np.asarray(t.target_id, np.int64))
    return [GroundTruthPath([GroundTruthState(state[i], timestamp=when[i],
                                              metadata={"target_id": target, "detected": detected[i]})
                             for i in rows.tolist()], id=names[target])
            for target, rows in zip(ids.tolist(), groups)]
