"""Track-oriented multiple hypothesis tracking (TOMHT) with the IMM: the baseline of Vargas Avila (2015).

Every track (a *family*, one id) keeps a tree of hypotheses whose leaves are
alternative contact sequences, each with its own IMM state and
log-likelihood-ratio score (Blackman & Popoli 1999; the thesis gives no MHT equations or parameters,
so these are ours):

* new family from the shared initiation: L = ln(beta_NT / beta_FT);
* detection: dL = ln P_D + ln N(nu; 0, S) - ln beta_FT, N the IMM mixture
  likelihood of the contact in (range m, azimuth rad) space;
* miss: dL = ln(1 - P_D P_G).

beta_FT is the clutter density in measurement space: a spatial density rho
(m^-2; fixed, or estimated per scan from the contacts in a square of
half-side ``clutter_radius_m`` around the predicted position) times the predicted range
(an area element is r dr dtheta). A scan of the MHT:

1. **branch** every leaf into a miss child and one child per gated contact
   (chi-square gate on the IMM combined prediction), keeping the miss child
   and the best ``max_track_branches - 1`` detection children (MATLAB's
   MaxNumTrackBranches); M/N counters and deletion rules run per child;
2. **global hypothesis**: the set of leaves, at most one per family, that
   shares no contact within the N-scan window and maximises the summed
   score (a leaf with a score <= 0 is less likely than "no target" and is
   never chosen). Families sharing a contact form a cluster; a one-family
   cluster takes its best leaf, the larger clusters are solved exactly: a
   compiled branch and bound, and where that would take too long one binary
   program (scipy's HiGHS `milp`) for all of them (`nnda.tracking.global_hypothesis`;
   of two sets with equal sums, either may be chosen). Families left out stay as
   hypotheses but are not reported;
3. **initiation** from the contacts no leaf kept by the branching took
   (``initiation_contacts = "untaken"``: a contact some hypothesis explains
   does not start a family of its own too; in S6's coverage 14 % fewer
   short-lived families at 1,000 clutter points a scan, 40 % fewer at 5,000)
   or, with ``"unchosen"``, from those the global hypothesis leaves free;
4. **pruning**: N-scan pruning (the decision ``n_scan`` scans back becomes
   final: a chosen family keeps only the leaves that agree with it there,
   and every leaf using a contact given there to another family goes), branch probability within a family
   below ``min_branch_probability``, score fallen more than
   ``deletion_score_drop`` below its maximum, at most
   ``max_hypotheses_per_track`` leaves per family and ``max_hypotheses`` in
   all (chosen leaves first, then by score; the families this cap ends are
   counted as "capped" deletions), and merging of leaves that
   share their last three contacts with a better leaf of any family.

The chosen leaf of each family is what the tracker reports; new families are
reported from their first scan, like the other trackers' preliminary tracks.
A family that loses its last leaf is reported once as deleted if it was ever
reported. The status reported is the family's: once reported confirmed, a family
stays confirmed until it is deleted, even when the global hypothesis
chooses one of its branches that is still preliminary (its confirmed branches'
contacts given to another family, or outscored).

Confirmation is M/N (3/4, as the neural method's; a new family's score starts at
ln(beta_NT / beta_FT) = ln(``new_target_ratio``)) or, with
``lifecycle.confirmation = "score"``, the track score of every contact
tracker (`nnda.tracking.lifecycle`): a new family starts at the two-point
start's ln(P_D / (A_w rho)) of the same clutter estimate, and Wald's test
on each leaf's score alone confirms (ln((1 - beta) / alpha), or the threshold of its family's birth
under ``false_tracks_per_scan``) and deletes
(a preliminary leaf at ln(beta / (1 - alpha)), a confirmed one that far
below its best score), alpha and beta the lifecycle's
``false_confirmation`` and ``false_deletion``; the M/N counts play no part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, ClassVar, Literal

import numba
import numpy as np
from pydantic import Field, model_validator

from nnda.data.dataset import Scan
from nnda.filters.batch import Batch
from nnda.filters.imm import IMMState
from nnda.filters.imm_kernels import estimate
from nnda.filters.kalman import GATE_99, gate_probability
from nnda.tracking.clutter_density import local_density
from nnda.tracking.gating import gate
from nnda.tracking.global_hypothesis import global_hypothesis
from nnda.tracking.lifecycle import SANITY_REASONS, advance_score_kernel, everywhere, sanity_kernel
from nnda.tracking.linearisation import update as linearised_update
from nnda.tracking.lookup import among, members, run_starts, sorted_find
from nnda.tracking.output import CONFIRMED, DELETED, NO_CONTACT, TrackerOutput
from nnda.tracking.protocol import TrackerConfig
from nnda.tracking.reports import Phase
from nnda.tracking.tracker import ContactTracker, ContactTrackerConfig, ScanContacts
from nnda.tracking.tracks import CONSECUTIVE, Tracks, branched_moved, branching_args, table_rows, tables_joined

#: history entry of a scan before the family existed, or whose contact is not known (a miss is NO_CONTACT)
UNKNOWN = -2


class MHTConfig(ContactTrackerConfig):
    """TOMHT settings; defaults are a standard Blackman-style TOMHT's and MATLAB trackerTOMHT's bounds."""

    @model_validator(mode="after")
    def _rule(self) -> MHTConfig:
        if self.lifecycle.confirmation == "existence":
            raise ValueError("lifecycle.confirmation = 'existence' (IPDA) is for the single-hypothesis trackers; "
                             "MHT's hypotheses carry scores: use 'score' or 'mn'")
        return self

    gate: Annotated[float, Field(gt=0, description="chi-square gate, 2 dof (9.21: P_G = 0.99)")] = GATE_99
    pd: Annotated[float, Field(gt=0, lt=1, description="detection probability used in the scores; "
                               "left out: the scan's sensor's declared_pd, else 0.9")] = 0.9
    new_target_ratio: Annotated[float, Field(gt=0, description="beta_NT / beta_FT")] = 0.1
    clutter_density: Annotated[float | None, Field(gt=0, description="clutter per m^2; None: local estimate")] = None
    clutter_radius_m: Annotated[float, Field(gt=0)] = 3_000.0
    n_scan: Annotated[int, Field(ge=1, description="N-scan pruning depth (scans of ambiguity kept)")] = 3
    max_track_branches: Annotated[int, Field(ge=1, description="children kept per leaf and scan, miss included")] = 3
    max_hypotheses_per_track: Annotated[int, Field(ge=1, description="leaves kept per family")] = 20
    max_hypotheses: Annotated[int, Field(ge=1, description="leaves kept in all; the chosen ones and "
                                         "then the best scores")] = 50_000
    max_exact_leaves: Annotated[int, Field(ge=1, description="largest cluster (in leaves) whose global "
                                           "hypothesis is solved exactly; larger ones greedily")] = 5_000
    min_branch_probability: Annotated[float, Field(ge=0, lt=1)] = 1e-3
    deletion_score_drop: Annotated[float, Field(gt=0, description="delete a leaf this far below its best score")] = 10.0
    initiation_contacts: Literal["untaken", "unchosen"] = Field(
        "untaken", description="the contacts that may start a new family: 'untaken', those no leaf kept by the "
        "scan's branching took, or 'unchosen', those the global hypothesis leaves free (as in the comparison "
        "with Vargas Avila (2015)); at 5,000 clutter points a scan 'untaken' opens 40 % fewer families")
    end_at_score_peak: bool = Field(True, description=(
        "a fixed-lag output ends a family deleted within its window at the last maximum of its chosen leaf's "
        "score (as of the scan before its deletion), the change time of the score-drop deletion (Page 1954), "
        "not only when it coasted to its deletion without a contact"))


@dataclass(frozen=True)
class Leaves(Batch):
    """L hypotheses: a track record each (family id = ``tracks.track_id``), score, best score
    so far, ``hist`` (L, n_scan): the contact index used in each of the last n_scan
    scans (oldest first; -1 miss, -2 unknown), and ``peak`` (L,): the time (s) the leaf's score last reached
    its best (its branch's, back to the family's birth)."""

    tracks: Tracks
    score: np.ndarray
    max_score: np.ndarray
    hist: np.ndarray
    peak: np.ndarray

    def _rows(self, index: np.ndarray | slice) -> Leaves:
        """`Batch.take` of an integer array in one compiled call (`tracks.table_rows`; MHT prunes its leaves every
        scan, where a take field by field costs more than the copying)."""
        if isinstance(index, slice):
            return super()._rows(index)
        return Leaves._of(table_rows(self._arrays(), index))

    @classmethod
    def joined(cls, a: Leaves, b: Leaves) -> Leaves:
        """`Batch.concat` of ``a`` then ``b`` in one compiled call (`tracks.tables_joined`; a scan's new families join
        the leaves every scan)."""
        return cls._of(tables_joined(a._arrays(), b._arrays()))

    def _arrays(self) -> tuple[np.ndarray, ...]:
        """The fields' arrays, the tracks' in `Tracks` order (the filter state's three in its place) first."""
        t = self.tracks
        f = t.filt
        return (t.track_id, t.status, f.x, f.P, f.mu, t.history, t.counts, t.scores, self.score, self.max_score,
                self.hist, self.peak)

    @classmethod
    def _of(cls, arrays: tuple[np.ndarray, ...]) -> Leaves:
        """The leaves of `_arrays`' tuple."""
        track_id, status, x, P, mu, history, counts, scores, score, max_score, hist, peak = arrays
        return cls(Tracks(track_id, status, IMMState(x, P, mu), history, counts, scores), score, max_score, hist,
                   peak)


@dataclass(frozen=True)
class _Shown:
    """What a leaf looks like in this scan's report: combined state (L, 4), covariance (L, 4, 4)."""

    x: np.ndarray
    P: np.ndarray


class MHTTracker(ContactTracker):
    """IMM + track-oriented MHT (the classical method of Vargas Avila 2015)."""

    name: ClassVar[str] = "mht"
    learns_pd = True
    takes_reports: ClassVar[bool] = True
    config_type: ClassVar[type[TrackerConfig]] = MHTConfig

    def reset(self) -> None:
        super().reset()
        self.leaves: Leaves | None = None
        # last reported id, state and covariance of every family reported at least once and alive, and whether
        # it was ever reported confirmed (it then stays so, whichever of its leaves is chosen)
        self.known = (np.empty(0, np.int64), np.empty((0, 4)), np.empty((0, 4, 4)), np.empty(0, bool))
        self.n_clusters_solved = 0  # multi-family clusters solved exactly
        self.n_clusters_greedy = 0  # clusters above max_exact_leaves, chosen greedily

    # ---------------------------------------------------------------------- one scan
    def _step(self, scan: Scan, phase: Phase) -> TrackerOutput:
        sc = self._checked(scan, phase)
        z, time = sc.z, sc.time
        leaves, shown, chosen = None, None, np.empty(0, np.int64)
        used = np.zeros(len(z), bool)
        if self.leaves is not None and len(self.leaves):
            leaves, shown, seen = self._branch(self.leaves, sc)
            chosen = self._global_hypothesis(leaves)
            if self._learns(sc):
                ids, *_, shown_confirmed = self.known  # the families reported confirmed before this scan
                self._count_detections(sc, members(leaves.tracks.track_id[chosen], ids[shown_confirmed]),
                                       None if seen is None else seen[chosen], leaves.hist[chosen, -1])
            now = leaves.hist[chosen if self.config.initiation_contacts == "unchosen" else slice(None), -1]
            used[now[now >= 0]] = True
        families = 0 if leaves is None else int(np.count_nonzero(run_starts(np.sort(leaves.tracks.track_id))))
        born, contact = self._initiate(sc, used, families)
        if born is not None:
            new = self._new_leaves(self._start_scores(born, sc, contact), contact)
            x, P = self.filter.estimate(born.filt)
            first = 0 if leaves is None else len(leaves)
            leaves = new if leaves is None else Leaves.joined(leaves, new)
            shown = _Shown(x, P) if shown is None else _Shown(np.concatenate([shown.x, x]),
                                                              np.concatenate([shown.P, P]))
            chosen = np.concatenate([chosen, first + np.arange(len(new))])
        self.leaves = None if leaves is None else self._prune(leaves, chosen)
        out = self._report(scan.index, time, leaves, shown, chosen)
        if self._ends_at_peak:
            self._note_peaks(out, leaves, chosen)
        return out

    @property
    def _peak_rule(self) -> bool:
        """Every rule: a leaf is deleted once its score falls ``deletion_score_drop`` below its best."""
        return True

    def _note_peaks(self, out: TrackerOutput, leaves: Leaves | None, chosen: np.ndarray) -> None:
        """Keep the score peak of every family that ``out`` reports or that still holds leaves: its ``chosen`` leaf's
        of ``leaves`` where it has one now, else as last kept (that of the leaf last chosen; `score_peaks`)."""
        ids, peak = np.empty(0, np.int64), np.empty(0)
        if leaves is not None and chosen.size:
            ids, peak = leaves.tracks.track_id[chosen], leaves.peak[chosen]
        ids, first = np.unique(np.concatenate([ids, self._peaks[0]]), return_index=True)  # the chosen leaf's first
        peak = np.concatenate([peak, self._peaks[1]])[first]
        alive = np.empty(0, np.int64) if self.leaves is None else self.leaves.tracks.track_id
        keep = members(ids, np.concatenate([out.track_id, alive]))
        self._peaks = (ids[keep], peak[keep])

    # ---------------------------------------------------------------------- branching
    def _branch(self, leaves: Leaves, scan: ScanContacts) -> tuple[Leaves, _Shown, np.ndarray | None]:
        """The leaves' children in ``scan`` (each leaf's miss and its gated contacts) that live on, their reported
        states, and which of them the scan observed (None: all)."""
        cfg, imm, tr = self.config, scan.filter, leaves.tracks
        z, xy, time = scan.z, scan.xy, scan.time
        L = len(leaves)
        pred = imm.predict(tr.filt, time - tr.t2, check=False)  # the leaves' own states: valid
        x_pred, P_pred, mp = pred.gating.x, pred.gating.P, pred.gating.measurement
        pd = self.score_pd(scan.sensor)
        miss_score = leaves.score + math.log(1.0 - pd * gate_probability(cfg.gate))
        observed = self._observed(scan, pred, tr.t2)  # a leaf the scan does not observe keeps its score and counters
        if observed is not None:
            miss_score = np.where(observed, miss_score, leaves.score)

        parent = np.arange(L)
        contact = np.full(L, NO_CONTACT, np.int64)
        score = miss_score
        if len(z):
            gated = gate(imm, mp, z, xy, cfg.gate, (x_pred, P_pred), check=False)
            pl, pj = gated.rows, gated.cols
            if pl.size:
                ll = imm.pair_log_likelihood(pred, pl, z[pj], check=False)
                beta_ft = self._clutter_density(x_pred, xy) * imm.measurement.area_jacobian(mp.z)
                det = leaves.score[pl] + math.log(pd) + ll - np.log(beta_ft[pl])
                order = np.lexsort((-det, pl))
                pl, pj, det = pl[order], pj[order], det[order]
                rank = np.arange(pl.size) - np.searchsorted(pl, pl)
                keep = rank < cfg.max_track_branches - 1
                parent = np.concatenate([parent, pl[keep]])
                contact = np.concatenate([contact, pj[keep]])
                score = np.concatenate([score, det[keep]])

        detected = contact >= 0  # the first L children are the leaves' misses, which keep their posteriors
        dp, dc = parent[L:], contact[L:]
        filt = tr.filt
        if dp.size:
            updated = linearised_update(imm, pred, z[dc], np.ones(dp.size, bool), rows=dp)
            filt = type(filt).concat([filt, updated])
        # the leaves the scan observed: with reports, those that took one
        seen = detected if scan.phase is Phase.REPORTS else None if observed is None else observed[parent]
        status, counts, scores, history, max_score, peak, hist = _children(
            parent, contact, everywhere(seen, parent.size), tr.status, tr.counts, tr.scores, tr.history,
            score, leaves.max_score, leaves.peak, leaves.hist, *branching_args(cfg.lifecycle), xy,
            np.ascontiguousarray(z[:, 1]), time)
        quality = np.zeros(len(status))  # the clutter around the confirmed leaves, for the track-quality rule
        judged = status == CONFIRMED
        if judged.any():
            quality[judged] = self._quality_density(scan, x_pred[parent[judged]])
        ids, *_, shown_confirmed = self.known  # a family reported confirmed ends as a confirmed track
        kept, fields, shown, lost = _kept_children(
            parent, detected, tr.track_id, tr.status, status, (filt.x, filt.P, filt.mu), history, counts, scores,
            score, max_score, hist, peak, x_pred, P_pred, imm.output_dim, quality, self._sanity_args,
            cfg.deletion_score_drop, np.sort(ids[shown_confirmed]), self.confirmation_rule == "mn",
            len(SANITY_REASONS))
        for reason, n in zip(("unconfirmed", "misses", "score", *SANITY_REASONS), lost):
            self.deletions[reason] += int(n)
        return Leaves._of(fields), _Shown(*shown), None if seen is None else seen[kept]

    def _clutter_density(self, x_pred: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """Clutter spatial density (m^-2) at each leaf's predicted position, (L,)."""
        cfg = self.config
        if cfg.clutter_density is not None:
            return np.full(len(x_pred), cfg.clutter_density)
        return local_density(xy, x_pred[:, [0, 2]], cfg.clutter_radius_m)

    def _new_leaves(self, born: Tracks, contact: np.ndarray) -> Leaves:
        k = len(born)
        hist = np.full((k, self.config.n_scan), UNKNOWN, np.int64)
        hist[:, -1] = contact
        if self.confirmation_rule != "mn":  # the clutter model's two-point start, as every contact tracker's
            score = np.ascontiguousarray(born.score)  # a column of the scores: one compiled layout
        else:
            score = np.full(k, math.log(self.config.new_target_ratio))
        return Leaves(born, score, score.copy(), hist, born.t2.copy())

    # ---------------------------------------------------------------------- global hypothesis
    def _global_hypothesis(self, leaves: Leaves) -> np.ndarray:
        """Indices of the chosen leaves (at most one per family), ordered by family (`global_hypothesis`);
        the clusters solved exactly and greedily are counted, the first greedy one of a run warned of."""
        chosen, solved, greedy = global_hypothesis(leaves.tracks.track_id, leaves.hist, leaves.score,
                                                   self.config.max_exact_leaves)
        self.n_clusters_solved += solved
        self.n_clusters_greedy += greedy
        if greedy:
            self._bound_hit("max_exact_leaves", "a cluster's global hypothesis chosen greedily, not exactly",
                            self.last_time)
        return chosen

    # ---------------------------------------------------------------------- pruning
    def _prune(self, leaves: Leaves, chosen: np.ndarray) -> Leaves | None:
        """The leaves that survive the scan's pruning (module docstring, step 4), ``chosen`` the global
        hypothesis' (and the new families'): N-scan pruning, branch probability, merging and the per-family
        bound in one compiled pass (`_kept`), then the ``max_hypotheses`` cap. None: no leaf left."""
        cfg = self.config
        family = leaves.tracks.track_id
        kept = _kept(family, leaves.hist, np.ascontiguousarray(leaves.score), chosen, min(3, cfg.n_scan),
                     cfg.min_branch_probability, cfg.max_hypotheses_per_track)  # one layout: one compiled version
        if kept.size > cfg.max_hypotheses:
            self._bound_hit("max_hypotheses", f"{kept.size - cfg.max_hypotheses} hypotheses pruned past the cap",
                            self.last_time)
            is_chosen = np.zeros(len(leaves), bool)
            is_chosen[chosen] = True
            before = np.unique(family[kept])
            kept = kept[np.lexsort((-leaves.score[kept], ~is_chosen[kept]))][: cfg.max_hypotheses]
            self.deletions["capped"] += int(before.size - np.unique(family[kept]).size)  # families cut whole
            kept = np.sort(kept)
        return leaves.take(kept) if kept.size else None

    # ---------------------------------------------------------------------- output
    def _report(self, scan: int, time: float, leaves: Leaves | None, shown: _Shown | None,
                chosen: np.ndarray) -> TrackerOutput:
        """Chosen leaves of the families still alive, then families that lost their last leaf (status DELETED,
        last reported state), each family once. A family reported confirmed once is reported confirmed until it
        is deleted, even when its chosen leaf is one of its branches that is still preliminary: the global
        hypothesis may give a confirmed branch's contacts to another family, or a preliminary branch may come to
        outscore the confirmed ones. A chosen family whose every leaf was pruned in this scan (the
        ``max_hypotheses`` cap) is reported as deleted only, if it was reported before. With
        ``lifecycle.report_existence``, a confirmed family whose chosen leaf has missed too many scans in a row
        is left out (`ContactTracker._hidden`)."""
        alive_ids = self.leaves.tracks.track_id if self.leaves is not None else np.empty(0, np.int64)
        if leaves is None:  # no leaf: only the known families to report gone
            d, none = self.filter.output_dim, np.empty(0, np.int64)
            of_leaves = (none, np.empty(0, np.int8), none, none, np.empty((0, d)), np.empty((0, d, d)), none)
        else:  # the columns contiguous: one compiled layout
            tr = leaves.tracks
            of_leaves = (tr.track_id, tr.status, np.ascontiguousarray(tr.counts[:, CONSECUTIVE]),
                         np.ascontiguousarray(leaves.hist[:, -1]), shown.x, shown.P, chosen)
        report, self.known = _reported(self.known, alive_ids, *of_leaves, self._misses_to_hide(self.last_sensor))
        return TrackerOutput(scan, time, *report)

    # ---------------------------------------------------------------------- fixed-lag output
    def best_branch(self, reported: TrackerOutput) -> tuple[np.ndarray, np.ndarray]:
        """The branch each family of ``reported`` (the output `step` just returned) is on in the global
        hypothesis: the families' ids (K,) and their chosen leaves' contacts of the last ``n_scan`` scans
        (K, n_scan), oldest first (NO_CONTACT a miss, UNKNOWN before the family); families without leaves
        left (reported deleted) are not among them. Read-only (`nnda.tracking.lag.RevisesBranches`): the
        chosen leaf is the family's leaf with the reported contact, and where several are, the one whose
        estimate is the reported one (the posterior's for a contact, the prediction's for a miss)."""
        n = self.config.n_scan
        none = (np.empty(0, np.int64), np.empty((0, n), np.int64))
        if self.leaves is None or not len(reported):
            return none
        leaves, tr = self.leaves, self.leaves.tracks
        rows = np.flatnonzero(reported.status != DELETED)
        rows = rows[np.argsort(reported.track_id[rows], kind="stable")]
        ids, contact = reported.track_id[rows], reported.contact[rows]
        if not ids.size:
            return none
        at, found = sorted_find(ids, tr.track_id)
        cand = np.flatnonzero(found & (contact[at] == leaves.hist[:, -1]))
        owner = at[cand]  # the reported row (of ids) each candidate leaf may be
        tie = np.bincount(owner, minlength=ids.size)[owner] > 1
        gap = np.zeros(cand.size)
        if tie.any():  # several leaves of a family with the reported contact: the one whose estimate was reported
            tied = tr.take(cand[tie])
            x, _ = self.filter.estimate(tied.filt)
            missed = leaves.hist[cand[tie], -1] == NO_CONTACT
            if missed.any():
                moved = self.filter.predict(tied.filt, reported.time - tied.t2, check=False)
                x = np.where(missed[:, None], moved.gating.x, x)
            gap[tie] = np.abs(x - reported.state[rows[owner[tie]]]).sum(axis=1)
        pick = np.lexsort((gap, owner))
        first = pick[run_starts(owner[pick])]
        return ids[owner[first]], leaves.hist[cand[first]]


@numba.njit(cache=True, nogil=True)
def _children(parent, contact, observed, status, counts, scores, history, score, leaf_max, leaf_peak, leaf_hist,
              m, misses_to_delete, max_misses, score_rule, exist, own_confirm, own_delete, lower, upper, early, run,
              xy, azimuth, time):
    """The life cycle of `MHTTracker._branch`'s M children in one call: child i is leaf ``parent[i]``'s
    (of the L leaves' track fields status (L,), counts (L, 3), scores (L, 4), history (L, 8), `Tracks`) with
    ``contact[i]`` (NO_CONTACT: its miss) and the leaf score ``score[i]`` after it. Its M/N counters and contact
    history move on (`tracks.branched_moved`, where ``observed`` (M,)); its best score so far and the time it was
    reached move on from the parent's (``leaf_max``, ``leaf_peak`` (L,)); under the ``score_rule`` its status is
    Wald's test on the leaf score (`lifecycle.advance_score_kernel`, as `lifecycle.score_bounds` gives its
    thresholds from ``lower``, ``upper``, ``early``: the child's own confirmation threshold where
    ``own_confirm``, its own deletion threshold where ``own_delete``), else the M/N counters'; its contact
    window is the parent's ``leaf_hist`` (L, n_scan) moved on by its contact. Returns the children's status,
    counts, scores, history, best score, its time and contact window."""
    M, n = parent.size, leaf_hist.shape[1]
    new, counts, scores, history, low, up = branched_moved(parent, contact, observed, status, counts, scores, history,
                                                           m, misses_to_delete, max_misses, False, exist, own_confirm,
                                                           own_delete, lower, upper, early, run, xy, azimuth, time)
    max_score, peak = np.empty(M), np.empty(M)
    hist = np.empty((M, n), np.int64)
    for i in range(M):
        a, b = leaf_max[parent[i]], score[i]
        max_score[i] = a if (a >= b or a != a) else b  # np.maximum, NaN and ties included
        peak[i] = time if b >= a else leaf_peak[parent[i]]
        hist[i, :n - 1] = leaf_hist[parent[i], 1:]
        hist[i, n - 1] = contact[i]
    if score_rule:  # Wald's test on the leaf's score, M/N counts ignored
        new = advance_score_kernel(status[parent], score, max_score, observed, up, low, early, exist,
                                   counts[:, CONSECUTIVE], run)
    return new, counts, scores, history, max_score, peak, hist


@numba.njit(cache=True, nogil=True)
def _kept_children(parent, detected, family, before, status, filt, history, counts, scores, score, max_score, hist,
                   peak, x_pred, P_pred, d, quality, sanity, score_drop, confirmed_ids, mn, n_reasons):
    """The end of `MHTTracker._branch` for its M children in one call (child i of leaf ``parent[i]``, whose
    ``family`` (L,) id and status ``before`` the scan (L,) it inherits; ``detected`` (M,) where it took a
    contact; its fields after `_children`: ``status``, ``filt`` (x, P, mu), ``history``, ``counts``, ``scores``,
    ``score``, ``max_score``, ``hist``, ``peak``). The estimate to report is the posterior's where it took a contact
    (`imm_kernels.estimate` on the first ``d`` entries), else its parent's prediction (x_pred (L, d), P_pred (L, d,
    d)); the sanity rules judge it (`lifecycle.sanity_kernel` with ``sanity``, the track-quality rule at the clutter
    density ``quality`` (M,) m^-2); a child lives on unless its life cycle or a sanity rule deleted it or its score
    fell more than ``score_drop`` below its best. Returns the children kept (ascending), their fields
    (`Leaves._arrays`), their reported estimate (x, P) and the families lost in this scan by reason (`_lost`,
    with the sorted ``confirmed_ids``, ``mn`` and ``n_reasons``)."""
    M = parent.size
    x_post, P_post = estimate(filt[0], filt[1], filt[2], d)
    for i in range(M):
        if not detected[i]:
            x_post[i], P_post[i] = x_pred[parent[i]], P_pred[parent[i]]
    code = sanity_kernel(x_post, P_post, quality, *sanity)
    alive = np.empty(M, np.bool_)
    for i in range(M):
        alive[i] = status[i] != DELETED and score[i] >= max_score[i] - score_drop and code[i] == 0
    ids = family[parent]
    lost = _lost(ids, before[parent], status, score, code, alive, confirmed_ids, mn, n_reasons)
    kept = np.flatnonzero(alive)
    fields = (ids[kept], status[kept], filt[0][kept], filt[1][kept], filt[2][kept], history[kept], counts[kept],
              scores[kept], score[kept], max_score[kept], hist[kept], peak[kept])
    return kept, fields, (x_post[kept], P_post[kept]), lost


@numba.njit(cache=True, nogil=True)
def _reported(known, alive_ids, family, status, consecutive, contact, shown_x, shown_P, chosen, hide):
    """`MHTTracker._report` in one call. ``known`` holds every family reported before and alive (ids (F,), last
    reported x (F, d), P (F, d, d), whether ever reported confirmed (F,)); ``alive_ids`` the families that keep
    leaves after the scan; the L leaves' ``family``, ``status``, ``consecutive`` misses and last ``contact`` (L,)
    and reported estimate (shown_x (L, d), shown_P (L, d, d)); ``chosen`` the global hypothesis' leaves. A
    chosen leaf of a family still alive is reported (confirmed if its family ever was), unless confirmed with
    ``hide`` misses in a row or more (`lifecycle.misses_to_hide`); then each known family without leaves, as
    deleted with its last report. Returns the report (track_id, status, x, P, contact) and the new ``known``."""
    ids, x, P, confirmed = known
    chosen = chosen[among(family[chosen], alive_ids)]
    fam = family[chosen]
    now = np.empty(chosen.size, np.int8)
    was = among(fam, ids[confirmed])
    for i in range(chosen.size):
        now[i] = CONFIRMED if was[i] else status[chosen[i]]
    show = np.flatnonzero(~((now == CONFIRMED) & (consecutive[chosen] >= hide)))
    stale = ~among(ids, fam)
    ids = np.concatenate((ids[stale], fam))
    x = np.concatenate((x[stale], shown_x[chosen]))
    P = np.concatenate((P[stale], shown_P[chosen]))
    confirmed = np.concatenate((confirmed[stale], now == CONFIRMED))
    alive = among(ids, alive_ids)
    gone = np.flatnonzero(~alive)
    report = (np.concatenate((fam[show], ids[gone])),
              np.concatenate((now[show], np.full(gone.size, DELETED, np.int8))),
              np.concatenate((shown_x[chosen][show], x[gone])),
              np.concatenate((shown_P[chosen][show], P[gone])),
              np.concatenate((contact[chosen][show], np.full(gone.size, NO_CONTACT, np.int64))))
    return report, (ids[alive], x[alive], P[alive], confirmed[alive])


@numba.njit(cache=True, nogil=True)
def _lost(family, before, status, score, code, alive, confirmed_ids, mn, n_reasons):
    """The families `MHTTracker._branch` loses, over the L children (all (L,)): those none of whose children is
    ``alive``, each judged by its best-scoring child (the first of equal scores): counts (3 + ``n_reasons``,) of the
    unconfirmed, those ended by misses (``mn``) and by their score, then by each sanity reason (``code`` 1, 2,
    ...). A family is confirmed if its child's status ``before`` the scan was, or its id is among the sorted
    ``confirmed_ids`` (reported confirmed before)."""
    counts = np.zeros(3 + n_reasons, np.int64)
    order = np.argsort(family, kind="mergesort")
    start = 0
    while start < order.size:
        end, best, any_alive = start + 1, order[start], alive[order[start]]
        while end < order.size and family[order[end]] == family[order[start]]:
            k = order[end]
            any_alive |= alive[k]
            if score[k] > score[best]:
                best = k
            end += 1
        start = end
        if any_alive:
            continue
        if code[best] > 0:
            counts[2 + code[best]] += 1
            continue
        at = np.searchsorted(confirmed_ids, family[best])
        confirmed = before[best] == CONFIRMED or (at < confirmed_ids.size and confirmed_ids[at] == family[best])
        if not confirmed:
            counts[0] += 1
        elif mn and status[best] == DELETED:
            counts[1] += 1
        else:
            counts[2] += 1
    return counts


#: `_kept`'s merging key: the last three contacts of a leaf (fewer padded with this, never a contact index)
_NO_ENTRY = -9
_TAIL = numba.types.UniTuple(numba.types.int64, 3)


@numba.njit(cache=True, nogil=True)
def _kept(family, hist, score, chosen, tail, min_probability, per_family):
    """`MHTTracker._prune` before its global cap, over L leaves (``family`` (L,) ids, ``hist`` (L, n_scan),
    ``score`` (L,)) of which ``chosen`` (at most one per family) are the global hypothesis': a family with a
    chosen leaf keeps the leaves that agree with it in the oldest scan of the window, and no leaf keeps a
    contact that scan gave another family's chosen leaf (N-scan pruning); a leaf goes whose share of its
    family's likelihood, exp(score - best) / sum, is below ``min_probability``, and a leaf whose last ``tail``
    contacts (all contacts) equal those of a better leaf (the first of equal scores stays); the chosen leaves
    stay whatever the rest says; then each family keeps its chosen leaf and its best-scoring others (the first
    of equal scores), ``per_family`` in all. Returns the kept leaves, ascending."""
    L = family.size
    order = np.argsort(family, kind="mergesort")
    of = np.empty(L, np.int64)  # each leaf's family, numbered in id order
    head = np.empty(L + 1, np.int64)  # family f's leaves: order[head[f]:head[f + 1]], ascending
    F = 0
    for i in range(L):
        if i == 0 or family[order[i]] != family[order[i - 1]]:
            head[F] = i
            F += 1
        of[order[i]] = F - 1
    head[F] = L
    pick = np.full(F, -1, np.int64)
    for c in chosen:
        pick[of[c]] = c
    keep = np.ones(L, np.bool_)
    # N-scan pruning: the window's oldest scan is decided now
    owner = np.full(max(1, hist[:, 0].max() + 1) if L else 1, -1, np.int64)  # the family each contact went to
    for c in chosen:
        if hist[c, 0] >= 0:
            owner[hist[c, 0]] = of[c]
    for k in range(L):
        c, oldest = pick[of[k]], hist[k, 0]
        if c >= 0 and oldest != hist[c, 0]:
            keep[k] = False
        if oldest >= 0 and owner[oldest] >= 0 and owner[oldest] != of[k]:
            keep[k] = False
    # branch probability within the family
    top = np.full(F, -np.inf)
    for k in range(L):
        top[of[k]] = max(top[of[k]], score[k])
    total = np.zeros(F)
    for k in range(L):
        total[of[k]] += math.exp(score[k] - top[of[k]])
    for k in range(L):
        if not math.exp(score[k] - top[of[k]]) / total[of[k]] >= min_probability:
            keep[k] = False
    # merging: of the leaves with the same last contacts, the best
    n = hist.shape[1]
    best = numba.typed.Dict.empty(_TAIL, numba.types.int64)
    for k in range(L):
        entry = [_NO_ENTRY, _NO_ENTRY, _NO_ENTRY]
        full = True
        for j in range(tail):
            entry[3 - tail + j] = hist[k, n - tail + j]
            full &= hist[k, n - tail + j] >= 0
        if not full:
            continue
        key = (entry[0], entry[1], entry[2])
        if key not in best:
            best[key] = k
        elif score[k] > score[best[key]]:
            keep[best[key]] = False
            best[key] = k
        else:
            keep[k] = False
    # at most per_family leaves a family, the chosen one first
    kept = np.zeros(L, np.bool_)
    for f in range(F):
        room = per_family
        if pick[f] >= 0:
            kept[pick[f]] = True
            room -= 1
        rest = order[head[f]:head[f + 1]]
        rest = rest[keep[rest] & (rest != pick[f])]
        for k in rest[np.argsort(-score[rest], kind="mergesort")][:max(room, 0)]:
            kept[k] = True
    return np.flatnonzero(kept)
