"""Filters (CV/CT EKFs in an IMM), the shared track life cycle and the association methods.

``make_tracker(name, sensor, params)`` builds any registered tracker
(``gnn``, ``jpda``, ``mht``, ``nn``); each consumes scans with ``step(scan)``
and returns a `TrackerOutput`.
"""

from nnda.tracking.imm import IMM, IMMPrediction, IMMState
from nnda.tracking.output import TrackerOutput, TrackStatus
from nnda.tracking.registry import TRACKERS, make_tracker
from nnda.tracking.tracker import Tracker, TrackerBase, TrackerConfig

__all__ = [
    "IMM", "IMMPrediction", "IMMState", "TRACKERS", "Tracker", "TrackerBase", "TrackerConfig",
    "TrackerOutput", "TrackStatus", "make_tracker",
]
