"""Track life cycle shared by every tracker (Vargas Avila 2015, Ch. 2 and Sec. 5.3): initiation window and
M/N logic.

* A contact not used by any track becomes an *initiator* (tentative track).
  On the next scan, each contact at a distance in [D_min, D_max] from it
  forms a preliminary track with it, D_min = V_min T - 3 sigma_r and
  D_max = V_max T + 3 sigma_r. An initiator with no such contact is
  discarded; contacts inside some initiator's window do not start initiators
  themselves (our reading: the thesis leaves it open).
* Preliminary tracks pass an M/N test counted from the third scan of their
  life (the thesis's eqs. 2.2-2.3): confirmed at the M-th detection, deleted
  at the (N-M+1)-th miss. Confirmed tracks are deleted when their consecutive
  misses exceed ``max_misses`` (its Sec. 5.5: survive 3, delete at the 4th).
* Track score (``confirmation = "score"``, Blackman & Popoli 1999,
  Sec. 6.2): instead of counting, a track carries the log-likelihood
  ratio of "target" against "clutter" of the contacts it used. The two-point
  start gives ln(P_D / (A_w rho)), A_w the initiation annulus' area and rho
  the clutter's area density at the second contact (the target's second
  contact falls anywhere in the annulus, clutter with density rho); each
  later scan adds ln(P_D l / lambda) for the contact the track reports, of
  likelihood l where the clutter density is lambda (both in the sensor's
  measurement space), or ln(1 - P_D P_G) for a miss (`log_miss_weight`); the clutter density is
  estimated per scan around the contact (`nnda.tracking.clutter_density`).
  Wald's sequential probability ratio test on it (`sprt_thresholds`): a
  preliminary track is confirmed when its score reaches ln((1 - beta) /
  alpha), alpha = ``false_confirmation`` (the probability of confirming a
  track of clutter) and beta = ``false_deletion`` (of deleting a target's
  track), and deleted early, when it falls to ln(beta_p / (1 - alpha)) with
  beta_p = ``preliminary_false_deletion``; a confirmed track is deleted when
  its score falls ln(beta / (1 - alpha)) below its maximum (the score-drop
  rule). Under this rule ``max_tracks`` counts only confirmed tracks against
  new ones and then keeps the preliminary tracks of best score (the
  tracker's cap). With P_D = 0.9 and beta = 1e-3 a confirmed track survives
  three misses and is deleted at the fourth, as the M/N rule's max_misses = 3.
* False tracks at a rate (``false_tracks_per_scan`` = r; Blackman & Popoli 1999, Sec. 6.2, where the
  false-confirmation probability comes from the wanted false-track rate): Wald's bound alpha holds per
  initiator (each is one trial of the test: the start score is its second contact's likelihood ratio,
  whichever pairs it opens), so with a fixed alpha the false tracks a run may confirm grow with the
  initiators, that is with the clutter count. With r set, the tracks born from one scan's N initiators
  confirm at Wald's threshold for alpha = r / N (`rate_threshold`): at most r false confirmations per
  scan in expectation at any clutter density, and a lower threshold where clutter is sparse (fewer
  initiators: faster confirmation). Each track keeps the threshold of its birth (``Tracks.confirm_at``);
  the deletion thresholds are as above.
* Clutter-adaptive (``confirmation = "adaptive"``, the default of every contact tracker): the score
  rule's test with a confirmation threshold per track, set at its birth from the clutter where it was
  born and a false-track rate per unit area and time, phi = ``false_track_rate`` (false tracks per hour
  per 1,000 km^2). A two-point start in clutter of area density rho (m^-2 per scan) is one trial of Wald's
  test; the clutter of an area A opens rho A such trials a scan, so confirming at alpha = phi T / rho
  (T the scan period) allows phi T A false confirmations a scan in that area, whatever rho is: the
  threshold ln((1 - beta) rho / (phi T)) (`adaptive_threshold`) rises by ln 10 where the clutter is ten
  times denser, and falls where it is sparse, so a track born away from the clutter confirms sooner. It is
  the existence rule's clutter cancellation (the prior odds P_D beta_NT / rho) on the track score,
  without the survival's decay, so MHT can run it too. A confirmed track is deleted as under the score
  rule, its score fallen ln(beta_k / (1 - alpha)) below its maximum, with beta_k = beta x min(1, rho /
  rho_dense) set at its birth too (`adaptive_deletion`; rho_dense = ``dense_clutter_per_km2``, beta_k at
  least beta / 100): a track that lost its target takes clutter in proportion to rho, so where clutter is
  sparse it waits longer for a target that turns (its contacts then fit badly, each lowering the score) or
  fades. A run of misses still ends it as the score rule's beta would: at ``max_misses`` + 1 misses in a
  row (`miss_run`; with P_D 0.9 and beta 1e-3 the score rule too survives three and not four), so a target
  that has gone is let go as soon as before.
* Existence (``confirmation = "existence"``; IPDA, Musicki, Evans &
  Stankovic 1994, and JIPDA, Musicki & Evans 2004): the track carries the
  log-odds of its probability of existence rho, predicted each scan as
  rho' = ``survival_probability`` rho (`predicted_log_odds`) and updated
  by the same likelihood ratio as the score (rho / (1 - rho) = (1 - delta)
  rho' / (1 - rho'), delta = P_D P_G - P_D l / lambda for the contact the
  track reports, P_D P_G without one; JPDA's reported contact comes from
  JIPDA's joint events). At birth it is
  the prior odds that the initiator is a new target's detection rather than
  clutter, P_D beta_NT / rho_1 (`birth_log_odds`: beta_NT =
  ``new_targets_per_scan`` over the sensor's coverage area, rho_1 the clutter's
  area density at the initiator), times the two-point start's ratio above.
  Since the odds never exceed the prior odds times the likelihood ratio of
  the contacts, whose mean under clutter is at most 1, a clutter initiator
  reaches odds c / (1 - c) with probability at most (prior odds) (1 - c) / c
  (Ville's inequality), and the clutter's initiators per scan cancel the
  clutter density: at most nu P_D (1 - c) / c false confirmations per scan
  at any clutter density (nu = ``new_targets_per_scan``, c =
  ``existence_confirmation``). The survival caps the odds a scan carries over
  at s / (1 - s) (199 at 0.995), so c must lie below s (checked): a
  confirmed track's existence then stays above c on detections whose ratio
  exceeds about 2, whatever the clutter density. A preliminary track is
  confirmed at rho >= c and deleted once its log-odds falls ln(beta_p / (1
  - alpha)) below its maximum (the score rule's early deletion, relative: a
  newborn's existence is tiny); a confirmed track is deleted at rho <=
  ``existence_deletion`` (0.01). JPDA then weighs each track's events by its
  existence (`jipda_log_ratio`) and updates its state conditioned on
  existence.
* Sanity deletion (every contact tracker, whatever its
  confirmation rule): a live track is deleted when its reported state is
  impossible: faster than ``max_speed_m_s`` (2.5 v_max by default), outside every sensor's
  coverage by more than its gate (`outside_coverage_m` against
  `gate_radius_m`), or with a position standard deviation (the largest
  axis of its position covariance) beyond ``max_position_sd_m``.
  `sanity_reasons` gives each track's reason; the trackers count their
  deletions by reason (`DELETION_REASONS`) in ``tracker.deletions``.
* Track quality (a sanity rule for confirmed tracks): a confirmed track is
  deleted ("quality") when its gate is expected to hold more than
  ``max_gate_clutter`` clutter contacts, n_c = rho x pi gamma sqrt(det(P_xy +
  sigma^2 I)) (`gate_clutter`): rho the clutter's area density around the
  track (the scan's contacts in the square of half-side ``clutter_radius_m``
  around its predicted position, `nnda.tracking.clutter_density.local_density`,
  whichever clutter model the tracker associates with; with gnn's and jpda's
  ``clutter_estimate = "unexplained"`` the contacts there less the confirmed
  tracks' expected detections, `unexplained_density`, so that a coasting
  track's own target is not counted as clutter around it), gamma the tracker's
  chi-square gate, P_xy the reported position covariance and sigma the
  sensors' least noise (m). Why this bound: against clutter, a target's
  contact at Mahalanobis distance d has the likelihood ratio P_D l / lambda
  = P_D gamma exp(-d^2 / 2) / (2 n_c); over the target's contacts (E
  exp(-d^2 / 2) = 1/2 on 2 dof) its mean is P_D gamma / (4 n_c), which falls
  below 1 (the target's own contact no likelier the target's than a clutter
  contact: the association can no longer tell them apart) at n_c = P_D gamma
  / 4 = 2.07 for P_D = 0.9 and gamma = 9.21; hence the default 2. The bound
  is relative to the gate and the clutter, not a size: with 1,000 contacts
  per scan over a 34 km square it deletes a confirmed track of round position
  covariance past about 280 m sd, with 100 over the presets' 16.6 km square
  past about 440 m, and where clutter is sparse only ``max_position_sd_m``
  bites. The other form, the gate's radius against the distance to the
  nearest confirmed track, is not used: at a crossing it meets the targets'
  own tracks, which JPDA keeps apart by design (S1 at 1,000 clutter, one
  run: 12 of 239 target-contact reports would meet it at half the distance,
  none this rule). The reported covariance (after the update, not the next
  prediction) and the least noise taken round give a lower bound on the next
  gate, so the rule errs towards keeping a track.
"""

