"""The proposed method: association by the trained MLP scorer (spec §8.2-§8.3, A8, A10).

Each scan, for all live tracks at once:

1. *gate*: a contact is a candidate for a track if it lies in the azimuth
   sector of the track's last contact or one of its two neighbours, and if
   reaching it from that contact needs a speed of 30..400 m/s
   (`nnda.models.features.candidate_pairs`, the gating used for training:
   a compiled search of the contacts on a grid of the speed gate's reach,
   so the work grows with the candidate pairs, not with tracks x contacts);
2. *score*: the pair features of every candidate pair go through the numpy
   scorer in one call per scan. The features are those of the set the model
   was trained on (`nnda.models.feature_sets`), computed by the training
   code: the seed's [ΔV, Δα, ΔT] from the track's last two contacts and the
   candidate (`nnda.models.features.pair_features`), and for
   ``imm-innovation-9`` also the track's IMM prediction read against the
   candidate (`nnda.models.innovation.innovation_features`: normalised
   innovation, Mahalanobis distance, log |S|, CT probability, track age),
   and for ``imm-context-14`` also each pair's standing among the scan's
   pairs (`nnda.models.context`: rank and d² margin among its track's
   candidates, their count, the other tracks that have the contact as a
   candidate and their least d²), from the same arrays in a few sorts. The
   gate and the first two feature sets take one compiled call a scan
   (`nnda.models.innovation.scan_features`, the training code's kernels);
3. *select*: pairs scoring above ``threshold`` (default 0: the network says
   "target") are matched greedily by descending score (`greedy_matching`):
   the best pair of the scan is taken, its track and contact leave the
   game, and so on. So each track gets the highest-scoring candidate still
   free, each contact goes to at most one track, and when two tracks want
   the same contact the one that scores it higher wins and the other falls
   back to its next candidate above the threshold, if any (A10). With
   ``confirmed_first`` the confirmed tracks take their pick before the
   preliminary ones, as GNN and JPDA do (off by default: the spec's rule).
   With ``association = "global"`` (issue 20) the pairs above the threshold
   are instead assigned in one least-cost assignment per scan
   (`global_matching`): a pair costs the negative log-odds of its score
   (`nnda.models.scorer.score_log_odds`, p = (1 + s) / 2), and a track may
   miss at the cost of the threshold's log-odds (threshold 0: log-odds 0,
   p = 1/2; log-odds L is threshold tanh(L / 2)). So the scan's choice
   maximises the sum of the chosen pairs' log-odds above the threshold's,
   and a track whose best pick would block a better total yields it.
   ``confirmed_first`` then solves the confirmed tracks' assignment first and
   the preliminary tracks' on the contacts left;
   With ``coast_gate`` set (issue 20), a confirmed track that has missed
   ``coast_after`` scans in a row or more and got no pair above the
   threshold takes, of the contacts still free in its chi-square gate (2
   dof) on the IMM's prediction, the one of least Mahalanobis d², as GNN
   would (`reacquire`). The network's domain ends where a coasting track's
   pairs leave the training pairs' (ΔT after a detection gap) or the
   candidate gate (a slow target far out, whose noisy step from its last
   contact looks slower than 30 m/s); the IMM's innovation, whose
   covariance grows while it coasts, still judges there, as in MHT and GNN.
   With it, the score rule (``lifecycle.confirmation = "score"``) deletes
   the tracks kept alive on clutter once their target has gone. Under
   ``confirmed_first`` the confirmed tracks pick and re-acquire before the
   preliminary ones choose among the contacts left, so a track just opened
   on a coasting track's target cannot take its contacts from it. With
   ``gate_after_miss`` a confirmed track that missed its last scan takes a
   network pick only inside that gate, so a clutter contact the network
   accepts after a gap cannot drag the track off its target. With
   ``association = "served"`` (needs ``coast_gate`` and ``confirmed_first``)
   the confirmed tracks' network pairs and their re-acquisition pairs go
   into one assignment (`served_matching`) that serves as many tracks as it
   can, as GNN does, and of those assignments takes the one of greatest
   log-odds: a track does not take, for a slightly better score, the only
   contact in a coasting neighbour's gate when it has another it accepts.
   With ``retrodiction`` a confirmed track that took a contact last scan
   and is left with none now goes back one scan: the track as it would be
   had it missed that scan, predicted to now, takes the nearest free
   contact in its gate, if there is one (`_retrodicted`). This is MHT's
   deferred decision kept to one scan and one alternative: one clutter
   contact inside the gate at a manoeuvre or in a detection gap pulls the
   filter so far that the target falls outside the gate a scan later;
4. *filter*: the chosen contact updates the track's IMM. With the seed's
   features the filter smooths the output only (spec §7.2); with the
   extended set its prediction is also what the network reads.

Contacts left over go to initiation, as for every tracker.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Annotated, ClassVar, Literal

import numba
import numpy as np
from pydantic import Field, model_validator

from nnda.data.scenario import Sensor
from nnda.errors import ConfigError, ModelError, TrackingError
from nnda.filters.imm import IMMPrediction
from nnda.models.context import IMM_CONTEXT, with_context
from nnda.models.feature_sets import FEATURE_SETS
from nnda.models.innovation import IMM_INNOVATION, scan_features
from nnda.models.scorer import Scorer, load_model, score_log_odds
from nnda.tracking.assignment import greedy_kernel, greedy_matching, least_cost_assignment
from nnda.tracking.gating import Gated, gate, gate_tracks
from nnda.tracking.output import CONFIRMED, DELETED, NO_CONTACT
from nnda.tracking.tracker import (
    Association,
    ContactTrackerConfig,
    ScanContacts,
    SingleHypothesisTracker,
    TrackerConfig,
    Tracks,
    hard_update,
    only_sensor,
)

#: the recipe of a model whose metadata records none: oracle pairs of the training data alone
NO_RECIPE = {"encounters": 0, "dagger": 0}


def life4() -> dict:
    """The neural tracker's settings for coasting tracks that issue 20 kept ("life4" in the README and
    studies/neural-ablation.toml; the demo's ``nn-life``), as `NeuralConfig` fields (a new dict each call):
    a coasting confirmed track takes its nearest free contact in the IMM's 99 % gate, and after a miss a
    network pick only inside it; the confirmed tracks pick first, in one assignment with their
    re-acquisitions (``served``); the one-scan retrodiction; a track deleted in the scan it took a contact
    gives the contact back; the score rule with false_confirmation 1e-5 and false_deletion 5e-4."""
    return {"coast_gate": 9.21, "coast_after": 0, "confirmed_first": True, "gate_after_miss": True,
            "retrodiction": True, "association": "served", "release_on_deletion": True,
            "lifecycle": {"confirmation": "score", "false_confirmation": 1e-5, "false_deletion": 5e-4}}


class NeuralConfig(ContactTrackerConfig):
    """Neural tracker settings: the model file, the feature set expected of it, the decision threshold and
    the association rule."""

    model: Path = Field(description="trained model file (model.json) or a directory holding one")
    feature_set: Literal[tuple(FEATURE_SETS)] | None = Field(  # type: ignore[valid-type]
        None, description="the feature set the model must have been trained on; None: the model's own")
    threshold: Annotated[float, Field(ge=-1.0, lt=1.0, description="a pair is a match if its score "
                                      "exceeds this (the scorer's outputs lie in (-1, 1)); under "
                                      "association 'global' also a track's miss option, at the cost of "
                                      "this score's negative log-odds")] = 0.0
    confirmed_first: bool = Field(False, description="confirmed tracks choose before preliminary ones "
                                  "(as in GNN and JPDA); False: one pass over all tracks")
    recipe: dict[str, int | float] | None = Field(
        None, description="training recipe the model must record (metadata 'recipe' of `nnda train`, e.g. "
        "{ encounters = 60, dagger = 1 }; a model without one was trained with neither); None: any")
    association: Literal["greedy", "global", "served"] = Field(
        "greedy", description="'greedy': pairs taken by descending score (spec A10); 'global': one least-cost "
        "assignment per scan, a pair costing the negative log-odds of its score, a miss the threshold's; "
        "'served': one assignment serving the most tracks, the confirmed ones also through the free contacts "
        "in their coast_gate, then of greatest log-odds (`served_matching`; needs coast_gate and "
        "confirmed_first)")
    coast_gate: Annotated[float | None, Field(
        gt=0, description="chi-square gate (2 dof; 9.21: P_G = 0.99) on the IMM's prediction within which a "
        "coasting confirmed track with no pair above the threshold takes its free contact of least Mahalanobis "
        "d²; None: off (the network decides alone)")] = None
    coast_after: Annotated[int, Field(
        ge=0, description="consecutive misses from which a confirmed track counts as coasting for "
                          "coast_gate (0: every confirmed track without a pick)")] = 1
    gate_after_miss: bool = Field(
        False, description="a confirmed track that missed its last scan takes a network pick only inside "
        "coast_gate (the IMM's gate, as MHT and GNN gate every pick): after a gap the network's candidates "
        "are pairs it rarely saw in training; needs coast_gate")
    retrodiction: bool = Field(
        False, description="a confirmed track left without a contact in the scan after one it took goes back "
        "one scan: if the track as it would be had it missed that scan has a free contact in its coast_gate "
        "now, it takes that branch and the nearest such contact (MHT's choice deferred by one scan, for one "
        "hypothesis); needs coast_gate")
    release_on_deletion: bool = Field(
        False, description="a track its life cycle or a sanity rule deletes in the scan it took a contact gives "
        "the contact back: it ends on a miss at its prediction, and the contact is free to start a track (a "
        "coasting track of a target that has gone takes clutter, and the score rule then ends it)")

    @model_validator(mode="after")
    def _needs_gate(self) -> NeuralConfig:
        for field in ("gate_after_miss", "retrodiction"):
            if getattr(self, field) and self.coast_gate is None:
                raise ValueError(f"{field} needs coast_gate (the gate it applies)")
        if self.association == "served" and (self.coast_gate is None or not self.confirmed_first):
            raise ValueError("association 'served' needs coast_gate (the confirmed tracks' gate) and "
                             "confirmed_first")
        return self


class NeuralTracker(SingleHypothesisTracker):
    """IMM tracker whose associations are decided by the trained MLP scorer (the proposed method).

    The scorer is loaded once, at construction, from ``config.model``;
    a missing file, a foreign format, a model trained on a feature
    definition this nnda does not compute, or on another set than
    ``config.feature_set``, or with another training recipe than
    ``config.recipe``, is refused with a ConfigError naming the field.
    """

    name: ClassVar[str] = "nn"
    config_type: ClassVar[type[TrackerConfig]] = NeuralConfig

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: NeuralConfig) -> None:
        # the pair features (azimuth sectors, speeds from two contacts) are those of one radar's contacts
        super().__init__(only_sensor(self.name, sensors), config)
        try:
            self.scorer: Scorer = load_model(self.config.model)
        except ModelError as exc:
            raise ConfigError(f"{self.name} tracker config, field 'model': {exc}") from None
        wanted, trained = self.config.feature_set, self.scorer.features.name
        if wanted is not None and wanted != trained:
            raise ConfigError(f"{self.name} tracker config, field 'model': {self.config.model} was trained on "
                              f"feature set {trained!r}, but this tracker is configured for {wanted!r} "
                              f"(field 'feature_set'); train a model on {wanted!r} or change the field")
        if self.config.recipe is not None:
            recorded = {**NO_RECIPE, **self.scorer.metadata.get("recipe", {})}
            wrong = {k: recorded.get(k) for k, v in self.config.recipe.items() if recorded.get(k) != v}
            if wrong:
                raise ConfigError(f"{self.name} tracker config, field 'model': {self.config.model} was trained "
                                  f"with recipe {wrong}, but field 'recipe' asks for "
                                  f"{ {k: self.config.recipe[k] for k in wrong} }; retrain it or change the field")
        self._extended = self.scorer.features in (IMM_INNOVATION, IMM_CONTEXT)
        self._context = self.scorer.features is IMM_CONTEXT
        #: if set, called each scan with (scan index, track id (P,), contact row (P,), features (P, F)) of
        #: every pair scored (`nnda.tracking.harvest`)
        self.harvest: Callable[[int, np.ndarray, np.ndarray, np.ndarray], None] | None = None

    def reset(self) -> None:
        super().reset()
        self._gated_of: Gated | None = None  # the scan's IMM gate (`_gated`)
        self._last_scan: tuple[Tracks, np.ndarray] | None = None  # its tracks and contacts, for `_retrodicted`

    def associate(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts) -> Association:
        given = tracks  # the retrodiction may revise them (`_retrodicted`)
        contact = np.full(len(tracks), NO_CONTACT, np.int64)
        if not len(scan.z):
            self._last_scan = None
            return hard_update(scan.filter, pred, scan.z, contact)
        # the framework's arrays are checked already (scan checks, filter outputs): no second check here;
        # the scorer still refuses a non-finite feature
        track, cand, score = self._scored(tracks, pred, scan)
        self._gated_of = None  # this scan's IMM gate (`_gated`), computed once if needed
        if self.config.gate_after_miss:
            after_miss = (tracks.status[track] == CONFIRMED) & (tracks.consecutive[track] >= 1)
            if after_miss.any():
                g = self._gated(tracks, pred, scan)
                inside = _among(track * len(scan.z) + cand, g.rows * len(scan.z) + g.cols)
                keep = ~after_miss | inside
                track, cand, score = track[keep], cand[keep], score[keep]
        if self.config.confirmed_first:  # the confirmed tracks pick, and re-acquire, before the others
            first = tracks.status[track] == CONFIRMED
            if self.config.association == "served":
                self._served(contact, tracks, pred, scan, track[first], cand[first], score[first])
            else:
                self._pick(contact, track[first], cand[first], score[first])
            contact = self._reacquired(tracks, pred, scan, contact)
            tracks, pred, contact = self._retrodicted(tracks, pred, scan, contact)
            rest = ~first & ~_given(contact, len(scan.z))[cand]
            self._pick(contact, track[rest], cand[rest], score[rest])
        else:
            self._pick(contact, track, cand, score)
            contact = self._reacquired(tracks, pred, scan, contact)
            tracks, pred, contact = self._retrodicted(tracks, pred, scan, contact)
        if self.config.retrodiction:  # kept as they are; the branches are made only when the next scan asks
            self._last_scan = (tracks, contact)
        assoc = hard_update(scan.filter, pred, scan.z, contact)
        return assoc if tracks is given else Association(assoc.contact, assoc.filt, revised=(tracks, pred))

    def _scored(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The scan's candidate pairs (track, cand) (P,) (`candidate_pairs`) and the scorer's output (P,) for
        them, on the model's feature set (`scan_features`: the candidates and the seed's or the IMM-extended
        features in one call)."""
        ext = self._extended
        track, cand, features = scan_features(
            scan.filter, pred, pred.gating.measurement if ext else None, tracks.p1, tracks.t1,
            tracks.p2, tracks.t2, tracks.az2, tracks.t0, scan.xy, scan.z, scan.time, ext)
        if not track.size:
            return track, cand, np.empty(0)
        if self._context:
            features = with_context(features, track, cand)
        if self.harvest is not None:
            self.harvest(scan.index, tracks.track_id[track], cand, features)
        score = self.scorer(features)
        if not np.isfinite(score).all():  # NaN never beats the threshold: it would track nothing silently
            raise TrackingError(f"{self.name}: scan {scan.index}: the model {self.config.model} scored "
                                f"{int((~np.isfinite(score)).sum())} of {score.size} pairs as NaN; its "
                                f"weights or normaliser are broken: retrain it")
        return track, cand, score

    def _pick(self, contact: np.ndarray, track: np.ndarray, cand: np.ndarray, score: np.ndarray) -> None:
        """Write into ``contact`` (K,) the picks of the association rule (greedy or global) among the pairs
        (track, cand, score) (P,) above the threshold."""
        if self.config.association == "greedy":
            match = score > self.config.threshold
            chosen_track, chosen_contact = greedy_matching(track[match], cand[match], score[match])
        elif self.config.association == "global":
            chosen_track, chosen_contact = global_matching(track, cand, score, self.config.threshold)
        else:
            none = np.empty(0, np.int64)
            chosen_track, chosen_contact = served_matching(track, cand, score, self.config.threshold, none, none,
                                                           np.empty(0))
        contact[chosen_track] = chosen_contact

    def _served(self, contact: np.ndarray, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts,
                track: np.ndarray, cand: np.ndarray, score: np.ndarray) -> None:
        """Write into ``contact`` (K,) the confirmed tracks' picks under association 'served': their pairs
        (track, cand, score) (P,) and, for those that count as coasting (``coast_after``), the contacts in
        their IMM gate of ``coast_gate`` (`_gated`), in one `served_matching`."""
        g = self._gated(tracks, pred, scan)
        near = self._coasting(tracks)[g.rows]
        rows, cols = served_matching(track, cand, score, self.config.threshold, g.rows[near], g.cols[near],
                                     g.d2[near])
        contact[rows] = cols

    def _reacquired(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts, contact: np.ndarray
                    ) -> np.ndarray:
        """``contact`` (K,) with the picks (`reacquire`) of the coasting confirmed tracks left without one,
        among the free contacts in their IMM gate of ``coast_gate`` (`gate_tracks`); unchanged when the
        gate is off."""
        cfg = self.config
        if cfg.coast_gate is None:
            return contact
        waiting = self._coasting(tracks) & (contact == NO_CONTACT)
        if not waiting.any():
            return contact
        g = self._gated(tracks, pred, scan)
        rows, cols = reacquire(g.rows, g.cols, g.d2, waiting, _given(contact, len(scan.z)), cfg.coast_gate)
        contact = contact.copy()
        contact[rows] = cols
        return contact

    def _coasting(self, tracks: Tracks) -> np.ndarray:
        """(K,) True for the confirmed tracks that count as coasting for ``coast_gate`` (``coast_after``)."""
        return (tracks.status == CONFIRMED) & (tracks.consecutive >= self.config.coast_after)

    def _retrodicted(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts, contact: np.ndarray
                     ) -> tuple[Tracks, IMMPrediction, np.ndarray]:
        """The retrodiction (``retrodiction``): the confirmed tracks that took a contact last scan and have
        none in ``contact`` (K,) now, replaced by their branch without that contact (`_skipping`) where the
        branch's prediction has free contacts in its gate of ``coast_gate``, each with the nearest of them
        (`reacquire`). Returns the revised (tracks, prediction, contact): the same objects when no track goes
        back."""
        unchanged = tracks, pred, contact
        if self._last_scan is None:
            return unchanged
        lost = np.flatnonzero((contact == NO_CONTACT) & (tracks.status == CONFIRMED) & (tracks.consecutive == 0))
        if not lost.size:
            return unchanged
        skipped = self._skipping(*self._last_scan)
        if skipped is None:
            return unchanged
        # track ids ascend in both (tracks keep their order; new ones come last, with higher ids)
        at = np.minimum(np.searchsorted(skipped.track_id, tracks.track_id[lost]), len(skipped) - 1)
        known = skipped.track_id[at] == tracks.track_id[lost]
        lost, at = lost[known], at[known]
        if not lost.size:
            return unchanged
        branch = skipped.take(at)
        branch_pred = scan.filter.predict(branch.filt, scan.time - branch.t2, check=False)
        g = gate_tracks(scan.filter, branch_pred, scan.z, scan.xy, self.config.coast_gate, check=False)[1]
        rows, cols = reacquire(g.rows, g.cols, g.d2, np.ones(lost.size, bool), _given(contact, len(scan.z)),
                               self.config.coast_gate)
        if not rows.size:
            return unchanged
        index = np.arange(len(tracks))
        index[lost[rows]] = len(tracks) + rows
        contact = contact.copy()
        contact[lost[rows]] = cols
        self._gated_of = None  # the revised tracks' gate differs
        return (Tracks.concat([tracks, branch]).take(index), IMMPrediction.concat([pred, branch_pred]).take(index),
                contact)

    def _skipping(self, tracks: Tracks, contact: np.ndarray) -> Tracks | None:
        """The confirmed tracks of last scan's ``tracks`` (K,) that took a contact in its ``contact`` (K,), as
        they would be had they missed it instead (the branches of `_retrodicted`): their last posterior kept,
        the miss counted in their life cycle and score; the ones such a miss deletes left out (None: no
        track left)."""
        rows = np.flatnonzero((contact != NO_CONTACT) & (tracks.status == CONFIRMED))
        if not rows.size:
            return None
        kept = tracks.take(rows)
        gain = None if self.confirmation_rule == "mn" else np.full(rows.size, self._log_miss)
        none = np.empty((0, 2))  # a miss reads no contact
        missed = kept.after_scan(np.full(rows.size, NO_CONTACT), kept.filt, none, none, np.nan,
                                 self.config.lifecycle, None, gain)
        alive = missed.status != DELETED
        return None if not alive.any() else missed if alive.all() else missed.take(alive)

    def _gated(self, tracks: Tracks, pred: IMMPrediction, scan: ScanContacts) -> Gated:
        """The pairs inside the confirmed tracks' IMM gate of ``coast_gate`` this scan (`gate` on
        ``pred.gating``, limited to their rows; rows index ``tracks``), computed once: every use of the gate
        is a confirmed track's, and the clutter's preliminary tracks outnumber them."""
        if self._gated_of is None:
            g = pred.gating
            self._gated_of = gate(scan.filter, g.measurement, scan.z, scan.xy, self.config.coast_gate, (g.x, g.P),
                                  rows=np.flatnonzero(tracks.status == CONFIRMED), check=False)
        return self._gated_of


