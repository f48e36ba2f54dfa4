"""A fixed-lag output for any tracker: the estimate of scan k - L with the decisions of scans up to k.

    lagged = FixedLag(tracker, lag=3)
    for scan in dataset.scans():
        online, late = lagged.step(scan)       # late: scan k - 3's revised output (None for the first 3 scans)
    rest = lagged.flush()                      # the last 3 scans' revised outputs, at the end of a run

`FixedLag` steps the tracker, keeps its last L + 1 outputs (scans k - L..k) and, once it has them, revises
the oldest one (Stone Soup's fixed-lag smoothers and MHT's N-scan decision are the anchors):

* **back-fill**: a track still preliminary at k - L that is reported CONFIRMED at any scan up to k is
  reported CONFIRMED at k - L (same track id): the confirmation delay no longer costs coverage;
* **smoothing**: the state (x, P) at k - L of a track reported in consecutive scans from k - L on is the
  Rauch-Tung-Striebel pass over its reported estimates up to the last of those scans (at most k), with the
  tracker's motion model (`LagMotion`). The estimates are the combined estimates of the IMM trackers, so
  the pass runs on them with one model, the IMM's one-step prediction of a combined estimate moment-matched
  to a linear one: the constant-velocity transition of the shared [x, vx, y, vy] (the coordinated turn's
  at a zero turn rate), and as process noise the models' noise weighted by the transition matrix's
  stationary model probabilities plus the coordinated turn's spread of its prior turn-rate variance along
  d f / d omega. The IMM's own prediction is wider where its model probabilities or turn rate have moved
  from those priors (a manoeuvre), and it was at least as wide as the filtered covariance it led to (an
  update never widens a covariance): where the model's predicted covariance falls short of the next
  filtered one, it is raised by the positive part of the difference. Without that bound the pass trusts
  the motion more than the filter did, and its "smoothed" positions come out worse than the filtered
  ones; with it, the smoothed covariance never exceeds the filtered one. This is an approximation of the IMM
  smoother (which runs one RTS pass per model and mixes them backwards with each track's own model
  probabilities, states the outputs do not carry); it is exact for a single CV model. A track deleted in
  the window (reported DELETED at any of scans k - L..k) keeps its filtered states; so does every track of
  a tracker without a motion model (`LagMotion.of` gives None: the PHD trackers, the peers), whose lagged
  output is the back-fill;
* **decided contacts**: a tracker that revises its earlier associations (`RevisesBranches`: MHT, whose
  track families keep each leaf's contacts of the last ``n_scan`` scans) reports, for each of its tracks
  at k - L, the contact of the current best global hypothesis's branch (the N-scan decision; from
  ``n_scan`` scans back on, the decision is final and stays as it was made). MHT's reported states of
  earlier scans may belong to branches that lost since; the smoothing takes them as they were reported.

* **ended tracks**: a track confirmed at k - L and reported DELETED within the window, with no contact from
  k - L up to its deletion, was coasting on a target that had gone (or never was): it is reported DELETED
  at k - L, the first scan of that coasted tail, and its rows in the later lagged outputs are dropped. A
  confirmed track no longer outlives its target by the scans its deletion rule waits; a track that coasts
  through a gap and then gets a contact again is not touched.
* **score peaks**: a tracker that tells when each track it deleted had its score at its maximum
  (`EndsAtScorePeak`: gnn, jpda, nn and mht with ``end_at_score_peak``, their default) has a confirmed track
  reported DELETED within the window ended at k - L when k - L comes after that maximum, contacts or not. The
  score-drop deletion (the score fallen a fixed amount below its maximum) is Page (1954)'s CUSUM test for a
  change from "target" to "clutter", and the test's estimate of when the change came is the last maximum of
  the score: from there on the track's contacts were, taken together, against its target. Where clutter is
  dense, a track that lost its target takes a clutter contact now and then (its gate grows with each miss),
  which the rule above, needing a contact-free tail, does not end.

The lagged output of a scan has the same tracks in the same order as its online output, but for the ended
tracks' dropped rows (no track is added): only status, state, covariance and contact may differ. With lag 0
(or a window of one output, as for the last scan of `flush`) the online output itself is returned.

Cost: one compiled call per scan over the window's reports (`_revised`), no Python loop over tracks;
MHT adds one vectorised look-up of its chosen leaves (`MHTTracker.best_branch`).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numba
import numpy as np

from nnda.data.dataset import Scan
from nnda.errors import ConfigError
from nnda.filters.imm import IMM
from nnda.filters.motion import CoordinatedTurn
from nnda.tracking.lookup import members, sorted_find
from nnda.tracking.output import CONFIRMED, DELETED, MAX_LAG, NO_CONTACT, PRELIMINARY, TrackerOutput
from nnda.tracking.protocol import Tracker


@runtime_checkable
class RevisesBranches(Protocol):
    """The optional capability of a tracker that revises its earlier associations (MHT).

    ``best_branch(reported)`` takes the output the tracker just returned and gives, for the tracks of
    that output it still holds hypotheses for, their ids (K,) and the contact each used in each of its
    last n scans on the branch the current best global hypothesis chose, (K, n) oldest first
    (`NO_CONTACT` a miss, any other negative value unknown); n is the tracker's decision depth.
    """

    def best_branch(self, reported: TrackerOutput) -> tuple[np.ndarray, np.ndarray]:
        ...


@runtime_checkable
class EndsAtScorePeak(Protocol):
    """The optional capability of a tracker that knows when each track it deleted last had its score at its
    maximum (the module docstring's score peaks).

    ``keep_score_peaks()`` asks the tracker, before its first scan, to keep its tracks' score peaks (work an
    online run does not need). ``score_peaks(reported)`` takes the output the tracker just returned and gives
    the ids (D,) of the tracks it reports DELETED and the time (s) of each one's last score maximum (D,); none
    where it does not tell.
    """

    def keep_score_peaks(self) -> None:
        ...

    def score_peaks(self, reported: TrackerOutput) -> tuple[np.ndarray, np.ndarray]:
        ...


@dataclass(frozen=True)
class LagMotion:
    """The motion model of the reported [x, vx, y, vy] the smoothing uses: the constant-velocity transition
    F(T) and the process noise Q(T) = T B0 + T^2 B1 + T^3 B2 + T^4 B3 of ``basis`` (4, 4, 4), plus ``turn_var``
    (rad/s)^2 J J^T, the spread of a turn-rate uncertainty: J = d f / d omega at omega = 0, (-vy T^2 / 2,
    -vy T, vx T^2 / 2, vx T) at the estimate's velocity (0 for a model without turns)."""

    basis: np.ndarray
    turn_var: float = 0.0

    @classmethod
    def of(cls, tracker: Tracker) -> LagMotion | None:
        """The motion of a tracker whose per-track filter (its ``filter`` attribute) is an `IMM`: the models'
        noise on the shared [x, vx, y, vy] and the coordinated-turn models' prior turn-rate variance
        (``omega_var0``), weighted by the stationary probabilities of the IMM's transition matrix (module
        docstring); None for a tracker without one (no smoothing)."""
        imm = getattr(tracker, "filter", None)
        if not isinstance(imm, IMM) or imm.output_dim != 4:
            return None
        weight = stationary(np.array(imm.tpm))
        basis = sum(w * np.asarray(m.noise_basis)[:, :4, :4] for w, m in zip(weight, imm.models))
        turn = sum(w * m.omega_var0 for w, m in zip(weight, imm.models) if isinstance(m, CoordinatedTurn))
        return cls(np.ascontiguousarray(basis, dtype=float), float(turn))


