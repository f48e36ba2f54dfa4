"""The framework the contact trackers share (`ContactTracker`): filters per sensor, initiation, life cycle.

`ContactTracker` holds what trackers that build tracks from
contacts share: a per-track filter component (the IMM of the config's
``motion``, `MotionConfig`, by default), one copy of it per sensor with
that sensor's measurement model, and the two-point initiation
(`nnda.tracking.initiation.TwoPointInitiation`). A scan is one sweep of one sensor: its contacts
update the tracks through that sensor's filter, so two radars' scans
refine the same tracks. The single-hypothesis trackers
(`nnda.tracking.single_hypothesis.SingleHypothesisTracker`: GNN, JPDA,
neural) then differ in one hook only, ``associate``; each scan:

1. check the scan (time increasing, a known sensor, (N, 2) finite real contacts:
   `nnda.tracking.protocol.checked_scan`);
2. predict every live track's filter to the scan time, over the time since
   its last update (a missed scan is not an update);
3. **associate** (the method's part): decide which contact, if any, updates
   each track and return the states after the scan (`nnda.tracking.tracks.Association`);
4. the M/N and deletion logic of `nnda.tracking.lifecycle`, then its sanity rules on the reported
   states (impossible speed, outside coverage, inflated covariance), deletions counted by reason;
5. initiation (`nnda.tracking.initiation`): the initiators of the sensor's last scan pair with this
   scan's unused contacts inside their [D_min, D_max] window, each pair
   opening a preliminary track (two-point start); unused contacts outside
   every window become that sensor's next initiators (Vargas Avila 2015,
   Ch. 2; contacts inside a window start none: our reading);
6. report every track (and those deleted in this scan, once more).

Track records are batched arrays (`nnda.tracking.tracks.Tracks`), so steps 2-6 have no Python
loop over tracks. MHT (`nnda.tracking.mht`) is a `ContactTracker` with its
own scan step over hypothesis trees. A window of asynchronous reports (a
sensor with ``reports``) runs these steps once per report time and once at
the window's end (`nnda.tracking.reports`) in the trackers that take it.
"""

from __future__ import annotations

import math
import warnings
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Annotated, ClassVar, Literal

import numba
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor, sensor_tuple
from nnda.data.sensor import observable
from nnda.errors import BoundWarning
from nnda.filters.imm import DEFAULT_TPM, IMM, IMMPrediction
from nnda.filters.imm_kernels import pair_log_likelihood
from nnda.filters.kalman import GATE_99, gate_probability
from nnda.filters.measurement import MeasurementModel, measurement_model
from nnda.filters.motion import ConstantVelocity, CoordinatedTurn
from nnda.tracking.clutter_density import coverage_area, local_density, unexplained_density
from nnda.tracking.detection_probability import (
    DEFAULT_PD,
    FROM_DEFAULT,
    DetectionProbabilities,
    DetectionRecord,
    detection_probabilities,
)
from nnda.tracking.initiation import TwoPointInitiation
from nnda.tracking.lifecycle import (
    DELETION_REASONS,
    LifecycleConfig,
    adaptive_threshold,
    birth_log_odds,
    deletion_threshold,
    misses_to_hide,
    sanity_args,
    sensor_noise_m,
    start_score,
)
from nnda.tracking.lookup import sorted_find
from nnda.tracking.marginals import log_miss_weight
from nnda.tracking.output import CONFIRMED, DELETED, NO_CONTACT, TrackerOutput
from nnda.tracking.protocol import TrackerConfig, checked_config, checked_scan, declare_reports
from nnda.tracking.reports import Phase, report_times, step_window
from nnda.tracking.target_classes import TargetClassUse, target_config
from nnda.tracking.tracks import CONFIRM_AT, DELETE_AT, MAX_SCORE, SCORE, Association, Tracks

