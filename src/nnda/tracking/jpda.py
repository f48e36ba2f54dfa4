"""Joint probabilistic data association with the IMM (baseline; Fortmann, Bar-Shalom & Scheffe 1983).

Each scan:

1. **Gate** every contact against each track's IMM gating prediction (the
   combined state) with the chi-square gate (9.21 on 2 dof:
   P_G = 0.99) of the shared sparse gating (`nnda.tracking.gating.gate`,
   as GNN). From here on everything works on the list of gated
   (track, contact) pairs, never on a tracks x contacts array, so a scan
   costs in proportion to its gated pairs.
   Confirmed tracks associate first; preliminary tracks then share the
   contacts that no confirmed track reported (step 5), as in GNN, so a new
   track cannot take a confirmed target's contact.
2. **Clusters**: tracks that share gated contacts, directly or through other
   tracks, form a cluster (connected components of the track-contact gate
   graph); clusters are independent.
3. **Joint events**: every way of giving each track of a cluster at most one
   of its gated contacts, each contact to at most one track, is enumerated
   exactly (a track alone in its cluster takes the PDA closed form). An
   event's weight is the product over its tracks of P_D l_tj / lambda for a
   track given contact j and 1 - P_D P_G for a track given none, where l_tj
   is the IMM mixture likelihood of the contact (`IMM.pair_log_likelihood`,
   in (m, rad) measurement space) and lambda the clutter density in the
   same space. The marginal association probabilities beta_tj (and beta_t0,
   no detection) sum the normalised weights of the events holding each
   assignment.

   Beyond ``max_joint_events`` (partial) events listed for one cluster the
   enumeration stops and that cluster's marginals come from loopy belief
   propagation over the same weights (`nnda.tracking.marginals`, Williams &
   Lau 2014), which is exact on clusters without cycles and close otherwise;
   ``JPDATracker.n_approximated`` counts these clusters (``n_clusters`` all
   clusters) since the last reset.
4. **Update** (the IMM-JPDA variant implemented here): given the track's
   beta and each model's own likelihoods, Bayes' rule splits every
   association over the models: P(contact j, model m) = beta_tj
   mu_m l_mj / l_tj and P(no contact, model m) = beta_t0 mu_m (mu the
   predicted mode probabilities). Summing over associations gives the new
   mode probabilities (for an isolated track this is the IMM-PDAF of Houles
   & Bar-Shalom 1989: mu_m (1 - P_D P_G + P_D sum_j l_mj / lambda),
   normalised); dividing by them gives each model's own association
   probabilities, with which each model makes the PDA update of
   Bar-Shalom: the combined innovation, the covariance mixture of the
   updated and not-updated cases and the spread-of-innovations term.
5. **Reported contact**: the contact with the highest beta_tj when it beats
   beta_t0, else none (NO_CONTACT); under JIPDA both given that the target
   exists (a newborn of existence 1e-5 would otherwise never report, nor
   update on, its own target's contacts). It drives the M/N counters and the output; two
   tracks may report the same contact if it is the best of both. On a scan
   where no contact beats beta_t0 the framework counts a miss and keeps the
   track's last posterior, so that scan's soft update is dropped.

Track quality: the PDA update's spread-of-innovations term keeps a track that shares its gate with
clutter vague, and such a track grows until the absolute limit (``lifecycle.max_position_sd_m``, 2 km)
ends it; at 1,000 clutter contacts per scan under M/N, thousands of confirmed reports a run had a position
sd over 1 km. The framework's sanity step deletes a confirmed track, reason "quality", once its gate is
expected to hold more than ``lifecycle.max_gate_clutter`` (2) clutter contacts at the local clutter
density (`nnda.tracking.lifecycle.gate_clutter`, the module docstring there says why 2).

Under ``lifecycle.confirmation = "existence"`` this is JIPDA (Musicki &
Evans 2004): each track's event terms are weighed by its predicted
probability of existence rho (`nnda.tracking.lifecycle.jipda_log_ratio`:
rho P_D l / lambda for a contact, 1 - P_D P_G rho for none), the
no-contact marginal then holds "no target" too, and the reported contact
and the state update use the association probabilities given that the
target exists (`given_existence`). At rho = 1 it is the JPDA above. The
existence takes IPDA's ratio of the reported contact, 1 - P_D P_G + P_D l /
lambda (a miss's, 1 - P_D P_G, without one), as GNN's does: JIPDA's soft
ratio over every gated contact walks up on a vague clutter-born track,
whose gate holds ~100 contacts at 5,000 per scan, until it confirms (15 of
a clutter-only scene's tracks in 100 scans), as the score rule's did.

Clutter density lambda, in contacts per m per rad of measurement space
(``clutter_density``): a fixed value, ``"scan"`` (each scan's contact count
over the coverage, (r_max - r_min) x 2 pi: 6.4e-4 for 100 uniform contacts
over 5-30 km, the MHT's figure), or by default ``"local"``: at each gated
contact, the scan's contacts in the square of half-side ``clutter_radius_m``
(3 km, itself included) per unit area (`nnda.tracking.clutter_density`, as
the MHT uses), times the contact's range (an area density rho
is rho r in (range, azimuth)). The presets put their clutter in a 16.6 km
square around the targets, about 8 times denser there than the scan-wide
figure says, and a JPDA fed the scan-wide figure keeps tracks alive on
clutter after their targets leave.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal

import numba
import numpy as np
from pydantic import Field

from nnda.filters import imm_kernels
from nnda.filters.imm import IMMPrediction, IMMState
from nnda.filters.kalman import GATE_99
from nnda.tracking.clutter_density import measurement_volume
from nnda.tracking.gating import gate_tracks, stage_pairs
from nnda.tracking.lifecycle import existence, jipda_log_ratio
from nnda.tracking.marginals import jpda_marginals
from nnda.tracking.output import NO_CONTACT
from nnda.tracking.protocol import TrackerConfig
from nnda.tracking.single_hypothesis import SingleHypothesisConfig, SingleHypothesisTracker
from nnda.tracking.tracker import CLUTTER_ESTIMATE_DOC, ClutterEstimate, ScanContacts
from nnda.tracking.tracks import Association, Tracks

#: added to probabilities before a log or a division, so a model of probability 0 stays finite
_TINY = 1e-300


class JPDAConfig(SingleHypothesisConfig):
    """JPDA settings: gate, detection probability, clutter density and the enumeration cap."""

    gate: Annotated[float, Field(gt=0, description="chi-square gate, 2 dof (9.21: P_G = 0.99)")] = GATE_99
    pd: Annotated[float, Field(gt=0, le=1, description="detection probability used in the event "
                               "weights; left out: the scan's sensor's declared_pd, else 0.9 (as the MHT's "
                               "scores)")] = 0.9
    clutter_density: Annotated[float, Field(gt=0)] | Literal["local", "scan"] = Field(
        "local", description="clutter contacts per m per rad of measurement space, or how to estimate it "
        "from each scan: 'local' (around each contact) or 'scan' (whole coverage)")
    clutter_radius_m: Annotated[float, Field(gt=0, description="half-side (m) of the square of the "
                                "'local' clutter density estimate")] = 3_000.0
    clutter_estimate: ClutterEstimate = Field("local", description=CLUTTER_ESTIMATE_DOC)
    max_joint_events: Annotated[int, Field(ge=1, description="partial joint events listed per cluster "
                                "(summed over its tracks) before falling back to loopy belief "
                                "propagation (1,000: no cluster of S1-S6 at 100 clutter points a scan "
                                "reaches it; in denser clutter the listing's cost grows faster than the "
                                "clutter, and at 1,000 points a scan the two give the same measures)")] = 1_000

def pda_update(pred: IMMPrediction, rows: np.ndarray, track: np.ndarray, z: np.ndarray, beta: np.ndarray,
               beta0: np.ndarray, polar: bool) -> IMMState:
    """IMM-JPDA update (module docstring, step 4) of the K tracks ``rows`` (K,) of the prediction ``pred``
    from their P gated pairs: ``track`` (P,), sorted, indexes ``rows``, z (P, 2) holds the pairs' contacts
    and ``beta`` (P,) their association probabilities; ``beta0`` (K,) is each track's probability of no
    detection; ``polar`` whether azimuth residuals wrap. One compiled call (`imm_kernels.pda_update`)."""
    mp, st, arr = pred.measurement, pred.state, imm_kernels.kernel_array
    return IMMState(*imm_kernels.pda_update(st.x, st.P, st.mu, mp.z, mp.S_inv, mp.log_det_S, mp.PHt,
                                            arr(rows, np.int64), arr(track, np.int64), arr(z), arr(beta),
                                            arr(beta0), polar))


def given_existence(log_odds: np.ndarray, beta: np.ndarray, beta0: np.ndarray, track: np.ndarray, log_miss: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """JIPDA's association probabilities given that the target exists, for K tracks whose predicted
    existence has log-odds ``log_odds`` (K,), from their marginals (``beta`` (P,) per pair of track ``track``
    (P,), ``beta0`` (K,) no contact, which holds "no target" too, of probability beta0 (1 - rho) / (1 - P_D
    P_G rho)): (P,) and (K,), for the reported contact and the state update."""
    rho, not_rho = existence(log_odds), existence(-log_odds)
    absent = np.maximum(beta0 * not_rho / (1.0 + np.expm1(log_miss) * rho), _TINY)
    given = beta / (1.0 - absent)[track]
    return given, np.maximum(1.0 - np.bincount(track, given, minlength=rho.size), 0.0)


@numba.njit(cache=True, nogil=True)
def best_pairs(track: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Index of each track's most probable pair (ties: its first); ``track`` (P,) sorted, every track
    0..K-1 present, ``beta`` (P,) without NaN. Returns (K,)."""
    best = np.empty(track[-1] + 1 if track.size else 0, np.int64)
    for p in range(track.size):
        t = track[p]
        if p == 0 or t != track[p - 1] or beta[p] > beta[best[t]]:
            best[t] = p
    return best


