"""Between nnda and Stone Soup: times, the polar measurement model, detections and tracks.

* Time: nnda counts seconds from the start of a run; Stone Soup stamps
  `datetime`s. Second t is ``EPOCH + t`` (microsecond resolution, exact for
  scan times k T with T a multiple of 1 us).
* Measurement of a polar sensor: Stone Soup's `CartesianToBearingRange`
  measures (bearing, range) with bearing = atan2(y', x') of the state
  components picked by ``mapping`` less ``translation_offset`` (in the
  mapping's order). With ``mapping = (2, 0)`` (y' = state x east, x' =
  state y north) and the offset (sensor y, sensor x) its bearing is
  atan2(x - x_s, y - y_s): our azimuth from the sensor, clockwise from
  north, so a detection's state vector is [azimuth rad, range m] unchanged,
  and the model's noise is diag(sigma_az^2, sigma_r^2) from the dataset's
  `Sensor`. Stone Soup wraps bearing residuals to [-pi, pi) itself.
* Measurement of a position sensor: Stone Soup's `LinearGaussian` on the
  state's (x, y) (indices 0, 2) with noise sigma_position^2 I; a
  detection's state vector is the fix [x m, y m].
* Tracks: Stone Soup's state [x, vx, y, vy] is ours (m, m/s); confirmed
  tracks are the tracker's, preliminary ones those the initiator still
  holds, and a track gone since the last scan is reported once as DELETED.

Requires Stone Soup (``pip install 'nnda[peers]'``).
"""

from __future__ import annotations

from collections.abc import Iterable
from datetime import datetime, timedelta

import numpy as np
from stonesoup.models.measurement.linear import LinearGaussian
from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
from stonesoup.types.detection import Detection
from stonesoup.types.state import State
from stonesoup.types.track import Track
from stonesoup.types.update import Update

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor
from nnda.tracking.output import NO_CONTACT, TrackerOutput, TrackStatus

#: Stone Soup time of second 0 of a run
EPOCH = datetime(2000, 1, 1)
#: metadata key of a detection's row in its scan's (N, 2) measurement array
ROW = "row"


def to_datetime(t: float) -> datetime:
    """Seconds since the start of the run -> Stone Soup timestamp."""
    return EPOCH + timedelta(seconds=float(t))


def to_seconds(when: datetime) -> float:
    """Stone Soup timestamp -> seconds since the start of the run."""
    return (when - EPOCH).total_seconds()


def measurement_model(sensor: Sensor, seed: int | None = None) -> CartesianToBearingRange | LinearGaussian:
    """Stone Soup's model of our sensor: for a polar radar [azimuth rad cw from north, range m] of
    [x, vx, y, vy] from the radar's position, for a sensor of position fixes [x m, y m]; ``seed`` seeds its
    noise when it simulates."""
    if sensor.kind == "position":
        return LinearGaussian(ndim_state=4, mapping=(0, 2), seed=seed,
                              noise_covar=sensor.sigma_position_m ** 2 * np.eye(2))
    return CartesianToBearingRange(ndim_state=4, mapping=(2, 0), seed=seed,
                                   noise_covar=np.diag([sensor.sigma_azimuth_rad ** 2, sensor.sigma_range_m ** 2]),
                                   translation_offset=np.array([[sensor.y_m], [sensor.x_m]]))


def to_detections(scan: Scan, model: CartesianToBearingRange | LinearGaussian) -> list[Detection]:
    """One scan's (N, 2) contacts as N Stone Soup detections measured by ``model`` (`measurement_model` of
    the scan's sensor), each knowing its row: [range m, azimuth rad] given to a polar model as [azimuth,
    range], position fixes [x m, y m] as they are."""
    when = to_datetime(scan.time)
    z = np.asarray(scan.measurements, float).reshape(-1, 2)
    if isinstance(model, CartesianToBearingRange):
        z = z[:, ::-1]
    return [Detection([[a], [b]], timestamp=when, measurement_model=model, metadata={ROW: i})
            for i, (a, b) in enumerate(z)]


def from_detections(detections: Iterable[Detection]) -> tuple[np.ndarray, np.ndarray]:
    """Detections -> times (N,) s and (N, 2) [range m, azimuth rad in [0, 2 pi)], in row order when known."""
    dets = sorted(detections, key=lambda d: d.metadata.get(ROW, 0))
    if not dets:
        return np.empty(0), np.empty((0, 2))
    times = np.array([to_seconds(d.timestamp) for d in dets])
    polar = np.array([[float(d.state_vector[1, 0]), float(d.state_vector[0, 0]) % (2 * np.pi)] for d in dets])
    return times, polar


class TrackBook:
    """Stone Soup tracks of one run -> our `TrackerOutput` per scan: stable integer ids, each track's
    status, the row it used this scan, and one DELETED report for tracks that vanish."""

    def __init__(self) -> None:
        self.ids: dict[Track, int] = {}
        self.alive: dict[Track, int] = {}  # last scan's tracks -> their status

    def output(self, scan: Scan, confirmed: Iterable[Track], preliminary: Iterable[Track]) -> TrackerOutput:
        """The report of one scan given the tracker's and the initiator's tracks after it."""
        when = to_datetime(scan.time)
        now = {t: int(TrackStatus.CONFIRMED) for t in confirmed}
        now.update({t: int(TrackStatus.PRELIMINARY) for t in preliminary if t not in now})
        gone = [t for t in self.alive if t not in now]
        rows = [(t, s) for t, s in now.items()] + [(t, int(TrackStatus.DELETED)) for t in gone]
        self.alive = now
        born = sorted((t for t, _ in rows if t not in self.ids), key=_birth)  # ids independent of set order
        first = len(self.ids)
        self.ids.update((t, first + i) for i, t in enumerate(born))
        rows.sort(key=lambda ts: self.ids[ts[0]])
        k = len(rows)
        state, cov = np.empty((k, 4)), np.empty((k, 4, 4))
        for i, (t, _) in enumerate(rows):
            state[i] = np.asarray(t.state_vector, float).ravel()
            cov[i] = np.asarray(t.covar, float)
        return TrackerOutput(scan.index, float(scan.time),
                             np.array([self.ids[t] for t, _ in rows], np.int64),
                             np.array([s for _, s in rows], np.int8), state, cov,
                             np.array([used_row(t.state, when) for t, _ in rows], np.int64))


def _birth(track: Track) -> tuple[datetime, int]:
    """When a track began and the row of its first detection: a key no two tracks share."""
    first = track.states[0]
    return first.timestamp, used_row(first, first.timestamp)


def used_row(state: State, when: datetime) -> int:
    """Row of the detection that made a track's ``state`` at ``when``, or -1 (a prediction, or older).

    For a mixture (JPDA) update: the detection of the most probable
    hypothesis (Stone Soup makes an update only when one beats the miss).
    """
    if not isinstance(state, Update) or state.timestamp != when:
        return NO_CONTACT
    hyp = state.hypothesis
    if hasattr(hyp, "single_hypotheses"):  # a MultipleHypothesis
        hits = [h for h in hyp if h]
        if not hits:
            return NO_CONTACT
        hyp = max(hits, key=lambda h: float(h.probability))
    det = hyp.measurement
    return int(det.metadata.get(ROW, NO_CONTACT)) if det is not None else NO_CONTACT