#: detection probability of the track score for a tracker whose config has none and whose sensors declare none
SCORE_PD = DEFAULT_PD
#: half-side (m) of the local clutter density's square for a tracker whose config has none
CLUTTER_RADIUS_M = 3_000.0
#: how a contact tracker estimates the clutter around a point from the scan's contacts (its ``clutter_estimate``)
ClutterEstimate = Literal["local", "unexplained"]
#: the ``clutter_estimate`` field's description, shared by the configs that have it
CLUTTER_ESTIMATE_DOC = ("the local clutter estimate: 'local', every contact in the square around the point (itself "
                        "included); 'unexplained', the contacts there less the contact itself and the tracks' "
                        "expected detections at their predicted positions, at least the scan's own such count over "
                        "the coverage (`nnda.tracking.clutter_density.unexplained_density`; for many close targets)")



class MotionConfig(BaseModel):
    """The per-track IMM's motion models and mode switching (defaults: Vargas Avila (2015), Sec. 5.6, the
    values `IMM.for_sensor` runs): the CV model's acceleration noise, the CT model's acceleration and
    turn-rate noise, and the probabilities of switching mode between scans (the off-diagonal of the TPM)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    cv_sigma_q: Annotated[float, Field(ge=0, description="CV model: acceleration noise (m/s^2)")] = (
        ConstantVelocity().sigma_q)
    ct_sigma_q: Annotated[float, Field(ge=0, description="CT model: acceleration noise (m/s^2)")] = (
        CoordinatedTurn().sigma_q)
    ct_sigma_omega: Annotated[float, Field(ge=0, description="CT model: turn-rate noise (rad/s)")] = (
        CoordinatedTurn().sigma_omega)
    p_cv_to_ct: Annotated[float, Field(gt=0, lt=1, description="probability that a CV track turns (CT) by the "
                                       "next scan")] = DEFAULT_TPM[0][1]
    p_ct_to_cv: Annotated[float, Field(gt=0, lt=1, description="probability that a CT track flies straight "
                                       "(CV) by the next scan")] = DEFAULT_TPM[1][0]
    noise: Literal["discrete", "continuous"] = Field("discrete", description=(
        "how the process noise grows with the time since a track's last update: 'discrete' (an acceleration "
        "of sd sigma_q held over the interval, velocity variance sigma_q^2 T^2: the model of Vargas Avila "
        "(2015), made for one fixed scan period) or 'continuous' (white-noise acceleration of spectral density "
        "sigma_q^2 in m^2/s^3, velocity variance sigma_q^2 T: consistent whatever the interval, for "
        "asynchronous reports whose gaps range from seconds to minutes)"))
    turn: Literal["second-order", "exact"] = Field("second-order", description=(
        "the CT model's transition: 'second-order' (the Taylor form of Vargas Avila (2015), eq. 5.17, good "
        "while the turn over one interval is small; over a long coast it gains speed, 6 times at 5 rad) or "
        "'exact' (the turn itself, sin and cos: keeps the speed over any interval)"))

    def imm(self, measurement: MeasurementModel) -> IMM:
        """The CV + CT IMM of these settings with ``measurement``; the defaults give `IMM.for_sensor`'s."""
        cv = ConstantVelocity(sigma_q=self.cv_sigma_q, noise_kind=self.noise)
        ct = CoordinatedTurn(sigma_q=self.ct_sigma_q, sigma_omega=self.ct_sigma_omega, noise_kind=self.noise,
                             form=self.turn)
        tpm = ((1.0 - self.p_cv_to_ct, self.p_cv_to_ct), (self.p_ct_to_cv, 1.0 - self.p_ct_to_cv))
        return IMM(models=(cv, ct), measurement=measurement, tpm=tpm)


class ContactTrackerConfig(TrackerConfig):
    """Settings of the trackers that build tracks from contacts: the per-track IMM's motion (unless the
    tracker is given its own filter), the initiation window and M/N life cycle."""

    motion: MotionConfig = MotionConfig()
    lifecycle: LifecycleConfig = LifecycleConfig()