def stationary(tpm: np.ndarray) -> np.ndarray:
    """The stationary distribution pi = pi T of a row-stochastic transition matrix (r, r) (the solution of
    the balance equations with sum(pi) = 1; a reducible chain gives one of its stationary distributions)."""
    r = tpm.shape[0]
    A = np.vstack([tpm.T - np.eye(r), np.ones((1, r))])
    pi = np.linalg.lstsq(A, np.r_[np.zeros(r), 1.0], rcond=None)[0]
    pi = np.clip(pi, 0.0, None)
    return pi / pi.sum()


def checked_lag(lag: object, where: str = "lag") -> int:
    """``lag`` as an int in [0, `MAX_LAG`]; ConfigError naming ``where`` and the value otherwise."""
    if isinstance(lag, bool) or not isinstance(lag, (int, np.integer)) or not 0 <= lag <= MAX_LAG:
        raise ConfigError(f"{where} = {lag!r}: give a whole number of scans from 0 (the online output only) to "
                          f"{MAX_LAG}")
    return int(lag)


class FixedLag:
    """``tracker`` with a fixed-lag output ``lag`` scans behind its online one (module docstring).

    ``step(scan)`` returns the tracker's online output of the scan and the revised output of the scan
    ``lag`` scans earlier (None until there is one); ``flush()`` the revised outputs of the scans still
    held, at the end of a run, so that every scan of the run has one lagged output, in scan order.
    ``revise(online)`` is the second half of ``step`` for a caller that steps the tracker itself.
    ``reset()`` resets the tracker and forgets the held outputs.
    """

    def __init__(self, tracker: Tracker, lag: int) -> None:
        self.tracker = tracker
        self.lag = checked_lag(lag)
        self.motion = LagMotion.of(tracker)
        self.revises = isinstance(tracker, RevisesBranches)
        self.peaks = isinstance(tracker, EndsAtScorePeak)
        if self.peaks:
            tracker.keep_score_peaks()
        self._held: deque[tuple[TrackerOutput, np.ndarray | None]] = deque()
        self._ended = np.empty(0, np.int64)  # ids of the ended tracks (module docstring), sorted
        #: the tracks deleted in the held scans that the tracker told a score peak of: ids, sorted, and times (s)
        self._peaks = (np.empty(0, np.int64), np.empty(0))

    def reset(self) -> None:
        self.tracker.reset()
        self._held.clear()
        self._ended = np.empty(0, np.int64)
        self._peaks = (np.empty(0, np.int64), np.empty(0))

    def step(self, scan: Scan) -> tuple[TrackerOutput, TrackerOutput | None]:
        """The tracker's output of ``scan`` and the revised output of the scan ``lag`` scans before (None
        while fewer scans have passed; with lag 0 the online output itself)."""
        online = self.tracker.step(scan)
        return online, self.revise(online)

    def revise(self, online: TrackerOutput) -> TrackerOutput | None:
        """`step`'s second half, for a caller that steps the tracker itself (and times it apart): take
        ``online``, the output the tracker just returned, and give the revised output ``lag`` scans back."""
        if self.lag == 0:
            return online
        self._held.append((online, None))
        if self.revises:
            self._decide(online)
        if self.peaks:
            self._note_peaks(online)
        if len(self._held) <= self.lag:
            return None
        return self._emit()

    def flush(self) -> list[TrackerOutput]:
        """The revised outputs of the scans held (the run's last ``lag`` scans or fewer), oldest first."""
        out = []
        while self._held:
            out.append(self._emit())
        return out

    def _emit(self) -> TrackerOutput:
        """The revised output of the oldest held scan, which is then let go."""
        window = [o for o, _ in self._held]
        contact = self._held[0][1]
        self._held.popleft()
        out = revised(window, self.motion, contact)
        if self._peaks[0].size:
            out = self._ended_at_peak(window[0], out)
        keep = ~members(out.track_id, self._ended)
        ended = out.track_id[keep & (out.status == DELETED) & (window[0].status != DELETED)]
        if ended.size:
            self._ended = np.union1d(self._ended, ended)
        if keep.all():
            return out
        return TrackerOutput(out.scan, out.time, out.track_id[keep], out.status[keep], out.state[keep],
                             out.covariance[keep], out.contact[keep])

    def _note_peaks(self, online: TrackerOutput) -> None:
        """Keep the score peaks the tracker tells of the tracks ``online`` reports DELETED (`EndsAtScorePeak`)."""
        ids, time = self.tracker.score_peaks(online)
        if not ids.size:
            return
        known, at = self._peaks
        ids, time = np.concatenate([known, ids]), np.concatenate([at, time])
        order = np.argsort(ids, kind="stable")
        self._peaks = (ids[order], time[order])

    def _ended_at_peak(self, first: TrackerOutput, out: TrackerOutput) -> TrackerOutput:
        """``out``, the revised output of ``first``, with its confirmed tracks that were deleted in the window
        after their score's last peak, at a time before ``first``'s, reported DELETED (module docstring);
        the peaks of the tracks ``first`` reports DELETED are then let go."""
        known, time = self._peaks
        at, found = sorted_find(known, first.track_id)
        ended = found & (first.status == CONFIRMED) & (time[at] < first.time)
        gone = members(known, first.track_id[first.status == DELETED])
        if gone.any():
            self._peaks = (known[~gone], time[~gone])
        if not ended.any():
            return out
        status = np.where(ended, DELETED, out.status).astype(out.status.dtype)
        return TrackerOutput(out.scan, out.time, out.track_id, status, out.state, out.covariance, out.contact)

    def _decide(self, online: TrackerOutput) -> None:
        """The contacts of the held scans on the current best branch of each track (`RevisesBranches`): the
        branch's history reaches n scans back; older decisions stay as they were last revised."""
        family, hist = self.tracker.best_branch(online)
        if not family.size:
            return
        order = np.argsort(family, kind="stable")
        family, hist = family[order], hist[order]
        n = hist.shape[1]
        held = len(self._held)
        for back in range(1, min(n, held)):  # scans k-1 .. k-n+1 (the current scan's contacts are reported)
            i = held - 1 - back
            out, contact = self._held[i]
            if not len(out):
                continue
            at, found = sorted_find(family, out.track_id)
            branch = hist[at, n - 1 - back]
            use = found & ((branch >= 0) | (branch == NO_CONTACT))
            if not use.any():
                continue
            contact = (out.contact if contact is None else contact).copy()
            contact[use] = branch[use]
            self._held[i] = (out, contact)


