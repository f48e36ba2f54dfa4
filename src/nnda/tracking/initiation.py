"""Two-point initiation: each sensor's initiators and the preliminary tracks their window pairs open
(Vargas Avila 2015, Ch. 2 and Sec. 5.3), for sweeps and for asynchronous reports."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numba
import numpy as np

from nnda.data.scenario import Sensor
from nnda.errors import BoundWarning
from nnda.filters.imm import IMM, IMMState
from nnda.filters.imm_kernels import start
from nnda.filters.measurement import converted_covariances
from nnda.tracking.lifecycle import (
    FAST_LINE_CONTACTS,
    FAST_LINE_EVIDENCE,
    LifecycleConfig,
    cap_pairs,
    cap_per_initiator,
    fast_lines_kernel,
    fast_share,
    fast_tolerance_m,
    free_pairs_kernel,
    no_lines,
    rate_threshold,
    search_reach,
    sensor_noise_m,
)
from nnda.tracking.output import PRELIMINARY
from nnda.tracking.reports import report_pairs
from nnda.tracking.tracks import AZ2, CONFIRM_AT, P1, P2, T0, T1, T2, X1, X2, Tracks


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
