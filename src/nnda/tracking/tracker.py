"""The tracker protocol, and the framework the single-hypothesis association methods share.

**Protocol.** A tracker is anything with a ``name``, a ``config_type`` (its
strict pydantic config, a `TrackerConfig`), ``reset()`` and ``step(scan) ->
TrackerOutput`` (`nnda.tracking.output`); it is built as
``cls(sensors, config)`` (a scenario's sensors, or one `Sensor`), by
`nnda.tracking.registry.make_tracker`. Nothing more is assumed: a peer
(Stone Soup), a PHD filter or a track-before-detect tracker meets it
without an IMM or an initiator. `checked_scan` is the scan check every one
of them can share; `nnda.data.scenario.sensor_tuple` reads the sensors.

**Framework.** `ContactTracker` holds what trackers that build tracks from
contacts share: a per-track filter component (the IMM of the config's
``motion``, `MotionConfig`, by default), one copy of it per sensor with
that sensor's measurement model, and the two-point initiation
(`TwoPointInitiation`). A scan is one sweep of one sensor: its contacts
update the tracks through that sensor's filter, so two radars' scans
refine the same tracks. The single-hypothesis trackers
(`SingleHypothesisTracker`: GNN, JPDA, neural) then differ in one hook
only, `associate`; each scan:

1. check the scan (time increasing, a known sensor, (N, 2) finite real contacts: `checked_scan`);
2. predict every live track's filter to the scan time, over the time since
   its last update (a missed scan is not an update);
3. **associate** (the method's part): decide which contact, if any, updates
   each track and return the states after the scan (`Association`);
4. the M/N and deletion logic of `nnda.tracking.lifecycle`, then its sanity rules on the reported
   states (impossible speed, outside coverage, inflated covariance), deletions counted by reason;
5. initiation: the initiators of the sensor's last scan pair with this
   scan's unused contacts inside their [D_min, D_max] window, each pair
   opening a preliminary track (two-point start); unused contacts outside
   every window become that sensor's next initiators (Vargas Avila 2015,
   Ch. 2; contacts inside a window start none: our reading);
6. report every track (and those deleted in this scan, once more).

Track records are batched arrays (`Tracks`), so steps 2-6 have no Python
loop over tracks. MHT (`nnda.tracking.mht`) is a `ContactTracker` with its
own scan step over hypothesis trees. A window of asynchronous reports (a
sensor with ``reports``) runs these steps once per report time and once at
the window's end (`nnda.tracking.reports`) in the trackers that take it.
"""

from __future__ import annotations

import math
import numbers
import warnings
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Annotated, ClassVar, Literal, NamedTuple, Protocol, runtime_checkable

import numba
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor, sensor_tuple
from nnda.data.sensor import observable
from nnda.errors import BoundWarning, TrackingError
from nnda.filters.batch import Batch
from nnda.filters.imm import DEFAULT_TPM, IMM, IMMPrediction, IMMState
from nnda.filters.imm_kernels import estimate, pair_log_likelihood, start
from nnda.filters.kalman import GATE_99, gate_probability
from nnda.filters.measurement import MeasurementModel, converted_covariances, measurement_model
from nnda.filters.motion import ConstantVelocity, CoordinatedTurn
from nnda.tracking.assignment import given
from nnda.tracking.clutter_density import coverage_area, local_density, unexplained_density
from nnda.tracking.continuation import continuation_pairs
from nnda.tracking.detection_probability import DEFAULT_PD, DetectionProbabilities, detection_probabilities
from nnda.tracking.lifecycle import (
    DELETION_REASONS,
    FAST_LINE_CONTACTS,
    FAST_LINE_EVIDENCE,
    SANITY_REASONS,
    LifecycleConfig,
    adaptive_threshold,
    advance_kernel,
    advance_score_kernel,
    birth_log_odds,
    cap_pairs,
    cap_per_initiator,
    deletion_threshold,
    everywhere,
    fast_lines_kernel,
    fast_share,
    fast_tolerance_m,
    free_pairs_kernel,
    miss_run,
    misses_to_hide,
    no_lines,
    predicted_log_odds,
    rate_threshold,
    sanity_args,
    sanity_kernel,
    score_bounds,
    search_reach,
    sensor_noise_m,
    start_score,
)
from nnda.tracking.linearisation import update as linearised_update
from nnda.tracking.lookup import sorted_find
from nnda.tracking.marginals import log_miss_weight
from nnda.tracking.output import CONFIRMED, DELETED, NO_CONTACT, PRELIMINARY, TrackerOutput
from nnda.tracking.reports import Phase, report_pairs, report_times, step_window
from nnda.tracking.target_classes import TargetClassUse, target_config

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


