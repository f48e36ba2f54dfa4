"""Stone Soup's GNN, JPDA and GM-PHD trackers behind our Tracker interface (``stonesoup-gnn``,
``stonesoup-jpda``, ``stonesoup-gmphd``).

Each is assembled from Stone Soup's own components and driven one scan at a
time through its `MultiTargetTracker` / `MultiTargetMixtureTracker`
(``update_tracker``); `nnda.peers.adapter` converts scans in and tracks out.
Parameters are matched to ours as `nnda.peers.parameters.MATCHING` lists
(the report's "Against Stone Soup" section prints it): the radar's noise
in Stone Soup's polar model (its bearing made our azimuth by ``mapping``),
one CV model with sigma_q = 10 m/s^2 (Stone Soup has no IMM), the 9.21
gate, P_D 0.9 and a per-scan local clutter density for JPDA, a
multi-measurement initiator confirming at M+2 updates, and deletion at
max_misses + 1 scans without an update. The GM-PHD peer (`StoneSoupGMPHD`)
is Stone Soup's `PointProcessMultiTargetTracker` with its GM hypothesiser,
PHD updater (an EKF inside) and mixture reducer, set up as our ``ekphd``.

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
from stonesoup.hypothesiser.gaussianmixture import GaussianMixtureHypothesiser
from stonesoup.hypothesiser.probability import PDAHypothesiser
from stonesoup.initiator.simple import MultiMeasurementInitiator
from stonesoup.measures import Mahalanobis
from stonesoup.mixturereducer.gaussianmixture import GaussianMixtureReducer
from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
from stonesoup.predictor.kalman import ExtendedKalmanPredictor
from stonesoup.tracker.pointprocess import PointProcessMultiTargetTracker
from stonesoup.tracker.simple import MultiTargetMixtureTracker, MultiTargetTracker
from stonesoup.types.state import GaussianState, TaggedWeightedGaussianState
from stonesoup.updater.kalman import ExtendedKalmanUpdater
from stonesoup.updater.pointprocess import PHDUpdater

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor
from nnda.data.sensor import polar_to_cart, wrap_angle
from nnda.filters.kalman import GATE_99
from nnda.filters.measurement import PolarMeasurement
from nnda.filters.motion import ConstantVelocity as NndaConstantVelocity
from nnda.peers.adapter import TrackBook, measurement_model, to_datetime, to_detections
from nnda.tracking.clutter_density import local_density
from nnda.tracking.detection_probability import detection_probabilities
from nnda.tracking.lifecycle import LifecycleConfig
from nnda.tracking.output import DELETED, TrackerOutput
from nnda.tracking.phd.birth import measurement_births
from nnda.tracking.phd.config import CommonConfig, MeasurementBirth
from nnda.tracking.phd.tracker import Cardinality, clutter, coverage_volume
from nnda.tracking.tracker import ContactTrackerConfig, TrackerConfig, checked_config, checked_scan, only_sensor


class PeerConfig(ContactTrackerConfig):
    """Settings of a Stone Soup peer; ``lifecycle`` gives M, N, max_misses and v_max (see the module table): Stone
    Soup's initiator and deleter count, so a peer runs the M/N rule whatever ``lifecycle.confirmation`` says."""

    lifecycle: LifecycleConfig = LifecycleConfig(confirmation="mn")

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
        #: the P_D of a peer whose config has one (`nnda.tracking.detection_probability`), else None
        self.detection = (detection_probabilities(self.name, self.config, self.sensors)
                          if "pd" in type(self.config).model_fields else None)
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
                                            prob_detect=self.detection[0], prob_gate=1.0 - math.exp(-cfg.gate / 2))
        return MultiTargetMixtureTracker(initiator=self.initiator, deleter=deleter, detector=None,
                                         data_associator=JPDA(self.hypothesiser), updater=self.updater)

    def _before(self, z: np.ndarray) -> None:
        cfg = self.config
        if cfg.clutter_density == "local" and len(z):
            xy = np.column_stack(polar_to_cart(z[:, 0], z[:, 1]))
            self.hypothesiser.clutter_spatial_density = float(
                np.mean(local_density(xy, xy, cfg.clutter_radius_m) * z[:, 0]))


#: our CV model, here only to lay out newborn states as [x, vx, y, vy] (Stone Soup's order too)
NEWBORN_LAYOUT = NndaConstantVelocity()


class PeerGMPHDConfig(CommonConfig):
    """GM-PHD peer settings: those of our ``ekphd`` (reduction preset, CV noise, p_S, p_D, clutter, gate) and
    its measurement-driven birth's rate and newborn speed spread."""

    birth: MeasurementBirth = MeasurementBirth()
    gate: Annotated[float, Field(gt=0)] = 50.0


