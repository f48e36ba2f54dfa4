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

from nnda.data.scenario import Sensor, sensor_tuple
from nnda.errors import ConfigError, validated
from nnda.tracking.glmb import GLMBTracker
from nnda.tracking.gnn import GNNTracker
from nnda.tracking.jpda import JPDATracker
from nnda.tracking.lifecycle import LifecycleConfig
from nnda.tracking.lmb import LMBTracker
from nnda.tracking.mht import MHTTracker
from nnda.tracking.neural import NeuralTracker
from nnda.tracking.phd.fusion import AAFusionTracker, CentralPHDTracker, FusionTracker, GCIFusionTracker
from nnda.tracking.phd.tracker import CPHDTracker, EKPHDTracker, GMPHDTracker, UKPHDTracker
from nnda.tracking.pmbm import PMBMTracker
from nnda.tracking.protocol import Tracker, reporting_trackers
from nnda.tracking.target_classes import as_given, class_params, refused
from nnda.tracking.tracker import ContactTracker

#: Stone Soup peer trackers: name -> "module:class", imported on first lookup
PEERS: dict[str, str] = {
    "stonesoup-gnn": "nnda.peers.trackers:StoneSoupGNN",
    "stonesoup-jpda": "nnda.peers.trackers:StoneSoupJPDA",
    "stonesoup-gmphd": "nnda.peers.trackers:StoneSoupGMPHD",
}
#: the association family of each tracker by name, the rows of a study report's "which family, where" table
#: (`nnda.reports.study_summary.family_table`); a tracker not listed (a plug-in) is its own family
FAMILIES: dict[str, str] = {
    "gnn": "global nearest neighbour", "stonesoup-gnn": "global nearest neighbour",
    "jpda": "joint probabilistic data association", "stonesoup-jpda": "joint probabilistic data association",
    "mht": "multiple hypothesis tracking",
    "pmbm": "multi-Bernoulli mixtures (PMBM, GLMB, LMB)", "glmb": "multi-Bernoulli mixtures (PMBM, GLMB, LMB)",
    "lmb": "multi-Bernoulli mixtures (PMBM, GLMB, LMB)",
    "nn": "neural association",
    **dict.fromkeys(("gmphd", "ekphd", "ukphd", "cphd", "stonesoup-gmphd"), "PHD filters (no association)"),
    **dict.fromkeys(("fusion-merge", "fusion-aa", "fusion-gci", "fusion-central"), "PHD fusion of two radars"),
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
    {cls.name: cls for cls in (GNNTracker, JPDATracker, MHTTracker, PMBMTracker, GLMBTracker, LMBTracker,
                               NeuralTracker,
                               GMPHDTracker, EKPHDTracker, UKPHDTracker, CPHDTracker,
                               FusionTracker, AAFusionTracker, GCIFusionTracker, CentralPHDTracker)})


def _tracker_class(name: str, where: str) -> type[Tracker]:
    if not isinstance(name, str) or name not in TRACKERS:
        raise ConfigError(f"{where}: unknown tracker {name!r}; choose one of {', '.join([*TRACKERS, *PEERS])}")
    try:
        return TRACKERS[name]
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None


def _owners(fields: set[str], name: str) -> list[str]:
    """The built-in trackers other than ``name`` whose config has every one of ``fields``."""
    return [other for other, cls in TRACKERS.items()  # the built-ins only: the peers are not imported here
            if other != name and fields <= set(cls.config_type.model_fields)]


def check_config(name: str, params: Mapping[str, Any] | None, where: str = "tracker config",
                 sensors: Sensor | Sequence[Sensor] | None = None):
    """The config of tracker ``name`` validated from ``params``; ConfigError naming ``where`` (a file, a study
    entry), the tracker and every problem, and, when the unknown fields are another tracker's, that tracker.
    Given the ``sensors`` it will track with, a contact tracker's config takes the class of target they declare
    for the fields ``params`` leaves out (`nnda.tracking.target_classes`): its own v_max 30 goes with the ships'
    v_min 0, not with the default 70."""
    cls = _tracker_class(name, where)
    if sensors is None or not issubclass(cls, ContactTracker) or not isinstance(params, Mapping):
        return _validated_config(cls, name, params, where)
    merged, use = class_params(name, params, sensor_tuple(sensors))
    if use is None:
        return _validated_config(cls, name, params, where)
    try:
        return as_given(_validated_config(cls, name, merged, where), params)
    except ConfigError as exc:
        raise ConfigError(f"{exc}\n  {refused(name, use, params, 'refused as above')}") from None


def _validated_config(cls: type[Tracker], name: str, params: Mapping[str, Any] | None, where: str):
    """`check_config` of ``params`` as they are."""
    if params is not None and not isinstance(params, Mapping):
        raise ConfigError(f"{where}: the {name} config must be a mapping of option names to values, got "
                          f"{type(params).__name__}")
    params = dict(params or {})
    try:
        return validated(cls.config_type, params, where, f"{name} config")
    except ConfigError as exc:
        extra = {k for k in params if isinstance(k, str)} - set(cls.config_type.model_fields)
        owners = _owners(extra, name) if extra else []
        if not owners:
            raise
        shown = ", ".join(owners[:4]) + (f" and {len(owners) - 4} more" if len(owners) > 4 else "")
        raise ConfigError(f"{exc}\n  the field(s) {', '.join(sorted(extra))} are options of tracker(s) {shown}, "
                          f"not of {name}: a config written for another tracker? Run it with that tracker, or "
                          f"remove those fields") from None


def make_tracker(name: str, sensors: Sensor | Sequence[Sensor], params: Mapping[str, Any] | None = None,
                 where: str = "tracker config") -> Tracker:
    """A tracker of kind ``name`` for ``sensors`` (a scenario's, or one) with its config validated from
    ``params`` (defaults: each config's; `check_config`); a tracker that cannot use these sensors is a
    ConfigError."""
    cls = _tracker_class(name, where)
    reporting = [s.name for s in sensor_tuple(sensors) if s.reports]
    if reporting and not getattr(cls, "takes_reports", False):
        raise ConfigError(f"{where}: tracker {name!r} does not take asynchronous reports (sensor "
                          f"{', '.join(map(repr, reporting))} has reports = true); trackers that do: "
                          f"{', '.join(reporting_trackers())}")
    config = check_config(name, params, where, sensors)
    try:
        return cls(sensors, config)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None


def confirmation_rule(name: str, params: Mapping[str, Any] | None = None) -> str | None:
    """The confirmation rule ("adaptive", "mn", "score" or "existence") a contact tracker of kind ``name`` runs
    with ``params`` (a study states it), or None for a tracker without one (PHD filters, peers, unknown kinds)."""
    if name in PEERS or name not in TRACKERS or not issubclass(TRACKERS[name], ContactTracker):
        return None
    if TRACKERS[name].own_confirmation is not None:
        return TRACKERS[name].own_confirmation
    lifecycle = dict(params or {}).get("lifecycle") or {}
    return str(lifecycle.get("confirmation", LifecycleConfig().confirmation))