class TrackerConfig(BaseModel):
    """Base of every tracker's config: strict (unknown fields, NaN and infinity refused), frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


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


class SingleHypothesisConfig(ContactTrackerConfig):
    """Settings of the single-hypothesis trackers whose lagged output can end a deleted track at its score's
    last peak (gnn, jpda, nn; `ContactTracker.score_peaks`)."""

    end_at_score_peak: bool = Field(True, description=(
        "a fixed-lag output ends a confirmed track that the life cycle deleted within its window at the last "
        "maximum of its score, the change time of the score-drop test (Page 1954), not only when it coasted "
        "to its deletion without a contact; under the score-type confirmation rules only"))
    continuation_gate: Annotated[float, Field(ge=0, description=(
        "track continuation (`nnda.tracking.continuation`): a track confirmed in a scan in which a confirmed "
        "track coasted continues that track, under its id, when its estimate lies within this chi-square "
        "threshold (4 dof) of one of the coasting track's motion models' predictions; the new track is then "
        "reported deleted. Joins the two segments of a target that turned out of its track's gate instead of "
        "reporting it lost and found again. 0: never"))] = 0.0


@runtime_checkable
class Tracker(Protocol):
    """What a study runs: one scan in, every track out. Built as ``cls(sensors, config)``.

    Optional capabilities, read where present (never by tracker name) by the fixed-lag output
    (`nnda.tracking.lag.FixedLag`): a ``filter`` attribute that is an `IMM` (every `ContactTracker`: its
    motion models smooth the lagged states, `nnda.tracking.lag.LagMotion`), and a ``best_branch(reported)``
    method (`nnda.tracking.lag.RevisesBranches`: MHT) giving each reported track's contacts of its last
    scans on the current best hypothesis's branch. A tracker without them gets the back-fill of
    confirmations only.
    """

    name: ClassVar[str]
    config_type: ClassVar[type[TrackerConfig]]

    def reset(self) -> None:
        """Forget everything (the start of a new run)."""

    def step(self, scan: Scan) -> TrackerOutput:
        """Process one sweep and report every track."""


def checked_config(tracker: Tracker, config: TrackerConfig | None) -> TrackerConfig:
    """``config``, or the tracker's default config when None; raises unless it is of the tracker's type."""
    config = config if config is not None else tracker.config_type()
    if not isinstance(config, tracker.config_type):
        raise TrackingError(f"{tracker.name}: config must be a {tracker.config_type.__name__}")
    return config


#: a contact's row for each kind of measurement: polar [range m, azimuth rad], position fixes [x m, y m]
CONTACT_ROW = {True: "[range m, azimuth rad]", False: "[x m, y m]"}


def checked_contacts(name: str, scan: Scan, polar: bool, sensor: str) -> np.ndarray:
    """The contacts of ``scan`` as a float (N, 2) array, one row `CONTACT_ROW` per contact (``polar``: range
    and azimuth from the sweeping sensor, named ``sensor``; else Cartesian fixes), checked for tracker
    ``name``: TrackingError naming the tracker, the scan and the sensor unless the measurements are real
    numbers (integer or float dtype) of shape (N, 2), or an empty 1-D array for a scan without contacts,
    each finite and, for a polar sensor, with a positive range. A vectorised check and one compiled pass per
    scan, never a Python loop over contacts."""
    what = CONTACT_ROW[polar]
    kind = "polar sensor" if polar else "sensor of position fixes"
    try:
        z = np.asarray(scan.measurements)
    except (ValueError, TypeError) as exc:  # a ragged nested list
        raise TrackingError(f"{name}: scan {scan.index} of {kind} {sensor!r}: measurements must be an (N, 2) "
                            f"array of real numbers, one row {what} per contact "
                            f"({' '.join(str(exc).split())})") from None
    if z.dtype.kind not in "iuf":
        raise TrackingError(f"{name}: scan {scan.index} of {kind} {sensor!r}: measurements must be real numbers "
                            f"(an integer or float array), one row {what} per contact; got dtype {z.dtype}")
    if z.ndim == 1 and z.size == 0:
        return np.empty((0, 2))
    if z.ndim != 2 or z.shape[1] != 2:
        raise TrackingError(f"{name}: scan {scan.index} of {kind} {sensor!r}: measurements must have shape "
                            f"(N, 2) {what}, one row per contact, got {z.shape}")
    z = z.astype(float, copy=False)
    if not _valid(z, polar):
        row = int(np.flatnonzero(~np.isfinite(z).all(axis=1) | (polar & ~(z[:, 0] > 0)))[0])
        raise TrackingError(f"{name}: scan {scan.index}: contact {row} is invalid {z[row].tolist()} "
                            f"({'non-finite or non-positive range' if polar else 'non-finite'}); give finite "
                            f"values{', with a range > 0 m' if polar else ''}")
    return z


def checked_scan(name: str, scan: Scan, last_time: float, sensors: tuple[Sensor, ...], last_sensor: int | None = None,
                 reports: bool = False) -> tuple[np.ndarray, float]:
    """The contacts z (N, 2) and time (s) of ``scan``, checked for tracker ``name`` built for ``sensors``.

    Raises TrackingError unless ``scan`` is a scan (`nnda.data.dataset.Scan`: index, time, measurements,
    sensor), its time is a finite number after ``last_time`` (or equal to it when the tracker gives the
    previous scan's sensor, ``last_sensor``, and this scan comes from another: two sensors' sweeps at one
    instant), its sensor is one of ``sensors`` (and sweeps, unless the tracker takes asynchronous ``reports``:
    `nnda.tracking.reports`) and its
    measurements pass `checked_contacts` for that sensor's kind ([range m, azimuth rad], positive ranges, for
    a polar sensor; [x m, y m] for a position sensor).
    """
    if not (hasattr(scan, "index") and hasattr(scan, "time") and hasattr(scan, "measurements")
            and hasattr(scan, "sensor")):  # one test a field, not a generator: every scan of every tracker
        raise TrackingError(f"{name}: step takes a scan (nnda.data.dataset.Scan: index, time, measurements, "
                            f"sensor), got {type(scan).__name__}")
    sensor = scan.sensor
    if not (isinstance(sensor, (int, np.integer)) and 0 <= sensor < len(sensors)):
        raise TrackingError(f"{name}: scan {scan.index} comes from sensor {sensor!r}, but this tracker was built "
                            f"for {len(sensors)} sensor(s) ({', '.join(s.name for s in sensors)})")
    if sensors[sensor].reports and not reports:
        raise TrackingError(f"{name}: scan {scan.index} comes from sensor {sensors[sensor].name!r} of asynchronous "
                            f"reports, which this tracker does not take; trackers that do: "
                            f"{', '.join(reporting_trackers())}")
    if type(scan.time) is not float and (isinstance(scan.time, (bool, np.bool_))  # a float passes at once
                                         or not isinstance(scan.time, numbers.Real)):
        raise TrackingError(f"{name}: scan {scan.index} has time {scan.time!r} of type {type(scan.time).__name__}; "
                            f"a scan's time is a number of seconds")
    time = float(scan.time)
    if not math.isfinite(time):
        raise TrackingError(f"{name}: scan {scan.index} has a non-finite time {scan.time}")
    if time < last_time or (time == last_time and (last_sensor is None or sensor == last_sensor)):
        raise TrackingError(f"{name}: scan {scan.index} at t = {time} s does not come after the previous scan "
                            f"(t = {last_time} s{'' if last_sensor is None else f', sensor {last_sensor}'}); scans "
                            f"must arrive in time order, those of two sensors at one instant in either order")
    return checked_contacts(name, scan, sensors[sensor].kind == "polar", sensors[sensor].name), time


def reporting_trackers() -> list[str]:
    """The names of the contact trackers defined so far that take asynchronous reports (``takes_reports``)."""
    found, todo = set(), [ContactTracker]
    while todo:
        cls = todo.pop()
        todo.extend(cls.__subclasses__())
        if cls.takes_reports and hasattr(cls, "name"):
            found.add(cls.name)
    return sorted(found)


@numba.njit(cache=True, nogil=True)
def _valid(z, polar):
    """Whether every contact of z (N, 2) is finite, with a positive range if ``polar`` (`checked_scan`'s test
    in one compiled pass: it runs on every scan of every tracker)."""
    for i in range(z.shape[0]):
        if not (math.isfinite(z[i, 0]) and math.isfinite(z[i, 1])) or (polar and not z[i, 0] > 0):
            return False
    return True


#: columns of `Tracks.history`: the contact before the last (x, y m; time s), the last (x, y m; time s; azimuth
#: rad) and the time (s) of the track's first contact
P1, T1, P2, T2, AZ2, T0 = slice(0, 2), 2, slice(3, 5), 5, 6, 7
#: the x columns of p1 and p2 (y follows each), for the compiled loops that write them entry by entry
X1, X2 = P1.start, P2.start
#: columns of `Tracks.counts`: the M/N counters
HITS, MISSES, CONSECUTIVE = 0, 1, 2
#: columns of `Tracks.scores`: the track score, its maximum so far, the score that confirms the track, the fall
#: from the maximum that deletes it once confirmed (adaptive rule)
SCORE, MAX_SCORE, CONFIRM_AT, DELETE_AT = 0, 1, 2, 3


def _column(field: str, column: int | slice, doc: str) -> property:
    """A read-only view of one column (or two) of a `Tracks` field."""
    return property(lambda tracks: getattr(tracks, field)[:, column], doc=doc)


@dataclass(frozen=True)
class Tracks(Batch):
    """K live tracks (preliminary or confirmed); every field has the track axis first.

    ``track_id`` (K,) int64, ``status`` (K,) int8; ``filt`` is the IMM
    posterior at the track's last update. The other fields are packed by
    kind, one array each (the scan loop hands whole records to its compiled
    steps, and each array crossing that boundary costs a conversion); their
    columns read as named views:

    - ``history`` (K, 8) float, the contact history: ``p1`` (K, 2) m and
      ``t1`` (s), the contact before the last; ``p2`` (K, 2) m (Cartesian),
      ``t2`` (s) and ``az2`` (rad), the last one, where ``filt`` stands;
      ``t0`` (s), the track's first contact;
    - ``counts`` (K, 3) int64: ``hits``, ``misses`` and ``consecutive``,
      the M/N counters of `nnda.tracking.lifecycle`;
    - ``scores`` (K, 4) float: ``score``, the track score (log-likelihood
      ratio of target against clutter; kept under the score rule, 0
      otherwise; under the existence rule the log-odds of the track's
      existence), ``max_score`` its maximum so far and ``confirm_at`` the
      score at which a preliminary track confirms under the score rule
      (Wald's threshold, or `lifecycle.rate_threshold` of its birth scan)
      and the adaptive rule (`lifecycle.adaptive_threshold` of its birth
      place); inf otherwise; ``delete_at``, under the adaptive rule the
      fall below ``max_score`` that deletes a confirmed track
      (`lifecycle.adaptive_deletion` of its birth place; 0 otherwise).
    """

    track_id: np.ndarray
    status: np.ndarray
    filt: IMMState
    history: np.ndarray
    counts: np.ndarray
    scores: np.ndarray

    p1 = _column("history", P1, "(K, 2) m: the contact before the last")
    t1 = _column("history", T1, "(K,) s: its time")
    p2 = _column("history", P2, "(K, 2) m: the last contact")
    t2 = _column("history", T2, "(K,) s: its time, that of ``filt``")
    az2 = _column("history", AZ2, "(K,) rad: its azimuth")
    t0 = _column("history", T0, "(K,) s: the time of the track's first contact")
    hits = _column("counts", HITS, "(K,) the M/N hits")
    misses = _column("counts", MISSES, "(K,) the M/N misses")
    consecutive = _column("counts", CONSECUTIVE, "(K,) the consecutive misses")
    score = _column("scores", SCORE, "(K,) the track score")
    max_score = _column("scores", MAX_SCORE, "(K,) its maximum so far")
    confirm_at = _column("scores", CONFIRM_AT, "(K,) the score that confirms a preliminary track")
    delete_at = _column("scores", DELETE_AT, "(K,) the fall from max_score that deletes a confirmed track")

    def rescored(self, score: np.ndarray, *, restart: bool = False) -> Tracks:
        """These tracks with the score (K,) replaced, and its maximum too with ``restart`` (a new track's)."""
        scores = self.scores.copy()
        scores[:, SCORE] = score
        if restart:
            scores[:, MAX_SCORE] = score
        return self.replaced(scores=scores)

    def after_scan(self, contact: np.ndarray, filt: IMMState, z: np.ndarray, xy: np.ndarray, time: float,
                   lifecycle: LifecycleConfig, observed: np.ndarray | None = None,
                   score_gain: np.ndarray | None = None) -> Tracks:
        """These tracks after a scan at ``time``: ``contact`` (K,) is the contact each used
        (NO_CONTACT: missed), ``filt`` their filter states from then on. The contact history moves on where
        a contact was used, and the M/N counters, the score (by ``score_gain`` (K,), the scan's
        log-likelihood ratio; None: 0) and the status advance (`lifecycle.advance`, or
        `lifecycle.advance_score` under the score rule) where the scan ``observed`` the track (default:
        everywhere), in one compiled call (`_scanned_moved`)."""
        status, counts, scores, history = _scanned_moved(*self._scan_args(contact, z, xy, time, lifecycle, observed,
                                                                          score_gain))
        return Tracks(self.track_id, status, filt, history, counts, scores)

    def _scan_args(self, contact: np.ndarray, z: np.ndarray, xy: np.ndarray, time: float,
                   lifecycle: LifecycleConfig, observed: np.ndarray | None, score_gain: np.ndarray | None) -> tuple:
        """The arguments of `_scanned_moved` for `after_scan`'s."""
        K, cfg = len(contact), lifecycle
        score_rule = cfg.confirmation != "mn"
        confirm_at = np.ascontiguousarray(self.scores[:, CONFIRM_AT])  # one compiled layout, whichever rule
        lower, upper, early = (score_bounds(cfg, K, confirm_at, self.scores[:, DELETE_AT]) if score_rule
                               else (confirm_at, confirm_at, 0.0))
        return (contact, everywhere(observed, K), self.status, self.counts, cfg.m, cfg.n - cfg.m + 1,
                cfg.max_misses, self.scores, np.zeros(K) if score_gain is None else score_gain,
                score_gain is not None, score_rule, cfg.confirmation == "existence", lower, upper, early,
                miss_run(cfg), self.history, xy, np.ascontiguousarray(z[:, 1]), time)

    def branched(self, parent: np.ndarray, filt: IMMState) -> Tracks:
        """The tracks of rows ``parent`` (M,), as `Batch.take` gives them, with the new filter states ``filt`` (M
        rows): a scan's children of these tracks, without a copy of the filter states they replace."""
        return Tracks(self.track_id[parent], self.status[parent], filt, self.history[parent], self.counts[parent],
                      self.scores[parent])

    def joined(self, other: Tracks) -> Tracks:
        """These tracks, then ``other``'s: `Batch.concat` of the two in one compiled call (`_joined`; the
        single-hypothesis trackers add a scan's new tracks every scan, where 8 concatenations cost more
        than the copying)."""
        track_id, status, x, P, mu, *rest = _joined(self._arrays(), other._arrays())
        return Tracks(track_id, status, IMMState(x, P, mu), *rest)

    def _arrays(self) -> tuple[np.ndarray, ...]:
        """The fields' arrays in field order, the filter state's three in its place."""
        f = self.filt
        return self.track_id, self.status, f.x, f.P, f.mu, self.history, self.counts, self.scores


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


@numba.njit(cache=True, nogil=True)
def _joined(a, b):
    """The arrays of `Tracks._arrays` ``a`` then ``b``, concatenated field by field."""
    return (np.concatenate((a[0], b[0])), np.concatenate((a[1], b[1])), np.concatenate((a[2], b[2])),
            np.concatenate((a[3], b[3])), np.concatenate((a[4], b[4])), np.concatenate((a[5], b[5])),
            np.concatenate((a[6], b[6])), np.concatenate((a[7], b[7])))


@numba.njit(cache=True, nogil=True)
def _scanned_moved(contact, observed, status, counts, m, misses_to_delete, max_misses, scores, gain, scored,
                   score_rule, exist, lower, upper, early, run, history, xy, azimuth, time):
    """`_scanned`, then `_moved_history`: (status, counts, scores, history)."""
    return (_scanned(contact, observed, status, counts, m, misses_to_delete, max_misses, scores, gain, scored,
                     score_rule, exist, lower, upper, early, run)
            + (_moved_history(contact, history, xy, azimuth, time),))


@numba.njit(cache=True, nogil=True)
def _finished(scan, ux, uP, umu, kx, kP, kmu, d, sanity, density, release, gx, gP, track_id, n_contacts):
    """The end of a scan for K tracks after association, in one call (`SingleHypothesisTracker._finish`).

    ``scan`` holds `_scanned_moved`'s arguments (`Tracks._scan_args`: the contact each track used first);
    the filter state from then on is the updated one (ux, uP, umu) where a contact was used, else the last
    (kx, kP, kmu) (`_picked`); the estimate to report is the updated one's on the first ``d`` entries
    (`imm_kernels.estimate`); the sanity rules (`lifecycle.sanity_kernel` with ``sanity``, `sanity_args`)
    then delete the live tracks they fail (the quality rule judges the confirmed tracks, at the clutter's
    area ``density`` (K,) m^-2 around each); with ``release`` a track deleted in this scan after it took a
    contact gives it back and reports its prediction's estimate (gx (K, d), gP (K, d, d)) instead.

    Returns the status after the scan (K,), the estimate (x (K, d), P (K, d, d)) and the contacts used (K,) to
    report, which of the scan's ``n_contacts`` they are, the scan's deletions (2 + 4 ints): preliminary tracks,
    confirmed tracks by their life cycle, then by each of `SANITY_REASONS`; and the surviving tracks' fields
    (`Tracks`: track_id (of ``track_id`` (K,)), status, (x, P, mu), history, counts, scores).
    """
    contact, before = scan[0], scan[2]
    status, counts, scores, history = _scanned_moved(*scan)
    fx, fP, fmu = _picked(contact != NO_CONTACT, ux, uP, umu, kx, kP, kmu)
    x, P = estimate(ux, uP, umu, d)
    deletions = np.zeros(2 + len(SANITY_REASONS), np.int64)
    code = sanity_kernel(x, P, np.where(status == CONFIRMED, density, 0.0), *sanity)
    for k in range(status.size):
        if status[k] == DELETED and before[k] != DELETED:
            if before[k] == PRELIMINARY:
                deletions[0] += 1
            elif before[k] == CONFIRMED:
                deletions[1] += 1
        elif code[k] > 0 and status[k] != DELETED:
            deletions[1 + code[k]] += 1
            status[k] = DELETED
    if release:
        contact = contact.copy()
        for k in range(status.size):
            if status[k] == DELETED and before[k] != DELETED and contact[k] != NO_CONTACT:
                x[k], P[k] = gx[k], gP[k]
                contact[k] = NO_CONTACT
    used = given(contact, n_contacts)
    alive = np.flatnonzero(status != DELETED)
    survivors = (track_id[alive], status[alive], (fx[alive], fP[alive], fmu[alive]), history[alive], counts[alive],
                 scores[alive])
    counted = (deletions[0], deletions[1], deletions[2], deletions[3], deletions[4], deletions[5])  # ints: no array
    return status, x, P, contact, used, counted, survivors


@numba.njit(cache=True, nogil=True)
def _scanned(contact, observed, status, counts, m, misses_to_delete, max_misses, scores, gain, scored, score_rule,
             exist, lower, upper, early, run):
    """`Tracks.after_scan`'s life cycle of K tracks in one call: the M/N counters ``counts`` (K, 3) and status
    (K,) (`lifecycle.advance`, from ``m``, ``misses_to_delete`` = n - m + 1 and ``max_misses``); if
    ``scored``, the score (column `SCORE` of ``scores`` (K, 4)) moved by ``gain`` (K,) where ``observed``
    (K,), and its maximum; under the ``score_rule`` (or the existence rule, ``exist``) the status of
    `lifecycle.advance_score` instead, with its thresholds ``lower``, ``upper`` (K,) and ``early``
    (`lifecycle.score_bounds`) and the misses in a row a confirmed track survives, ``run``
    (`lifecycle.miss_run`). Returns new (status, counts, scores)."""
    new, hits, misses, consecutive = advance_kernel(status, counts[:, HITS], counts[:, MISSES],
                                                    counts[:, CONSECUTIVE], contact != NO_CONTACT, observed, m,
                                                    misses_to_delete, max_misses)
    counts = np.empty_like(counts)
    counts[:, HITS], counts[:, MISSES], counts[:, CONSECUTIVE] = hits, misses, consecutive
    scores = scores.copy()
    if scored:
        for k in range(scores.shape[0]):
            scores[k, SCORE] += gain[k] if observed[k] else 0.0
            a, b = scores[k, MAX_SCORE], scores[k, SCORE]
            scores[k, MAX_SCORE] = a if (a >= b or a != a) else b  # np.maximum, NaN and ties included
    if score_rule:
        new = advance_score_kernel(status, scores[:, SCORE], scores[:, MAX_SCORE], observed, upper, lower, early,
                                   exist, consecutive, run)
    return new, counts, scores


@numba.njit(cache=True, nogil=True)
def _moved_history(contact, history, xy, azimuth, time):
    """`Tracks.after_scan`'s contact history (K, 8) (columns of `Tracks.history`): where ``contact`` (K,)
    names a contact (not NO_CONTACT), the last contact becomes the one before and the contact's position xy
    (N, 2) m, ``azimuth`` (N,) rad and the scan ``time`` (s) the last; a copy."""
    history = history.copy()
    for k in range(contact.size):
        c = contact[k]
        if c != NO_CONTACT:
            history[k, X1], history[k, X1 + 1], history[k, T1] = history[k, X2], history[k, X2 + 1], history[k, T2]
            history[k, X2], history[k, X2 + 1], history[k, T2], history[k, AZ2] = xy[c, 0], xy[c, 1], time, azimuth[c]
    return history


class Shown(NamedTuple):
    """One block of a scan's output (`TrackerOutput.from_blocks`): K tracks' ids and status after the scan,
    the combined estimate x (K, 4), P (K, 4, 4) to report and the contact each used (NO_CONTACT: none)."""

    track_id: np.ndarray
    status: np.ndarray
    x: np.ndarray
    P: np.ndarray
    contact: np.ndarray


@dataclass(frozen=True)
class Association:
    """What a method decided for K tracks in one scan.

    ``contact`` (K,) is the index of the contact that updated each track (or
    NO_CONTACT: a miss); ``filt`` the filter states after the scan: the updated state of
    a track with a contact, the prediction (``pred.state``) of one without. ``score_gain`` (K,)
    is the scan's track-score increment when the method computes its own (JPDA under the
    existence rule: JIPDA's); None: the framework's, from the chosen contact. ``revised`` holds the
    tracks and their prediction as the method revised them before deciding (same tracks, same order;
    the neural tracker's retrodiction puts some tracks back on the branch that skipped their last
    contact), which the life cycle then moves on from; None: as handed to the method.
    """

    contact: np.ndarray
    filt: IMMState
    score_gain: np.ndarray | None = None
    revised: tuple[Tracks, IMMPrediction] | None = None


class TwoPointInitiation:
    """Initiators and the preliminary tracks they open (Vargas Avila 2015, Ch. 2 and Sec. 5.3), per sensor.

    Holds each sensor's unused contacts of its previous scan; ``__call__``
    pairs them with the same sensor's unused contacts of this scan inside the
    [D_min, D_max] window of ``lifecycle`` (from that sensor's scan period
    and noise) and starts a preliminary track per pair with that sensor's
    filter's two-point start. Track ids count up from 0 after each `reset`,
    over all sensors. At most ``lifecycle.max_tracks`` tracks live at once:
    ``n_refused`` counts the pairs refused for want of room since the last
    reset, and the first refusal of a run is a `BoundWarning`.

    The window's ``v_max`` refuses faster targets: ``n_too_fast`` counts, since the last reset, the lines of
    contacts of one sensor's consecutive scans, each pair of them refused beyond the window (initiator b, free
    contact c, D_max < |c - b| <= 2 v_max T + 3 sigma, `LifecycleConfig.fast_window`) and each contact within
    `lifecycle.fast_tolerance_m` of the line's extrapolation b + (b - a) from the two before, long enough that
    clutter lines them up with a chance below 1/1000 (`lifecycle.fast_lines`; six contacts in S1-S6's
    clutter): a target between v_max and 2 v_max that the window kept from starting a track. The first of a run
    is a `BoundWarning` naming ``lifecycle.v_max`` and the ``tracker``; nothing else changes (the pairs open no
    track).
    """

    def __init__(self, filters: Sequence[IMM], lifecycle: LifecycleConfig, sensors: Sequence[Sensor],
                 tracker: str = "tracker") -> None:
        self.filters = tuple(filters)
        self.lifecycle = lifecycle
        self.tracker = tracker
        self.windows = tuple(lifecycle.window(s.scan_period_s, sensor_noise_m(s)) for s in sensors)
        self.fast_windows = tuple(lifecycle.fast_window(s.scan_period_s, sensor_noise_m(s)) for s in sensors)
        self.fast_tolerance = tuple(fast_tolerance_m(sensor_noise_m(s), s.scan_period_s) for s in sensors)
        self.noise = tuple(sensor_noise_m(s) for s in sensors)
        self.reset()

    def reset(self) -> None:
        """Forget every initiator; ids start again at 0."""
        n = len(self.filters)
        self.contacts = [np.empty((0, 2))] * n  # per sensor: contacts of its previous scan
        self.xy = [np.empty((0, 2))] * n  # and their Cartesian positions (m)
        self.time = [-np.inf] * n
        self.next_id = 0
        self.n_refused = 0
        #: lines of contacts refused for ``lifecycle.v_max`` since the last reset (class docstring)
        self.n_too_fast = 0
        self._fast = [no_lines()] * n  # per sensor: the lines of refused fast pairs to continue (`fast_lines`)
        #: per sensor of asynchronous reports: the unused reports waiting for a pair, (z, xy, time (s))
        self.waiting = [(np.empty((0, 2)), np.empty((0, 2)), np.empty(0))] * n

    def __call__(self, z: np.ndarray, xy: np.ndarray, used: np.ndarray, time: float, live: int, sensor: int = 0
                 ) -> tuple[Tracks | None, np.ndarray | None]:
        """Open preliminary tracks from ``sensor``'s initiators with this scan's contacts z (N, 2), xy
        (N, 2) m that no track ``used`` (N,), given ``live`` tracks already; keep the contacts outside
        every window as the sensor's next initiators.

        Returns the new tracks (or None) and the contact each one used.
        """
        lifecycle, (d_min, d_max), (fast_max, d_fast) = self.lifecycle, self.windows[sensor], self.fast_windows[sensor]
        init_xy, before, imm = self.xy[sensor], self.time[sensor], self.filters[sensor]
        room = max(lifecycle.max_tracks - live, 0)
        threshold = self._confirmation_threshold(len(init_xy)) if len(init_xy) else math.inf  # unused: no pair
        rest_z, rest_xy, contact, fields, filt, refused, n_fast, self._fast[sensor] = _initiated(
            init_xy, before, z, xy, np.asarray(used, np.bool_), d_min, d_max, d_fast, search_reach(d_max, d_fast),
            lifecycle.max_tracks_per_initiator or 0, room, self.next_id, time, threshold, self._fast[sensor],
            fast_max, self.fast_tolerance[sensor], fast_share(fast_max, d_fast, self.fast_tolerance[sensor]),
            imm.polar, imm.measurement.R, *imm.start_arrays)
        if refused:
            self._refuse(refused, live, time)
        if n_fast:
            self._refuse_fast(n_fast, time, sensor)
        self.contacts[sensor], self.xy[sensor], self.time[sensor] = rest_z, rest_xy, time
        if not contact.size:
            return None, None
        self.next_id += len(contact)
        track_id, status, history, counts, scores = fields
        return Tracks(track_id, status, IMMState(*filt), history, counts, scores), contact

    def _born(self, z: np.ndarray, contact: np.ndarray, fields: tuple, dt: float | np.ndarray, sensor: int
              ) -> tuple[Tracks, np.ndarray]:
        """The preliminary tracks of `_opened`'s ``fields`` with their second ``contact`` (K,) of z, ``dt`` (s,
        scalar or (K,)) after their first, started by the sensor's filter (two-point start); ids move on."""
        track_id, status, history, counts, scores = fields
        p2, cov2 = self.filters[sensor].measurement.position(z[contact])
        history[:, P2] = p2
        born = Tracks(track_id, status, self.filters[sensor].start(history[:, P1], p2, cov2, dt), history,
                      counts, scores)
        self.next_id += len(contact)
        return born, contact

    def reports(self, z: np.ndarray, xy: np.ndarray, used: np.ndarray, time: float, live: int, sensor: int = 0
                ) -> tuple[Tracks | None, np.ndarray | None]:
        """`__call__` for asynchronous reports (`nnda.tracking.reports`): the reports z (N, 2), xy (N, 2) m at
        ``time`` that no track ``used`` (N,) pair with ``sensor``'s unused reports of the last
        ``lifecycle.report_gap_s`` inside the speed window of each pair's own time difference
        (`reports.report_pairs`); each pair opens a preliminary track, whose first contact leaves the waiting
        reports; the reports in no pair wait in turn. The window's middle and fast lines are the sweeps'
        (``max_tracks_per_initiator`` and ``n_too_fast`` do not apply); ``max_tracks`` does, keeping the pairs
        of shortest wait."""
        cfg = self.lifecycle
        wz, wxy, wt = self.waiting[sensor]
        recent = wt >= time - cfg.report_gap_s
        wz, wxy, wt = wz[recent], wxy[recent], wt[recent]
        free, i, j = report_pairs(wxy, time - wt, xy, used, cfg, self.noise[sensor])
        room = max(cfg.max_tracks - live, 0)
        if len(i) > room:
            self._refuse(len(i) - room, live, time)
            keep = np.sort(np.argsort(-wt[i], kind="stable")[:room])
            i, j = i[keep], j[keep]
        threshold = self._confirmation_threshold(len(wxy)) if len(i) else math.inf
        rest_z, rest_xy, contact, fields, _ = _opened(free, i, j, j, wxy, z, xy, self.next_id, wt, time, threshold)
        spent = np.zeros(len(wt), bool)
        spent[i] = True
        self.waiting[sensor] = (np.concatenate([wz[~spent], rest_z]), np.concatenate([wxy[~spent], rest_xy]),
                                np.concatenate([wt[~spent], np.full(len(rest_z), time)]))
        if not contact.size:
            return None, None
        return self._born(z, contact, fields, time - wt[i], sensor)

    def _refuse_fast(self, n: int, time: float, sensor: int) -> None:
        """Count ``n`` lines refused for ``lifecycle.v_max``; the first of a run is a `BoundWarning`."""
        first = not self.n_too_fast
        self.n_too_fast += n
        if first:
            cfg, (d_max, d_fast) = self.lifecycle, self.fast_windows[sensor]
            warnings.warn(
                f"{self.tracker}, t = {time} s: {self.n_too_fast} line(s) of contacts moving between v_max and "
                f"2 v_max (pairs {d_max:.0f} to {d_fast:.0f} m apart a scan) refused by the initiation window: a "
                f"target faster than lifecycle.v_max = {cfg.v_max:g} m/s (config field) never starts a track. Raise "
                f"lifecycle.v_max above the fastest target's speed (tracks faster than lifecycle.max_speed_m_s, "
                f"{cfg.speed_limit:g} m/s here, are deleted too); later cases of this run are only counted "
                f"(initiation.n_too_fast)", BoundWarning, stacklevel=4)

    def _confirmation_threshold(self, initiators: int) -> float:
        """The score at which the tracks born from a scan's ``initiators`` confirm under the score rule:
        Wald's threshold, or with ``false_tracks_per_scan`` `lifecycle.rate_threshold` for that many
        initiators (each one is an independent trial of the test: its pairs' start scores are its second
        contact's likelihood ratio); inf under the other rules (the adaptive rule sets each track's own,
        `ContactTracker._start_scores`)."""
        cfg = self.lifecycle
        if cfg.confirmation != "score":
            return math.inf
        if cfg.false_tracks_per_scan is None:
            return cfg.score_thresholds[1]
        return rate_threshold(cfg.false_tracks_per_scan, cfg.false_deletion, initiators)

    def _refuse(self, n: int, live: int, time: float) -> None:
        if not self.n_refused:
            warnings.warn(f"t = {time} s: {n} new track(s) refused, {live} live already and at most "
                          f"{self.lifecycle.max_tracks} allowed (lifecycle.max_tracks); later refusals of this "
                          f"run are only counted (n_refused)", BoundWarning, stacklevel=4)
        self.n_refused += n


@numba.njit(cache=True, nogil=True)
def _opened(free, i, j, windowed, initiators, z, xy, first_id, before, time, confirm_at):
    """`TwoPointInitiation`'s new tracks in one call: the free contacts ``free`` (F,) outside every window
    (not among ``windowed``, indices into ``free``), the next initiators: their z, xy (M, 2); the contacts
    (K,) of the window pairs (i, j) (K,) that open tracks (j indexes ``free``); and the tracks' fields but
    the filter state (`Tracks`: track_id from ``first_id``, status, history: p1 the initiators (I, 2) of i,
    t1 = t0 their times ``before`` (I,), t2 = ``time``, az2, p2 left to the caller; counts; scores, with
    ``confirm_at``); and which free contacts are windowed (F,) bool."""
    spoken = np.zeros(free.size, np.bool_)
    spoken[windowed] = True
    rest = free[~spoken]
    contact = free[j]
    k = contact.size
    history = np.zeros((k, 8))
    scores = np.zeros((k, 4))
    for t in range(k):
        history[t, X1], history[t, X1 + 1] = initiators[i[t], 0], initiators[i[t], 1]
        history[t, T1], history[t, T0], history[t, T2], history[t, AZ2] = (before[i[t]], before[i[t]], time,
                                                                           z[contact[t], 1])
        scores[t, CONFIRM_AT] = confirm_at
    fields = (np.arange(first_id, first_id + k), np.full(k, PRELIMINARY, np.int8), history,
              np.zeros((k, 3), np.int64), scores)
    return z[rest], xy[rest], contact, fields, spoken


@numba.njit(cache=True, nogil=True)
def _initiated(init_xy, before, z, xy, used, d_min, d_max, d_fast, reach, per_initiator, room, first_id, time,
               confirm_at, lines, fast_max, tol, share, polar, R, x_rest, P_rest, mu0):
    """`TwoPointInitiation.__call__` for a sweep in one call: the window pairs of the initiators ``init_xy``
    (I, 2) m of the scan at ``before`` s with the contacts z, xy (N, 2) no track ``used`` (N,), out to the fast
    window's ``d_fast`` (`lifecycle.free_pairs_kernel`, over cells of ``reach``), at most ``per_initiator`` an
    initiator (< 1: any, `lifecycle.cap_per_initiator`) and ``room`` in all (`lifecycle.cap_pairs`); the tracks
    they open (`_opened`) with their two-point starts (`imm_kernels.start` from ``x_rest``, ``P_rest`` and
    ``mu0``, the second fix's covariance that of the ``polar`` measurement of noise R (2, 2), or R); and the
    fast ``lines`` continued (`lifecycle.fast_lines` with ``fast_max``, ``tol`` and ``share``). Returns the next
    initiators (z, xy), the opened tracks' second contacts (K,), their fields but the filter state (`_opened`),
    their filter state (x, P, mu), the pairs refused for want of room, the fast lines completed, and the lines
    to continue."""
    free, i, j, fi, fj = free_pairs_kernel(init_xy, xy, used, d_min, d_max, d_fast, reach)
    i, j = cap_per_initiator(i, j, init_xy, xy[free], d_min, d_max, per_initiator)
    windowed = j  # every windowed contact is spoken for, opened or not
    refused = max(i.size - room, 0)
    i, j = cap_pairs(i, j, init_xy, xy[free], d_min, d_max, room)
    rest_z, rest_xy, contact, fields, spoken = _opened(free, i, j, windowed, init_xy, z, xy, first_id,
                                                       np.full(init_xy.shape[0], before), time, confirm_at)
    n_fast, lines = fast_lines_kernel(init_xy, xy, free, spoken, fi, fj, lines[0], lines[1], lines[2], lines[3],
                                      lines[4], lines[5], fast_max, tol, time - before, share, FAST_LINE_EVIDENCE,
                                      FAST_LINE_CONTACTS)
    k = contact.size
    history = fields[2]
    p1, p2 = np.empty((k, 2)), np.empty((k, 2))
    for t in range(k):
        p1[t, 0], p1[t, 1] = history[t, X1], history[t, X1 + 1]
        p2[t, 0], p2[t, 1] = xy[contact[t], 0], xy[contact[t], 1]  # the fix's position, as the scan converted it
        history[t, X2], history[t, X2 + 1] = p2[t, 0], p2[t, 1]
    if polar:
        cov2 = converted_covariances(z[contact], R[0, 0], R[1, 1])
    else:
        cov2 = np.empty((k, 2, 2))
        for t in range(k):
            cov2[t] = R
    filt = start(p1, p2, cov2, np.full(1, time - before), x_rest, P_rest, mu0)
    return rest_z, rest_xy, contact, fields, filt, refused, n_fast, lines


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
        self.filter = (track_filter if track_filter is not None
                       else self.config.motion.imm(measurement_model(self.sensors[0])))
        self.filters = (self.filter, *(self.filter.for_measurement(measurement_model(s)) for s in self.sensors[1:]))
        self.initiation = TwoPointInitiation(self.filters, self.config.lifecycle, self.sensors, self.name)
        self.reset()

    def reset(self) -> None:
        """Forget every track and initiator (start of a new run)."""
        self.initiation.reset()
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

    @cached_property
    def _misses_to_hide(self) -> np.ndarray | None:
        """Per sensor, the misses in a row after which a confirmed track is left out of the output
        (`lifecycle.misses_to_hide` at the sensor's P_D and the gate's P_G) (S,); None without
        ``lifecycle.report_existence``."""
        cfg = self.config.lifecycle
        if cfg.report_existence is None:
            return None
        p_gate = gate_probability(self.gate_threshold)
        return np.array([misses_to_hide(cfg, self.score_pd(s) * p_gate) for s in range(len(self.sensors))])

    def _hidden(self, status: np.ndarray, consecutive: np.ndarray, sensor: int) -> np.ndarray | None:
        """Which of K reported tracks (their ``status`` (K,) after the scan and misses in a row ``consecutive``
        (K,)) are left out of the output after a scan of ``sensor`` (``lifecycle.report_existence``): the
        confirmed ones past `_misses_to_hide`; None when none is (or without the rule)."""
        if self._misses_to_hide is None:
            return None
        hidden = (status == CONFIRMED) & (consecutive >= self._misses_to_hide[sensor])
        return hidden if hidden.any() else None

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
        when set, else the sensor's declared P_D, else the config's default or 0.9 (`SCORE_PD`; ``detection``)."""
        return self.detection[sensor]

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
        gain, rows, at, target = _gains(assoc.contact, self._log_miss[scan.sensor], self._log_pd[scan.sensor], mp.z,
                                        mp.S_inv, mp.log_det_S, pred.state.mu, scan.z, scan.filter.polar)
        gain[rows] = target - np.log(self.clutter_density(scan, at))
        return gain

    @cached_property
    def _release(self) -> bool:
        """The config's ``release_on_deletion`` (False for a tracker without it)."""
        return bool(getattr(self.config, "release_on_deletion", False))

    @cached_property
    def _log_pd(self) -> tuple[float, ...]:
        """ln P_D of the track score per sensor (`score_pd`)."""
        return tuple(math.log(pd) for pd in self.detection.values)

    @cached_property
    def _log_miss(self) -> tuple[float, ...]:
        """ln(1 - P_D P_G) per sensor, a miss's score increment (`log_miss_weight`)."""
        return tuple(log_miss_weight(pd, self.gate_threshold) for pd in self.detection.values)

    def track_management(self) -> dict:
        """What a study records of the run so far: the confirmation rule, the deletions by reason and the lines
        of contacts the initiation window refused as faster than ``lifecycle.v_max`` (``too_fast_lines``,
        `TwoPointInitiation.n_too_fast`)."""
        return {"confirmation": self.confirmation_rule, "deletions": dict(self.deletions),
                "too_fast_lines": self.initiation.n_too_fast}

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


def hard_update(track_filter: IMM, pred: IMMPrediction, z: np.ndarray, contact: np.ndarray) -> Association:
    """Update each track with its chosen contact: ``contact`` (K,) indexes the checked contacts z (N, 2)
    (NO_CONTACT: the track keeps its prediction); a poorly linearised track takes the
    converted-measurement update (`nnda.tracking.linearisation.update`)."""
    detected = contact != NO_CONTACT
    if not detected.any():
        return Association(contact, pred.state)
    # rows without a contact are masked, whichever contact they hold
    return Association(contact, linearised_update(track_filter, pred, z[np.maximum(contact, 0)], detected))


class SingleHypothesisTracker(ContactTracker):
    """Base of the single-hypothesis trackers: each track follows one contact sequence.

    Subclasses set ``name`` (and ``config_type``) and implement `associate`.
    """

    def reset(self) -> None:
        super().reset()
        self.tracks: Tracks | None = None
        #: new tracks that continued a coasting one since the last reset (``continuation_gate``, `_continued`)
        self.continued = 0

    def track_management(self) -> dict:
        """`ContactTracker.track_management`, and with ``continuation_gate`` set the tracks that continued a
        coasting one (``continued``)."""
        managed = super().track_management()
        if self._continuation_gate > 0:
            managed["continued"] = self.continued
        return managed

    @property
    def _continuation_gate(self) -> float:
        """The config's ``continuation_gate`` (`SingleHypothesisConfig`; 0, no continuation, for a config without
        the field, a plug-in's)."""
        return getattr(self.config, "continuation_gate", 0.0)

    @property
    def _score_rule(self) -> bool:
        """Whether the confirmation rule keeps a track score that the score-drop test deletes on."""
        return self.confirmation_rule in ("adaptive", "score")

    @property
    def _peak_rule(self) -> bool:
        """Score peaks mean a change time only under the score-type rules, whose score-drop test deletes."""
        return self._score_rule

    @abstractmethod
    def associate(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts) -> Association:
        """Associate the scan's contacts (``scan.z``, ``scan.xy``) with the tracks.

        ``pred`` is every track's prediction to ``scan.time`` (s) by
        ``scan.filter``. Return the contact chosen for each track and the
        states after the scan (updated, or the prediction for a track without
        a contact; see `hard_update`).
        """

    def _step(self, scan: Scan, phase: Phase) -> TrackerOutput:
        """One pass of the scan step (module docstring) in ``phase``."""
        sc = self._checked(scan, phase)
        z, time = sc.z, sc.time
        used = None  # the contacts the tracks reported (N,); None: no track, none
        hidden = None  # the old tracks left out of the output (`_hidden`)
        shown: list[Shown] = []  # the output's blocks: old tracks, new ones
        tracks = self.tracks
        if tracks is not None:
            # IPDA's Markov prediction of the existence probability, once a sweep or a report window
            if self.confirmation_rule == "existence" and phase is not Phase.REPORTS:
                survival = self.config.lifecycle.survival_probability
                tracks = tracks.rescored(predicted_log_odds(tracks.score, survival))
            pred = sc.filter.predict(tracks.filt, time - tracks.t2, check=False)
            if self._unexplained:  # a confirmed track is expected to give a gated contact P_D P_G of the time
                confirmed = tracks.status == CONFIRMED
                self._explained = (sc, pred.gating.x[confirmed][:, 0:3:2],
                                   np.full(int(confirmed.sum()),
                                           self.score_pd(sc.sensor) * gate_probability(self.gate_threshold)))
            assoc = self.associate(tracks, pred, sc)
            if assoc.revised is not None:
                tracks, pred = assoc.revised
            tracks, block, used, hidden = self._finish(tracks, pred, assoc, sc)
            shown.append(block)
        score_rule = self.confirmation_rule != "mn"
        # under the score rule only confirmed tracks take room from new ones: the cap then keeps the best scores
        held = 0 if tracks is None else np.count_nonzero(tracks.status == CONFIRMED) if score_rule else len(tracks)
        born, born_contact = self._initiate(sc, np.zeros(len(z), bool) if used is None else used, held)
        if born is not None:
            born = self._start_scores(born, sc, born_contact)
            if score_rule:
                tracks, born, born_contact = self._capped(tracks, born, born_contact, shown, time)
        if born is not None:
            shown.append(Shown(born.track_id, born.status, *self.filter.estimate(born.filt), born_contact))
            tracks = born if tracks is None else tracks.joined(born)
        self.tracks = tracks
        if hidden is not None:  # after the cap, which reads the old tracks' block row by row
            shown[0] = Shown(*(a[~hidden] for a in shown[0]))
        return TrackerOutput.from_blocks(scan.index, time, shown)

    def _finish(self, tracks: Tracks, pred: IMMPrediction, assoc: Association, scan: ScanContacts
                ) -> tuple[Tracks | None, Shown, np.ndarray, np.ndarray | None]:
        """The scan's end for the K tracks the method decided for, in one compiled call (`_finished`): a track
        with a contact takes its updated state, a missed one keeps its last posterior (no update) and reports its
        prediction; the life cycle (`Tracks.after_scan`, with the score's increments of `_score_gain`); the
        sanity rules on the reported states (`nnda.tracking.lifecycle.sanity_reasons`); with the config's
        ``release_on_deletion``, a track deleted in this scan after it took a contact gives the contact back,
        reported as a miss with its prediction's estimate. The scan's deletions are counted in ``deletions``
        by reason. Returns the tracks that live on (None: none), the K tracks' report, which of the scan's
        contacts it holds (N,) and which of the K rows to leave out of the output (`_hidden`; None: none). With
        ``end_at_score_peak``, each track's score peak is kept (`score_peaks`)."""
        cfg, u, k, g = self.config.lifecycle, assoc.filt, tracks.filt, pred.gating
        seen, gain = self._observed(scan, pred, tracks.t2, assoc.contact), self._score_gain(pred, scan, assoc)
        if self._ends_at_peak:
            self._note_peaks(tracks, gain if seen is None else np.where(seen, gain, 0.0), scan.time)
        args = tracks._scan_args(assoc.contact, scan.z, scan.xy, scan.time, cfg, seen, gain)
        status, x, P, contact, used, deletions, survivors = _finished(
            args, u.x, u.P, u.mu, k.x, k.P, k.mu, self.filter.output_dim, self._sanity_args, self._quality_density(
                scan, g.x), self._release, g.x, g.P, tracks.track_id, len(scan.z))
        if any(deletions):
            for reason, n in zip(("unconfirmed", self._ended_reason, *SANITY_REASONS), deletions):
                self.deletions[reason] += n
        track_id, status_alive, filt, *rest = survivors
        alive = None if not track_id.size else Tracks(track_id, status_alive, IMMState(*filt), *rest)
        block = Shown(tracks.track_id, status, x, P, contact)
        if alive is not None and self._continuation_gate > 0:
            alive, block = self._continued(tracks, pred, alive, block, seen)
        hidden = None
        if self._misses_to_hide is not None and alive is not None:
            consecutive = np.zeros(len(status), np.int64)
            consecutive[block.status != DELETED] = alive.consecutive
            hidden = self._hidden(block.status, consecutive, scan.sensor)
        return alive, block, used, hidden

    def _continued(self, tracks: Tracks, pred: IMMPrediction, alive: Tracks, block: Shown,
                   seen: np.ndarray | None) -> tuple[Tracks, Shown]:
        """Track continuation (``continuation_gate``, `nnda.tracking.continuation`) at the end of a scan, for the
        K ``tracks`` as they were before it and their prediction ``pred``: a track confirmed in this scan whose
        first contact came after the last contact before this scan of a confirmed track (which was coasting
        when the new one started), and which `continuation_pairs` matches to it, continues that track. The
        old track keeps its id, status and first contact time; if the scan missed it (observed, ``seen``; None:
        everywhere) it takes the new one's filter state, contact history, counters, score and score peak and
        this scan's report, else it keeps its own. The new track is reported deleted without its contact.
        ``alive`` are the surviving tracks (in ``block``'s order, its rows not DELETED), ``block`` the K
        tracks' report; returns both after the joins, which `continued` counts."""
        status, contact = block.status, block.contact
        new = np.flatnonzero((status == CONFIRMED) & (tracks.status == PRELIMINARY))
        old = (status == CONFIRMED) & (tracks.status == CONFIRMED)
        old = np.flatnonzero(old if seen is None else old & (seen | (contact != NO_CONTACT)))
        if not (new.size and old.size):
            return alive, block
        d, state = self.filter.output_dim, pred.state
        o, n = continuation_pairs(state.x[old, :, :d], state.P[old, :, :d, :d], block.x[new], block.P[new],
                                  tracks.t2[old][:, None] < tracks.t0[new][None, :], self._continuation_gate)
        if not o.size:
            return alive, block
        old, new = old[o], new[n]
        self.continued += int(old.size)
        taken = contact[old] == NO_CONTACT  # the old tracks that take the new one's state
        rows = np.flatnonzero(status != DELETED)  # alive's rows in the block
        at_old, at_new = np.searchsorted(rows, old), np.searchsorted(rows, new)
        source = np.arange(len(alive))  # each surviving row's fields come from itself, or from its new track
        source[at_old[taken]] = at_new[taken]
        kept = np.delete(np.arange(len(alive)), at_new)  # the new tracks that continued an old one go
        joined = alive.take(source[kept])
        history = joined.history.copy()
        history[:, T0] = alive.history[kept, T0]
        joined = joined.replaced(track_id=alive.track_id[kept], status=alive.status[kept], history=history)
        x, P, contact, status = block.x.copy(), block.P.copy(), contact.copy(), status.copy()
        into, out = old[taken], new[taken]
        x[into], P[into], contact[into] = x[out], P[out], contact[out]
        contact[new], status[new] = NO_CONTACT, DELETED
        if self._ends_at_peak and into.size:
            ids, peak = self._peaks
            peak = peak.copy()
            peak[sorted_find(ids, block.track_id[into])[0]] = peak[sorted_find(ids, block.track_id[out])[0]]
            self._peaks = (ids, peak)
        return joined, block._replace(status=status, x=x, P=P, contact=contact)

    def _note_peaks(self, tracks: Tracks, gain: np.ndarray, time: float) -> None:
        """Keep, for each of the K ``tracks``, the time its score last reached its maximum: ``time`` (s) when its
        score after this scan's increment ``gain`` (K,; 0 for an unobserved track) does, else as before (a track
        born in the scan before: the time of its last contact, its maximum since its birth)."""
        before = self._peak_of(tracks.track_id, tracks.t2)
        peak = np.where(tracks.score + gain >= tracks.max_score, time, before)
        order = np.argsort(tracks.track_id)
        self._peaks = (tracks.track_id[order], peak[order])

    def _capped(self, tracks: Tracks | None, born: Tracks, contact: np.ndarray, shown: list[Shown], time: float
                ) -> tuple[Tracks | None, Tracks | None, np.ndarray]:
        """The score rule's cap on live tracks (``lifecycle.max_tracks``): past it, the preliminary tracks of
        lowest score (old or just born) go, so a target's track, whose score grows with every contact, is
        not refused for clutter-born ones. A dropped old track is reported as deleted in this scan
        (``shown``'s first block), a dropped new one never; both are counted as "capped"."""
        old = 0 if tracks is None else len(tracks)
        room = self.config.lifecycle.max_tracks
        if old + len(born) <= room:
            return tracks, born, contact
        status = np.concatenate([np.empty(0, np.int8) if tracks is None else tracks.status, born.status])
        score = np.concatenate([np.empty(0) if tracks is None else tracks.score, born.score])
        prelim = np.flatnonzero(status == PRELIMINARY)
        n_keep = max(room - (status.size - prelim.size), 0)
        drop = prelim[np.argsort(-score[prelim], kind="stable")[n_keep:]]
        keep = np.ones(status.size, bool)
        keep[drop] = False
        self.deletions["capped"] += int(drop.size)
        self._bound_hit("max_tracks", f"{drop.size} preliminary track(s) of lowest score dropped, {room} live "
                        f"at most", time)
        if old and not keep[:old].all():
            block = shown[0]
            gone = np.flatnonzero(~keep[:old])
            shown_status = block.status.copy()
            shown_status[np.flatnonzero(block.status != DELETED)[gone]] = DELETED
            shown[0] = block._replace(status=shown_status)
            tracks = tracks.take(np.flatnonzero(keep[:old])) if keep[:old].any() else None
        new = np.flatnonzero(keep[old:])
        return tracks, (born.take(new) if new.size else None), contact[new]


@numba.njit(cache=True, nogil=True)
def _picked(rows, ax, aP, amu, bx, bP, bmu):
    """Per track, the state of IMM state ``a`` where ``rows`` (K,) is true, else that of ``b``, from their arrays
    (x (K, r, n), P (K, r, n, n), mu (K, r)): new arrays."""
    x, P, mu = bx.copy(), bP.copy(), bmu.copy()
    for k in range(rows.size):
        if rows[k]:
            x[k], P[k], mu[k] = ax[k], aP[k], amu[k]
    return x, P, mu


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
