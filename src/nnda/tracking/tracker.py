"""The tracker framework every association method plugs into (conventions.md, "Interfaces").

A tracker consumes one scan at a time, ``step(scan) -> TrackerOutput``. The
shared parts live here so that trackers differ in association only:

1. check the scan (time increasing, (N, 2) finite polar contacts);
2. predict every live track's IMM to the scan time, over the time since its
   last update (spec §7.1.8: a missed scan is not an update);
3. **associate** (the method's own part, `Tracker._maintain`): decide which
   contact, if any, updates each track and return the updated IMM states;
4. the M/N and deletion logic of `nnda.tracking.lifecycle`;
5. initiation: last scan's initiators pair with this scan's unused contacts
   inside their [D_min, D_max] window, each pair opening a preliminary
   track (two-point IMM start); unused contacts outside every window become
   the next initiators (spec §4, A11);
6. report every track (and those deleted in this scan, once more).

Track records are batched arrays (`Tracks`), so steps 2-6 have no Python
loop over tracks.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor
from nnda.data.sensor import polar_to_cart
from nnda.errors import TrackingError
from nnda.filters.batch import Batch
from nnda.filters.imm import IMM, IMMPrediction, IMMState
from nnda.tracking.lifecycle import LifecycleConfig, advance, cap_per_initiator, window_pairs
from nnda.tracking.output import DELETED, PRELIMINARY, TrackerOutput


class TrackerConfig(BaseModel):
    """Settings every tracker shares; subclasses add their association's own."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    lifecycle: LifecycleConfig = LifecycleConfig()


@dataclass(frozen=True)
class Tracks(Batch):
    """K live tracks (preliminary or confirmed); every field has the track axis first.

    ``filt`` is the IMM posterior at the track's last update, at time ``t2``
    (s), from the contact at ``p2`` (m, Cartesian) with azimuth ``az2`` (rad);
    ``p1``/``t1`` is the contact before it. ``hits``, ``misses`` and
    ``consecutive`` are the M/N counters of `nnda.tracking.lifecycle`.
    """

    track_id: np.ndarray
    status: np.ndarray
    filt: IMMState
    p1: np.ndarray
    t1: np.ndarray
    p2: np.ndarray
    t2: np.ndarray
    az2: np.ndarray
    hits: np.ndarray
    misses: np.ndarray
    consecutive: np.ndarray

    def after_scan(self, contact: np.ndarray, filt: IMMState, z: np.ndarray, xy: np.ndarray, time: float,
                   lifecycle: LifecycleConfig) -> Tracks:
        """These tracks after a scan at ``time``: ``contact`` (K,) is the contact each used (-1:
        missed), ``filt`` their IMM states from then on. The contact history moves on where a
        contact was used, and the M/N counters and status advance (`lifecycle.advance`)."""
        det = contact >= 0
        c = np.maximum(contact, 0)
        d1 = det[:, None]
        status, hits, misses, consecutive = advance(self.status, self.hits, self.misses, self.consecutive,
                                                    det, lifecycle)
        return Tracks(
            track_id=self.track_id, status=status, filt=filt,
            p1=np.where(d1, self.p2, self.p1), t1=np.where(det, self.t2, self.t1),
            p2=np.where(d1, xy[c] if len(xy) else 0.0, self.p2), t2=np.where(det, time, self.t2),
            az2=np.where(det, z[c, 1] if len(z) else 0.0, self.az2),
            hits=hits, misses=misses, consecutive=consecutive,
        )


@dataclass(frozen=True)
class Association:
    """What a method decided for K tracks in one scan.

    ``contact`` (K,) is the index of the contact that updated each track (or
    -1: a miss); ``filt`` the IMM states after the scan: the updated state of
    a track with a contact, the prediction (``pred.state``) of one without.
    """

    contact: np.ndarray
    filt: IMMState