from __future__ import annotations

import functools
import math
from typing import Annotated, Literal

import numba
import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from nnda.data.scenario import Sensor
from nnda.data.sensor import TWO_PI
from nnda.filters.imm_kernels import wrap_angle_kernel
from nnda.tracking.clutter_density import MAX_CELLS_PER_AXIS, contact_cells
from nnda.tracking.output import CONFIRMED, DELETED, PRELIMINARY


class LifecycleConfig(BaseModel):
    """Initiation window, confirmation and deletion. The window and the M/N counts are those of Vargas Avila
    (2015)'s proposed (neural) method, Sec. 5.3 and 5.5; its rule is ``confirmation = "mn"``
    (`THESIS_LIFECYCLE`). The default rule is the clutter-adaptive score test ("adaptive"), which keeps the
    false tracks at a rate per area and time whatever the clutter density."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    v_min: Annotated[float, Field(ge=0, description="slowest target (m/s) for the initiation window")] = 70.0
    v_max: Annotated[float, Field(gt=0, description="fastest target (m/s) for the initiation window")] = 200.0
    m: Annotated[int, Field(ge=1, description="detections that confirm a preliminary track")] = 3
    n: Annotated[int, Field(ge=1, description="scans of the M/N window")] = 4
    max_misses: Annotated[int, Field(ge=0, description="consecutive misses a confirmed track survives")] = 3
    max_tracks_per_initiator: Annotated[int | None, Field(
        ge=1, description="at most this many preliminary tracks per initiator, those whose implied "
        "speed is nearest the window's middle (a rule Vargas Avila (2015), Ch. 2, mentions but does not use; "
        "None = off)")] = None
    max_tracks: Annotated[int, Field(
        ge=1, description="live tracks (preliminary and confirmed; for MHT, track families) at most: past "
        "it, a scan opens only as many new tracks as there is room for, those whose implied speed is "
        "nearest the window's middle, with a BoundWarning. Bounds memory and time when clutter is far "
        "denser than the window was made for")] = 10_000
    confirmation: Literal["adaptive", "mn", "score", "existence"] = Field(
        "adaptive", description="how preliminary tracks are confirmed and tracks deleted: 'adaptive' (Wald's "
        "test on the track score, each track's confirmation threshold from the clutter density where it was "
        "born and false_track_rate; deletion as 'score'), 'mn' (M/N counts, max_misses; the rule of Vargas "
        "Avila (2015)), 'score' (Wald's test on the track score, thresholds from false_confirmation and "
        "false_deletion) or 'existence' (IPDA / JIPDA: the probability of target existence, its log-odds "
        "against the same thresholds; not for MHT)")
    false_track_rate: Annotated[float, Field(
        gt=0, description="adaptive rule: phi, the false tracks per hour per 1,000 km^2 of coverage the "
        "confirmation allows in expectation (at most; each track confirms at Wald's threshold for alpha = "
        "phi T / rho, rho the clutter's area density where it was born, T the scan period)")] = 2.0
    dense_clutter_per_km2: Annotated[float, Field(
        gt=0, description="adaptive rule: clutter contacts per km^2 per scan at and above which a confirmed track "
        "is deleted at the score rule's false_deletion; where it was born in sparser clutter its beta falls in "
        "proportion (down to false_deletion / 100): a track that has lost its target takes clutter in "
        "proportion to the clutter's density, so in sparse clutter it can afford to wait longer for a "
        "manoeuvring or fading target")] = 1.0
    survival_probability: Annotated[float, Field(
        gt=0, le=1, description="existence rule: probability that a target exists still at the next scan "
        "(the Markov chain of IPDA)")] = 0.995
    existence_confirmation: Annotated[float, Field(
        gt=0, lt=1, description="existence rule: c, a preliminary track is confirmed at this existence "
        "probability; below survival_probability, the cap a scan carries over. At most new_targets_per_scan "
        "P_D (1 - c) / c false confirmations per scan are expected")] = 0.99
    new_targets_per_scan: Annotated[float, Field(
        gt=0, description="existence rule: nu, targets expected to appear per scan in a sensor's coverage; "
        "an initiator's prior existence odds are P_D nu / (coverage area x clutter density there)")] = 0.05
    existence_deletion: Annotated[float, Field(
        gt=0, lt=1, description="existence rule: a track is deleted at this existence probability")] = 0.01
    false_confirmation: Annotated[float, Field(
        gt=0, lt=1, description="score rule: alpha, the probability of confirming a track of clutter")] = 1e-6
    false_deletion: Annotated[float, Field(
        gt=0, lt=1, description="score rule: beta, the probability of deleting a target's track")] = 1e-3
    false_tracks_per_scan: Annotated[float | None, Field(
        gt=0, lt=1, description="score rule: r, the false confirmations per scan allowed: the tracks born "
        "from a scan's N initiators confirm at Wald's threshold for alpha = r / N instead of "
        "false_confirmation (`rate_threshold`); None: alpha = false_confirmation for every track")] = None
    preliminary_false_deletion: Annotated[float, Field(
        gt=0, lt=1, description="score rule: beta for preliminary tracks, whose deletion threshold is "
        "ln(beta / (1 - alpha)) with this beta: early deletion of the clutter-born ones, which rarely "
        "outlive a miss")] = 0.1
    max_speed_m_s: Annotated[float | None, Field(
        gt=0, description="delete a track whose estimated speed exceeds this (m/s), above v_max; None: "
        "2.5 v_max. A track of a real target is not that far off after a coast, while a coasting track "
        "that takes clutter absorbs the jump into its velocity and speeds up with every such step")] = None
    max_position_sd_m: Annotated[float | None, Field(
        gt=0, description="delete a track whose position standard deviation (largest axis of its position "
        "covariance) exceeds this (m; None: no limit)")] = 2_000.0
    max_gate_clutter: Annotated[float | None, Field(
        gt=0, description="track quality: delete a confirmed track whose gate is expected to hold more than this "
        "many clutter contacts (the local clutter density around it times its gate's area from its position "
        "covariance and the measurement noise): it can no longer tell its target's contact from clutter. At 2 "
        "the target's own contact is on average no likelier the target's than clutter (P_D x gate / 4 at P_D "
        "= 0.9 and the 9.21 gate); None: no such rule")] = 2.0
    quality_deletion: bool = Field(True, description="delete confirmed tracks by the track-quality rule "
                                   "(max_gate_clutter); False: no such rule, as in Vargas Avila (2015)")
    coverage_deletion: bool = Field(True, description="delete a track outside every sensor's coverage by more "
                                    "than its gate")
    report_existence: Annotated[float | None, Field(
        gt=0, lt=1, description="leave a confirmed track out of the output while the probability that its target "
        "still exists, after its misses in a row, is below this (`misses_to_hide`: from 1 at its last contact, "
        "each scan that misses it weighs it by survival_probability and 1 - P_D P_G), as the labelled trackers' "
        "report_existence does; the track lives on and is reported again, confirmed and with its id, at its next "
        "contact. None: every confirmed track is reported")] = None
    estimate_pd: bool = Field(True, description="under the score, adaptive and existence rules, learn the P_D of a "
                              "sensor for which neither the tracker's config nor the sensor gives one: the assumed "
                              "value lowered, never raised, to the detection record of the tracker's confirmed tracks "
                              "so far (`nnda.tracking.detection_probability.DetectionRecord`; GNN, JPDA, MHT and the "
                              "labelled trackers). Never under M/N, whose confirmed tracks are mostly "
                              "clutter's where clutter is dense. False: the assumed value throughout")
    report_gap_s: Annotated[float, Field(
        gt=0, description="asynchronous reports (a sensor with reports = true): the longest a track may go "
        "without a report (s) before each window's end counts as a miss for it (a report of one target says "
        "nothing of the others, so no other miss is counted), and how long an unused report waits for a later "
        "one to start a track with")] = 60.0

    @model_validator(mode="after")
    def _order(self) -> LifecycleConfig:
        if self.v_min >= self.v_max:
            raise ValueError("v_min must be below v_max")
        if self.m > self.n:
            raise ValueError("M/N needs m <= n")
        for alpha in ("false_confirmation", "false_tracks_per_scan"):
            for field in ("false_deletion", "preliminary_false_deletion"):
                total = (getattr(self, alpha) or 0.0) + getattr(self, field)
                if total >= 1:
                    raise ValueError(f"{alpha} + {field} = {total:g} must be below 1 (else the score test's "
                                     f"thresholds cross)")
        if self.existence_deletion >= self.existence_confirmation:
            raise ValueError("existence_deletion must be below existence_confirmation")
        if self.survival_probability < 1 and self.existence_confirmation >= self.survival_probability:
            raise ValueError(f"existence_confirmation = {self.existence_confirmation:g} must be below "
                             f"survival_probability = {self.survival_probability:g}: the survival caps the "
                             f"existence a scan carries over, and weak detections never reach the threshold")
        if self.speed_limit <= self.v_max:
            raise ValueError(f"max_speed_m_s = {self.max_speed_m_s} must exceed v_max = {self.v_max}: a track "
                             f"of the fastest target would be deleted")
        return self

    @property
    def speed_limit(self) -> float:
        """The speed (m/s) beyond which a track is deleted: ``max_speed_m_s``, or 2.5 v_max."""
        return self.max_speed_m_s if self.max_speed_m_s is not None else 2.5 * self.v_max

    @property
    def gate_clutter_bound(self) -> float | None:
        """The track-quality rule's bound on the clutter contacts expected in a confirmed track's gate, or None
        without the rule (``quality_deletion`` False or ``max_gate_clutter`` None)."""
        return self.max_gate_clutter if self.quality_deletion else None

    @property
    def score_thresholds(self) -> tuple[float, float]:
        """(deletion, confirmation) thresholds of the score rule (`sprt_thresholds`)."""
        return sprt_thresholds(self.false_confirmation, self.false_deletion)

    @functools.cached_property
    def score_limits(self) -> tuple[float, float, float]:
        """(lower, upper, early): `score_bounds`' thresholds shared by every track, worked out once (the scan
        loop asks each scan): the score rule's `score_thresholds` or, under the existence rule, the log-odds of
        ``existence_deletion`` and ``existence_confirmation``; and the preliminary tracks' deletion threshold."""
        if self.confirmation == "existence":  # thresholds on the existence probability's log-odds
            lower, upper = (math.log(p) - math.log1p(-p) for p in (self.existence_deletion,
                                                                   self.existence_confirmation))
        else:
            lower, upper = self.score_thresholds
        return lower, upper, sprt_thresholds(self.false_confirmation, self.preliminary_false_deletion)[0]

    def window_area(self, scan_period: float, sigma_range: float) -> float:
        """Area (m^2) of the initiation annulus (`window`)."""
        d_min, d_max = self.window(scan_period, sigma_range)
        return math.pi * (d_max**2 - d_min**2)

    def window(self, scan_period: float, sigma_range: float) -> tuple[float, float]:
        """(D_min, D_max) in m for the initiation annulus."""
        return (max(0.0, self.v_min * scan_period - 3 * sigma_range),
                self.v_max * scan_period + 3 * sigma_range)

    def fast_window(self, scan_period: float, sigma_range: float) -> tuple[float, float]:
        """(D_max, D_fast) in m: the annulus just beyond the initiation window where a target between v_max and
        2 v_max moves in a scan, D_fast = 2 v_max T + 3 sigma. Pairs there are refused only for ``v_max``;
        the initiation counts the lines they form (`fast_lines`)."""
        return self.window(scan_period, sigma_range)[1], 2 * self.v_max * scan_period + 3 * sigma_range


