"""Stone Soup's GNN, JPDA and GM-PHD trackers behind our Tracker interface (``stonesoup-gnn``,
``stonesoup-jpda``, ``stonesoup-gmphd``).

Each is assembled from Stone Soup's own components and driven one scan at a
time through its `MultiTargetTracker` / `MultiTargetMixtureTracker`
(``update_tracker``); `nnda.peers.adapter` converts scans in and tracks out.
A peer takes several sensors, polar radars and sensors of position fixes in
any mix: each scan's detections carry the Stone Soup measurement model of
the scan's sensor (`nnda.peers.adapter.measurement_model`), which Stone
Soup's updaters, hypothesisers and initiators use in place of their own,
and the scan's P_D and clutter density are its sensor's.
Parameters are matched to ours as `nnda.peers.parameters.MATCHING` lists
(the report's "Against Stone Soup" section prints it): the radar's noise
in Stone Soup's polar model (its bearing made our azimuth by ``mapping``),
one CV model with sigma_q = 10 m/s^2 (Stone Soup has no IMM;
`transition_model`), the 9.21 gate, P_D 0.9 and a per-scan local clutter
density for JPDA, a multi-measurement initiator confirming at M+2 updates,
and deletion at max_misses + 1 scans without an update, counting only the
scans whose sensor observes the track (`ObservedStepsDeleter`). The GM-PHD
peer (`StoneSoupGMPHD`) is Stone Soup's `PointProcessMultiTargetTracker` with its GM hypothesiser,
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
from stonesoup.base import Property
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
from stonesoup.types.update import Update
from stonesoup.updater.kalman import ExtendedKalmanUpdater
from stonesoup.updater.pointprocess import PHDUpdater

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor, sensor_tuple
from nnda.data.sensor import observable, polar_to_cart_at, wrap_angle
from nnda.filters.kalman import GATE_99, gate_probability
from nnda.filters.measurement import measurement_model as nnda_measurement_model
from nnda.filters.motion import ConstantVelocity as NndaConstantVelocity
from nnda.peers.adapter import TrackBook, measurement_model, to_datetime, to_detections
from nnda.tracking.clutter_density import local_density
from nnda.tracking.detection_probability import detection_probabilities
from nnda.tracking.lifecycle import LifecycleConfig
from nnda.tracking.output import DELETED, TrackerOutput
from nnda.tracking.phd.birth import measurement_births
from nnda.tracking.phd.config import CommonConfig, MeasurementBirth
from nnda.tracking.phd.tracker import Cardinality, clutter, coverage_volume
from nnda.tracking.protocol import TrackerConfig, checked_config, checked_scan
from nnda.tracking.tracker import ContactTrackerConfig


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


def transition_model(sigma_q: float, sensors: tuple[Sensor, ...]) -> CombinedLinearGaussianTransitionModel:
    """Stone Soup's CV model on x and y for a peer of ``sensors``: white-noise acceleration (its
    `ConstantVelocity`, continuous in time: velocity variance q dt over any interval dt s, whichever sensor
    scans next) of spectral density q = sigma_q^2 T (m^2/s^3), T the shortest scan period (s) of ``sensors``:
    over T the velocity variance is sigma_q^2 T^2, that of an acceleration of sd sigma_q (m/s^2) held over
    one period of the fastest sensor (the one radar's period for one radar)."""
    q = sigma_q ** 2 * min(s.scan_period_s for s in sensors)
    return CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])


def observed_by(sensors: tuple[Sensor, ...], sensor: int, means: np.ndarray) -> np.ndarray:
    """(K,) bool: whether a scan of ``sensors[sensor]`` observes the states of means (K, 4) [x, vx, y, vy]
    (`nnda.data.sensor.observable`: inside its coverage, or outside every sensor's); all, with one sensor."""
    if len(sensors) == 1:
        return np.ones(len(means), bool)
    return observable(sensors, sensor, means[:, 0], means[:, 2])