@numba.njit(cache=True, nogil=True)
def _gains(contact, log_miss, log_pd, z_pred, S_inv, log_det, mu, z, polar):
    """`ContactTracker._score_gain`'s compiled part: the gains (K,) of a miss, ``log_miss``, everywhere; the
    tracks ``rows`` that took a contact of ``contact`` (K,), and those contacts; and ln P_D + the IMM
    likelihood of each (`imm_kernels.pair_log_likelihood` on the prediction's z_pred, S_inv, log_det, mu,
    of the contacts z (N, 2)). The caller subtracts the clutter density's log."""
    rows = np.flatnonzero(contact != NO_CONTACT)
    at = contact[rows]
    target = log_pd + pair_log_likelihood(z_pred, S_inv, log_det, mu, rows, z[at], polar)
    return np.full(contact.size, log_miss), rows, at, target



class ContactTracker(ABC):
    """Base of the trackers that build tracks from contacts: the sensors, a per-track filter, initiation.

    Construct with the scenario's sensors (`nnda.data.scenario.Sensor`: kind,
    position, noise, coverage, scan period; or one sensor), a config and
    optionally the per-track filter (default: the CV + CT IMM of the config's
    ``motion``, `MotionConfig.imm`, with the first sensor's measurement model);
    the other sensors get copies of it with their own measurement models
    (`IMM.for_measurement`). ``step(scan)`` processes one sweep of one of the
    sensors.
    """

    name: ClassVar[str]
    config_type: ClassVar[type[TrackerConfig]] = ContactTrackerConfig
    #: whether the tracker takes a sensor of asynchronous reports (`nnda.tracking.reports`; it implements `_step`)
    takes_reports: ClassVar[bool] = False
    #: the rule of a tracker that confirms its tracks by its own posterior whatever ``lifecycle.confirmation``
    #: says (the labelled random-finite-set trackers: "existence"); None: the life cycle's rule
    own_confirmation: ClassVar[str | None] = None
    #: whether the tracker counts its confirmed tracks' detections (`_count_detections`), so that it can learn a
    #: sensor's P_D (``lifecycle.estimate_pd``, `score_pd`)
    learns_pd: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        declare_reports(cls)  # named by the scan check's and the registry's refusals of reports

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: ContactTrackerConfig | None = None,
                 track_filter: IMM | None = None) -> None:
        self.sensors = sensor_tuple(sensors)
        #: the config with the values of the class of target the sensors declare, and what it took from it
        #: (`nnda.tracking.target_classes`; None when no sensor declares one: the config as given)
        self.config, self.targets = target_config(self.name, checked_config(self, config), self.sensors)
        self.targets: TargetClassUse | None
        #: the P_D of each sensor's scans and where it came from (`score_pd`)
        self.detection: DetectionProbabilities = detection_probabilities(
            self.name, self.config, self.sensors, default=SCORE_PD)
        learn = self.learns_pd and self.config.lifecycle.estimate_pd and self.confirmation_rule != "mn"
        #: the P_D each sensor's scans use now: ``detection``'s, or learnt from the run so far (`score_pd`)
        self.pd_record = DetectionRecord(self.detection, [learn and s == FROM_DEFAULT for s in self.detection.sources])
        self.filter = (track_filter if track_filter is not None
                       else self.config.motion.imm(measurement_model(self.sensors[0])))
        self.filters = (self.filter, *(self.filter.for_measurement(measurement_model(s)) for s in self.sensors[1:]))
        self.initiation = TwoPointInitiation(self.filters, self.config.lifecycle, self.sensors, self.name)
        self.reset()

    def reset(self) -> None:
        """Forget every track and initiator (start of a new run)."""
        self.initiation.reset()
        self.pd_record.reset()
        self._log_misses: dict[int, tuple[float, float]] = {}  # per sensor, the last (P_D, `_log_miss`)
        self.last_time, self.last_sensor = -np.inf, -1
        self._bounds_hit: set[str] = set()
        self._density_of: tuple[ScanContacts, np.ndarray] | None = None  # (scan, `_contact_density`)
        #: the scan, the tracks' predicted positions (K, 2) m and expected detections (K,) (`_explained_by`)
        self._explained: tuple[ScanContacts, np.ndarray, np.ndarray] | None = None
        #: tracks deleted since the last reset, by reason (`nnda.tracking.lifecycle.DELETION_REASONS`)
        self.deletions: dict[str, int] = dict.fromkeys(DELETION_REASONS, 0)
        #: the live tracks' ids (ascending) and the time (s) each one's score last reached its maximum, as of the
        #: last scan (those deleted in it included; `score_peaks`)
        self._peaks = (np.empty(0, np.int64), np.empty(0))

    #: whether a fixed-lag output asked for the tracks' score peaks (`keep_score_peaks`)
    _peaks_wanted: bool = False

    def keep_score_peaks(self) -> None:
        """`nnda.tracking.lag.EndsAtScorePeak`: keep the tracks' score peaks from the next scan on (a fixed-lag
        output asks, before the first scan; an online run keeps no record of them, though MHT's leaves carry
        their own peak time whatever is asked)."""
        self._peaks_wanted = True

    @property
    def _peak_rule(self) -> bool:
        """Whether the tracker's deletion is a score-drop test, whose change time is the score's last peak."""
        return False

    @property
    def _ends_at_peak(self) -> bool:
        """Whether the tracker keeps its tracks' score peaks: asked to (`keep_score_peaks`), with its config's
        ``end_at_score_peak`` set (a config without the field: never), under a rule that deletes on a score drop
        (`_peak_rule`)."""
        return self._peaks_wanted and getattr(self.config, "end_at_score_peak", False) and self._peak_rule

    def score_peaks(self, reported: TrackerOutput) -> tuple[np.ndarray, np.ndarray]:
        """`nnda.tracking.lag.EndsAtScorePeak`: of the output ``reported`` that the tracker just returned, the ids
        (D,) of the tracks reported DELETED and the time (s) each one's score last reached its maximum (D,);
        none without ``end_at_score_peak`` (`_ends_at_peak`)."""
        if not self._ends_at_peak:
            return np.empty(0, np.int64), np.empty(0)
        gone = reported.track_id[reported.status == DELETED]
        return gone, self._peak_of(gone, np.full(gone.size, np.nan))

    def _peak_of(self, ids: np.ndarray, unknown: np.ndarray) -> np.ndarray:
        """The time (s) of the score's last maximum of the tracks ``ids`` (M,) as of the last scan, ``unknown``'s
        (M,) for a track it did not hold."""
        known, time = self._peaks
        if not known.size:
            return unknown
        at, found = sorted_find(known, ids)
        return np.where(found, time[at], unknown)

    @cached_property
    def gate_threshold(self) -> float:
        """The chi-square gate (2 dof) of the tracker's config, or 9.21 (P_G = 0.99) for a tracker without one
        (the coverage rule of the sanity deletion measures a track's distance outside coverage in gates)."""
        return float(getattr(self.config, "gate", GATE_99))

    @cached_property
    def _sanity_args(self) -> tuple:
        """The sanity rules' settings for this tracker's sensors, gate and life cycle (`sanity_args`)."""
        return sanity_args(self.sensors, self.gate_threshold, self.config.lifecycle)

    def _hidden(self, status: np.ndarray, consecutive: np.ndarray, sensor: int) -> np.ndarray | None:
        """Which of K reported tracks (their ``status`` (K,) after the scan and misses in a row ``consecutive``
        (K,)) are left out of the output after a scan of ``sensor`` (``lifecycle.report_existence``): the
        confirmed ones past `lifecycle.misses_to_hide` at the sensor's P_D and the gate's P_G; None when none is
        (or without the rule)."""
        if self.config.lifecycle.report_existence is None:
            return None
        hidden = (status == CONFIRMED) & (consecutive >= self._misses_to_hide(sensor))
        return hidden if hidden.any() else None

    def _misses_to_hide(self, sensor: int) -> int:
        """The misses in a row after which a confirmed track is left out of the output after a scan of ``sensor``
        (`lifecycle.misses_to_hide` at the sensor's P_D and the gate's P_G; 2^62, never, without the rule)."""
        return misses_to_hide(self.config.lifecycle, self.score_pd(sensor) * gate_probability(self.gate_threshold))

    def _quality_density(self, scan: ScanContacts, x: np.ndarray) -> np.ndarray:
        """The track-quality rule's clutter density (m^-2) around K tracks at positions x (K, 4) ([x, vx, y,
        vy]): the scan's contacts in the square of half-side ``clutter_radius_m`` (`local_density`), or with
        ``clutter_estimate`` "unexplained" those the confirmed tracks do not explain (`_unexplained_density`:
        a coasting track's own target's contact is not clutter around it); zeros without the rule
        (`LifecycleConfig.gate_clutter_bound` None)."""
        if self.config.lifecycle.gate_clutter_bound is None:
            return np.zeros(len(x))
        if self._unexplained:
            return self._unexplained_density(scan, x[:, 0:3:2], 0.0)
        return local_density(scan.xy, x[:, 0:3:2], self._clutter_radius, self.sensors[scan.sensor])

    @property
    def _ended_reason(self) -> str:
        """The deletion reason of a confirmed track its life cycle ended."""
        return "misses" if self.confirmation_rule == "mn" else "score"

    @property
    def confirmation_rule(self) -> str:
        """The rule that confirms and deletes this tracker's tracks: "adaptive" (SPRT, clutter-adaptive
        threshold), "mn" (M/N counts), "score" (SPRT) or "existence" (IPDA / JIPDA, or the tracker's own
        posterior: `own_confirmation`)."""
        return self.own_confirmation or self.config.lifecycle.confirmation

    def score_pd(self, sensor: int) -> float:
        """The detection probability of the track score in a scan of ``sensor`` (an index): the config's ``pd``
        when set, else the sensor's declared P_D, else the config's default or 0.9 (`SCORE_PD`; ``detection``),
        learnt from the run so far with ``lifecycle.estimate_pd`` (`pd_record`)."""
        return self.pd_record[sensor]

    def _learns(self, scan: ScanContacts) -> bool:
        """Whether ``scan`` adds to `pd_record`: a sweep of a sensor whose P_D the tracker learns."""
        return scan.phase is Phase.SWEEP and self.pd_record.learn[scan.sensor]

    def _count_detections(self, scan: ScanContacts, confirmed: np.ndarray, seen: np.ndarray | None,
                          contact: np.ndarray) -> None:
        """Add a sweep's detections to `pd_record` (callers ask `_learns` first): of K tracks, those
        ``confirmed`` (K,) before the scan and observed by it (``seen`` (K,); None: all), and which of them took
        a contact (``contact`` (K,))."""
        observed = confirmed if seen is None else confirmed & seen
        self.pd_record.add(scan.sensor, int(np.count_nonzero(contact[observed] != NO_CONTACT)),
                           int(np.count_nonzero(observed)))

    def clutter_density(self, scan: ScanContacts, at: np.ndarray) -> np.ndarray:
        """Clutter density in the measurement space of the scan's sensor (polar: (m rad)^-1) at its
        contacts ``at`` (M,): the scan's contacts around each over the part of the square (half-side the
        config's ``clutter_radius_m`` or 3 km) inside the sensor's coverage (`local_density`), times the area
        Jacobian."""
        return self._contact_density(scan)[at] * scan.filter.measurement.area_jacobian(scan.z[at])

    def _contact_density(self, scan: ScanContacts) -> np.ndarray:
        """The local clutter density (m^-2) at every contact of ``scan`` (N,), counted once per scan: the score
        rule asks for it at the initiators and at the updating contacts, JPDA at the gated ones. `local_density`,
        or with ``clutter_estimate`` "unexplained" `unexplained_density` (each contact itself left out)."""
        if self._density_of is None or self._density_of[0] is not scan:
            density = (self._unexplained_density(scan, scan.xy, 1.0) if self._unexplained else
                       local_density(scan.xy, scan.xy, self._clutter_radius, self.sensors[scan.sensor]))
            self._density_of = (scan, density)
        return self._density_of[1]

    @cached_property
    def _unexplained(self) -> bool:
        """Whether the local clutter estimate leaves out what the tracks explain: ``clutter_estimate``
        "unexplained" while the config's ``clutter_density`` (where it has one) asks for the local estimate."""
        cfg = self.config
        return (getattr(cfg, "clutter_estimate", "local") == "unexplained"
                and getattr(cfg, "clutter_density", None) in (None, "local"))

    def _explained_by(self, scan: ScanContacts) -> tuple[np.ndarray, np.ndarray]:
        """The tracks' predicted positions (K, 2) m and expected detections (K,) in ``scan``, as the scan step set
        them after its prediction (none before: no track yet)."""
        if self._explained is None or self._explained[0] is not scan:
            return np.empty((0, 2)), np.empty(0)
        return self._explained[1], self._explained[2]

    def _unexplained_density(self, scan: ScanContacts, at: np.ndarray, own: float | np.ndarray) -> np.ndarray:
        """`unexplained_density` (m^-2) at the points ``at`` (Q, 2) m of the scan's contacts, ``own`` of them the
        queries' own, less the tracks' expected detections (`_explained_by`)."""
        sensor = self.sensors[scan.sensor]
        return unexplained_density(scan.xy, at, self._clutter_radius, coverage_area(sensor), sensor,
                                   *self._explained_by(scan), own)

    @cached_property
    def _clutter_radius(self) -> float:
        return float(getattr(self.config, "clutter_radius_m", CLUTTER_RADIUS_M))

    def _start_scores(self, born: Tracks, scan: ScanContacts, contact: np.ndarray) -> Tracks:
        """``born``, the scan's new tracks (their arrays their own: the initiation made them), with the score of
        its two-point start (`lifecycle.start_score`) under the score rule written into its scores; under the
        adaptive rule also each track's confirmation and deletion thresholds from the clutter density at its
        second contact (`lifecycle.adaptive_threshold`, `lifecycle.adaptive_deletion`); under the existence
        rule also the initiators' prior (`lifecycle.birth_log_odds`; the clutter around each initiator counted
        in this scan's contacts)."""
        rule = self.confirmation_rule
        if rule == "mn":
            return born
        sensor = self.sensors[scan.sensor]
        cfg = self.config.lifecycle
        density = self._contact_density(scan)[contact]
        pd, area = self.score_pd(scan.sensor), self._window_areas[scan.sensor]
        if rule == "existence":
            score = start_score(pd, area, density) + birth_log_odds(
                pd, cfg.new_targets_per_scan / coverage_area(sensor),
                local_density(scan.xy, born.p1, self._clutter_radius, sensor))
            born.scores[:, SCORE] = born.scores[:, MAX_SCORE] = score
        else:
            _started(born.scores, density, pd, area, rule == "adaptive", cfg.false_track_rate, cfg.false_deletion,
                     sensor.scan_period_s, cfg.false_confirmation, cfg.dense_clutter_per_km2)
        return born

    @cached_property
    def _window_areas(self) -> tuple[float, ...]:
        """The initiation annulus' area (m^2) of each sensor (`LifecycleConfig.window_area`)."""
        cfg = self.config.lifecycle
        return tuple(cfg.window_area(s.scan_period_s, sensor_noise_m(s)) for s in self.sensors)

    def _score_gain(self, pred: IMMPrediction, scan: ScanContacts, assoc: Association) -> np.ndarray | None:
        """The scan's track-score increments (K,) under the score rule (None under M/N): the method's own,
        else ln(P_D l / lambda) for the chosen contact and ln(1 - P_D P_G) for a miss."""
        if self.confirmation_rule == "mn":
            return None
        if assoc.score_gain is not None:
            return assoc.score_gain
        mp = pred.measurement
        sensor = scan.sensor
        gain, rows, at, target = _gains(assoc.contact, self._log_miss(sensor), math.log(self.score_pd(sensor)), mp.z,
                                        mp.S_inv, mp.log_det_S, pred.state.mu, scan.z, scan.filter.polar)
        gain[rows] = target - np.log(self.clutter_density(scan, at))
        return gain

    @cached_property
    def _release(self) -> bool:
        """The config's ``release_on_deletion`` (False for a tracker without it)."""
        return bool(getattr(self.config, "release_on_deletion", False))

    def _log_miss(self, sensor: int) -> float:
        """ln(1 - P_D P_G) of a scan of ``sensor``, a miss's score increment (`log_miss_weight`, `score_pd`),
        computed again only when the sensor's P_D changed."""
        pd = self.score_pd(sensor)
        last = self._log_misses.get(sensor)
        if last is None or last[0] != pd:
            last = self._log_misses[sensor] = (pd, log_miss_weight(pd, self.gate_threshold))
        return last[1]

    def track_management(self) -> dict:
        """What a study records of the run so far: the confirmation rule, the deletions by reason and the lines
        of contacts the initiation window refused as faster than ``lifecycle.v_max`` (``too_fast_lines``,
        `TwoPointInitiation.n_too_fast`) and, where it learns a sensor's P_D, the values learnt so far
        (``learnt_pd``: per sensor, None for one it does not learn; `DetectionRecord`)."""
        managed = {"confirmation": self.confirmation_rule, "deletions": dict(self.deletions),
                   "too_fast_lines": self.initiation.n_too_fast}
        if any(self.pd_record.learn):
            managed["learnt_pd"] = self.pd_record.record()
        return managed

    def _bound_hit(self, field: str, what: str, time: float) -> None:
        """A BoundWarning the first time in a run that the bound of config ``field`` bites (``what`` it did);
        the tracker's own counters say how often."""
        if field not in self._bounds_hit:
            self._bounds_hit.add(field)
            warnings.warn(f"{self.name}, t = {time} s: {what} (config field {field}); later cases of this run are "
                          f"only counted", BoundWarning, stacklevel=3)

    def step(self, scan: Scan) -> TrackerOutput:
        """Process one scan and report every track: a sweep in one pass of `_step`, a window of asynchronous
        reports (a sensor with ``reports``) report time by report time (`nnda.tracking.reports`)."""
        sensor = getattr(scan, "sensor", None)
        if not (isinstance(sensor, (int, np.integer)) and 0 <= sensor < len(self.sensors)
                and self.sensors[sensor].reports):
            return self._step(scan, Phase.SWEEP)  # also for a scan `checked_scan` refuses
        z, _ = checked_scan(self.name, scan, self.last_time, self.sensors, self.last_sensor, True)
        return step_window(self._step, scan, report_times(self.name, scan, self.last_time, len(z)))

    @abstractmethod
    def _step(self, scan: Scan, phase: Phase) -> TrackerOutput:
        """One pass of the tracker's scan step over ``scan`` in ``phase`` (`nnda.tracking.reports.Phase`; always
        a sweep for a tracker that takes no asynchronous reports, ``takes_reports`` False)."""

    def _checked(self, scan: Scan, phase: Phase = Phase.SWEEP) -> ScanContacts:
        """The scan checked (`checked_scan`) and, from here on, the one being processed (``last_time``,
        ``last_sensor``: bound warnings name its time). A report window's end (`Phase.DUE`) may fall at the
        time of its last report (`nnda.tracking.reports.report_times` checked it is not earlier)."""
        last = -np.inf if phase is Phase.DUE else self.last_time
        z, time = checked_scan(self.name, scan, last, self.sensors, self.last_sensor, self.takes_reports)
        self.last_time, self.last_sensor = time, int(scan.sensor)
        imm = self.filters[scan.sensor]
        return ScanContacts(scan.index, time, int(scan.sensor), imm, z, imm.measurement.cartesian(z), phase)

    def _observed(self, scan: ScanContacts, pred: IMMPrediction, since: np.ndarray | None = None,
                  contact: np.ndarray | None = None) -> np.ndarray | None:
        """Which tracks the scan observed (K,); None: all. A sweep: those its sensor can see at their predicted
        positions, inside its coverage or outside every sensor's (a track nobody sees still misses; None with
        one sensor). Asynchronous reports (`nnda.tracking.reports`): those that took a report (``contact``
        (K,), before association none); at a window's end, those last updated (``since`` (K,), s) more than
        ``lifecycle.report_gap_s`` ago."""
        if scan.phase is Phase.REPORTS:
            return np.zeros(len(pred.state.x), bool) if contact is None else contact != NO_CONTACT
        if scan.phase is Phase.DUE:
            return scan.time - since > self.config.lifecycle.report_gap_s
        if len(self.sensors) == 1:
            return None
        x = self.filter.estimate(pred.state)[0]
        return observable(self.sensors, scan.sensor, x[:, 0], x[:, 2])

    def _initiate(self, scan: ScanContacts, used: np.ndarray, live: int) -> tuple[Tracks | None, np.ndarray | None]:
        """New preliminary tracks from the scan's contacts no track ``used`` (N,), ``live`` tracks held already
        (`TwoPointInitiation`): a sweep's with the sensor's last sweep, reports with the sensor's unused
        reports of the last ``lifecycle.report_gap_s``; none at a report window's end."""
        if scan.phase is Phase.DUE:
            return None, None
        start = self.initiation.reports if scan.phase is Phase.REPORTS else self.initiation
        return start(scan.z, scan.xy, used, scan.time, live, scan.sensor)