class TrackerBase(ABC):
    """What every tracker shares: the radar, one IMM, one life cycle, scan checks, initiation, output.

    Construct with the radar (`nnda.data.Sensor`: noise, coverage, scan
    period) and a config; ``step(scan)`` processes one sweep.
    """

    name: ClassVar[str]
    config_type: ClassVar[type[TrackerConfig]] = TrackerConfig

    def __init__(self, sensor: Sensor, config: TrackerConfig | None = None) -> None:
        self.sensor = sensor
        self.config = config if config is not None else self.config_type()
        if not isinstance(self.config, self.config_type):
            raise TrackingError(f"{self.name}: config must be a {self.config_type.__name__}")
        self.imm = IMM.for_sensor(sensor)
        self.d_min, self.d_max = self.config.lifecycle.window(sensor.scan_period_s, sensor.sigma_range_m)
        self.reset()

    def reset(self) -> None:
        """Forget every track and initiator (start of a new run)."""
        self.initiators = np.empty((0, 2))  # polar contacts of the previous scan
        self.initiator_xy = np.empty((0, 2))  # and their Cartesian positions (m)
        self.initiator_time = -np.inf
        self.last_time = -np.inf
        self._next_id = 0

    @abstractmethod
    def step(self, scan: Scan) -> TrackerOutput:
        """Process one sweep and report every track."""

    def _checked(self, scan: Scan) -> tuple[np.ndarray, float]:
        time = float(scan.time)
        if not math.isfinite(time):
            raise TrackingError(f"{self.name}: scan {scan.index} has a non-finite time {scan.time}")
        if time <= self.last_time:
            raise TrackingError(f"{self.name}: scan {scan.index} at t = {time} s does not come after the "
                                f"previous scan (t = {self.last_time} s); scans must arrive in time order")
        z = np.asarray(scan.measurements, dtype=float)
        if z.size == 0:
            return np.empty((0, 2)), time
        if z.ndim != 2 or z.shape[1] != 2:
            raise TrackingError(f"{self.name}: scan {scan.index}: measurements must have shape (N, 2) "
                                f"[range m, azimuth rad], got {z.shape}")
        if not (np.isfinite(z).all() and (z[:, 0] > 0).all()):
            row = int(np.flatnonzero(~np.isfinite(z).all(axis=1) | ~(z[:, 0] > 0))[0])
            raise TrackingError(f"{self.name}: scan {scan.index}: contact {row} is invalid {z[row].tolist()} "
                                f"(non-finite or non-positive range)")
        return z, time

    def _initiate(self, z: np.ndarray, xy: np.ndarray, used: np.ndarray, time: float
                  ) -> tuple[Tracks | None, np.ndarray | None]:
        """Open preliminary tracks from last scan's initiators; keep unused contacts as initiators.

        Returns the new tracks (or None) and the contact each one used.
        """
        free = np.flatnonzero(~used)
        born, contact = None, None
        in_window = np.zeros(len(free), bool)
        if len(self.initiators) and len(free):
            init_xy, free_xy = self.initiator_xy, xy[free]
            i, j = window_pairs(init_xy, free_xy, self.d_min, self.d_max)
            i, j = cap_per_initiator(i, j, init_xy, free_xy, self.d_min, self.d_max,
                                     self.config.lifecycle.max_tracks_per_initiator)
            if len(i):
                in_window[j] = True
                contact = free[j]
                p1 = init_xy[i]
                p2, cov2 = self.imm.measurement.position(z[contact])
                k = len(i)
                zeros = np.zeros(k, np.int64)
                born = Tracks(
                    track_id=np.arange(self._next_id, self._next_id + k, dtype=np.int64),
                    status=np.full(k, PRELIMINARY, np.int8),
                    filt=self.imm.start(p1, p2, cov2, time - self.initiator_time),
                    p1=p1, t1=np.full(k, self.initiator_time), p2=p2, t2=np.full(k, time),
                    az2=z[contact, 1], hits=zeros, misses=zeros.copy(), consecutive=zeros.copy(),
                )
                self._next_id += k
        rest = free[~in_window]
        self.initiators, self.initiator_xy, self.initiator_time = z[rest], xy[rest], time
        return born, contact

    @staticmethod
    def _output(scan: int, time: float, reports: list[tuple]) -> TrackerOutput:
        if not reports:
            return TrackerOutput(scan, time, np.empty(0, np.int64), np.empty(0, np.int8), np.empty((0, 4)),
                                 np.empty((0, 4, 4)), np.empty(0, np.int64))
        ids, status, x, P, contact = (np.concatenate(parts) for parts in zip(*reports))
        return TrackerOutput(scan, time, ids.astype(np.int64), status.astype(np.int8), x, P,
                             contact.astype(np.int64))