class ObservedStepsDeleter(UpdateTimeStepsDeleter):
    """Stone Soup's `UpdateTimeStepsDeleter` counting only the scans whose sensor observes the track: a track
    goes once more than ``time_steps_since_update`` such scans have passed without an update. A scan observes
    a track whose position then lies in its sensor's coverage or outside every sensor's
    (`nnda.data.sensor.observable`, our trackers' rule): a radar that does not cover a track counts no miss
    against it. With one sensor every scan observes every track: Stone Soup's own deleter."""

    sensors: tuple = Property(doc="the tracker's sensors (`Sensor`)")
    sensor_at: dict = Property(doc="scan time (datetime) -> the index of its sensor in ``sensors``")

    def check_for_deletion(self, track, **kwargs) -> bool:
        """True unless an update lies within the last ``time_steps_since_update`` observing scans."""
        steps = set()
        for state in track[::-1]:
            if self._observed(state):
                steps.add(state.timestamp)
                if len(steps) > self.time_steps_since_update:
                    return True
            if isinstance(state, Update) and state.hypothesis:
                return False
        return False

    def _observed(self, state) -> bool:
        return bool(observed_by(self.sensors, self.sensor_at[state.timestamp],
                                np.asarray(state.state_vector, float).reshape(1, 4))[0])


class StoneSoupTracker:
    """A Stone Soup multi-target tracker stepped one scan at a time; subclasses pick the association.

    Meets our `nnda.tracking.protocol.Tracker` protocol: built as ``cls(sensors, config)`` for polar radars
    and sensors of position fixes in any mix; each scan's detections carry its sensor's measurement model.
    """

    name: ClassVar[str]
    config_type: ClassVar[type[TrackerConfig]]

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: PeerConfig | None = None) -> None:
        self.sensors = sensor_tuple(sensors)
        self.config = checked_config(self, config)
        #: the P_D of a peer whose config has one (`nnda.tracking.detection_probability`), else None
        self.detection = (detection_probabilities(self.name, self.config, self.sensors)
                          if "pd" in type(self.config).model_fields else None)
        #: Stone Soup's measurement model of each sensor, carried by that sensor's detections
        self.models = tuple(measurement_model(s) for s in self.sensors)
        self.reset()

    def reset(self) -> None:
        """Build a fresh Stone Soup tracker (the start of a new run)."""
        self.last_time = -np.inf
        cfg = self.config
        self.predictor = ExtendedKalmanPredictor(transition_model(cfg.sigma_q, self.sensors))
        self.updater = ExtendedKalmanUpdater(measurement_model=None)  # each detection's own
        life = cfg.lifecycle
        speed_var = (life.v_max / 2) ** 2
        self.sensor_at: dict = {}  # scan time -> its sensor, for the deleters
        self.initiator = MultiMeasurementInitiator(
            prior_state=GaussianState(np.zeros((4, 1)), np.diag([0.0, speed_var, 0.0, speed_var])),
            measurement_model=None, deleter=self._deleter(life.n - life.m + 1),
            data_associator=GNNWith2DAssignment(self._distance_hypothesiser()),
            updater=self.updater, min_points=life.m + 2)
        self.tracker = self._tracker(self._deleter(life.max_misses + 1))
        self.book = TrackBook()

    def _deleter(self, steps: int) -> ObservedStepsDeleter:
        return ObservedStepsDeleter(steps, sensors=self.sensors, sensor_at=self.sensor_at)

    def _distance_hypothesiser(self) -> DistanceHypothesiser:
        return DistanceHypothesiser(self.predictor, self.updater, Mahalanobis(),
                                    missed_distance=math.sqrt(self.config.gate))

    @abstractmethod
    def _tracker(self, deleter: UpdateTimeStepsDeleter):
        """The Stone Soup tracker around ``self.initiator`` and ``deleter``."""

    def _before(self, z: np.ndarray, sensor: int) -> None:
        """Per-scan settings from the contacts z (N, 2) of sensor ``sensor`` (index; none by default)."""

    def step(self, scan: Scan) -> TrackerOutput:
        """Process one sweep and report every track (confirmed, held by the initiator, just deleted)."""
        z, time = checked_scan(self.name, scan, self.last_time, self.sensors)
        sensor, when = scan.sensor, to_datetime(time)
        scan = Scan(scan.index, time, z, sensor)
        self._before(z, sensor)
        self.sensor_at[when] = sensor
        self.tracker.update_tracker(when, set(to_detections(scan, self.models[sensor])))
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
    """Stone Soup EKF tracker with JPDA (exact joint events) and Gaussian-mixture reduction.

    Stone Soup's `PDAHypothesiser` takes one P_D: each scan's is its sensor's, for every track. A track
    outside that sensor's coverage has none of its contacts in its gate, so its update is its prediction, as
    with P_D 0 (our trackers' rule), except near the coverage's edge.
    """

    name: ClassVar[str] = "stonesoup-jpda"
    config_type: ClassVar[type[TrackerConfig]] = PeerJPDAConfig

    def _tracker(self, deleter):
        cfg = self.config
        density = cfg.clutter_density if cfg.clutter_density != "local" else 1.0  # set per scan
        self.hypothesiser = PDAHypothesiser(self.predictor, self.updater, clutter_spatial_density=density,
                                            prob_detect=self.detection[0], prob_gate=gate_probability(cfg.gate))
        return MultiTargetMixtureTracker(initiator=self.initiator, deleter=deleter, detector=None,
                                         data_associator=JPDA(self.hypothesiser), updater=self.updater)

    def _before(self, z: np.ndarray, sensor: int) -> None:
        """The sensor's P_D and, for the 'local' density, the mean over the contacts of the contacts per m^2 in
        the square around each, in the sensor's measurement space (times range for a polar sensor: per m rad;
        per m^2 for position fixes)."""
        cfg, s = self.config, self.sensors[sensor]
        self.hypothesiser.prob_detect = self.detection[sensor]
        if cfg.clutter_density == "local" and len(z):
            polar = s.kind == "polar"
            xy = np.column_stack(polar_to_cart_at(s.position, z[:, 0], z[:, 1])) if polar else z
            density = local_density(xy, xy, cfg.clutter_radius_m)
            self.hypothesiser.clutter_spatial_density = float(np.mean(density * z[:, 0] if polar else density))