def revised(window: list[TrackerOutput], motion: LagMotion | None, contact: np.ndarray | None = None
            ) -> TrackerOutput:
    """The revised output of ``window[0]`` given the outputs of the scans after it, ``window[1:]`` (module
    docstring: back-fill, an ended track's status and, with ``motion``, smoothing); ``contact`` (K,) replaces
    its contacts when given. A window of one output, with no contacts given, is that output itself."""
    first = window[0]
    if len(window) == 1 and contact is None:
        return first
    contact = first.contact if contact is None else contact
    if len(window) == 1 or not len(first):
        return TrackerOutput(first.scan, first.time, first.track_id, first.status, first.state, first.covariance,
                             contact)
    sizes = np.array([len(o) for o in window], np.int64)
    starts = np.concatenate([[0], np.cumsum(sizes)])
    ids = np.concatenate([o.track_id for o in window]).astype(np.int64, copy=False)
    status = np.concatenate([o.status for o in window]).astype(np.int8, copy=False)
    x = np.concatenate([o.state for o in window]).astype(float, copy=False)
    P = np.concatenate([o.covariance for o in window]).astype(float, copy=False)
    used = np.concatenate([contact, *(o.contact for o in window[1:])]).astype(np.int64, copy=False)
    times = np.array([o.time for o in window], float)
    smooth = motion is not None
    basis, turn_var = (motion.basis, motion.turn_var) if smooth else (np.zeros((4, 4, 4)), 0.0)
    new_status, xs, Ps = _revised(ids, status, x, P, used, starts, times, basis, turn_var, smooth)
    return TrackerOutput(first.scan, first.time, first.track_id, new_status, xs, Ps, contact)


