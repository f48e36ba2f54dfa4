"""What every tracker returns per scan."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np


class TrackStatus(IntEnum):
    """Life stages of a track (Vargas Avila 2015, Ch. 2): initiator -> preliminary -> confirmed -> deleted."""

    TENTATIVE = 0
    PRELIMINARY = 1
    CONFIRMED = 2
    DELETED = 3


#: TrackStatus values as plain ints, for comparisons with status arrays in hot paths: numpy probes an
#: IntEnum member for array interfaces through the enum's slow attribute lookup (~5x slower per compare)
PRELIMINARY, CONFIRMED, DELETED = int(TrackStatus.PRELIMINARY), int(TrackStatus.CONFIRMED), int(TrackStatus.DELETED)

#: the contact index of a track that used no contact in a scan (missed, or reported without one)
NO_CONTACT = -1
#: the largest fixed lag (scans) of `nnda.tracking.lag.FixedLag`: the window's outputs are held and revised
#: every scan (here, so that the command line names it without loading the trackers)
MAX_LAG = 100


@dataclass(frozen=True)
class TrackerOutput:
    """Tracks reported after one scan; every array has the track count K first.

    ``state`` is [x, vx, y, vy] (m, m/s) and ``covariance`` its (4, 4)
    covariance (for the IMM trackers, its combined estimate); ``contact`` is
    the row of the scan's measurement array used by the track in this scan,
    or NO_CONTACT (also for trackers that do not associate contacts).
    Tracks deleted in this scan are reported once more with status DELETED.
    Tentative tracks (single contacts waiting for a second one) are not
    reported: they have no state yet.
    """

    scan: int
    time: float
    track_id: np.ndarray  # (K,) int64
    status: np.ndarray  # (K,) int8, TrackStatus values
    state: np.ndarray  # (K, 4)
    covariance: np.ndarray  # (K, 4, 4)
    contact: np.ndarray  # (K,) int64

    @classmethod
    def empty(cls, scan: int, time: float) -> TrackerOutput:
        """No tracks after scan ``scan`` at ``time`` (s)."""
        return cls(scan, time, np.empty(0, np.int64), np.empty(0, np.int8), np.empty((0, 4)),
                   np.empty((0, 4, 4)), np.empty(0, np.int64))

    @classmethod
    def from_blocks(cls, scan: int, time: float, blocks: list[tuple[np.ndarray, ...]]) -> TrackerOutput:
        """The tracks of several blocks, each (track_id, status, state, covariance, contact) with its own K."""
        if not blocks:
            return cls.empty(scan, time)
        ids, status, x, P, contact = (np.concatenate(parts) for parts in zip(*blocks))
        return cls(scan, time, ids.astype(np.int64, copy=False), status.astype(np.int8, copy=False), x, P,
                   contact.astype(np.int64, copy=False))

    @property
    def confirmed(self) -> np.ndarray:
        """Boolean mask of confirmed tracks, (K,)."""
        return self.status == TrackStatus.CONFIRMED

    def __len__(self) -> int:
        return int(self.track_id.size)
