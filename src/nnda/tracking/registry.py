"""Trackers by name: ``make_tracker("gnn", sensor, {...})`` validates the config and builds one."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pydantic import ValidationError

from nnda.data.scenario import Sensor
from nnda.errors import ConfigError
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
    try:
        config = cls.config_type.model_validate(dict(params or {}))
    except ValidationError as exc:
        problems = "; ".join(f"{'.'.join(map(str, e['loc'])) or '<top>'}: {e['msg']}" for e in exc.errors())
        raise ConfigError(f"{where}: invalid {name} config: {problems}") from None
    return cls(sensor, config)
