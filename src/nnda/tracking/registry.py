"""Trackers by name: ``make_tracker("gnn", sensor, {...})`` validates the config and builds one."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from nnda.data.scenario import Sensor
from nnda.errors import ConfigError, validated
from nnda.tracking.gnn import GNNTracker
from nnda.tracking.jpda import JPDATracker
from nnda.tracking.mht import MHTTracker
from nnda.tracking.neural import NeuralTracker
from nnda.tracking.tracker import TrackerBase

TRACKERS: dict[str, type[TrackerBase]] = {cls.name: cls for cls in (GNNTracker, JPDATracker, MHTTracker, NeuralTracker)}


def make_tracker(name: str, sensor: Sensor, params: Mapping[str, Any] | None = None,
                 where: str = "tracker config") -> TrackerBase:
    """A tracker of kind ``name`` with its config validated from ``params`` (defaults: the spec's)."""
    try:
        cls = TRACKERS[name]
    except KeyError:
        raise ConfigError(f"{where}: unknown tracker {name!r}; choose one of {', '.join(TRACKERS)}") from None
    return cls(sensor, validated(cls.config_type, dict(params or {}), where, f"{name} config"))
