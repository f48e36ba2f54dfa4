"""Trackers by name: ``make_tracker("gnn", sensors, {...})`` validates the config and builds one.

`TRACKERS` maps a name to its class. Iterating it gives the built-in
trackers; the Stone Soup peers (`PEERS`, the ``nnda[peers]`` extra) are
members too (``name in TRACKERS``, ``TRACKERS[name]``) but are imported only
when looked up, by module name as plug-ins are: nnda never imports Stone
Soup unless a peer is asked for, this layer never imports `nnda.peers`
(which sits above it), and a missing install is a ConfigError that names
the extra.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping, Sequence
from typing import Any

from nnda.data.scenario import Sensor
from nnda.errors import ConfigError, validated
from nnda.tracking.gnn import GNNTracker
from nnda.tracking.jpda import JPDATracker
from nnda.tracking.lifecycle import LifecycleConfig
from nnda.tracking.mht import MHTTracker
from nnda.tracking.neural import NeuralTracker
from nnda.tracking.phd.fusion import AAFusionTracker, CentralPHDTracker, FusionTracker
from nnda.tracking.phd.tracker import CPHDTracker, EKPHDTracker, GMPHDTracker, UKPHDTracker
from nnda.tracking.tracker import ContactTracker, Tracker

#: Stone Soup peer trackers: name -> "module:class", imported on first lookup
PEERS: dict[str, str] = {
    "stonesoup-gnn": "nnda.peers.trackers:StoneSoupGNN",
    "stonesoup-jpda": "nnda.peers.trackers:StoneSoupJPDA",
    "stonesoup-gmphd": "nnda.peers.trackers:StoneSoupGMPHD",
}
#: the optional extra the peers need (`nnda.peers.EXTRA` says the same to the peers' own commands)
PEERS_EXTRA = "pip install 'nnda[peers]'"


class _Registry(dict):
    """The built-in trackers, plus the peers found (and imported) on lookup."""

    def __contains__(self, name: object) -> bool:
        return super().__contains__(name) or name in PEERS

    def __missing__(self, name: str) -> type[Tracker]:
        if name not in PEERS:
            raise KeyError(name)
        module, cls = PEERS[name].split(":")
        try:
            importlib.import_module("stonesoup")  # checked on every lookup, even with the peer module loaded
            return getattr(importlib.import_module(module), cls)
        except ImportError as exc:
            raise ConfigError(f"tracker {name!r} needs Stone Soup, which is not installed ({exc}); "
                              f"install the peers extra: {PEERS_EXTRA}") from None


TRACKERS: dict[str, type[Tracker]] = _Registry(
    {cls.name: cls for cls in (GNNTracker, JPDATracker, MHTTracker, NeuralTracker,
                               GMPHDTracker, EKPHDTracker, UKPHDTracker, CPHDTracker,
                               FusionTracker, AAFusionTracker, CentralPHDTracker)})


def make_tracker(name: str, sensors: Sensor | Sequence[Sensor], params: Mapping[str, Any] | None = None,
                 where: str = "tracker config") -> Tracker:
    """A tracker of kind ``name`` for ``sensors`` (a scenario's, or one) with its config validated from
    ``params`` (defaults: each config's); a tracker that cannot use these sensors is a ConfigError."""
    if name not in TRACKERS:
        raise ConfigError(f"{where}: unknown tracker {name!r}; choose one of {', '.join([*TRACKERS, *PEERS])}")
    try:
        cls = TRACKERS[name]
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    config = validated(cls.config_type, dict(params or {}), where, f"{name} config")
    try:
        return cls(sensors, config)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None


def confirmation_rule(name: str, params: Mapping[str, Any] | None = None) -> str | None:
    """The confirmation rule ("mn", "score" or "existence") a contact tracker of kind ``name`` runs with ``params``
    (a study states it), or None for a tracker without one (PHD filters, peers, unknown kinds)."""
    if name in PEERS or name not in TRACKERS or not issubclass(TRACKERS[name], ContactTracker):
        return None
    lifecycle = dict(params or {}).get("lifecycle") or {}
    return str(lifecycle.get("confirmation", LifecycleConfig().confirmation))
