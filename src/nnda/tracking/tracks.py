"""Track records: K live tracks in batched arrays, and what a scan decides for them.

`Tracks` packs each track's id, status, filter state, contact history, M/N
counters and scores by kind, one array each, with named column views; its
scan step (`Tracks.after_scan`) moves the counters, the score, the status and
the contact history in one compiled call. `Association` is what an
association method returns for a scan, `Shown` one block of a scan's output.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from nnda.filters.batch import Batch
from nnda.filters.imm import IMMPrediction, IMMState
from nnda.tracking.lifecycle import (
    LifecycleConfig,
    advance_kernel,
    advance_score_kernel,
    everywhere,
    miss_run,
    score_bounds,
)
from nnda.tracking.output import NO_CONTACT

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
        everywhere), in one compiled call (`scanned_moved`)."""
        status, counts, scores, history = scanned_moved(*self.scan_args(contact, z, xy, time, lifecycle, observed,
                                                                          score_gain))
        return Tracks(self.track_id, status, filt, history, counts, scores)

    def scan_args(self, contact: np.ndarray, z: np.ndarray, xy: np.ndarray, time: float,
                   lifecycle: LifecycleConfig, observed: np.ndarray | None, score_gain: np.ndarray | None) -> tuple:
        """The arguments of `scanned_moved` for `after_scan`'s."""
        K, cfg = len(contact), lifecycle
        score_rule = cfg.confirmation != "mn"
        confirm_at = np.ascontiguousarray(self.scores[:, CONFIRM_AT])  # one compiled layout, whichever rule
        lower, upper, early = (score_bounds(cfg, K, confirm_at, self.scores[:, DELETE_AT]) if score_rule
                               else (confirm_at, confirm_at, 0.0))
        return (contact, everywhere(observed, K), self.status, self.counts, cfg.m, cfg.n - cfg.m + 1,
                cfg.max_misses, self.scores, np.zeros(K) if score_gain is None else score_gain,
                score_gain is not None, score_rule, cfg.confirmation == "existence", lower, upper, early,
                miss_run(cfg), self.history, xy, np.ascontiguousarray(z[:, 1]), time)

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
def _joined(a, b):
    """The arrays of `Tracks._arrays` ``a`` then ``b``, concatenated field by field."""
    return (np.concatenate((a[0], b[0])), np.concatenate((a[1], b[1])), np.concatenate((a[2], b[2])),
            np.concatenate((a[3], b[3])), np.concatenate((a[4], b[4])), np.concatenate((a[5], b[5])),
            np.concatenate((a[6], b[6])), np.concatenate((a[7], b[7])))


@numba.njit(cache=True, nogil=True)
def table_rows(a, rows):
    """A table of tracks taken at ``rows`` (M,): ``a`` its twelve arrays, the eight of its `Tracks`
    (`Tracks._arrays`) and four the table adds per track (MHT's leaves, the labelled trackers' rows), each at
    ``rows``, in one call."""
    return (a[0][rows], a[1][rows], a[2][rows], a[3][rows], a[4][rows], a[5][rows], a[6][rows], a[7][rows],
            a[8][rows], a[9][rows], a[10][rows], a[11][rows])


@numba.njit(cache=True, nogil=True)
def tables_joined(a, b):
    """Two tables of tracks as one: `table_rows`' twelve arrays ``a``, then ``b``'s, concatenated array by array."""
    return (np.concatenate((a[0], b[0])), np.concatenate((a[1], b[1])), np.concatenate((a[2], b[2])),
            np.concatenate((a[3], b[3])), np.concatenate((a[4], b[4])), np.concatenate((a[5], b[5])),
            np.concatenate((a[6], b[6])), np.concatenate((a[7], b[7])), np.concatenate((a[8], b[8])),
            np.concatenate((a[9], b[9])), np.concatenate((a[10], b[10])), np.concatenate((a[11], b[11])))


@numba.njit(cache=True, nogil=True)
def scanned_moved(contact, observed, status, counts, m, misses_to_delete, max_misses, scores, gain, scored,
                   score_rule, exist, lower, upper, early, run, history, xy, azimuth, time):
    """`_scanned`, then `_moved_history`: (status, counts, scores, history)."""
    return (_scanned(contact, observed, status, counts, m, misses_to_delete, max_misses, scores, gain, scored,
                     score_rule, exist, lower, upper, early, run)
            + (_moved_history(contact, history, xy, azimuth, time),))


def branching_args(cfg: LifecycleConfig) -> tuple:
    """`branched_moved`'s settings from the life cycle ``cfg``, from ``m`` to ``run``: the M/N counts, whether a score
    rule (and which) decides the status, whether each child's own thresholds replace the scalar ones of
    `lifecycle.score_bounds`, those scalars and `lifecycle.miss_run`."""
    lower, upper, early = cfg.score_limits
    return (cfg.m, cfg.n - cfg.m + 1, cfg.max_misses, cfg.confirmation != "mn", cfg.confirmation == "existence",
            cfg.confirmation != "existence", cfg.confirmation == "adaptive", lower, upper, early, miss_run(cfg))


@numba.njit(cache=True, nogil=True)
def branched_moved(parent, contact, observed, status, counts, scores, history, m, misses_to_delete, max_misses,
                   score_rule, exist, own_confirm, own_delete, lower, upper, early, run, xy, azimuth, time):
    """`scanned_moved` (no score gain) of the children of rows ``parent`` (M,) of K tracks' status (K,), counts (K,
    3), scores (K, 4) and history (K, 8), with the score test's thresholds of `lifecycle.score_bounds`: the scalars
    ``lower`` and ``upper``, or per child its own confirmation threshold (``own_confirm``, column `CONFIRM_AT` of its
    scores) and its own deletion threshold (``own_delete``, column `DELETE_AT`). Returns the children's status,
    counts, scores and history, and those thresholds (lower, upper (M,) each)."""
    M = parent.size
    p_scores = scores[parent]
    low, up = np.full(M, lower), np.full(M, upper)
    for i in range(M):
        if own_confirm:
            up[i] = p_scores[i, CONFIRM_AT]
        if own_delete:
            low[i] = p_scores[i, DELETE_AT]
    return scanned_moved(contact, observed, status[parent], counts[parent], m, misses_to_delete, max_misses, p_scores,
                         np.zeros(M), False, score_rule, exist, low, up, early, run, history[parent], xy, azimuth,
                         time) + (low, up)


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