#: our CV model, here only to lay out newborn states as [x, vx, y, vy] (Stone Soup's order too)
NEWBORN_LAYOUT = NndaConstantVelocity()


class PeerGMPHDConfig(CommonConfig):
    """GM-PHD peer settings: those of our ``ekphd`` (reduction preset, CV noise, p_S, p_D, clutter, gate) and
    its measurement-driven birth's rate and newborn speed spread."""

    birth: MeasurementBirth = MeasurementBirth()
    gate: Annotated[float, Field(gt=0)] = 50.0


class SetAsidePHDUpdater(PHDUpdater):
    """Stone Soup's `PHDUpdater` whose update also returns ``aside``: the components a scan's sensor does not
    observe, predicted to the scan by the tracker (P_D 0 for them, as our trackers take it: missed, weight
    times p_S), so that the mixture reduction and the tracks see them as Stone Soup's own."""

    aside: list = Property(default=None, doc="components left out of this scan's update, already predicted")

    def update(self, hypotheses):
        """Stone Soup's PHD update of ``hypotheses``, with ``aside`` added to the posterior mixture."""
        mixture = super().update(hypotheses)
        mixture.components.extend(self.aside or ())
        return mixture


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

    Several sensors: each scan's P_D, clutter (over its coverage) and newborn components are its sensor's;
    Stone Soup's updater takes one P_D, so the components the scan's sensor does not observe (predicted
    outside its coverage and inside another's) are set aside, predicted, and rejoin the posterior with
    their weight times p_S (`SetAsidePHDUpdater`): P_D 0 for them, as in our ``ekphd``; a newborn set aside
    is kept, no longer a birth. p_S is ``ps`` per shortest scan period, ps^(dt / T), as ours.
    """

    name: ClassVar[str] = "stonesoup-gmphd"
    config_type: ClassVar[type[TrackerConfig]] = PeerGMPHDConfig

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: PeerGMPHDConfig | None = None) -> None:
        self.sensors = sensor_tuple(sensors)
        self.config = checked_config(self, config)
        #: the P_D of each sensor and where it came from (`nnda.tracking.detection_probability`)
        self.detection = detection_probabilities(self.name, self.config, self.sensors)
        #: per sensor: our measurement model (contacts' positions for clutter and births), Stone Soup's
        #: (carried by its detections) and its coverage in its measurement space (m rad, or m^2 for fixes)
        self.measurements = tuple(nnda_measurement_model(s) for s in self.sensors)
        self.models = tuple(measurement_model(s) for s in self.sensors)
        self.volumes = tuple(coverage_volume(s, polar=s.kind == "polar") for s in self.sensors)
        self.period = min(s.scan_period_s for s in self.sensors)
        self.reset()

    def reset(self) -> None:
        """Build a fresh Stone Soup tracker (the start of a new run)."""
        cfg, first = self.config, self.sensors[0]
        self.last_time = -np.inf
        self.predictor = ExtendedKalmanPredictor(transition_model(cfg.sigma_q, self.sensors))
        self.updater = SetAsidePHDUpdater(ExtendedKalmanUpdater(measurement_model=None), clutter_spatial_density=1.0,
                                          prob_detection=self.detection[0], prob_survival=cfg.ps)
        hypothesiser = GaussianMixtureHypothesiser(DistanceHypothesiser(
            self.predictor, self.updater.updater, Mahalanobis(), missed_distance=math.sqrt(cfg.gate)),
            order_by_detection=True)
        reducer = GaussianMixtureReducer(prune_threshold=cfg.prune_threshold, merge_threshold=cfg.merge_threshold,
                                         max_number_components=cfg.max_components)
        mid = 0.5 * (first.min_range_m + first.max_range_m)  # north of the first sensor, where the EKF is defined
        self.tracker = PointProcessMultiTargetTracker(
            detector=None, hypothesiser=hypothesiser, updater=self.updater, reducer=reducer,
            extraction_threshold=cfg.extraction_threshold,
            birth_component=TaggedWeightedGaussianState(
                [[first.x_m], [0.0], [first.y_m + mid], [0.0]], np.diag([1e6, 1e4, 1e6, 1e4]), weight=0.0,
                tag=TaggedWeightedGaussianState.BIRTH))
        self.births: list[TaggedWeightedGaussianState] = []
        self.book = TrackBook()
        self.cardinality: Cardinality | None = None

    def _set_aside(self, sensor: int, when, survival: float) -> list:
        """Take the components (newborn included) that this scan's sensor does not observe out of the mixture
        and give them to the updater predicted to ``when``, weight times ``survival`` (a newborn's kept, under a
        fresh tag); return the observed components that are not newborn."""
        mixture, aside = self.tracker.gaussian_mixture, []
        if len(self.sensors) > 1:  # one sensor observes every component
            predicted = [self.predictor.predict(c, timestamp=when) for c in mixture]
            seen = observed_by(self.sensors, sensor,
                               np.array([np.ravel(p.state_vector) for p in predicted], float).reshape(-1, 4))
            for c, pred in ((c, p) for c, p, s in zip(mixture.components, predicted, seen) if not s):
                if c.tag == TaggedWeightedGaussianState.BIRTH:  # a fresh tag: no longer a birth
                    aside.append(TaggedWeightedGaussianState(pred.state_vector, pred.covar, weight=c.weight,
                                                             timestamp=when))
                else:
                    aside.append(TaggedWeightedGaussianState(pred.state_vector, pred.covar,
                                                             weight=c.weight * survival, timestamp=when, tag=c.tag))
            mixture.components = [c for c, s in zip(mixture.components, seen) if s]
        self.updater.aside = aside
        return [c for c in mixture if c.tag != TaggedWeightedGaussianState.BIRTH]

    def step(self, scan: Scan) -> TrackerOutput:
        """Process one sweep; report the extracted components as confirmed tracks (no contact)."""
        cfg = self.config
        z, time = checked_scan(self.name, scan, self.last_time, self.sensors)
        sensor, when = scan.sensor, to_datetime(time)
        scan = Scan(scan.index, time, z, sensor)
        xy, cov = self.measurements[sensor].position(z)
        pd = self.detection[sensor]
        survival = cfg.ps ** ((time - self.last_time) / self.period) if np.isfinite(self.last_time) else cfg.ps
        self.updater.prob_detection, self.updater.prob_survival = pd, survival
        self.tracker.gaussian_mixture.components.extend(self.births)
        observed = self._set_aside(sensor, when, survival)
        polar = self.sensors[sensor].kind == "polar"
        rate, log_c = clutter(cfg, z, xy, self.volumes[sensor], polar,
                              pd * float(sum(c.weight for c in observed)) + cfg.birth.rate)
        # Stone Soup takes one clutter density per scan: the mean of the contacts' kappa
        self.updater.clutter_spatial_density = float(np.mean(rate * np.exp(log_c))) if len(z) else 1.0
        # Stone Soup's PHD updater takes the likelihood of the raw bearing difference (no wrap), and its
        # model predicts bearings in [-pi, pi): the contacts' azimuths go in the same range, so only a
        # target crossing due south (the seam) is lost
        wrapped = np.column_stack([z[:, 0], wrap_angle(z[:, 1])]) if polar and len(z) else z
        self.tracker.update_tracker(when, set(to_detections(Scan(scan.index, time, wrapped), self.models[sensor])))
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
