"""Filters (CV/CT EKFs in an IMM), the shared track life cycle and the association methods.

``make_tracker(name, sensor, params)`` builds any registered tracker
(``gnn``, ``jpda``, ``mht``, ``nn``); each consumes scans with ``step(scan)``
and returns a `TrackerOutput`.
"""

from nnda.tracking.imm import IMM, IMMPrediction, IMMState
from nnda.tracking.output import TrackerOutput, TrackStatus
from nnda.tracking.tracker import Tracker, TrackerBase, TrackerConfig

_REGISTRY = ("TRACKERS", "make_tracker")


def __getattr__(name: str):
    # The registry imports every tracker, the neural one with its model code, which itself runs
    # the IMM of this package: loading it on first use keeps `import nnda.tracking.imm` free of cycles.
    if name in _REGISTRY:
        from nnda.tracking import registry
        return getattr(registry, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "IMM", "IMMPrediction", "IMMState", "TRACKERS", "Tracker", "TrackerBase", "TrackerConfig",
    "TrackerOutput", "TrackStatus", "make_tracker",
]