class StoneSoupGMPHD:
    """Stone Soup's GM-PHD tracker (`PointProcessMultiTargetTracker`: `GaussianMixtureHypothesiser` over a
    `DistanceHypothesiser`, `PHDUpdater` around an `ExtendedKalmanUpdater`, `GaussianMixtureReducer`),
    stepped one scan at a time and reporting the components above the extraction threshold.

    Stone Soup's PHD updater evaluates the likelihood of a contact's bearing without wrapping the
    difference, so contacts are given with azimuths in [-pi, pi), its model's range: a target crossing due
    south (the seam) loses its likelihood there.

    Stone Soup's tracker adds one birth component per scan; measurement-driven birth is not among its
    components, so the newborn components of our ``ekphd`` (one per contact of the previous scan,
    velocity 0 +/- the birth speed spread, weight rate / N: Stone Soup's update does not say how much of
    a contact its components explain) are put into its mixture before each scan, tagged as births (Stone
    Soup drops a birth its first update misses, as ours does), and its own birth component weighs 0.
    """

    name: ClassVar[str] = "stonesoup-gmphd"
    config_type: ClassVar[type[TrackerConfig]] = PeerGMPHDConfig

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: PeerGMPHDConfig | None = None) -> None:
        self.sensor = sensor = only_sensor(self.name, sensors)
        self.sensors = (sensor,)
        self.config = checked_config(self, config)
        #: the P_D and where it came from (`nnda.tracking.detection_probability`)
        self.detection = detection_probabilities(self.name, self.config, self.sensors)
        self.polar = PolarMeasurement.from_sensor(sensor)
        self.volume = coverage_volume(sensor, polar=True)
        self.reset()

    def reset(self) -> None:
        """Build a fresh Stone Soup tracker (the start of a new run)."""
        cfg, sensor = self.config, self.sensor
        self.last_time = -np.inf
        self.model = measurement_model(sensor)
        q = cfg.sigma_q ** 2 * sensor.scan_period_s
        predictor = ExtendedKalmanPredictor(
            CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)]))
        self.updater = PHDUpdater(ExtendedKalmanUpdater(self.model), clutter_spatial_density=1.0,
                                  prob_detection=self.detection[0], prob_survival=cfg.ps)
        hypothesiser = GaussianMixtureHypothesiser(DistanceHypothesiser(
            predictor, self.updater.updater, Mahalanobis(), missed_distance=math.sqrt(cfg.gate)),
            order_by_detection=True)
        reducer = GaussianMixtureReducer(prune_threshold=cfg.prune_threshold, merge_threshold=cfg.merge_threshold,
                                         max_number_components=cfg.max_components)
        mid = 0.5 * (sensor.min_range_m + sensor.max_range_m)  # away from the radar, where the EKF is defined
        self.tracker = PointProcessMultiTargetTracker(
            detector=None, hypothesiser=hypothesiser, updater=self.updater, reducer=reducer,
            extraction_threshold=cfg.extraction_threshold,
            birth_component=TaggedWeightedGaussianState(
                [[0.0], [0.0], [mid], [0.0]], np.diag([1e6, 1e4, 1e6, 1e4]), weight=0.0,
                tag=TaggedWeightedGaussianState.BIRTH))
        self.births: list[TaggedWeightedGaussianState] = []
        self.book = TrackBook()
        self.cardinality: Cardinality | None = None

    def step(self, scan: Scan) -> TrackerOutput:
        """Process one sweep; report the extracted components as confirmed tracks (no contact)."""
        cfg = self.config
        z, time = checked_scan(self.name, scan, self.last_time, self.sensors)
        scan = Scan(scan.index, time, z)
        xy, cov = self.polar.position(z)
        mixture = self.tracker.gaussian_mixture
        rate, log_c = clutter(cfg, z, xy, self.volume, True,
                              self.detection[0] * float(sum(c.weight for c in mixture)) + cfg.birth.rate)
        # Stone Soup takes one clutter density per scan: the mean of the contacts' kappa
        self.updater.clutter_spatial_density = float(np.mean(rate * np.exp(log_c))) if len(z) else 1.0
        mixture.components.extend(self.births)
        when = to_datetime(time)
        # Stone Soup's PHD updater takes the likelihood of the raw bearing difference (no wrap), and its
        # model predicts bearings in [-pi, pi): the contacts' azimuths go in the same range, so only a
        # target crossing due south (the seam) is lost
        wrapped = np.column_stack([z[:, 0], wrap_angle(z[:, 1])]) if len(z) else z
        self.tracker.update_tracker(when, set(to_detections(Scan(scan.index, time, wrapped), self.model)))
        born = measurement_births(xy, cov, np.zeros(len(z)), cfg.birth.rate, cfg.birth.speed_sigma_m_s,
                                  NEWBORN_LAYOUT, 0)
        self.births = [TaggedWeightedGaussianState(m[:, None], P, weight=w, tag=TaggedWeightedGaussianState.BIRTH,
                                                   timestamp=when)
                       for w, m, P in zip(born.weights, born.means, born.covariances)]
        self.last_time = time
        shown = sorted((t for t in self.tracker.tracks
                        if t.state.timestamp == when and t.state.weight > cfg.extraction_threshold),
                       key=lambda t: (t.states[0].timestamp, *np.ravel(t.states[0].state_vector)))
        out = self.book.output(scan, shown, [])
        keep = out.status != DELETED  # a PHD reports no deletions: a track below the threshold is not shown
        self.cardinality = Cardinality(scan.index, time, float(self.tracker.estimated_number_of_targets), None,
                                       None, int(keep.sum()))
        return TrackerOutput(out.scan, out.time, out.track_id[keep], out.status[keep], out.state[keep],
                             out.covariance[keep], out.contact[keep])