@numba.njit(cache=True, nogil=True)
def _stage_pairs(confirmed, status, g_rows, g_cols, taken, log_pd, log_density, z_pred, S_inv, log_det, mu, z, polar):
    """One stage of `JPDATracker.associate` in one call: of the gated pairs (g_rows, g_cols (P,), grouped by
    track), those of the confirmed tracks (``confirmed``; else the others, by ``status`` (K,)) whose contact is
    not ``taken`` (N,). Returns the stage's tracks ``rows`` (T,), each pair's index among them ``track`` (Q,)
    and its contact ``cols`` (Q,), and its log likelihood ratio against clutter (Q,): ``log_pd`` plus the IMM
    mixture likelihood of the contact (`imm_kernels.pair_log_likelihood` on the prediction's z_pred, S_inv,
    log_det, mu, of the contacts z (N, 2)) less the clutter's ``log_density`` (N,) there."""
    keep = stage_pairs(confirmed, status, g_rows, g_cols, taken)
    m = keep.size
    rows, track, cols = np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m, np.int64)
    n = 0
    for q in range(m):
        p = keep[q]
        if q == 0 or g_rows[p] != g_rows[keep[q - 1]]:
            rows[n] = g_rows[p]
            n += 1
        track[q], cols[q] = n - 1, g_cols[p]
    rows = rows[:n]
    log_ratio = (log_pd + imm_kernels.pair_log_likelihood(z_pred, S_inv, log_det, mu, rows[track], z[cols], polar)
                 - log_density[cols])
    return rows, track, cols, log_ratio