@dataclass(frozen=True)
class ScanContacts:
    """One checked scan as the framework hands it to a method.

    ``sensor`` indexes the tracker's sensors and ``filter`` is the per-track
    filter with that sensor's measurement model; ``z`` (N, 2) holds the
    contacts in its measurement space (polar: [range m, azimuth rad] from the
    sensor) and ``xy`` (N, 2) their positions (m, scenario frame); ``phase``
    says whether they are a sweep's or asynchronous reports'
    (`nnda.tracking.reports.Phase`).
    """

    index: int
    time: float
    sensor: int
    filter: IMM
    z: np.ndarray
    xy: np.ndarray
    phase: Phase = Phase.SWEEP



@numba.njit(cache=True, nogil=True)
def _started(scores, density, pd, area, adaptive, rate, beta, period, alpha, dense_per_km2):
    """`ContactTracker._start_scores` under the score and adaptive rules, in one compiled call: into ``scores``
    (K, 4) (`Tracks.scores`) of new tracks whose second contacts lie where the clutter density is ``density`` (K,)
    m^-2, the two-point start's score (`lifecycle.start_score` for P_D ``pd`` and the window's ``area`` m^2) and,
    if ``adaptive``, the thresholds of its birth place (`lifecycle.adaptive_threshold` at ``rate`` false tracks
    per hour per 1,000 km^2, ``beta`` and the scan ``period`` s; `lifecycle.deletion_threshold`)."""
    score = start_score(pd, area, density)
    scores[:, SCORE] = score
    scores[:, MAX_SCORE] = score
    if adaptive:
        scores[:, CONFIRM_AT] = adaptive_threshold(rate, beta, density, period)
        scores[:, DELETE_AT] = deletion_threshold(beta, alpha, dense_per_km2, density)
