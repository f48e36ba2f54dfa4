"""Poisson multi-Bernoulli mixture (PMBM) tracker, track-oriented (Williams 2015; García-Fernández,
Williams, Granström & Svensson 2018), with the IMM of every contact tracker as single-target density.

    tracker = make_tracker("pmbm", scenario.sensors, {"pd": 0.9, "max_global_hypotheses": 50})
    outputs = [tracker.step(scan) for scan in dataset.scans()]

**Relation to** `nnda.tracking.mht`: this is a track-oriented MHT whose tracks (Bernoullis, one label each)
carry an existence probability r in every single-target hypothesis (STH), with the undetected targets as a
Poisson component, and whose global hypotheses are kept as a weighted mixture (the best
``max_global_hypotheses``, ranked by Murty's k-best assignment) instead of the single best set of leaves.
A miss multiplies an STH's weight by 1 - r P_D and sets r to r (1 - P_D) / (1 - r P_D); a detection
multiplies it by r P_D l(z) and sets r to 1 (l the IMM mixture likelihood of the contact); a contact
left to clutter weighs lambda_c(z), the clutter density in measurement space (fixed ``clutter_density``
m^-2, or the local estimate every contact tracker uses, times the area Jacobian). Between scans r becomes
``survival_probability`` r. A scan:

1. predict and gate every STH in one batch (`IMM.predict`, `nnda.tracking.gating.gate`), the detection
   children updated in one batch (`nnda.tracking.linearisation.update`), the miss children keeping their
   posterior (predicted again from their last update);
2. per global hypothesis, the k best data associations of the scan, cluster by cluster (Bernoullis
   sharing gated contacts; `nnda.tracking.pmbm_hypotheses`), k = ceil(``max_global_hypotheses`` W_h);
   the new weights normalised;
3. pruning: an STH whose existence falls below ``min_existence`` is dropped (the Bernoulli absent in that
   global hypothesis), equal global hypotheses merged, those below ``min_hypothesis_weight`` dropped,
   N-scan pruning (the best hypothesis's assignment ``n_scan`` scans back becomes final: `_n_scan_agrees`)
   and at most ``max_global_hypotheses`` kept (a `BoundWarning` the first time in a run, ``n_capped``
   counts the scans); a Bernoulli absent from every global hypothesis is deleted;
4. birth from the Poisson component (below), into every global hypothesis that leaves the contact free.

**Poisson component: measurement-driven.** A Gaussian mixture of undetected targets over a 2 s radar's
coverage (tens of km, speeds up to v_max in any direction) would need thousands of components to give a
new target's first contact a usable velocity; like the PHD trackers' adaptive birth
(`nnda.tracking.phd.birth`) the intensity is instead placed where contacts are, in the form the contact
trackers share: the contacts no Bernoulli took in the best global hypothesis are the Poisson's
measurements; each pairs with the initiators of the sensor's previous scan inside the initiation window
(`TwoPointInitiation`), and a pair opens a new Bernoulli with the two-point start's state. Its existence is
the posterior probability that the pair is a new target rather than clutter: odds P_D beta_NT / rho_1 (the
undetected targets' density beta_NT = ``birth_rate`` per scan over the coverage area, rho_1 the clutter at
the initiator) times P_D / (A_w rho_2) (the second contact anywhere in the window's area A_w, against the
clutter rho_2 there); in a global hypothesis where its contact is free it is present with that r and the
hypothesis's weight gains the factor 1 + odds (lambda_c + e over lambda_c), elsewhere it is absent. A
contact the best hypothesis gives to a Bernoulli opens none, as in the other contact trackers, and a
contact paired with several initiators opens a Bernoulli per pair (the initiation's rule; PMBM proper
opens one, its density a mixture over the pairs): both are the approximations of this formulation.

**Output.** The Bernoullis present in the highest-weight global hypothesis are reported with their STH's
estimate there (the prediction after a miss) and contact, by label (the track id, stable for the
Bernoulli's life). A Bernoulli is CONFIRMED once its marginal existence (r summed over the global
hypotheses by weight) reaches ``existence_threshold`` and stays so; before, it is reported PRELIMINARY.
A reported Bernoulli that is deleted is reported once more as DELETED with its last estimate. The life
cycle's initiation window, v_max and ``max_tracks`` (live Bernoullis) apply; its confirmation rule,
M/N counts and sanity rules do not: status comes from existence alone, whatever ``lifecycle.confirmation``
says (`ContactTracker.confirmation_rule` is "existence").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, ClassVar

import numpy as np
from pydantic import Field, model_validator

from nnda.data.dataset import Scan
from nnda.filters.batch import Batch
from nnda.filters.kalman import GATE_99
from nnda.tracking.clutter_density import coverage_area, local_density
from nnda.tracking.gating import gate
from nnda.tracking.lifecycle import birth_log_odds, sensor_noise_m, start_score
from nnda.tracking.linearisation import update as linearised_update
from nnda.tracking.output import NO_CONTACT, TrackerOutput, TrackStatus
from nnda.tracking.pmbm_hypotheses import scan_hypotheses
from nnda.tracking.tracker import ContactTracker, ContactTrackerConfig, ScanContacts, TrackerConfig, Tracks

#: history entry of a scan before the Bernoulli existed (a miss is NO_CONTACT)
UNKNOWN = -2


class PMBMConfig(ContactTrackerConfig):
    """PMBM settings (module docstring); probabilities per scan of the sensor."""

    @model_validator(mode="after")
    def _order(self) -> PMBMConfig:
        if self.min_existence >= self.existence_threshold:
            raise ValueError(f"min_existence = {self.min_existence:g} must be below existence_threshold = "
                             f"{self.existence_threshold:g}: a Bernoulli would be pruned before it is confirmed")
        return self

    pd: Annotated[float, Field(gt=0, le=1, description="P_D, probability that a target is detected in a scan")] = 0.9
    survival_probability: Annotated[float, Field(gt=0, lt=1, description="p_S, probability that a target "
                                                 "exists still at the next scan")] = 0.99
    birth_rate: Annotated[float, Field(gt=0, description="beta_NT: targets expected to appear per scan in the "
                                       "sensor's coverage (the Poisson birth intensity, uniform over it)")] = 0.5
    clutter_density: Annotated[float | None, Field(gt=0, description="clutter per m^2; None: the local "
                                                   "estimate around each contact")] = None
    clutter_radius_m: Annotated[float, Field(gt=0, description="half-side (m) of the local estimate's "
                                             "square")] = 3_000.0
    gate: Annotated[float, Field(gt=0, description="chi-square gate, 2 dof (9.21: P_G = 0.99)")] = GATE_99
    max_global_hypotheses: Annotated[int, Field(ge=1, description="global hypotheses kept, best weights "
                                                "first")] = 50
    n_scan: Annotated[int, Field(ge=1, description="N-scan pruning depth (scans of ambiguity kept)")] = 3
    existence_threshold: Annotated[float, Field(gt=0, lt=1, description="marginal existence probability at "
                                                "which a Bernoulli is confirmed")] = 0.99
    min_existence: Annotated[float, Field(ge=0, lt=1, description="an STH of lower existence is dropped "
                                          "(its Bernoulli absent there)")] = 1e-4
    min_hypothesis_weight: Annotated[float, Field(ge=0, lt=1, description="global hypotheses of lower "
                                                  "normalised weight are dropped")] = 1e-4


@dataclass(frozen=True)
class STH(Batch):
    """S single-target hypotheses: track records (``tracks.track_id`` = the Bernoulli's label; filter state
    at the last update, at ``tracks.t2``), existence ``r`` (S,), ``hist`` (S, n_scan) the contact of each of
    the last n_scan scans (oldest first; NO_CONTACT a miss, UNKNOWN before birth), and the estimate reported
    for the last scan, ``x`` (S, 4), ``P`` (S, 4, 4)."""

    tracks: Tracks
    r: np.ndarray
    hist: np.ndarray
    x: np.ndarray
    P: np.ndarray


class PMBMTracker(ContactTracker):
    """IMM + track-oriented Poisson multi-Bernoulli mixture (module docstring)."""

    name: ClassVar[str] = "pmbm"
    config_type: ClassVar[type[TrackerConfig]] = PMBMConfig
    own_confirmation: ClassVar[str | None] = "existence"

    def reset(self) -> None:
        super().reset()
        self.sth: STH | None = None
        self.labels = np.empty(0, np.int64)  # (L,) live Bernoullis' labels
        self.hyp = np.zeros((1, 0), np.int64)  # (H, L) STH of each Bernoulli per global hypothesis, -1 absent
        self.log_w = np.zeros(1)  # (H,) normalised log weights
        self.known = (np.empty(0, np.int64), np.empty((0, 4)), np.empty((0, 4, 4)))  # reported labels, last x, P
        self.confirmed = np.empty(0, np.int64)  # labels reported confirmed
        self.n_capped = 0  # scans where max_global_hypotheses bit

    # ---------------------------------------------------------------------- one scan
    def step(self, scan: Scan) -> TrackerOutput:
        sc = self._checked(scan)
        self.last_time = sc.time
        if self.sth is not None:
            self._update(sc)
            self._prune()
        best = int(np.argmax(self.log_w))
        used = np.zeros(len(sc.z), bool)
        if self.sth is not None:
            chosen = self.hyp[best][self.hyp[best] >= 0]
            now = self.sth.hist[chosen, -1]
            used[now[now >= 0]] = True
        born, contact = self.initiation(sc.z, sc.xy, used, sc.time, self.labels.size, sc.sensor)
        if born is not None:
            self._birth(born, contact, sc)
        return self._report(scan.index, sc.time)

    # ---------------------------------------------------------------------- update
    def _update(self, scan: ScanContacts) -> None:
        """Predict and update every STH in one batch, then the k best associations of each global
        hypothesis (module docstring, steps 1-2)."""
        cfg, imm, old = self.config, scan.filter, self.sth
        z, xy, time, S = scan.z, scan.xy, scan.time, len(old)
        tr = old.tracks
        r = cfg.survival_probability * old.r
        pred = imm.predict(tr.filt, time - tr.t2, check=False)
        pd = np.full(S, cfg.pd)
        observed = self._observed(scan, pred)
        if observed is not None:
            pd = np.where(observed, pd, 0.0)
        log_miss = np.log1p(-r * pd)
        pl = pj = np.empty(0, np.int64)
        gain = np.empty(0)
        if len(z):
            g = pred.gating
            gated = gate(imm, g.measurement, z, xy, cfg.gate, (g.x, g.P), check=False)
            ok = pd[gated.rows] > 0
            pl, pj = gated.rows[ok], gated.cols[ok]
            if pl.size:
                ll = imm.pair_log_likelihood(pred, pl, z[pj], check=False)
                clutter = self._clutter(scan, pj)
                gain = np.log(r[pl] * pd[pl]) + ll - np.log(clutter) - log_miss[pl]
        # children: the S miss children (index s), then one detection child per gated pair
        parent = np.concatenate([np.arange(S), pl])
        contact = np.concatenate([np.full(S, NO_CONTACT, np.int64), pj])
        children = tr.take(parent)
        filt = children.filt
        if pl.size:
            updated = linearised_update(imm, pred.take(pl), z[pj], np.ones(pl.size, bool))
            filt = type(filt).concat([tr.filt, updated])
        tracks = children.after_scan(contact, filt, z, xy, time, cfg.lifecycle)
        r_miss = r * (1.0 - pd) / np.exp(log_miss)
        x_post, P_post = imm.estimate(updated) if pl.size else (np.empty((0, 4)), np.empty((0, 4, 4)))
        self.sth = STH(tracks, np.concatenate([r_miss, np.ones(pl.size)]),
                       np.column_stack([old.hist[parent, 1:], contact]),
                       np.concatenate([pred.gating.x, x_post]), np.concatenate([pred.gating.P, P_post]))
        pair_child = S + np.arange(pl.size)
        hyps, weights = [], []
        for h in range(len(self.log_w)):
            k = max(1, math.ceil(cfg.max_global_hypotheses * math.exp(self.log_w[h])))
            present = self.hyp[h][self.hyp[h] >= 0]
            kids, gains = scan_hypotheses(self.hyp[h], pl, pj, pair_child, gain, k)
            hyps.append(kids)
            weights.append(self.log_w[h] + log_miss[present].sum() + gains)
        self.hyp = np.concatenate(hyps)
        self.log_w = _normalised(np.concatenate(weights))

    def _clutter(self, scan: ScanContacts, at: np.ndarray) -> np.ndarray:
        """Clutter density in the scan's measurement space at its contacts ``at`` (M,): the fixed
        ``clutter_density`` or the local estimate (`ContactTracker.clutter_density`), times the area
        Jacobian."""
        if self.config.clutter_density is None:
            return self.clutter_density(scan, at)
        return self.config.clutter_density * scan.filter.measurement.area_jacobian(scan.z[at])

    # ---------------------------------------------------------------------- pruning
    def _prune(self) -> None:
        """Step 3 of the module docstring; keeps only the STHs and Bernoullis some global hypothesis uses."""
        cfg, sth = self.config, self.sth
        hyp = np.where((self.hyp >= 0) & (sth.r[np.maximum(self.hyp, 0)] >= cfg.min_existence), self.hyp, -1)
        hyp, log_w = _merged(hyp, self.log_w)
        best = int(np.argmax(log_w))
        keep = log_w >= math.log(cfg.min_hypothesis_weight) if cfg.min_hypothesis_weight > 0 else np.ones_like(
            log_w, bool)
        keep &= _n_scan_agrees(hyp, sth.hist[np.maximum(hyp, 0), 0], best)
        keep[best] = True
        idx = np.flatnonzero(keep)
        if idx.size > cfg.max_global_hypotheses:
            if not self.n_capped:
                self._bound_hit("max_global_hypotheses", f"{idx.size - cfg.max_global_hypotheses} global "
                                f"hypotheses pruned past the cap", self.last_time)
            self.n_capped += 1
            idx = idx[np.argsort(-log_w[idx], kind="stable")[: cfg.max_global_hypotheses]]
        hyp, log_w = hyp[np.sort(idx)], _normalised(log_w[np.sort(idx)])
        live = (hyp >= 0).any(axis=0)
        hyp = hyp[:, live]
        used = np.unique(hyp[hyp >= 0])
        remap = np.full(len(sth), -1, np.int64)
        remap[used] = np.arange(used.size)
        self.hyp, self.log_w, self.labels = np.where(hyp >= 0, remap[np.maximum(hyp, 0)], -1), log_w, self.labels[live]
        self.sth = sth.take(used) if used.size else None

    # ---------------------------------------------------------------------- birth
    def _birth(self, born: Tracks, contact: np.ndarray, scan: ScanContacts) -> None:
        """New Bernoullis from the Poisson component (module docstring), added to every global hypothesis."""
        cfg, sensor = self.config, self.sensors[scan.sensor]
        area = cfg.lifecycle.window_area(sensor.scan_period_s, sensor_noise_m(sensor))
        if cfg.clutter_density is None:
            rho2 = self._contact_density(scan)[contact]
            rho1 = local_density(scan.xy, born.p1, cfg.clutter_radius_m, sensor)
        else:
            rho2 = rho1 = np.full(len(born), cfg.clutter_density)
        log_odds = start_score(cfg.pd, area, rho2) + birth_log_odds(cfg.pd, cfg.birth_rate / coverage_area(sensor),
                                                                    rho1)
        r = np.exp(-np.logaddexp(0.0, -log_odds))
        hist = np.full((len(born), cfg.n_scan), UNKNOWN, np.int64)
        hist[:, -1] = contact
        x, P = self.filter.estimate(born.filt)
        new = STH(born, r, hist, x, P)
        first = 0 if self.sth is None else len(self.sth)
        self.sth = new if self.sth is None else STH.concat([self.sth, new])
        taken = np.zeros((len(self.log_w), len(scan.z) + 1), bool)  # contacts detected, per global hypothesis
        rows, cols = np.nonzero(self.hyp >= 0)
        if rows.size:
            last = self.sth.hist[self.hyp[rows, cols], -1]
            taken[rows, last] = True  # a miss (-1) marks the spare last column
        free = ~taken[:, contact]  # (H, B)
        self.hyp = np.column_stack([self.hyp, np.where(free, first + np.arange(len(born)), -1)])
        self.log_w = _normalised(self.log_w + (free * np.logaddexp(0.0, log_odds)).sum(axis=1))
        self.labels = np.concatenate([self.labels, born.track_id])

    # ---------------------------------------------------------------------- output
    def existence(self) -> np.ndarray:
        """Marginal existence probability (L,) of each live Bernoulli (``labels``) over the global hypotheses."""
        if self.sth is None:
            return np.zeros(self.labels.size)
        r = np.where(self.hyp >= 0, self.sth.r[np.maximum(self.hyp, 0)], 0.0)
        return np.exp(self.log_w) @ r

    def _report(self, scan: int, time: float) -> TrackerOutput:
        """The best global hypothesis's Bernoullis, then the reported ones deleted in this scan (docstring)."""
        blocks = []
        ids, x, P = self.known
        if self.sth is not None and self.labels.size:
            chosen = self.hyp[int(np.argmax(self.log_w))]
            shown = np.flatnonzero(chosen >= 0)
            s = chosen[shown]
            label = self.labels[shown]
            confirmed = self.existence()[shown] >= self.config.existence_threshold
            self.confirmed = np.union1d(self.confirmed, label[confirmed])
            status = np.where(np.isin(label, self.confirmed), TrackStatus.CONFIRMED, TrackStatus.PRELIMINARY)
            blocks.append((label, status, self.sth.x[s], self.sth.P[s], self.sth.hist[s, -1]))
            stale = ~np.isin(ids, label)
            ids = np.concatenate([ids[stale], label])
            x = np.concatenate([x[stale], self.sth.x[s]])
            P = np.concatenate([P[stale], self.sth.P[s]])
        gone = ~np.isin(ids, self.labels)
        if gone.any():
            blocks.append((ids[gone], np.full(gone.sum(), TrackStatus.DELETED, np.int8), x[gone], P[gone],
                           np.full(gone.sum(), NO_CONTACT)))
            was = np.isin(ids[gone], self.confirmed)
            self.deletions["score"] += int(was.sum())
            self.deletions["unconfirmed"] += int((~was).sum())
            self.confirmed = self.confirmed[~np.isin(self.confirmed, ids[gone])]
        self.known = (ids[~gone], x[~gone], P[~gone])
        return TrackerOutput.from_blocks(scan, time, blocks)


