"""Stone Soup's GNN and JPDA trackers behind our Tracker interface (``stonesoup-gnn``, ``stonesoup-jpda``).

Each is assembled from Stone Soup's own components and driven one scan at a
time through its `MultiTargetTracker` / `MultiTargetMixtureTracker`
(``update_tracker``); `nnda.peers.adapter` converts scans in and tracks out.
Parameters are matched to ours as `nnda.peers.parameters.MATCHING` lists
(the report's "Against Stone Soup" section prints it): the radar's noise
in Stone Soup's polar model (its bearing made our azimuth by ``mapping``),
one CV model with sigma_q = 10 m/s^2 (Stone Soup has no IMM), the 9.21
gate, P_D 0.9 and a per-scan local clutter density for JPDA, a
multi-measurement initiator confirming at M+2 updates, and deletion at
max_misses + 1 scans without an update.

Requires Stone Soup (``pip install 'nnda[peers]'``); build through
`nnda.tracking.registry.make_tracker`, which checks that first.
"""

from __future__ import annotations

import math
from abc import abstractmethod
from collections.abc import Sequence
from typing import Annotated, ClassVar, Literal

import numpy as np
from pydantic import Field
from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
from stonesoup.dataassociator.probability import JPDA
from stonesoup.deleter.time import UpdateTimeStepsDeleter
from stonesoup.hypothesiser.distance import DistanceHypothesiser
from stonesoup.hypothesiser.probability import PDAHypothesiser
from stonesoup.initiator.simple import MultiMeasurementInitiator
from stonesoup.measures import Mahalanobis
from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
from stonesoup.predictor.kalman import ExtendedKalmanPredictor
from stonesoup.tracker.simple import MultiTargetMixtureTracker, MultiTargetTracker
from stonesoup.types.state import GaussianState
from stonesoup.updater.kalman import ExtendedKalmanUpdater

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor
from nnda.data.sensor import polar_to_cart
from nnda.filters.kalman import GATE_99
from nnda.peers.adapter import TrackBook, measurement_model, to_datetime, to_detections
from nnda.tracking.clutter_density import local_density
from nnda.tracking.output import TrackerOutput
from nnda.tracking.tracker import ContactTrackerConfig, TrackerConfig, checked_config, checked_scan, only_sensor


class PeerConfig(ContactTrackerConfig):
    """Settings of a Stone Soup peer; ``lifecycle`` gives M, N, max_misses and v_max (see the module table)."""

    sigma_q: Annotated[float, Field(ge=0, description="CV process noise (m/s^2); covers the presets' turns "
                                    "(see the module table)")] = 10.0
    gate: Annotated[float, Field(gt=0, description="chi-square gate, 2 dof (9.21: P_G = 0.99)")] = GATE_99


class PeerJPDAConfig(PeerConfig):
    """JPDA peer settings: detection probability and clutter density, as our JPDA's."""

    pd: Annotated[float, Field(gt=0, lt=1, description="detection probability in the event weights")] = 0.9
    clutter_density: Annotated[float, Field(gt=0)] | Literal["local"] = Field(
        "local", description="clutter contacts per m per rad, or 'local': each scan's mean over its "
        "contacts of the density in a square of half-side clutter_radius_m, times range")
    clutter_radius_m: Annotated[float, Field(gt=0)] = 3_000.0


class StoneSoupTracker:
    """A Stone Soup multi-target tracker stepped one scan at a time; subclasses pick the association.

    Meets our `nnda.tracking.tracker.Tracker` protocol: built as ``cls(sensors, config)`` for one polar radar.
    """

    name: ClassVar[str]
    config_type: ClassVar[type[TrackerConfig]]

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: PeerConfig | None = None) -> None:
        self.sensor = only_sensor(self.name, sensors)
        self.sensors = (self.sensor,)
        self.config = checked_config(self, config)
        self.reset()

    def reset(self) -> None:
        """Build a fresh Stone Soup tracker (the start of a new run)."""
        self.last_time = -np.inf
        cfg, sensor = self.config, self.sensor
        self.model = measurement_model(sensor)
        q = cfg.sigma_q ** 2 * sensor.scan_period_s
        self.predictor = ExtendedKalmanPredictor(
            CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)]))
        self.updater = ExtendedKalmanUpdater(self.model)
        life = cfg.lifecycle
        speed_var = (life.v_max / 2) ** 2
        self.initiator = MultiMeasurementInitiator(
            prior_state=GaussianState(np.zeros((4, 1)), np.diag([0.0, speed_var, 0.0, speed_var])),
            measurement_model=self.model, deleter=UpdateTimeStepsDeleter(life.n - life.m + 1),
            data_associator=GNNWith2DAssignment(self._distance_hypothesiser()),
            updater=self.updater, min_points=life.m + 2)
        self.tracker = self._tracker(UpdateTimeStepsDeleter(life.max_misses + 1))
        self.book = TrackBook()

    def _distance_hypothesiser(self) -> DistanceHypothesiser:
        return DistanceHypothesiser(self.predictor, self.updater, Mahalanobis(),
                                    missed_distance=math.sqrt(self.config.gate))

    @abstractmethod
    def _tracker(self, deleter: UpdateTimeStepsDeleter):
        """The Stone Soup tracker around ``self.initiator`` and ``deleter``."""

    def _before(self, z: np.ndarray) -> None:
        """Per-scan settings from the contacts z (N, 2) polar (none by default)."""

    def step(self, scan: Scan) -> TrackerOutput:
        """Process one sweep and report every track (confirmed, held by the initiator, just deleted)."""
        z, time = checked_scan(self.name, scan, self.last_time, self.sensors)
        scan = Scan(scan.index, time, z)
        self._before(z)
        self.tracker.update_tracker(to_datetime(time), set(to_detections(scan, self.model)))
        self.last_time = time
        return self.book.output(scan, self.tracker.tracks, self.initiator.holding_tracks)


class StoneSoupGNN(StoneSoupTracker):
    """Stone Soup EKF tracker with global nearest neighbour association (GNNWith2DAssignment)."""

    name: ClassVar[str] = "stonesoup-gnn"
    config_type: ClassVar[type[TrackerConfig]] = PeerConfig

    def _tracker(self, deleter):
        return MultiTargetTracker(initiator=self.initiator, deleter=deleter, detector=None,
                                  data_associator=GNNWith2DAssignment(self._distance_hypothesiser()),
                                  updater=self.updater)


class StoneSoupJPDA(StoneSoupTracker):
    """Stone Soup EKF tracker with JPDA (exact joint events) and Gaussian-mixture reduction."""

    name: ClassVar[str] = "stonesoup-jpda"
    config_type: ClassVar[type[TrackerConfig]] = PeerJPDAConfig

    def _tracker(self, deleter):
        cfg = self.config
        density = cfg.clutter_density if cfg.clutter_density != "local" else 1.0  # set per scan
        self.hypothesiser = PDAHypothesiser(self.predictor, self.updater, clutter_spatial_density=density,
                                            prob_detect=cfg.pd, prob_gate=1.0 - math.exp(-cfg.gate / 2))
        return MultiTargetMixtureTracker(initiator=self.initiator, deleter=deleter, detector=None,
                                         data_associator=JPDA(self.hypothesiser), updater=self.updater)

    def _before(self, z: np.ndarray) -> None:
        cfg = self.config
        if cfg.clutter_density == "local" and len(z):
            xy = np.column_stack(polar_to_cart(z[:, 0], z[:, 1]))
            self.hypothesiser.clutter_spatial_density = float(
                np.mean(local_density(xy, xy, cfg.clutter_radius_m) * z[:, 0]))