@numba.njit(cache=True, nogil=True)
def _stage_update(rows, track, cols, beta, beta0, contact, taken, x, P, mu, xp, Pp, mup, z_pred, S_inv, log_det, PHt,
                  z, polar):
    """The decisions of one stage of `JPDATracker.associate` (its tracks ``rows`` (T,), their pairs' ``track``
    (Q,) and ``cols`` (Q,) as `_stage_pairs` gives them, association probabilities ``beta`` (Q,) and ``beta0``
    (T,)), in place: each track whose most probable pair (`best_pairs`) beats no contact reports that contact
    (``contact`` (K,), ``taken`` (N,)) and takes its soft update (`imm_kernels.pda_update` of the prediction xp,
    Pp, mup measured as z_pred, S_inv, log_det, PHt, from the contacts z (N, 2)) into x, P, mu (K, ...).
    Returns each track's best pair (T,) and whether it won (T,)."""
    best = best_pairs(track, beta)
    wins = beta[best] > beta0
    winner = np.cumsum(wins) - 1  # a winning track's index among the winners
    for t in range(rows.size):
        if wins[t]:
            contact[rows[t]] = cols[best[t]]
            taken[cols[best[t]]] = True
    won = wins[track]
    active = rows[wins]
    ux, uP, umu = imm_kernels.pda_update(xp, Pp, mup, z_pred, S_inv, log_det, PHt, active, winner[track[won]],
                                         z[cols[won]], beta[won], beta0[wins], polar)
    for t in range(active.size):
        x[active[t]], P[active[t]], mu[active[t]] = ux[t], uP[t], umu[t]
    return best, wins


