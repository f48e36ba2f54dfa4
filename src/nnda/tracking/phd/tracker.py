"""The PHD trackers: ``gmphd``, ``ekphd``, ``ukphd`` and ``cphd`` behind the Tracker protocol.

Each is built as ``cls(sensors, config, measurement=None)``: one sensor or
several (polar radars, each with its noise, position and coverage, or
position sensors), a config (`nnda.tracking.phd.config`) and, with one
sensor, optionally the measurement model of the scans' contacts as a
component (default: each sensor's, `nnda.filters.measurement.measurement_model`;
a `PositionMeasurement` makes the contacts Cartesian (x, y) fixes, whose
update is linear whatever the linearisation: there ``ekf`` and ``ukf`` name
how the motion is predicted, and the clutter is spread over
``clutter_area_m2`` when given). The motion model says where the position
sits in its state (`MotionModel.position`): the pedestrian heading models
[x, y, v, alpha] take Cartesian fixes only. The prediction is the EKF's
(the motion's Jacobian), or the unscented transform's with ``ukf``. One
scan (J components, N contacts):

1. predict the posterior to the scan time (survival ps per shortest scan
   period of the sensors: ps^(dt / T); with one sensor dt = T), add spawned
   components, last scan's newborn components (predicted, without ps) and
   static births (`nnda.tracking.phd.gmphd`, `nnda.tracking.phd.birth`);
2. update with every (component, contact) pair inside the chi-square gate
   at once (at most ``max_pairs`` candidate pairs: past it, the lightest
   predicted components sit the scan out, counted, with a BoundWarning
   the first time in a run): GM-PHD weights (`gmphd.phd_weights`) or, for ``cphd``, the
   cardinalised ones with the cardinality distribution
   (`nnda.tracking.phd.cphd`); only copies heavier than the prune threshold
   are built, and a newborn component's missed copy is dropped (a target is
   born detected) unless the scan's sensor cannot see it;
3. merge and cap (`nnda.filters.mixture`; J_max, or with
   ``components_per_contact`` c at least c N for N contacts, with
   ``components_per_target`` c_t at least c_t times the expected target
   count; what the cap drops is counted, with a BoundWarning the first time
   in a run), make labels unique (`nnda.tracking.phd.extraction`);
4. newborn components for the next scan from this scan's contacts, weighted
   by how little the filter explains them (measurement-driven birth; at a
   sensor's first sweep with contacts, by how crowded their squares are,
   ``first_sweep_births``);
5. report the extracted components (weight >= the extraction threshold; or,
   ``cphd`` with ``extraction="map"``, its MAP count of heaviest ones; with
   ``extraction_scans`` = k, only labels once extracted after k sweeps in a row of one sensor, each
   sensor's sweeps counted apart; with ``coast_misses`` = m, a reported label also while its weight
   is at least the threshold times (1 - p_D)^m: `nnda.tracking.phd.extraction`) as
   CONFIRMED tracks, id = label, state [x, vx, y, vy] (`MotionModel.to_cv`), no contact (a PHD
   associates none); the scan's target-count estimate is in
   ``tracker.cardinality``.

Several sensors (the iterated-corrector PHD and CPHD): each scan updates
with its own sensor's measurement model, clutter volume and detection
probability (``sensor_pd``, else ``pd`` when set, else the sensor's declared P_D,
`nnda.tracking.detection_probability`), in time order. A component the
scan's sensor cannot see at its predicted mean (outside its range limits or
sector) gets p_D = 0 from that scan, so it is not thinned by a sensor that
could not have detected it, unless no sensor covers it (then it misses, as
with one sensor, where p_D is the same everywhere); the CPHD's cardinality
update uses the intensity-weighted miss probability <1 - p_D, v> / <1, v>.

After `step`, ``tracker.mixture`` holds the posterior intensity (at most
J_max components) and ``tracker.cardinality`` a `Cardinality` record of the
scan. The work and memory of a scan grow with J_max + N components and the
gated pairs, not with J x N.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor, sensor_tuple
from nnda.data.sensor import observable
from nnda.errors import BoundWarning, ConfigError
from nnda.filters.kalman import MeasurementPrediction
from nnda.filters.measurement import MeasurementModel, PositionMeasurement, measurement_model
from nnda.filters.mixture import Mixture, cap, merge
from nnda.filters.motion import POS
from nnda.tracking.clutter_density import coverage_area, local_density, measurement_volume, unexplained_density
from nnda.tracking.detection_probability import FROM_CONFIG, DetectionProbabilities, detection_probabilities
from nnda.tracking.output import CONFIRMED, NO_CONTACT, TrackerOutput
from nnda.tracking.phd import cphd, gmphd
from nnda.tracking.phd.birth import first_sweep_births, measurement_births
from nnda.tracking.phd.config import (
    CommonConfig,
    CPHDConfig,
    EKPHDConfig,
    GMPHDConfig,
    PHDConfig,
    StaticBirth,
    UKPHDConfig,
)
from nnda.tracking.phd.extraction import (
    above,
    coast_floor,
    coasting,
    default_coast_misses,
    heaviest,
    persistent,
    relabel_duplicates,
)
from nnda.tracking.protocol import TrackerConfig, checked_config, checked_contacts, checked_scan


@dataclass(frozen=True)
class Cardinality:
    """The target count after one scan.

    ``mean`` is the expected number of targets (a PHD: the updated
    intensity's total weight, before pruning; the CPHD: the mean of its
    distribution), ``map`` the CPHD's most probable count (None for a PHD),
    ``distribution`` the CPHD's p(n), n = 0..N_max (None for a PHD),
    ``extracted`` the number of tracks reported, ``variance`` the count's
    variance where a tracker gives it without a distribution (the labelled
    trackers' mixture of multi-Bernoulli counts; None otherwise).
    """

    scan: int
    time: float
    mean: float
    map: int | None
    distribution: np.ndarray | None
    extracted: int
    variance: float | None = None


#: the floor of the per-scan clutter estimate: never exactly no clutter, so that a contact no component
#: explains is clutter, not a scan the CPHD's model cannot have produced
MIN_SCAN_CLUTTER = 1e-3


def clutter(config: CommonConfig, z: np.ndarray, xy: np.ndarray, volume: float, polar: bool,
            expected_detections: float, explained: Explained | None = None) -> tuple[float, np.ndarray]:
    """(lambda, log clutter spatial density (N,)) of one scan for ``config.clutter`` (see
    `nnda.tracking.phd.config`): contacts z (N, 2) as measured, xy (N, 2) m their Cartesian positions,
    ``volume`` the coverage in the update's measurement space (m rad if ``polar``, else m^2),
    ``expected_detections`` p_D times the predicted target count, ``explained`` what the predicted intensity
    explains (for ``"unexplained"``)."""
    n = len(z)
    if config.clutter in ("local", "unexplained"):
        if config.clutter == "local":  # lambda the contact count
            density = local_density(xy, xy, config.clutter_radius_m)  # contacts per m^2
            rate, share = float(n), float(max(n, 1))
        else:  # lambda the contacts less the expected detections, as "scan"
            density = unexplained_density(xy, xy, config.clutter_radius_m, explained.area, explained.sensor,
                                          explained.at, explained.expected, 1.0)
            rate = share = max(n - expected_detections, MIN_SCAN_CLUTTER)
        if polar:
            density = density * z[:, 0]  # per m rad: dx dy = r dr d(azimuth)
        return rate, np.log(density / share)
    rate = max(n - expected_detections, MIN_SCAN_CLUTTER) if config.clutter == "scan" else float(config.clutter)
    return rate, np.full(n, -np.log(volume))


@dataclass(frozen=True)
class Explained:
    """What a scan's predicted intensity explains, for the ``"unexplained"`` clutter estimate
    (`unexplained_density`): its components' positions ``at`` (J, 2) m and expected detections ``expected``
    (J,) (p_D times weight), the scan's sensor (its coverage bounds the squares; None for fixes spread over
    ``clutter_area_m2``) and the area (m^2) its clutter falls in."""

    at: np.ndarray
    expected: np.ndarray
    sensor: Sensor | None
    area: float


def sensor_detection(name: str, config: PHDConfig, sensors: tuple[Sensor, ...]) -> DetectionProbabilities:
    """Each sensor's detection probability for tracker ``name`` and its source: ``config.sensor_pd``, else
    ``config.pd`` when set, else the sensor's declared P_D, else the default ``pd``
    (`nnda.tracking.detection_probability`); ConfigError when ``sensor_pd`` gives another number of them than
    there are ``sensors``."""
    if config.sensor_pd is None:
        return detection_probabilities(name, config, sensors)
    pds = config.sensor_pd
    if len(pds) != len(sensors):
        raise ConfigError(f"{name}: sensor_pd gives {len(pds)} detection probabilities for "
                          f"{len(sensors)} sensor(s) ({', '.join(s.name for s in sensors)})")
    return DetectionProbabilities(tuple(s.name for s in sensors), tuple(pds),
                                  (f"{FROM_CONFIG} (sensor_pd)",) * len(sensors))


def coverage_volume(sensor: Sensor, polar: bool) -> float:
    """The sensor's coverage in the update's measurement space: m rad for polar contacts, else m^2."""
    return measurement_volume(sensor) if polar else coverage_area(sensor)


@dataclass(frozen=True)
class SensorView:
    """What the update takes from one of a tracker's sensors: its contacts' measurement model and how the
    components are linearised for it, its coverage ``volume`` in the update's measurement space
    (`coverage_volume`, or the config's ``clutter_area_m2``), its detection probability ``pd``, whether its
    contacts are Cartesian fixes and whether the update linearises the polar measurement (``polar``: false
    for Cartesian fixes, whose update is linear whatever the linearisation)."""

    sensor: Sensor
    measurement: MeasurementModel
    linearisation: gmphd.Linearisation
    volume: float
    pd: float
    cartesian: bool
    polar: bool


#: a scan's weight dropped by the mixture cap from which the cap is said to bite (`GMPHDTracker._capped`)
CAPPED_WEIGHT_WARNING = 0.1
#: the probability of the CPHD's largest count N_max from which a fixed support is said to bite
#: (`CPHDTracker._report`)
CAPPED_CARDINALITY_WARNING = 0.01


class GMPHDTracker:
    """Gaussian-mixture PHD tracker (Vo & Ma 2006) with tag propagation; see the module docstring."""

    name: ClassVar[str] = "gmphd"
    config_type: ClassVar[type[TrackerConfig]] = GMPHDConfig

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: PHDConfig | None = None,
                 measurement: MeasurementModel | None = None) -> None:
        self.sensors = sensor_tuple(sensors)
        self.config = cfg = checked_config(self, config)
        if measurement is not None and len(self.sensors) != 1:
            raise ConfigError(f"{self.name}: a measurement model replaces the one sensor's; this tracker has "
                              f"{len(self.sensors)} sensors")
        #: the P_D of each sensor's scans and where it came from
        self.detection = sensor_detection(self.name, cfg, self.sensors)
        names = [s.name for s in self.sensors]
        unknown = sorted(set(cfg.use_sensors or ()) - set(names))
        if unknown:
            raise ConfigError(f"{self.name}: use_sensors names {', '.join(map(repr, unknown))}, which this scene "
                              f"does not have (its sensors: {', '.join(names)})")
        self.used = np.array([cfg.use_sensors is None or n in cfg.use_sensors for n in names])
        #: the misses in a row a reported label is shown through (`extraction.default_coast_misses`)
        self.coast_misses = default_coast_misses(cfg.coast_misses, int(self.used.sum()))
        self.motion = cfg.motion_model()
        self.transform = cfg.unscented.transform() if cfg.linearisation == "ukf" else None  # UT prediction
        self.views = tuple(self._view(s, measurement, pd)
                           for s, pd in zip(self.sensors, self.detection.values, strict=True))
        self.period = min(s.scan_period_s for s in self.sensors)
        birth = cfg.birth
        self.static = None if not isinstance(birth, StaticBirth) else Mixture.make(
            [c.weight for c in birth.components], [c.mean for c in birth.components],
            [c.covariance for c in birth.components], np.zeros(len(birth.components), np.int64))
        self.spawn_covariance = None if cfg.spawn is None else np.asarray(cfg.spawn.covariance, dtype=float)
        self.label = self.name  # how its warnings name it (a fusion tracker's local filter: with its sensor)
        self.reset()

    def _view(self, sensor: Sensor, measurement: MeasurementModel | None, pd: float) -> SensorView:
        cfg = self.config
        measurement = measurement if measurement is not None else measurement_model(sensor)
        cartesian = isinstance(measurement, PositionMeasurement)
        position = self.motion.position
        if not cartesian and not np.array_equal(position, POS):
            raise ConfigError(f"{self.name}: motion {cfg.motion!r} has the state [x, y, v, alpha], which the "
                              f"polar radar measurement of sensor {sensor.name!r} does not take; it needs "
                              f"Cartesian position fixes (a sensor of kind 'position')")
        polar = not cartesian and cfg.linearisation != "linear"
        linearisation = (gmphd.Linear(measurement, position) if not polar else
                         gmphd.EKF(measurement) if cfg.linearisation == "ekf" else
                         gmphd.UKF(measurement, cfg.unscented.transform()))
        volume = (cfg.clutter_area_m2 if not polar and cfg.clutter_area_m2 is not None
                  else coverage_volume(sensor, polar))
        return SensorView(sensor, measurement, linearisation, volume, pd, cartesian, polar)

    def reset(self) -> None:
        """Forget the intensity, the newborn components and the labels (the start of a run)."""
        n = self.config.state_dim
        self.mixture = Mixture.empty(n)
        self.newborn = Mixture.empty(n)
        self.next_label = 0
        #: the sensors of the sweeps with contacts since the reset (a sensor's first one: `birth.first_sweep_births`)
        self.swept: set[int] = set()
        self.last_time, self.last_sensor = -np.inf, -1
        self.cardinality: Cardinality | None = None
        #: predicted components left out of a scan's update by ``max_pairs`` since the last reset, and the
        #: candidate pairs they would have formed (`_within_pairs`)
        self.n_dropped_components = 0
        self.n_dropped_pairs = 0
        #: components the mixture cap dropped after merging since the last reset (`_capped`), and their weight
        self.n_capped_components = 0
        self.capped_weight = 0.0
        self._bounds_hit: set[str] = set()
        # per sensor: the labels extracted after its last sweep (sorted) and after how many of its sweeps in a row
        # (`extraction.streaks`); the labels confirmed so far (sorted: `extraction.persistent`)
        self.extraction_streaks = [(np.empty(0, np.int64), np.empty(0, np.int64)) for _ in self.sensors]
        self.confirmed_labels = np.empty(0, np.int64)

    def intensity_at(self, time: float) -> Mixture:
        """The posterior intensity predicted to ``time`` (s) without births (survivors, p_S per `_survival`):
        what a fusion centre takes from this filter between its scans; the posterior itself at its scan time."""
        if not np.isfinite(self.last_time) or time == self.last_time or not len(self.mixture):
            return self.mixture
        return gmphd.predict(self.mixture, self.motion, time - self.last_time, self._survival(time), self.transform)

    # ------------------------------------------------------------------ steps
    def _fresh(self, k: int) -> np.ndarray:
        labels = np.arange(self.next_label, self.next_label + k, dtype=np.int64)
        self.next_label += k
        return labels

    def _checked(self, scan: Scan) -> tuple[np.ndarray, float]:
        """The scan's contacts (N, 2) and time: the scan, its time and sensor by `checked_scan`, its contacts by
        `checked_contacts` for this filter's measurement of that sensor (range and azimuth, or Cartesian fixes:
        a polar radar's plots may be given to it as fixes)."""
        if not hasattr(scan, "measurements"):
            return checked_scan(self.name, scan, self.last_time, self.sensors)  # refused there, named
        _, time = checked_scan(self.name, Scan(scan.index, scan.time, np.empty((0, 2)), scan.sensor), self.last_time,
                               self.sensors, self.last_sensor)  # the time and the sensor index first
        view = self.views[scan.sensor]
        return checked_contacts(self.name, scan, not view.cartesian, view.sensor.name), time

    def _survival(self, time: float) -> float:
        """p_S from the last scan to ``time`` (s): ``ps`` per shortest scan period, ps^(dt / T)."""
        return self.config.ps ** ((time - self.last_time) / self.period) if np.isfinite(self.last_time) else 1.0

    def _predicted(self, time: float, survival: float) -> tuple[Mixture, float, slice]:
        """Step 1: the predicted intensity at ``time`` (s) with p_S ``survival``, the weight of its births,
        and where last scan's newborn components are in it (survivors, newborn, spawned, static births)."""
        cfg = self.config
        parts, born, newborn = [self.mixture], 0.0, slice(0, 0)
        if np.isfinite(self.last_time):
            dt = time - self.last_time
            old, nb = self.mixture, self.newborn
            # survivors (times p_S) and newborn (not: they are born now) predicted in one call
            ps = np.concatenate([np.full(len(old), survival), np.ones(len(nb))])
            parts = [gmphd.predict(Mixture.concat([old, nb]) if len(nb) else old, self.motion, dt, ps,
                                   self.transform)]
            born += float(nb.weights.sum())
            newborn = slice(len(old), len(old) + len(nb))
            if cfg.spawn is not None and len(old):
                parts.append(gmphd.spawn(old, self.motion, dt, cfg.spawn.weight, self.spawn_covariance,
                                         self._fresh(len(old))))
        if self._static_births():
            s = self.static
            parts.append(Mixture(s.weights, s.means, s.covariances, self._fresh(len(s))))
            born += float(s.weights.sum())
        return (Mixture.concat(parts) if len(parts) > 1 else parts[0]), born, newborn

    def _static_births(self) -> int:
        """How many static birth components this scan's prediction adds (they end it): at every scan, or at the
        first only."""
        if self.static is None or not (self.config.birth.every_scan or not np.isfinite(self.last_time)):
            return 0
        return len(self.static)

    def _within_pairs(self, pred: Mixture, born: float, newborn: slice | np.ndarray, view: SensorView,
                      zc: np.ndarray, contact_R: np.ndarray | None, time: float
                      ) -> tuple[Mixture, float, slice | np.ndarray, MeasurementPrediction | None]:
        """Step 2's bound ``max_pairs``: the prediction, its birth weight and where last scan's newborn are in
        it, as they are when the (component, contact) candidate pairs fit the bound (counted without forming
        them, and only when J x N exceeds it); else its heaviest components whose pairs fit (ties: the earlier),
        in their order, the left-out births' weight taken from ``born``, the newborn as indices. Each time
        counted (``n_dropped_components``, ``n_dropped_pairs``); the first time in a run a BoundWarning. Last,
        the measurement prediction of the components returned when the count made it (for `pairs`), else None."""
        limit = self.config.max_pairs
        if limit is None or len(pred) * len(zc) <= limit:
            return pred, born, newborn, None
        mp = view.linearisation.prediction(pred)
        counts = view.linearisation.pair_counts(mp, zc, contact_R, self.config.gate)
        total = int(counts.sum())
        if total <= limit:
            return pred, born, newborn, mp
        order = np.lexsort((np.arange(len(pred)), -pred.weights))  # heaviest first, ties: the earlier
        keep = np.zeros(len(pred), bool)
        keep[order[np.cumsum(counts[order]) <= limit]] = True
        last_newborn = np.zeros(len(pred), bool)
        last_newborn[newborn] = True
        births = last_newborn.copy()
        births[len(pred) - self._static_births():] = True
        born = max(born - float(pred.weights[births & ~keep].sum()), 0.0)
        kept = int(counts[keep].sum())
        dropped = len(pred) - int(keep.sum())
        self.n_dropped_components += dropped
        self.n_dropped_pairs += total - kept
        if "max_pairs" not in self._bounds_hit:
            self._bounds_hit.add("max_pairs")
            warnings.warn(f"{self.label}, t = {time} s: {len(pred):,} predicted components and {len(zc):,} contacts "
                          f"would form {total:,} candidate pairs, above the bound of {limit:,}; the {dropped:,} "
                          f"lightest components were left out of the update (config field max_pairs: raise it, "
                          f"or None for no bound); later cases of this run are only counted "
                          f"(n_dropped_components, n_dropped_pairs)", BoundWarning, stacklevel=3)
        return pred.take(keep), born, np.flatnonzero(last_newborn[keep]), mp.take(keep)

    def _detection(self, view: SensorView, scan_sensor: int, pred: Mixture) -> float | np.ndarray:
        """p_D of the predicted components for the scan's sensor: its ``pd`` with one sensor used; with
        several, per component (J,): ``pd`` inside its coverage or outside every used sensor's, else 0."""
        if self.used.sum() == 1:
            return view.pd
        used = [s for s, u in zip(self.sensors, self.used) if u]
        x, y = self.motion.position
        seen = observable(used, int(self.used[:scan_sensor].sum()), pred.means[:, x], pred.means[:, y])
        return np.where(seen, view.pd, 0.0)

    def _weights(self, pred: Mixture, pairs: gmphd.Pairs, rate: float, log_c: np.ndarray, born: float,
                 pd: float | np.ndarray, survival: float) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Step 2's weights with detection probability ``pd`` (a number or (J,)) and the prediction's p_S
        ``survival``: of the detection copies (P,), of the missed copies (J,), and the posterior
        cardinality distribution (None: a PHD has none)."""
        with np.errstate(divide="ignore"):
            log_kappa = np.log(rate) + log_c
        det, missed = gmphd.phd_weights(pred.weights, pairs, pd, log_kappa)
        return det, missed, None

    def _extracted(self, post: Mixture, map_count: int | None) -> np.ndarray:
        return above(post, self.config.extraction_threshold)

    def step(self, scan: Scan) -> TrackerOutput:
        """Process one sweep; report the extracted components as confirmed tracks."""
        z, time = self._checked(scan)
        cfg, view = self.config, self.views[scan.sensor]
        if not self.used[scan.sensor]:  # a scan this filter does not take: its prediction is the report
            pred = self.intensity_at(time)
            return self._report(scan.index, scan.sensor, time, pred,
                                *self._predicted_count(pred, self._survival(time)))
        survival = self._survival(time)
        pred, born, newborn = self._predicted(time, survival)
        zc, contact_R = view.linearisation.contacts(z)
        pred, born, newborn, mp = self._within_pairs(pred, born, newborn, view, zc, contact_R, time)
        xy, cov = view.measurement.position(z)
        pairs = view.linearisation.pairs(pred, zc, contact_R, cfg.gate, mp)
        pd = self._detection(view, scan.sensor, pred)
        expected = pd * float(pred.weights.sum()) if np.ndim(pd) == 0 else float(pd @ pred.weights)
        explained = None
        if cfg.clutter == "unexplained":
            fixes = not view.polar and cfg.clutter_area_m2 is not None  # spread over that area, not the coverage
            explained = Explained(pred.means[:, self.motion.position], pd * pred.weights,
                                  None if fixes else view.sensor, view.volume if not view.polar
                                  else coverage_area(view.sensor))
        rate, log_c = clutter(cfg, z, xy, view.volume, view.polar, expected, explained)
        det, missed, dist = self._weights(pred, pairs, rate, log_c, born, pd, survival)
        # a newborn its first update misses is dropped (measurement birth), unless that sensor cannot see it
        missed[newborn] = 0.0 if np.ndim(pd) == 0 else np.where(pd[newborn] > 0, 0.0, missed[newborn])
        if dist is None:
            mean, map_count = float(missed.sum() + det.sum()), None
        else:
            mean, map_count = float(np.arange(len(dist)) @ dist), int(np.argmax(dist))
        post = gmphd.posterior(pred, pairs, missed, det, cfg.prune_threshold)
        post = merge(post, cfg.merge_threshold, cfg.merge_covariance, self.motion.angles)
        post = self._capped(post, len(z), float(missed.sum() + det.sum()), time)
        post, self.next_label = relabel_duplicates(post, self.next_label)
        self.mixture = post
        birth = cfg.birth
        if birth.kind == "measurement" and len(z):
            if cfg.first_sweep_births and scan.sensor not in self.swept:
                self.newborn = first_sweep_births(xy, cov, cfg.clutter_radius_m, birth.speed_sigma_m_s, self.motion,
                                                  self.next_label)
            else:
                explained = np.bincount(pairs.i, det, minlength=len(z))
                self.newborn = measurement_births(xy, cov, explained, birth.rate, birth.speed_sigma_m_s,
                                                  self.motion, self.next_label)
            self.next_label += len(self.newborn)
            self.swept.add(scan.sensor)
        else:
            self.newborn = Mixture.empty(cfg.state_dim)
        self.last_time, self.last_sensor = time, scan.sensor
        return self._report(scan.index, scan.sensor, time, post, mean, map_count, dist)

    def _component_cap(self, contacts: int, targets: float) -> int:
        """J_max after a scan of ``contacts`` contacts whose posterior intensity has the mass ``targets`` (the
        expected target count): ``max_components``, with ``components_per_contact`` c (not 0 or None) at least
        ceil(c x contacts), with ``components_per_target`` c_t (not 0 or None) at least ceil(c_t x targets)."""
        cfg = self.config
        limit = cfg.max_components
        per = cfg.components_per_contact
        if per:
            limit = max(limit, int(np.ceil(per * contacts)))
        per = cfg.components_per_target
        if per and np.isfinite(targets):
            limit = max(limit, int(np.ceil(per * targets)))
        return limit

    def _capped(self, mixture: Mixture, contacts: int, targets: float, time: float) -> Mixture:
        """Step 3's cap on the merged ``mixture`` of a scan of ``contacts`` contacts and the expected target count
        ``targets``: its `_component_cap` heaviest components (`cap`); those it drops are counted
        (``n_capped_components``, ``capped_weight``), with a BoundWarning the first time in a run that a scan's
        dropped weight reaches `CAPPED_WEIGHT_WARNING` (a tenth of a target's expected mass: the cap routinely
        drops a clutter tail of negligible weight, which loses no target)."""
        limit = self._component_cap(contacts, targets)
        if len(mixture) <= limit:
            return mixture
        kept = cap(mixture, limit)
        dropped = len(mixture) - limit
        weight = float(mixture.weights.sum() - kept.weights.sum())
        self.n_capped_components += dropped
        self.capped_weight += weight
        if weight >= CAPPED_WEIGHT_WARNING and "max_components" not in self._bounds_hit:
            self._bounds_hit.add("max_components")
            cfg = self.config
            heaviest = float(np.sort(mixture.weights)[::-1][limit])
            warnings.warn(
                f"{self.label}, t = {time} s: the mixture cap of {limit:,} components (config field max_components "
                f"= {cfg.max_components}, grown by components_per_contact = {cfg.components_per_contact} x "
                f"{contacts:,} contacts and components_per_target = {cfg.components_per_target} x {targets:.1f} "
                f"expected targets) dropped the {dropped:,} lightest of {len(mixture):,} merged components, of "
                f"weight {weight:.3g} in all, the heaviest {heaviest:.3g} (extraction threshold "
                f"{cfg.extraction_threshold}): a target whose components it drops is lost; raise max_components or "
                f"components_per_target. Later cases of this run are only counted (n_capped_components, "
                f"capped_weight)", BoundWarning, stacklevel=3)
        return kept

    def _predicted_count(self, pred: Mixture, survival: float) -> tuple[float, int | None, np.ndarray | None]:
        """(mean, MAP count, distribution) of the target count of the predicted intensity ``pred``."""
        return float(pred.weights.sum()), None, None

    def _report(self, scan: int, sensor: int, time: float, mixture: Mixture, mean: float, map_count: int | None,
                dist: np.ndarray | None) -> TrackerOutput:
        """The scan's output: the extracted components of ``mixture`` as confirmed tracks, id = label, in
        label order, of the labels once extracted after ``extraction_scans`` sweeps in a row of one sensor
        (this scan's: ``sensor``); records the scan's `Cardinality`."""
        shown = self._extracted(mixture, map_count)
        shown = shown[np.argsort(mixture.labels[shown], kind="stable")]
        cfg = self.config
        shown, self.extraction_streaks[sensor], self.confirmed_labels = persistent(
            mixture.labels, shown, self.extraction_streaks[sensor], self.confirmed_labels, cfg.extraction_scans)
        if self.coast_misses:
            floor = coast_floor(cfg.extraction_threshold, self.views[sensor].pd, self.coast_misses)
            shown = coasting(mixture.weights, mixture.labels, shown, self.confirmed_labels, floor)
        self.cardinality = Cardinality(scan, time, mean, map_count, dist, len(shown))
        k = len(shown)
        x, P = self.motion.to_cv(mixture.means[shown], mixture.covariances[shown])
        return TrackerOutput(scan, time, mixture.labels[shown], np.full(k, CONFIRMED, np.int8), x, P,
                             np.full(k, NO_CONTACT, np.int64))


class EKPHDTracker(GMPHDTracker):
    """GM-PHD with the EKF linearisation of the polar radar measurement (EK-PHD)."""

    name: ClassVar[str] = "ekphd"
    config_type: ClassVar[type[TrackerConfig]] = EKPHDConfig


class UKPHDTracker(GMPHDTracker):
    """GM-PHD with the unscented transform of the polar radar measurement (UK-PHD)."""

    name: ClassVar[str] = "ukphd"
    config_type: ClassVar[type[TrackerConfig]] = UKPHDConfig


class CPHDTracker(GMPHDTracker):
    """Cardinalised PHD tracker (Vo, Vo & Cantoni 2007): the intensity and the distribution of the target
    count on 0..N_max, N_max = max_cardinality at the start of a run, doubled before a scan whose last
    posterior mean times ``cardinality_per_target`` passes it (`cphd.support_for`); EK linearisation by default."""

    name: ClassVar[str] = "cphd"
    config_type: ClassVar[type[TrackerConfig]] = CPHDConfig

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: CPHDConfig | None = None,
                 measurement: MeasurementModel | None = None) -> None:
        super().__init__(sensors, config, measurement)
        if self.config.extraction == "map":  # the MAP count's heaviest components, none coasting beside them
            self.coast_misses = 0

    def reset(self) -> None:
        super().reset()
        self.distribution = np.zeros(self.config.max_cardinality + 1)
        self.distribution[0] = 1.0  # no target before the first scan
        #: scans since the last reset whose cardinality put `CAPPED_CARDINALITY_WARNING` or more on N_max with
        #: the support fixed (``cardinality_per_target`` None; `_report`)
        self.n_cardinality_capped = 0

    def _supported(self, born: float) -> np.ndarray:
        """The last posterior cardinality on the support this scan needs: grown to hold ``cardinality_per_target``
        times its mean and the ``born`` expected births (`cphd.support_for`); with that None, as it is."""
        cfg = self.config
        if cfg.cardinality_per_target is None:
            return self.distribution
        return cphd.support_for(self.distribution, cfg.max_cardinality, cfg.cardinality_per_target, born)

    def _weights(self, pred, pairs, rate, log_c, born, pd, survival):
        p = cphd.predict_cardinality(self._supported(born), survival, born)  # births: Poisson of the birth weight
        det, missed, p = cphd.cphd_weights(pred.weights, pairs, pd, rate, log_c, p)
        self.distribution = p
        return det, missed, p

    def _predicted_count(self, pred, survival):
        p = cphd.predict_cardinality(self.distribution, survival, 0.0)
        return float(np.arange(len(p)) @ p), int(np.argmax(p)), p

    def _report(self, scan, sensor, time, mixture, mean, map_count, dist):
        """As the PHD's; with the support fixed (``cardinality_per_target`` None), a scan whose cardinality puts
        `CAPPED_CARDINALITY_WARNING` or more on N_max is counted (``n_cardinality_capped``), with a BoundWarning
        the first time in a run (a growing support holds the count from the next scan on)."""
        if self.config.cardinality_per_target is None and dist[-1] >= CAPPED_CARDINALITY_WARNING:
            self.n_cardinality_capped += 1
            if "max_cardinality" not in self._bounds_hit:
                self._bounds_hit.add("max_cardinality")
                warnings.warn(
                    f"{self.label}, t = {time} s: the cardinality support 0..{len(dist) - 1} (config field "
                    f"max_cardinality = {self.config.max_cardinality}, cardinality_per_target = None) puts "
                    f"p = {dist[-1]:.3g} on its largest count: more targets than it holds are counted as "
                    f"{len(dist) - 1}; raise max_cardinality or set cardinality_per_target (e.g. 1.5) to let it "
                    f"grow. Later cases of this run are only counted (n_cardinality_capped)", BoundWarning,
                    stacklevel=3)
        return super()._report(scan, sensor, time, mixture, mean, map_count, dist)

    def _extracted(self, post, map_count):
        if self.config.extraction == "map":
            return heaviest(post, map_count)
        return super()._extracted(post, map_count)