@numba.njit(cache=True, nogil=True)
def _revised(ids, status, x, P, used, starts, times, basis, turn_var, smooth):
    """`revised`'s compiled part over a window of W outputs, output w in rows starts[w]:starts[w + 1] of
    ids (N,), status (N,), x (N, 4), P (N, 4, 4), the contacts used (N,), at times (W,) s. Returns the first
    output's status (K,) after the back-fill and the ended tracks' DELETED, and its states x (K, 4),
    P (K, 4, 4), RTS-smoothed with the CV transition and the process noise of ``basis`` (4, 4, 4) and
    ``turn_var`` (`LagMotion`) when ``smooth``."""
    W = times.size
    K = starts[1]
    # where each track of the first output is in every later one (-1: absent)
    where = np.full((K, W), -1, np.int64)
    for k in range(K):
        where[k, 0] = k
    first_ids = ids[:K]
    order = np.argsort(first_ids)
    sorted_ids = first_ids[order]
    for w in range(1, W):
        for r in range(starts[w], starts[w + 1]):
            i = np.searchsorted(sorted_ids, ids[r])
            if i < K and sorted_ids[i] == ids[r]:
                where[order[i], w] = r
    new_status = status[:K].copy()
    xs = x[:K].copy()
    Ps = P[:K].copy()
    for k in range(K):
        deleted = False
        coasting = status[k] == CONFIRMED  # a confirmed track with no contact so far in the window
        confirmed_later = False
        for w in range(W):
            r = where[k, w]
            if r >= 0:
                if status[r] == DELETED:
                    if coasting and not deleted:
                        new_status[k] = DELETED
                    deleted = True
                elif w > 0 and status[r] == CONFIRMED:
                    confirmed_later = True
                coasting = coasting and used[r] == NO_CONTACT
            else:
                coasting = coasting and deleted
        if new_status[k] == PRELIMINARY and confirmed_later:
            new_status[k] = CONFIRMED
        if not smooth or deleted:
            continue
        end = 0
        while end + 1 < W and where[k, end + 1] >= 0:
            end += 1
        if end == 0:
            continue
        r = where[k, end]
        x_s = x[r].copy()
        P_s = P[r].copy()
        for w in range(end - 1, -1, -1):
            _rts_step(x[where[k, w]], P[where[k, w]], P[where[k, w + 1]], times[w + 1] - times[w], basis, turn_var,
                      x_s, P_s)
        xs[k] = x_s
        Ps[k] = P_s
    return new_status, xs, Ps


