"""The single-hypothesis trackers' scan (GNN, JPDA, neural): each track follows one contact sequence.

`SingleHypothesisTracker` is a `nnda.tracking.tracker.ContactTracker` whose
subclasses implement one hook, ``associate`` (steps of the framework's
module docstring); the scan's end after association (life cycle, sanity
rules, the estimates to report, the contacts used) is one compiled call
(`_finished`).
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Annotated

import numba
import numpy as np
from pydantic import Field

from nnda.data.dataset import Scan
from nnda.filters.imm import IMM, IMMPrediction, IMMState
from nnda.filters.imm_kernels import estimate
from nnda.filters.kalman import gate_probability
from nnda.tracking.assignment import given
from nnda.tracking.continuation import continuation_pairs
from nnda.tracking.lifecycle import SANITY_REASONS, predicted_log_odds, sanity_kernel
from nnda.tracking.linearisation import update as linearised_update
from nnda.tracking.lookup import sorted_find
from nnda.tracking.output import CONFIRMED, DELETED, NO_CONTACT, PRELIMINARY, TrackerOutput
from nnda.tracking.reports import Phase
from nnda.tracking.tracker import ContactTracker, ContactTrackerConfig, ScanContacts
from nnda.tracking.tracks import T0, Association, Shown, Tracks, scanned_moved


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



@numba.njit(cache=True, nogil=True)
def _finished(scan, ux, uP, umu, kx, kP, kmu, d, sanity, density, release, gx, gP, track_id, n_contacts):
    """The end of a scan for K tracks after association, in one call (`SingleHypothesisTracker._finish`).

    ``scan`` holds `scanned_moved`'s arguments (`Tracks.scan_args`: the contact each track used first);
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
    status, counts, scores, history = scanned_moved(*scan)
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

    learns_pd = True

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
        if self._learns(scan):
            self._count_detections(scan, tracks.status == CONFIRMED, seen, assoc.contact)
        if self._ends_at_peak:
            self._note_peaks(tracks, gain if seen is None else np.where(seen, gain, 0.0), scan.time)
        args = tracks.scan_args(assoc.contact, scan.z, scan.xy, scan.time, cfg, seen, gain)
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
        if cfg.report_existence is not None and alive is not None:
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