def global_matching(rows: np.ndarray, cols: np.ndarray, score: np.ndarray, threshold: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """One-to-one matching of candidate pairs of least total cost, with a miss option per row.

    ``rows``, ``cols`` (P,) index the pairs' tracks and contacts, ``score``
    (P,) their scores in [-1, 1]. A pair costs -log-odds of its score
    (`score_log_odds`); a row may miss at -log-odds of ``threshold``, so a
    pair scoring at most ``threshold`` is never worth taking. Returns the
    assigned (rows, cols) of `least_cost_assignment`, or, when no contact is
    any other row's candidate too, each row's best pair above ``threshold``
    (the same optimum, found by `greedy_matching` without the solver).
    """
    rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
    keep = score > threshold
    rows, cols, score = rows[keep], cols[keep], score[keep]
    if rows.size == 0 or np.bincount(cols).max() == 1:
        return greedy_matching(rows, cols, score)
    miss = np.full(int(rows.max()) + 1, -score_log_odds(threshold))
    return least_cost_assignment(rows, cols, -score_log_odds(score), miss)


def served_matching(rows: np.ndarray, cols: np.ndarray, score: np.ndarray, threshold: float,
                    gate_rows: np.ndarray, gate_cols: np.ndarray, gate_d2: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """One-to-one matching that serves the most rows, and of those the one the network likes best.

    ``rows``, ``cols`` (P,) index the network's candidate pairs, ``score`` (P,)
    their scores in [-1, 1]; a pair above ``threshold`` is worth its log-odds
    above the threshold's (`score_log_odds`). ``gate_rows``, ``gate_cols``,
    ``gate_d2`` (Q,) are pairs a row may take on the IMM's word alone (inside
    its gate), worth nothing beyond a tie-break towards the least d² (a pair
    in both lists is worth its score). A row may miss. The matching has the
    most pairs (GNN's aim: each pair is worth more than any sum of log-odds)
    and, among those, the greatest total log-odds, then the least total d²
    of its gate-only pairs. Returns the assigned (rows, cols) of
    `least_cost_assignment`, or, when no contact is in two rows' pairs, each
    row's best pair (`greedy_matching`: the same optimum without the solver).
    """
    done, rows, cols, worth, tie = _served_pairs(
        np.asarray(rows, np.int64), np.asarray(cols, np.int64), np.asarray(score, np.float64), float(threshold),
        np.asarray(gate_rows, np.int64), np.asarray(gate_cols, np.int64), np.asarray(gate_d2, np.float64))
    if done:  # no contact wanted twice: each row's best pair (most scans; no solver)
        return rows, cols
    unit = 1.0 + 2.0 * float(worth.sum())  # a pair more outweighs every sum of log-odds
    return least_cost_assignment(rows, cols, tie - worth - unit, np.zeros(int(rows.max()) + 1))


@numba.njit(cache=True, nogil=True)
def _served_pairs(rows, cols, score, threshold, gate_rows, gate_cols, gate_d2):
    """The pairs of `served_matching`: the network's above ``threshold``, worth their log-odds above its,
    with no tie-break, then the gate pairs not among them, worth 0, with tie-break 1e-6 d². Returns whether
    the matching is done and the rows, cols (M,) and, if it is not, their worth and tie (M,): done when no
    column occurs twice, the rows and cols then those of each row's best pair (`greedy_kernel` on worth -
    tie), or when there is no pair. One compiled pass: this runs twice a scan, where a dozen numpy calls
    cost ~0.1 ms."""
    keep = np.flatnonzero(score > threshold)
    n = 1
    for c in cols[keep]:
        n = max(n, c + 1)
    for c in gate_cols:
        n = max(n, c + 1)
    taken = np.sort(rows[keep] * n + cols[keep])
    extra = np.flatnonzero(~_among(gate_rows * n + gate_cols, taken))  # a network pair keeps its own worth
    m = keep.size + extra.size
    out_rows, out_cols = np.empty(m, np.int64), np.empty(m, np.int64)
    worth, tie = np.zeros(m), np.zeros(m)
    base = score_log_odds(threshold)
    for k, i in enumerate(keep):
        out_rows[k], out_cols[k], worth[k] = rows[i], cols[i], score_log_odds(score[i]) - base
    for k, i in enumerate(extra):
        j = keep.size + k
        out_rows[j], out_cols[j], tie[j] = gate_rows[i], gate_cols[i], 1e-6 * gate_d2[i]
    wanted = np.zeros(n, np.int64)
    contested = False
    for c in out_cols:
        wanted[c] += 1
        contested |= wanted[c] > 1
    if m == 0 or contested:
        return m == 0, out_rows, out_cols, worth, tie
    picked_rows, picked_cols = greedy_kernel(out_rows, out_cols, worth - tie)
    return True, picked_rows, picked_cols, worth, tie


def reacquire(rows: np.ndarray, cols: np.ndarray, d2: np.ndarray, waiting: np.ndarray, taken: np.ndarray,
              gate: float) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-neighbour picks of the rows still ``waiting`` for a contact, by the IMM's gate.

    ``rows``, ``cols`` (P,) index the candidate pairs' tracks and contacts, ``d2`` (P,) their squared
    Mahalanobis distances; ``waiting`` (K,) flags the tracks that may pick, ``taken`` (N,) the contacts
    already given. Pairs of a waiting row with a free contact and d² <= ``gate`` are matched one-to-one
    by ascending d² (`greedy_matching`). Returns the (rows, cols) picked.
    """
    free = waiting[rows] & (d2 <= gate) & ~taken[cols]
    return greedy_matching(rows[free], cols[free], -d2[free])


def _given(contact: np.ndarray, n: int) -> np.ndarray:
    """(n,) True for the contacts some track of ``contact`` (K,) took (np.isin costs tens of µs a call)."""
    given = np.zeros(n, bool)
    given[contact[contact != NO_CONTACT]] = True
    return given


@numba.njit(cache=True, nogil=True)
def _among(keys: np.ndarray, sorted_keys: np.ndarray) -> np.ndarray:
    """(P,) True for the ``keys`` found in ``sorted_keys`` (ascending), by binary search (compiled: also
    called from `_served_pairs`)."""
    if not sorted_keys.size:
        return np.zeros(keys.size, np.bool_)
    pos = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return sorted_keys[pos] == keys