class JPDATracker(SingleHypothesisTracker):
    """IMM tracker with joint probabilistic data association (baseline)."""

    name: ClassVar[str] = "jpda"
    takes_reports: ClassVar[bool] = True
    config_type: ClassVar[type[TrackerConfig]] = JPDAConfig

    def reset(self) -> None:
        super().reset()
        self.n_clusters = 0  # clusters seen since the last reset
        self.n_approximated = 0  # of which solved by belief propagation (over max_joint_events)

    def clutter_density(self, scan: ScanContacts, at: np.ndarray) -> np.ndarray:
        """Clutter density in the measurement space of the scan's sensor (polar: (m rad)^-1) at its
        contacts ``at`` (M,)."""
        cfg = self.config
        if cfg.clutter_density == "scan":
            return np.full(at.size, len(scan.z) / measurement_volume(self.sensors[scan.sensor]))
        if cfg.clutter_density == "local":
            return super().clutter_density(scan, at)
        return np.full(at.size, cfg.clutter_density)

    def associate(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts) -> Association:
        cfg = self.config
        contact = np.full(len(tracks), NO_CONTACT, np.int64)
        state = IMMState(pred.state.x.copy(), pred.state.P.copy(), pred.state.mu.copy())
        imm, z = scan.filter, scan.z
        pd, log_miss = self.score_pd(scan.sensor), self._log_miss(scan.sensor)
        gain = np.full(len(tracks), log_miss)  # the score's increments; a miss's without a reported contact
        if not len(z):
            return Association(contact, state, gain)
        g = gate_tracks(imm, pred, z, scan.xy, cfg.gate, check=False)[1]
        near = np.zeros(len(z), bool)
        near[g.cols] = True
        near = np.flatnonzero(near)  # the contacts in some gate
        log_density = np.zeros(len(z))
        log_density[near] = np.log(self.clutter_density(scan, near))
        taken = np.zeros(len(z), bool)
        mp, st = pred.measurement, pred.state
        jipda = self.confirmation_rule == "existence"
        for stage in (True, False):  # confirmed tracks first, as in GNN
            rows, track, cols, log_ratio = _stage_pairs(stage, tracks.status, g.rows, g.cols, taken, math.log(pd),
                                                        log_density, mp.z, mp.S_inv, mp.log_det_S, st.mu, z,
                                                        imm.polar)
            if not track.size:
                continue
            if jipda:  # JIPDA: each track's events weighed by its predicted existence
                own, log_odds = log_ratio, tracks.score[rows]
                log_ratio = jipda_log_ratio(log_ratio, log_miss, existence(log_odds)[track])
            m = jpda_marginals(track, cols, log_ratio, rows.size, log_miss, cfg.max_joint_events)
            beta, beta0 = m.beta, m.beta0
            if jipda:
                beta, beta0 = given_existence(log_odds, beta, beta0, track, log_miss)
            approximated = int(np.count_nonzero(m.approximated))
            self.n_clusters += m.approximated.size
            self.n_approximated += approximated
            if approximated:
                self._bound_hit("max_joint_events", f"{approximated} cluster(s) past the joint-event cap solved by "
                                "loopy belief propagation, not enumeration", scan.time)
            # the reported contact: the most probable given that the target exists (JIPDA's state update), as
            # JPDA's at rho = 1; against the unconditional beta0, which holds "no target", a newborn of tiny
            # existence never reports its target's contacts nor updates on them, and its gate only grows. The
            # soft update only for the tracks that report a contact (the framework keeps the others').
            best, wins = _stage_update(rows, track, cols, beta, beta0, contact, taken, state.x, state.P, state.mu,
                                       st.x, st.P, st.mu, mp.z, mp.S_inv, mp.log_det_S, mp.PHt, z, imm.polar)
            if jipda:  # IPDA's ratio of the reported contact, a miss's for none (as GNN's, the module
                # docstring): the soft ratio over all the gate's contacts walks up on a vague clutter-born track
                # (its gate holds ~100 contacts at 5,000 per scan) until it confirms
                gain[rows] = np.where(wins, np.logaddexp(log_miss, own[best]), log_miss)
            else:  # the score rule scores the reported contact sequence, the framework's increment (GNN's) from
                # this stage's ratios: the PDA ratio's drift is ~0 for a vague clutter-born track, whose score
                # would then walk until it confirms
                gain[rows[wins]] = log_ratio[best[wins]]
        return Association(contact, state, gain)