class Tracker(TrackerBase):
    """Base of the single-hypothesis trackers: each track follows one contact sequence.

    Subclasses set ``name`` and implement `_maintain`.
    """

    def reset(self) -> None:
        super().reset()
        self.tracks: Tracks | None = None

    # ------------------------------------------------------------------ the method's part
    @abstractmethod
    def _maintain(self, tracks: Tracks, pred: IMMPrediction, z: np.ndarray, xy: np.ndarray,
                  time: float) -> Association:
        """Associate this scan's contacts z (N, 2) polar / xy (N, 2) Cartesian with the tracks.

        ``pred`` is every track's IMM prediction to ``time``. Return the
        contact chosen for each track and the IMM states after the scan
        (updated, or the prediction for a track without a contact).
        """

    def hard_update(self, pred: IMMPrediction, z: np.ndarray, contact: np.ndarray) -> Association:
        """IMM update of each track with its chosen contact (``contact`` (K,), -1 = none: the track
        keeps its prediction)."""
        detected = contact >= 0
        if not detected.any():
            return Association(contact, pred.state)
        # z comes from a checked scan; rows without a contact are masked, whichever contact they hold
        return Association(contact, self.imm.update(pred, z[np.maximum(contact, 0)], detected, check=False))

    # ------------------------------------------------------------------ one scan
    def step(self, scan: Scan) -> TrackerOutput:
        """Process one sweep and report every track."""
        z, time = self._checked(scan)
        xy = np.empty((len(z), 2))
        xy[:, 0], xy[:, 1] = polar_to_cart(z[:, 0], z[:, 1])
        used = np.zeros(len(z), bool)
        shown = []  # (tracks, IMM state to report, contact used) per block of the output
        tracks = self.tracks
        if tracks is not None:
            pred = self.imm.predict(tracks.filt, time - tracks.t2, check=False)
            assoc = self._maintain(tracks, pred, z, xy, time)
            c = assoc.contact
            det = c >= 0
            used[c[det]] = True
            # a missed track keeps its last posterior (§7.1.8) and reports its prediction
            tracks = tracks.after_scan(c, _pick(det, assoc.filt, tracks.filt), z, xy, time, self.config.lifecycle)
            shown.append((tracks, assoc.filt, c))
            alive = np.flatnonzero(tracks.status != DELETED)
            tracks = None if not alive.size else tracks if alive.size == len(tracks) else tracks.take(alive)
        born, born_contact = self._initiate(z, xy, used, time)
        if born is not None:
            shown.append((born, born.filt, born_contact))
            tracks = born if tracks is None else Tracks.concat([tracks, born])
        self.tracks = tracks
        self.last_time = time
        return self._shown(scan.index, time, shown)

    def _shown(self, scan: int, time: float, blocks: list[tuple[Tracks, IMMState, np.ndarray]]) -> TrackerOutput:
        """The scan's output from blocks of (tracks, the IMM state to report, contact used): one
        combined estimate for all of them."""
        if not blocks:
            return self._output(scan, time, [])
        tracks, states, contact = zip(*blocks)
        x, P = self.imm.estimate(states[0] if len(states) == 1 else IMMState.concat(states))
        return TrackerOutput(scan, time, np.concatenate([t.track_id for t in tracks]),
                             np.concatenate([t.status for t in tracks]), x, P,
                             np.concatenate(contact).astype(np.int64, copy=False))


def _pick(rows: np.ndarray, a: IMMState, b: IMMState) -> IMMState:
    """Per track, the state of ``a`` where ``rows`` (K,) is true, else that of ``b``."""
    return IMMState(*(np.where(rows.reshape(-1, *[1] * (u.ndim - 1)), u, v)
                      for u, v in ((a.x, b.x), (a.P, b.P), (a.mu, b.mu))))