#: the life-cycle settings of Vargas Avila (2015) beyond the defaults: its M/N rule and no track-quality deletion
#: (the studies that reproduce the thesis pin them, e.g. ``params = {"lifecycle": THESIS_LIFECYCLE}``)
THESIS_LIFECYCLE: dict[str, str | bool] = {"confirmation": "mn", "quality_deletion": False}


#: why a track was deleted, the keys of ``tracker.deletions``: its confirmation test failed (a preliminary
#: track), its misses (M/N) or its score (score and adaptive rules) ended a confirmed track, a sanity rule
#: (sanity: speed, coverage, covariance, or a confirmed track's quality), or the score rule's cap on live tracks
#: dropped it for want of room
DELETION_REASONS = ("unconfirmed", "misses", "score", "speed", "coverage", "covariance", "quality", "capped")
#: codes of `sanity_reasons`: 0 sane, else 1 + the index of the reason in SANITY_REASONS
SANITY_REASONS = ("speed", "coverage", "covariance", "quality")


def sprt_thresholds(alpha: float, beta: float) -> tuple[float, float]:
    """Wald's thresholds (lower, upper) on a log-likelihood ratio for error probabilities alpha (accepting
    "target" for clutter) and beta (rejecting it for a target): ln(beta / (1 - alpha)), ln((1 - beta) / alpha)."""
    return math.log(beta / (1.0 - alpha)), math.log((1.0 - beta) / alpha)


def rate_threshold(rate: float, beta: float, trials: int) -> float:
    """Confirmation threshold of ``trials`` >= 1 independent starts of the test in one scan (its initiators)
    when at most ``rate`` false confirmations per scan are allowed: Wald's ln((1 - beta) / alpha) at
    alpha = rate / trials, that is ln((1 - beta) trials / rate)."""
    return math.log((1.0 - beta) * trials / rate)