@numba.njit(cache=True, nogil=True)
def _cholesky(A):
    """The lower Cholesky factor L (n, n) of the symmetric (n, n) ``A``, and whether it exists (every pivot
    positive: A positive definite); L is incomplete when it does not."""
    n = A.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        d = A[j, j]
        for m in range(j):
            d -= L[j, m] * L[j, m]
        if not d > 0.0:
            return L, False
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, n):
            v = A[i, j]
            for m in range(j):
                v -= L[i, m] * L[j, m]
            L[i, j] = v / L[j, j]
    return L, True


@numba.njit(cache=True, nogil=True)
def _negative_definite(A):
    """Whether the symmetric (n, n) ``A`` is negative definite: -A has a Cholesky factor."""
    return _cholesky(-A)[1]


@numba.njit(cache=True, nogil=True)
def _rts_step(xf, Pf, nxt, T, basis, turn_var, x_s, P_s):
    """One backward step of `_revised`'s RTS pass, in place: the smoothed x_s (4,), P_s (4, 4) of the next scan
    become this scan's, from its filtered xf (4,), Pf (4, 4), the next scan's filtered covariance ``nxt``
    (4, 4), the interval T (s) and the motion (``basis``, ``turn_var``; `LagMotion`). The CV transition F is
    applied by its structure; the predicted covariance Pp = F Pf F^T + Q is raised to at least ``nxt`` (the
    positive part of nxt - Pp added); C = Pf F^T Pp^-1 from Pp's Cholesky factor."""
    FP = np.empty((4, 4))  # F Pf
    for j in range(4):
        FP[0, j] = Pf[0, j] + T * Pf[1, j]
        FP[1, j] = Pf[1, j]
        FP[2, j] = Pf[2, j] + T * Pf[3, j]
        FP[3, j] = Pf[3, j]
    T2 = T * T
    J = np.array([-0.5 * T2 * xf[3], -T * xf[3], 0.5 * T2 * xf[1], T * xf[1]])
    Pp = np.empty((4, 4))  # F Pf F^T + Q
    for i in range(4):
        Pp[i, 0] = FP[i, 0] + T * FP[i, 1]
        Pp[i, 1] = FP[i, 1]
        Pp[i, 2] = FP[i, 2] + T * FP[i, 3]
        Pp[i, 3] = FP[i, 3]
    for i in range(4):
        for j in range(4):
            Pp[i, j] += T * basis[0, i, j] + T2 * basis[1, i, j] + T2 * T * basis[2, i, j] + T2 * T2 * basis[3, i, j] \
                + turn_var * J[i] * J[j]
    short = np.empty((4, 4))
    for i in range(4):
        for j in range(i, 4):
            Pp[i, j] = Pp[j, i] = 0.5 * (Pp[i, j] + Pp[j, i])
            short[i, j] = short[j, i] = 0.5 * (nxt[i, j] + nxt[j, i]) - Pp[i, j]
    # an update never widens a covariance, so the filter's own prediction to the next scan held at least its
    # filtered covariance there: where the model's falls short of it, raise it by the difference's positive
    # part (the common case, Pp above it, skips the eigendecomposition)
    if not _negative_definite(short):
        ev, V = np.linalg.eigh(short)
        for m in range(4):
            if ev[m] > 0.0:
                for i in range(4):
                    for j in range(4):
                        Pp[i, j] += ev[m] * V[i, m] * V[j, m]
    Ct = _solved(Pp, FP)  # C^T = Pp^-1 F Pf (Pf symmetric)
    nu = np.empty(4)  # x_s - F xf
    nu[0] = x_s[0] - (xf[0] + T * xf[1])
    nu[1] = x_s[1] - xf[1]
    nu[2] = x_s[2] - (xf[2] + T * xf[3])
    nu[3] = x_s[3] - xf[3]
    D = P_s - Pp
    CD = np.zeros((4, 4))  # C D
    for i in range(4):
        for j in range(4):
            for m in range(4):
                CD[i, j] += Ct[m, i] * D[m, j]
    for i in range(4):
        v = xf[i]
        for m in range(4):
            v += Ct[m, i] * nu[m]
        x_s[i] = v
    for i in range(4):
        for j in range(i, 4):
            v = 0.0
            for m in range(4):
                v += CD[i, m] * Ct[m, j]
            P_s[i, j] = P_s[j, i] = 0.5 * (Pf[i, j] + Pf[j, i]) + v


@numba.njit(cache=True, nogil=True)
def _solved(A, B):
    """A^-1 B for a symmetric positive definite A (4, 4) and B (4, 4), by A's Cholesky factor (a general solve
    where the factorisation fails)."""
    n = A.shape[0]
    L, ok = _cholesky(A)
    if not ok:
        return np.linalg.solve(A, B)
    X = B.copy()
    for c in range(B.shape[1]):
        for i in range(n):  # L y = b
            v = X[i, c]
            for m in range(i):
                v -= L[i, m] * X[m, c]
            X[i, c] = v / L[i, i]
        for i in range(n - 1, -1, -1):  # L^T x = y
            v = X[i, c]
            for m in range(i + 1, n):
                v -= L[m, i] * X[m, c]
            X[i, c] = v / L[i, i]
    return X