def _n_scan_agrees(hyp: np.ndarray, oldest: np.ndarray, best: int) -> np.ndarray:
    """N-scan pruning (H,): which global hypotheses ``hyp`` (H, L) agree with hypothesis ``best`` on the scan
    ``n_scan`` back, ``oldest`` (H, L) each STH's contact there. A Bernoulli present in both must have made
    the same choice (contact or miss), and no contact that a Bernoulli of ``best`` took may be taken by
    another one. A Bernoulli absent from one of them (pruned there for its low existence) constrains nothing
    by itself: its absence says nothing of that scan."""
    L = hyp.shape[1]
    both = (hyp >= 0) & (hyp[best] >= 0)
    same = ((oldest == oldest[best]) | ~both).all(axis=1)
    took = (hyp >= 0) & (oldest >= 0)
    mine = took[best]
    owned = np.unique(oldest[best][mine])
    pairs = np.unique(oldest[best][mine] * L + np.flatnonzero(mine))
    key = oldest * L + np.arange(L)
    other = took & np.isin(oldest, owned) & ~np.isin(key, pairs)
    return same & ~other.any(axis=1)


def _normalised(log_w: np.ndarray) -> np.ndarray:
    """Log weights (H,) shifted so that their exponentials sum to one."""
    return log_w - np.logaddexp.reduce(log_w)


def _merged(hyp: np.ndarray, log_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Equal global hypotheses (rows of ``hyp``) as one, their weights summed."""
    if not hyp.shape[1]:
        return hyp[:1], np.logaddexp.reduce(log_w, keepdims=True)
    rows, inverse = np.unique(hyp, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    order = np.argsort(inverse, kind="stable")
    starts = np.r_[0, np.flatnonzero(np.diff(inverse[order])) + 1]
    return rows, np.logaddexp.reduceat(log_w[order], starts)