#: square metres in 1,000 km^2 and seconds in an hour: ``false_track_rate``'s unit
_PER_1000_KM2_HOUR = 1e9 * 3600.0


@numba.njit(cache=True, nogil=True)
def adaptive_threshold(rate, beta, density, scan_period):
    """Confirmation thresholds (K,) of the adaptive rule (module docstring) for tracks born where the clutter's
    area density is ``density`` (m^-2 per scan, (K,) floats) from a sensor of scan period ``scan_period`` (s), at
    ``rate`` false tracks per hour per 1,000 km^2: Wald's ln((1 - beta) / alpha) at alpha = phi T / rho."""
    phi = rate / _PER_1000_KM2_HOUR  # m^-2 s^-1
    keep, rate_term = math.log1p(-beta), math.log(phi * scan_period)
    out = np.empty(density.size)
    for k in range(density.size):
        out[k] = keep + math.log(density[k]) - rate_term
    return out


def adaptive_deletion(cfg: LifecycleConfig, density: np.ndarray) -> np.ndarray:
    """Deletion thresholds (K,) of confirmed tracks under the adaptive rule (module docstring) for tracks born where
    the clutter's area density is ``density`` (m^-2 per scan, (K,) floats): ln(beta_k / (1 - alpha)), beta_k =
    ``false_deletion`` x min(1, density / ``dense_clutter_per_km2``), at least ``false_deletion`` / 100."""
    return deletion_threshold(cfg.false_deletion, cfg.false_confirmation, cfg.dense_clutter_per_km2, density)


@numba.njit(cache=True, nogil=True)
def deletion_threshold(beta, alpha, dense_per_km2, density):
    """`adaptive_deletion` from the config's ``false_deletion`` beta, ``false_confirmation`` alpha and
    ``dense_clutter_per_km2``, compiled (the scan step writes it for every new track)."""
    dense, keep = dense_per_km2 * 1e-6, math.log1p(-alpha)  # m^-2
    out = np.empty(density.size)
    for k in range(density.size):
        out[k] = math.log(beta * min(max(density[k] / dense, 0.01), 1.0)) - keep
    return out


@numba.njit(cache=True, nogil=True)
def start_score(pd, window_area, density):
    """Score of a two-point start (module docstring): ln(P_D / (A_w rho)) for the area densities of clutter
    ``density`` (m^-2, (K,) floats) at the second contacts and the initiation annulus' area A_w (m^2)."""
    log_pd = math.log(pd)
    out = np.empty(density.size)
    for k in range(density.size):
        out[k] = log_pd - math.log(window_area * density[k])
    return out


def birth_log_odds(pd: float, new_density: float, density: np.ndarray) -> np.ndarray:
    """Prior log-odds that initiators are new targets' detections, not clutter (existence rule, module
    docstring): ln(P_D beta_NT / rho_1) for the new-target density ``new_density`` beta_NT (m^-2 per scan)
    and the clutter's area densities ``density`` (m^-2, (K,)) at the initiators."""
    return math.log(pd * new_density) - np.log(density)


def advance_score(status: np.ndarray, score: np.ndarray, max_score: np.ndarray, cfg: LifecycleConfig,
                  observed: np.ndarray | None = None, confirm_at: np.ndarray | None = None,
                  delete_at: np.ndarray | None = None, consecutive: np.ndarray | None = None) -> np.ndarray:
    """One scan of the score rule for K tracks whose ``score`` (K,) is already this scan's (and ``max_score``
    its maximum so far): the new status (module docstring). A track not ``observed`` keeps its status.
    ``confirm_at`` (K,) is each track's confirmation threshold under ``false_tracks_per_scan`` or the adaptive
    rule (that of its birth, `rate_threshold`, `adaptive_threshold`); None: Wald's for
    ``false_confirmation``. ``delete_at`` (K,) is each confirmed track's deletion threshold under the
    adaptive rule (`adaptive_deletion`), and ``consecutive`` (K,) its misses in a row (this scan's included), of
    which it survives `miss_run`. One compiled loop over the tracks (`advance_score_kernel`)."""
    status = np.asarray(status)
    lower, upper, early = score_bounds(cfg, status.size, confirm_at, delete_at)
    run = miss_run(cfg)
    consecutive = np.zeros(status.size, np.int64) if consecutive is None else np.asarray(consecutive, np.int64)
    return advance_score_kernel(status, np.asarray(score, float), np.asarray(max_score, float),
                                everywhere(observed, status.size), upper, lower, early,
                                cfg.confirmation == "existence", consecutive, run)


def misses_to_hide(cfg: LifecycleConfig, pd_gated: float) -> int:
    """The misses in a row after which a confirmed track is left out of the output (``report_existence``), for a
    sensor that detects a target inside the gate with probability ``pd_gated`` (P_D P_G): the least n with r_n
    below the threshold, where r_0 = 1 (the track's last contact was its target's) and a missed scan predicts
    r by the survival probability p_S and updates it as IPDA does, r' = (1 - P_D P_G) p_S r / (1 - P_D P_G p_S
    r). 2^62 (never) without the rule, or where r never falls below it (p_S = 1 and P_D P_G = 0)."""
    threshold, survival = cfg.report_existence, cfg.survival_probability
    if threshold is None:
        return 2**62
    r = 1.0
    for n in range(1, 10_000):
        r = (1.0 - pd_gated) * survival * r / (1.0 - pd_gated * survival * r)
        if r < threshold:
            return n
    return 2**62


def miss_run(cfg: LifecycleConfig) -> int:
    """The consecutive misses a confirmed track survives whatever its score under ``cfg``'s rule: ``max_misses``
    under the adaptive rule (module docstring), no bound (2^62) under the others."""
    return cfg.max_misses if cfg.confirmation == "adaptive" else 2**62


def score_bounds(cfg: LifecycleConfig, K: int, confirm_at: np.ndarray | None = None,
                 delete_at: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """The thresholds of `advance_score` for K tracks: (lower (K,), upper (K,), early), on the score (Wald's,
    ``confirm_at`` (K,) the upper one per track when given, and under the adaptive rule ``delete_at`` (K,)
    the lower one) or under the existence rule on the existence's log-odds; early is the preliminary tracks'
    deletion threshold."""
    lower, upper, early = cfg.score_limits
    if cfg.confirmation != "existence":
        if confirm_at is not None:
            upper = confirm_at
        if delete_at is not None and cfg.confirmation == "adaptive":
            lower = delete_at
    return _per_track(lower, K), _per_track(upper, K), early


def _per_track(value: float | np.ndarray, K: int) -> np.ndarray:
    """A threshold for each of K tracks, (K,) floats, contiguous (a column of the scores is not: a kernel given
    both kinds would be compiled twice)."""
    return np.ascontiguousarray(value, float) if np.ndim(value) else np.full(K, float(value))


@numba.njit(cache=True, nogil=True)
def advance_score_kernel(status, score, max_score, observed, upper, lower, early, exist, consecutive, run):
    """`advance_score`'s loop over K tracks, all arrays (K,) but ``early``: a preliminary track is confirmed at
    ``upper``
    and then deleted where its score (existence: its log-odds' fall from the maximum) is at most ``early``; a
    confirmed track is deleted where its score's fall from the maximum (existence: its log-odds) is at most
    ``lower``, or whose ``consecutive`` misses exceed ``run``; a track not ``observed`` keeps its status."""
    new = status.copy()
    for k in range(status.size):
        if not observed[k]:
            continue
        # a confirmed track's score falls from its maximum, its existence (log-odds) to the threshold itself;
        # a preliminary track's score to the threshold itself, its existence from its maximum
        fallen = score[k] - max_score[k]
        if status[k] == PRELIMINARY:
            if score[k] >= upper[k]:
                new[k] = CONFIRMED
            if (fallen if exist else score[k]) <= early:
                new[k] = DELETED
        elif status[k] == CONFIRMED and ((score[k] if exist else fallen) <= lower[k] or consecutive[k] > run):
            new[k] = DELETED
    return new


def everywhere(observed: np.ndarray | None, K: int) -> np.ndarray:
    """``observed`` (K,) as a boolean array; None: every track observed."""
    return np.ones(K, np.bool_) if observed is None else np.asarray(observed, np.bool_)


def predicted_log_odds(log_odds: np.ndarray, survival: float) -> np.ndarray:
    """IPDA's prediction of the existence probability, rho' = survival rho, on log-odds ln(rho / (1 - rho)),
    kept within +-700 (a certain track stays finite)."""
    rho = survival * existence(log_odds)
    with np.errstate(divide="ignore"):
        return np.clip(np.log(rho) - np.log1p(-rho), -700.0, 700.0)


def existence(log_odds: np.ndarray) -> np.ndarray:
    """The probability rho of the log-odds ln(rho / (1 - rho))."""
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(log_odds, float)))


def jipda_log_ratio(log_ratio: np.ndarray, log_miss: float, rho: np.ndarray) -> np.ndarray:
    """JIPDA's event terms in JPDA's form (Musicki & Evans 2004): a track of predicted existence ``rho`` (P,)
    (one per pair) weighs a contact rho P_D l / lambda and no contact 1 - P_D P_G rho; divided by
    (1 - P_D P_G rho) / (1 - P_D P_G), which leaves every track's marginals as they are, its no-contact term
    is JPDA's exp(``log_miss``) and its pairs' ``log_ratio`` (ln(P_D l / lambda)) move by ln rho -
    ln(1 - P_D P_G rho) + log_miss: exactly 0 at rho = 1, where JIPDA is JPDA."""
    miss = -np.expm1(log_miss)  # P_D P_G
    return log_ratio + (np.log(rho) - np.log1p(-miss * rho) + log_miss)


def position_sd(P: np.ndarray) -> np.ndarray:
    """Standard deviation (m) along the largest axis of the position covariance of states' covariances
    P (K, 4, 4) ([x, vx, y, vy]). Returns (K,)."""
    P = np.asarray(P, float)
    return _each(_position_sd, P, np.empty((0, 0)), 0.0, 0.0)


def outside_coverage_m(sensor: Sensor, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """How far (m) positions (x, y) in m (arrays of one shape) lie outside ``sensor``'s coverage (0 inside):
    the range beyond its range limits and, for a sector, the cross-range distance beyond its edges,
    combined."""
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    xy = np.stack([x.ravel(), y.ravel()], axis=-1)
    return _each(_outside_m, xy, _coverage((sensor,)), 0.0, 0.0).reshape(x.shape)


def gate_radius_m(P: np.ndarray, noise_m: float, gate: float) -> np.ndarray:
    """Radius (m) of a chi-square ``gate`` around states of covariance P (K, 4, 4): sqrt(gate) times the
    largest position standard deviation combined with the measurement noise ``noise_m`` (m)."""
    return _each(_gate_radius_m, np.asarray(P, float), np.empty((0, 0)), float(noise_m), float(gate))


def gate_clutter(P: np.ndarray, density: np.ndarray, noise_m: float, gate: float) -> np.ndarray:
    """Clutter contacts expected inside the chi-square ``gate`` (2 dof) of K states of covariance P (K, 4, 4)
    where the clutter's area density is ``density`` (K,) m^-2: density x pi gate sqrt(det(P_xy + noise_m^2 I)),
    P_xy the position block (the track-quality rule's n_c, module docstring). Returns (K,)."""
    P = np.asarray(P, float)
    density = np.broadcast_to(np.asarray(density, float), P.shape[:1])
    return _gate_clutter(P, np.ascontiguousarray(density), float(noise_m), float(gate))


def sanity_reasons(x: np.ndarray, P: np.ndarray, sensors: tuple[Sensor, ...], gate: float,
                   cfg: LifecycleConfig, density: np.ndarray | None = None) -> np.ndarray:
    """Which of K track states x (K, 4), P (K, 4, 4) are impossible, and why: (K,) int8 codes, 0 for a
    sane track, else 1 + the index in SANITY_REASONS of the first rule it breaks (module docstring).
    ``gate`` is the tracker's chi-square gate (2 dof) for the coverage and quality rules; ``density`` (K,)
    the clutter's area density (m^-2) around each track the quality rule judges (the confirmed ones; 0 for
    the others), None: no quality rule. One compiled loop over the tracks (`sanity_kernel`)."""
    x, P = np.asarray(x, float), np.asarray(P, float)
    density = np.zeros(x.shape[0]) if density is None else np.broadcast_to(np.asarray(density, float), x.shape[:1])
    return sanity_kernel(x, P, np.ascontiguousarray(density), *sanity_args(sensors, gate, cfg))


def sanity_args(sensors: tuple[Sensor, ...], gate: float, cfg: LifecycleConfig) -> tuple:
    """`sanity_kernel`'s settings after x, P and the clutter density: the sensors' coverage (`_coverage`), their
    least noise (m), the gate, whether the coverage rule applies, the largest position sd (m; inf: no limit),
    the speed limit (m/s) and the clutter contacts a confirmed track's gate may hold (inf: no quality rule)."""
    max_sd = math.inf if cfg.max_position_sd_m is None else cfg.max_position_sd_m
    max_clutter = math.inf if cfg.gate_clutter_bound is None else cfg.gate_clutter_bound
    return (_coverage(tuple(sensors)), min(sensor_noise_m(s) for s in sensors), float(gate), cfg.coverage_deletion,
            max_sd, cfg.speed_limit, max_clutter)


@functools.cache
def _coverage(sensors: tuple[Sensor, ...]) -> np.ndarray:
    """(S, 7) the coverage of each sensor as `_outside_m` reads it: position x, y (m), range limits (m), 1 for
    a full circle (else 0), boresight and half field of view (rad)."""
    return np.array([[*s.position, s.min_range_m, s.max_range_m, float(s.full_circle), s.boresight_rad,
                      s.half_fov_rad] for s in sensors])


_kernel = numba.njit(cache=True, nogil=True)


@_kernel
def _position_sd(P, k, coverage, noise_m, gate):
    """`position_sd` of track k of P (K, 4, 4)."""
    a, b, c = P[k, 0, 0], P[k, 0, 2], P[k, 2, 2]
    v = 0.5 * (a + c) + math.hypot(0.5 * (a - c), b)
    return math.sqrt(0.0 if v < 0.0 else v)


@_kernel
def _gate_radius_m(P, k, coverage, noise_m, gate):
    """`gate_radius_m` of track k of P (K, 4, 4)."""
    sd = _position_sd(P, k, coverage, noise_m, gate)
    return math.sqrt(gate * (sd * sd + noise_m * noise_m))


@_kernel
def _outside_m(xy, k, coverage, noise_m, gate):
    """`outside_coverage_m` of position k of xy (K, 2) m: the least over the sensors' ``coverage`` (S, 7)
    (`_coverage`)."""
    least = math.inf
    for s in range(coverage.shape[0]):
        ox, oy, min_r, max_r, full, boresight, half_fov = coverage[s]
        px, py = xy[k, 0] - ox, xy[k, 1] - oy
        r = math.hypot(px, py)
        along = max(min_r - r, r - max_r)
        along = 0.0 if along < 0.0 else along
        if full == 0.0:
            beyond = abs(wrap_angle_kernel(math.atan2(px, py) % TWO_PI - boresight)) - half_fov
            beyond = 0.0 if beyond < 0.0 else min(beyond, 0.5 * math.pi)
            along = math.hypot(along, r * math.sin(beyond))
        least = min(least, along)
    return least


@_kernel
def _each(one, a, coverage, noise_m, gate):
    """``one(a, k, coverage, noise_m, gate)`` for every k of a's first axis, (K,)."""
    out = np.empty(a.shape[0])
    for k in range(a.shape[0]):
        out[k] = one(a, k, coverage, noise_m, gate)
    return out


@_kernel
def _gate_area(P, k, noise_m, gate):
    """Area (m^2) of the chi-square ``gate`` ellipse of track k of P (K, 4, 4) with the measurement noise
    ``noise_m`` (m) on both axes: pi gate sqrt(det(P_xy + noise_m^2 I))."""
    n2 = noise_m * noise_m
    a, b, c = P[k, 0, 0] + n2, P[k, 0, 2], P[k, 2, 2] + n2
    det = a * c - b * b
    return math.pi * gate * math.sqrt(det if det > 0.0 else 0.0)


@_kernel
def _gate_clutter(P, density, noise_m, gate):
    """`gate_clutter`'s loop over the K tracks of P (K, 4, 4), density (K,)."""
    out = np.empty(P.shape[0])
    for k in range(P.shape[0]):
        out[k] = density[k] * _gate_area(P, k, noise_m, gate)
    return out


@_kernel
def sanity_kernel(x, P, density, coverage, noise_m, gate, coverage_deletion, max_sd, speed_limit, max_clutter):
    """`sanity_reasons`' loop over K tracks x (K, 4), P (K, 4, 4): the coverage rule against the sensors'
    ``coverage`` (S, 7) (`_coverage`), then the position standard deviation against ``max_sd`` (m; inf: no
    limit), then the track quality: the clutter expected in the gate at the area ``density`` (K,) m^-2 (0:
    not judged) against ``max_clutter``; then the speed against ``speed_limit`` (m/s), which overrides the
    other three."""
    K = x.shape[0]
    code = np.zeros(K, np.int8)
    xy = x[:, 0:3:2]
    for k in range(K):
        if coverage_deletion and _outside_m(xy, k, coverage, 0.0, 0.0) > _gate_radius_m(P, k, coverage, noise_m, gate):
            code[k] = 2
        if code[k] == 0 and _position_sd(P, k, coverage, noise_m, gate) > max_sd:
            code[k] = 3
        if code[k] == 0 and density[k] > 0.0 and density[k] * _gate_area(P, k, noise_m, gate) > max_clutter:
            code[k] = 4
        if math.hypot(x[k, 1], x[k, 3]) > speed_limit:
            code[k] = 1
    return code


def sensor_noise_m(sensor: Sensor) -> float:
    """The sensor's noise along a distance (m): range noise (polar), or position noise."""
    return sensor.sigma_range_m if sensor.kind == "polar" else sensor.sigma_position_m


def window_pairs(initiators: np.ndarray, contacts: np.ndarray, d_min: float, d_max: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """All (initiator, contact) index pairs whose distance lies in [d_min, d_max].

    ``initiators`` (I, 2) and ``contacts`` (J, 2) are Cartesian positions in m.
    Returns two int64 arrays of equal length, sorted by initiator then contact.
    The contacts are bucketed by their square cell about ``d_max`` wide (a
    spatial hash), and each initiator tests only those of its own cell and
    the 8 around it, in one compiled loop (`_cell_pairs`): the work grows
    linearly with the contacts at a given density, whatever the coverage's
    extent.
    """
    return free_window_pairs(initiators, contacts, np.zeros(len(contacts), np.bool_), d_min, d_max)[1:]


def free_window_pairs(initiators: np.ndarray, contacts: np.ndarray, used: np.ndarray, d_min: float, d_max: float
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`window_pairs` of the ``initiators`` (I, 2) with the ``contacts`` (N, 2) m that no track ``used`` (N,),
    in one compiled call: the free contacts' indices (F,) ascending, and the pairs (i, j) (P,), j indexing
    them."""
    return sweep_pairs(initiators, contacts, used, d_min, d_max, d_max)[:3]


def sweep_pairs(initiators: np.ndarray, contacts: np.ndarray, used: np.ndarray, d_min: float, d_max: float,
                d_fast: float) -> tuple[np.ndarray, ...]:
    """`free_window_pairs` and, from the same search, the pairs (fi, fj) (Q,) whose distance lies in (d_max,
    d_fast] (`LifecycleConfig.fast_window`: those `fast_lines` continues; none for d_fast = d_max): (free, i,
    j, fi, fj), each sorted by initiator then contact."""
    return free_pairs_kernel(np.ascontiguousarray(initiators, float), np.ascontiguousarray(contacts, float),
                             np.asarray(used, np.bool_), float(d_min), float(d_max), float(d_fast),
                             search_reach(d_max, d_fast))


def search_reach(d_max: float, d_fast: float) -> float:
    """The cell side (m) of `sweep_pairs`' search out to the larger of ``d_max`` and ``d_fast``: a margin over it
    keeps rounding at the cells' edges from dropping a pair."""
    reach = max(d_max, d_fast)
    return reach + 1e-6 * (1.0 + reach)


@numba.njit(cache=True, nogil=True)
def free_pairs_kernel(initiators, contacts, used, d_min, d_max, d_fast, reach):
    """`sweep_pairs`: the free contacts, then `_cell_pairs` with them out to ``d_fast`` (none without
    initiators), split at ``d_max``."""
    free = np.flatnonzero(~used)
    none = np.empty(0, np.int64)
    if not initiators.shape[0] or not free.size:
        return free, none, none, none, none
    xy = contacts[free]
    i, j = _cell_pairs(initiators, xy, d_min, max(d_max, d_fast), reach)
    window = np.empty(i.size, np.bool_)
    hi2 = d_max * d_max
    for p in range(i.size):  # the distance as `_cell_pairs` computes it
        dx = initiators[i[p], 0] - xy[j[p], 0]
        dy = initiators[i[p], 1] - xy[j[p], 1]
        window[p] = dx * dx + dy * dy <= hi2
    return free, i[window], j[window], i[~window], j[~window]


@numba.njit(cache=True, nogil=True)
def _bucket(ix, iy, mask):
    """The hash table bucket of the cell (ix, iy): Teschner et al. (2003)'s spatial hash, ``mask`` + 1 buckets (a
    power of two)."""
    return ((ix * 73856093) ^ (iy * 19349663)) & mask


#: `_cell_pairs` counts its contacts into a table of every cell of their grid while the grid has at most
#: _DENSE_PER_CONTACT cells a contact plus _DENSE_FLOOR (a scan's contacts over its coverage), else into a hash
#: table (contacts spread thinly over a wide area, where a table of every cell would cost more than the contacts)
_DENSE_PER_CONTACT, _DENSE_FLOOR = 4, 4_096


@numba.njit(cache=True, nogil=True)
def _cell_pairs(initiators, contacts, d_min, d_max, reach):
    """`window_pairs`' loop: the contacts counted (a counting sort: contact order within a cell) by their square
    cell of side ``reach`` (> d_max; doubled while an axis would have more than
    `clutter_density.MAX_CELLS_PER_AXIS`; `clutter_density.contact_cells`), into a table of every cell of the grid
    while it is small against the contacts (`_DENSE_PER_CONTACT`), else into a hash table of 2 to 4 buckets a
    contact (`_bucket`), so the grid's extent costs nothing; per initiator, the contacts of its cell and the 8
    around it (three runs of the table, one per column of cells, or each distinct bucket once) whose squared
    distance lies in [d_min^2, d_max^2], in contact order. Costs O(N) plus, per initiator, a few look-ups and the
    contacts of its cells (and of the cells sharing their buckets): linear in the contacts at a given density."""
    n = contacts.shape[0]
    lo0, hi0, lo1, hi1 = contacts[0, 0], contacts[0, 0], contacts[0, 1], contacts[0, 1]
    for b in range(1, n):
        lo0, hi0 = min(lo0, contacts[b, 0]), max(hi0, contacts[b, 0])
        lo1, hi1 = min(lo1, contacts[b, 1]), max(hi1, contacts[b, 1])
    cell = reach
    while max(hi0 - lo0, hi1 - lo1) / cell > MAX_CELLS_PER_AXIS:
        cell *= 2.0
    n0, n1 = int((hi0 - lo0) // cell) + 1, int((hi1 - lo1) // cell) + 1
    dense = n0 * n1 <= _DENSE_PER_CONTACT * n + _DENSE_FLOOR
    size = n0 * n1 if dense else 64
    while not dense and size < 2 * n:
        size *= 2
    mask = size - 1
    ix, iy = contact_cells(contacts, lo0, lo1, cell)
    key = np.empty(n, np.int64)
    for b in range(n):
        key[b] = ix[b] * n1 + iy[b] if dense else _bucket(ix[b], iy[b], mask)
    start = np.zeros(size + 1, np.int64)
    for b in range(n):
        start[key[b] + 1] += 1
    for k in range(size):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    order = np.empty(n, np.int64)
    for b in range(n):
        order[fill[key[b]]] = b
        fill[key[b]] += 1
    n_init = len(initiators)
    # per initiator, the non-empty runs [first, last) of ``order`` holding its 3 x 3 cells' contacts (-1: no more)
    first = np.full((n_init, 9), -1, np.int64)
    last = np.empty((n_init, 9), np.int64)
    most = 0
    for a in range(n_init):
        u, v = (initiators[a, 0] - lo0) // cell, (initiators[a, 1] - lo1) // cell  # as `contact_cells`
        if not (-1.0 <= u <= n0 and -1.0 <= v <= n1):
            continue
        k = 0
        v0, v1 = max(int(v) - 1, 0), min(int(v) + 1, n1 - 1)
        for cx in range(max(int(u) - 1, 0), min(int(u) + 1, n0 - 1) + 1):
            if dense:  # the column's cells v0..v1 are one run of the table
                if start[cx * n1 + v1 + 1] > start[cx * n1 + v0]:
                    first[a, k], last[a, k] = start[cx * n1 + v0], start[cx * n1 + v1 + 1]
                    most += last[a, k] - first[a, k]
                    k += 1
                continue
            for cy in range(v0, v1 + 1):
                h = _bucket(cx, cy, mask)
                seen = start[h + 1] == start[h]  # empty; else its run's start names the bucket
                for t in range(k):  # a bucket two cells share, once (a loop: ``in`` builds a mask per test)
                    seen |= first[a, t] == start[h]
                if not seen:
                    first[a, k], last[a, k] = start[h], start[h + 1]
                    most += last[a, k] - first[a, k]
                    k += 1
    i = np.empty(most, np.int64)
    j = np.empty(most, np.int64)
    lo2, hi2 = d_min * d_min, d_max * d_max
    m = 0
    for a in range(n_init):
        begin = m
        for k in range(9):
            if first[a, k] < 0:
                break
            for t in range(first[a, k], last[a, k]):
                b = order[t]
                dx = initiators[a, 0] - contacts[b, 0]
                dy = initiators[a, 1] - contacts[b, 1]
                d2 = dx * dx + dy * dy
                if lo2 <= d2 <= hi2:
                    i[m], j[m] = a, b
                    m += 1
        if m - begin > 1:
            j[begin:m] = np.sort(j[begin:m])
    return i[:m], j[:m]


def fast_tolerance_m(sigma: float, scan_period: float) -> float:
    """Radius (m) around a line's extrapolation b + (b - a) within which a third contact continues a refused fast
    pair (a, b) (`fast_lines`): 3 sqrt(6) sigma, the three contacts' noise on the second difference, plus
    the drift of a 2 g manoeuvre over the scan period T, 2 g T^2."""
    return 3.0 * math.sqrt(6.0) * sigma + 2.0 * 9.81 * scan_period**2


#: a line of refused fast pairs counts (`fast_lines`) once the chance that clutter lined it up falls below
#: exp(-FAST_LINE_EVIDENCE) = 1/1000, and it holds at least `FAST_LINE_CONTACTS` contacts
FAST_LINE_EVIDENCE = math.log(1000.0)
FAST_LINE_CONTACTS = 4


def fast_lines(initiators: np.ndarray, contacts: np.ndarray, free: np.ndarray, spoken: np.ndarray, lines: tuple,
               d_max: float, d_fast: float, tol: float, dt: float, pairs: tuple | None = None) -> tuple[int, tuple]:
    """One scan of the lines of refused fast pairs: the pairs (initiator, free contact) of the ``initiators``
    (I, 2) and the ``free`` (F,) of the ``contacts`` (N, 2) m whose distance lies in (d_max, d_fast]
    (`LifecycleConfig.fast_window`), each continuing the ``lines`` of the scan before (``dt`` s earlier) of its
    initiator whose extrapolation its contact lies within ``tol`` m of (`fast_tolerance_m`).

    A line's evidence is -ln of the chance that clutter continued it so: each continuation adds -ln min(1, n pi
    tol^2 / A), n the refused pairs of its initiator (the contacts of the annulus of area A around it: the local
    clutter, the line's own contact included) and pi tol^2 the area a continuing contact falls in. A line counts
    once its evidence reaches `FAST_LINE_EVIDENCE` with at least `FAST_LINE_CONTACTS` contacts: in S1-S6's clutter
    (100 contacts a scan over a 16.6 km square or more, T = 2 s, sigma = 30 m: one pair per initiator adds 1.8)
    six contacts in line, where clutter is ten times denser (about 6 pairs per initiator) never.

    Returns the contacts that complete a line (each counted once) and the lines to continue at the next scan:
    those whose contact is not ``spoken`` (F,) for by a window (it becomes an initiator), as (initiator index
    (L,) among the next initiators, ascending; position (L, 2) m; velocity (L, 2) m/s; contacts in line (L,);
    evidence (L,); counted already (L,)). ``lines`` starts as `no_lines`. ``pairs`` (fi, fj) are those pairs
    when `sweep_pairs` found them already with the window's (``free`` ascending); None: searched here. One
    compiled call (`fast_lines_kernel`)."""
    initiators, contacts = np.ascontiguousarray(initiators, float), np.ascontiguousarray(contacts, float)
    if pairs is None:  # the free contacts (ascending) are those no track used
        used = np.ones(len(contacts), np.bool_)
        used[free] = False
        pairs = sweep_pairs(initiators, contacts, used, d_max, d_max, d_fast)[3:]
    return fast_lines_kernel(initiators, contacts, free, spoken, *pairs, *lines, float(d_max), float(tol), float(dt),
                             fast_share(d_max, d_fast, tol), FAST_LINE_EVIDENCE, FAST_LINE_CONTACTS)


def fast_share(d_max: float, d_fast: float, tol: float) -> float:
    """pi tol^2 / A: the share of the fast annulus (d_max, d_fast] m, of area A, in which a contact continuing a
    line falls (`fast_lines`)."""
    return math.pi * tol * tol / (math.pi * (d_fast * d_fast - d_max * d_max))


def no_lines() -> tuple:
    """`fast_lines`' lines before a sensor's first scan: none."""
    return (np.empty(0, np.int64), np.empty((0, 2)), np.empty((0, 2)), np.empty(0, np.int64), np.empty(0),
            np.empty(0, np.bool_))


@numba.njit(cache=True, nogil=True)
def fast_lines_kernel(initiators, contacts, free, spoken, i, j, after, at, velocity, length, evidence, told, d_max,
                      tol, dt, share, enough, contacts_min):
    """`fast_lines`: the pairs (i, j) over (d_max, d_fast] (`sweep_pairs`), each matched against the lines of its
    initiator (``after`` ascending), in one pass; of the lines a pair continues, the one of most evidence."""
    if not initiators.shape[0] or not free.size:
        return 0, (np.empty(0, np.int64), np.empty((0, 2)), np.empty((0, 2)), np.empty(0, np.int64), np.empty(0),
                   np.empty(0, np.bool_))
    xy = contacts[free]
    rank = np.cumsum(~spoken) - 1  # a free contact's index among the next initiators
    tol2, lo2 = tol * tol, d_max * d_max
    beyond = np.zeros(i.size, np.bool_)
    per = np.zeros(initiators.shape[0], np.int64)  # refused pairs per initiator
    for p in range(i.size):
        dx, dy = xy[j[p], 0] - initiators[i[p], 0], xy[j[p], 1] - initiators[i[p], 1]
        if dx * dx + dy * dy > lo2:  # on the window's edge: the window takes it
            beyond[p] = True
            per[i[p]] += 1
    done = np.zeros(free.size, np.bool_)
    inline = np.full(i.size, 2, np.int64)
    proof = np.zeros(i.size)
    counted = np.zeros(i.size, np.bool_)
    keep = np.zeros(i.size, np.bool_)
    q0 = 0
    for p in range(i.size):
        if not beyond[p]:
            continue
        a, b = i[p], j[p]
        gain = -math.log(min(1.0, per[a] * share))
        while q0 < after.size and after[q0] < a:
            q0 += 1
        q = q0
        while q < after.size and after[q] == a:
            ex, ey = xy[b, 0] - (at[q, 0] + velocity[q, 0] * dt), xy[b, 1] - (at[q, 1] + velocity[q, 1] * dt)
            if ex * ex + ey * ey <= tol2 and (inline[p] == 2 or evidence[q] + gain > proof[p]):
                inline[p], proof[p], counted[p] = length[q] + 1, evidence[q] + gain, told[q]
            q += 1
        if not counted[p] and proof[p] >= enough and inline[p] >= contacts_min:
            done[b] = True
            counted[p] = True
        if not spoken[b]:
            keep[p] = True
    k = np.flatnonzero(keep)
    k = k[np.argsort(rank[j[k]], kind="mergesort")]
    new_at = np.empty((k.size, 2))
    new_v = np.empty((k.size, 2))
    for t in range(k.size):
        a, b = i[k[t]], j[k[t]]
        new_at[t, 0], new_at[t, 1] = xy[b, 0], xy[b, 1]
        new_v[t, 0], new_v[t, 1] = (xy[b, 0] - initiators[a, 0]) / dt, (xy[b, 1] - initiators[a, 1]) / dt
    return int(done.sum()), (rank[j[k]], new_at, new_v, inline[k], proof[k], counted[k])


@numba.njit(cache=True, nogil=True)
def _off_middle(i, j, initiators, contacts, d_min, d_max):
    """|distance - window middle| (m) of each window pair (i, j) (P,) of the initiators (I, 2) and contacts
    (N, 2) m, (P,)."""
    middle = 0.5 * (d_min + d_max)
    off = np.empty(i.size)
    for p in range(i.size):
        off[p] = abs(math.hypot(initiators[i[p], 0] - contacts[j[p], 0], initiators[i[p], 1] - contacts[j[p], 1])
                     - middle)
    return off


@numba.njit(cache=True, nogil=True)
def cap_per_initiator(i, j, initiators, contacts, d_min, d_max, cap):
    """Keep at most ``cap`` >= 1 of each initiator's window pairs (i, j (P,) sorted by i; of the initiators (I, 2)
    and contacts (N, 2) m): those whose distance is nearest the middle of [d_min, d_max] (ties: the earlier
    pair), each initiator's in that order; ``cap`` < 1 keeps every pair as it is (the config's None)."""
    if cap < 1 or i.size == 0:
        return i, j
    by_off = np.argsort(_off_middle(i, j, initiators, contacts, d_min, d_max), kind="mergesort")
    order = by_off[np.argsort(i[by_off], kind="mergesort")]  # by initiator, then off the middle, then position
    keep = np.empty(i.size, np.int64)
    m = 0
    for p in range(order.size):
        if p < cap or i[order[p - cap]] != i[order[p]]:  # fewer than cap pairs of its initiator before it
            keep[m] = order[p]
            m += 1
    return i[keep[:m]], j[keep[:m]]


@numba.njit(cache=True, nogil=True)
def cap_pairs(i, j, initiators, contacts, d_min, d_max, room):
    """Keep at most ``room`` >= 0 of all window pairs (i, j (P,) sorted by i, then j): those whose distance is
    nearest the middle of [d_min, d_max] (ties: the earlier pair), in their order."""
    if i.size <= room:
        return i, j
    keep = np.sort(np.argsort(_off_middle(i, j, initiators, contacts, d_min, d_max), kind="mergesort")[:room])
    return i[keep], j[keep]


def advance(status: np.ndarray, hits: np.ndarray, misses: np.ndarray, consecutive: np.ndarray,
            detected: np.ndarray, cfg: LifecycleConfig, observed: np.ndarray | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One scan of the M/N and deletion logic for a batch of tracks, all arrays (K,).

    ``hits``/``misses`` count detections and misses since the M/N test began
    (the scan after the track became preliminary); ``consecutive`` counts
    consecutive misses. Call once per scan for each existing preliminary or
    confirmed track. A track not ``observed`` (K,) by the scan (outside the
    coverage of the sensor that swept it; default: all observed) keeps its
    counters and status. Returns new (status, hits, misses, consecutive),
    from one compiled loop over the tracks (`advance_kernel`).
    """
    status = np.asarray(status)
    return advance_kernel(status, np.asarray(hits, np.int64), np.asarray(misses, np.int64),
                          np.asarray(consecutive, np.int64), np.asarray(detected, np.bool_),
                          everywhere(observed, status.size), cfg.m, cfg.n - cfg.m + 1, cfg.max_misses)


@numba.njit(cache=True, nogil=True)
def advance_kernel(status, hits, misses, consecutive, detected, observed, m, misses_to_delete, max_misses):
    """`advance`'s loop over K tracks, all arrays (K,): a preliminary track is confirmed at ``m`` hits and
    then deleted at ``misses_to_delete`` misses, a confirmed one (also one just confirmed) at more than
    ``max_misses`` consecutive misses; a track not ``observed`` keeps its status and counters."""
    status, hits, misses, consecutive = status.copy(), hits.copy(), misses.copy(), consecutive.copy()
    for k in range(status.size):
        if not observed[k]:
            continue
        if detected[k]:
            hits[k] += 1
            consecutive[k] = 0
        else:
            misses[k] += 1
            consecutive[k] += 1
        if status[k] == PRELIMINARY:
            if hits[k] >= m:
                status[k] = CONFIRMED
            if misses[k] >= misses_to_delete:
                status[k] = DELETED
        if status[k] == CONFIRMED and consecutive[k] > max_misses:
            status[k] = DELETED
    return status, hits, misses, consecutive
