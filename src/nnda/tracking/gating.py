"""Which contacts may update which tracks: the chi-square gate on the IMM's combined prediction.

Gating returns the pairs inside the gate in sparse form (track row, contact
column, squared Mahalanobis distance), so association scales with the pairs
that matter rather than with tracks x contacts. For small problems every pair
is tested at once; for large ones the contacts are binned in cells
(`nnda.tracking.box_pairs`) and each track keeps those within a circle that
encloses its gate ellipse.

A track whose polar linearisation does not hold (`nnda.tracking.linearisation`:
a prediction whose spread is comparable to its range) gates a contact only
if the contact also passes the chi-square test in Cartesian space, given the
track's combined predicted ``estimate``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from nnda.filters.imm import IMM, IMMPrediction
from nnda.filters.imm_kernels import squared_distance
from nnda.filters.kalman import MeasurementPrediction
from nnda.tracking.box_pairs import Contacts, candidates
from nnda.tracking.linearisation import LINEARISATION_LIMIT_RAD, cartesian_d2, poor_pairs
from nnda.tracking.output import CONFIRMED

#: below this many track-contact pairs the dense test is faster than building a k-d tree
DENSE_PAIRS = 60_000


@dataclass(frozen=True)
class Gated:
    """Pairs inside the gate, ordered by track then contact; arrays of shape (P,)."""

    rows: np.ndarray
    cols: np.ndarray
    d2: np.ndarray


def gate(imm: IMM, mp: MeasurementPrediction, z: np.ndarray, xy: np.ndarray, threshold: float | np.ndarray,
         estimate: tuple[np.ndarray, np.ndarray] | None = None, *, rows: np.ndarray | None = None,
         check: bool = True) -> Gated:
    """Pairs (track, contact) with squared Mahalanobis distance <= ``threshold``, by track row, then contact.

    ``mp`` is the combined measurement prediction of K tracks
    (`IMM.combined_measurement`), ``z`` (N, 2) the contacts in the
    measurement space of ``imm.measurement`` and ``xy`` (N, 2) their
    Cartesian positions (m). ``estimate`` is the combined prediction (x (K, 4), P (K, 4, 4),
    `IMM.estimate` of ``pred.state``) the Cartesian test of poorly linearised tracks needs
    (module docstring); without it every pair is judged by the linearised test alone. ``rows``
    (R,) ascending limits the gate to those tracks (the pairs' rows still index ``mp``; None: all K).
    ``threshold`` is one gate for all, or each gated track's own ((R,), or (K,) without ``rows``).
    ``check=False`` skips the check of z (for the trackers, whose scan loop checks every scan's contacts).
    """
    K, N = len(mp.z), len(z)
    tracks = np.arange(K) if rows is None else np.asarray(rows, np.int64)
    limit = np.asarray(threshold, np.float64)
    if limit.ndim and limit.shape != tracks.shape:
        raise ValueError(f"gate: thresholds of shape {limit.shape} for {tracks.size} gated tracks")
    if tracks.size == 0 or N == 0:
        empty = np.empty(0, np.int64)
        return Gated(empty, empty, np.empty(0))
    by_track = limit  # the pairs' gate, by track row: a scalar, or (K,)
    if limit.ndim:
        by_track = np.zeros(K)
        by_track[tracks] = limit
    if tracks.size * N <= DENSE_PAIRS:
        return _cartesian_check(imm, mp, z, by_track, estimate,
                                Gated(*imm.gated_pairs(mp, z, limit, tracks, check=check)))
    # radius of a circle holding the gate ellipse: sqrt(threshold * its largest spread in metres^2)
    measurement = imm.measurement
    radius = np.sqrt(limit * measurement.spread(mp.z[tracks], mp.S[tracks])) + 1.0
    centre = measurement.cartesian(mp.z[tracks])
    j, cols = candidates(Contacts(xy, 0.0), centre, np.repeat(radius[:, None], 2, axis=1))
    return _cartesian_check(imm, mp, z, by_track, estimate, Gated(*_candidates_inside(
        j, cols, tracks, xy, centre, radius, mp.z, mp.S_inv, z, by_track.reshape(-1), imm.polar)))


@numba.njit(cache=True, nogil=True)
def _candidates_inside(j, cols, tracks, xy, centre, radius, z_pred, S_inv, z, limit, polar):
    """`gate`'s test of the candidate pairs (j, cols) (P,) of `box_pairs.candidates` (by contact, then j) in one
    pass: those inside the circle of ``radius`` (J,) m about ``centre`` (J, 2) that holds the gate of track
    ``tracks[j]`` and within its gate, ``limit`` (K,) by track row or (1,) for all, of the squared Mahalanobis
    distance (`imm_kernels.squared_distance` of z (N, 2) from z_pred (K, 2), S_inv (K, 2, 2)). Returns their
    rows, cols and d2, by track, then contact (a stable counting sort on j)."""
    P, J = j.size, centre.shape[0]
    keep = np.empty(P, np.int64)
    d2 = np.empty(P)
    count = np.zeros(J + 1, np.int64)
    n = 0
    for p in range(P):
        c, t = cols[p], j[p]
        dx, dy = xy[c, 0] - centre[t, 0], xy[c, 1] - centre[t, 1]
        if dx * dx + dy * dy > radius[t] * radius[t]:  # outside the circle in the square
            continue
        row = tracks[t]
        d = squared_distance(z_pred, S_inv, row, z, c, polar)
        if d <= limit[row if limit.size > 1 else 0]:
            keep[n], d2[n] = p, d
            count[t + 1] += 1
            n += 1
    for t in range(J):
        count[t + 1] += count[t]
    rows_out, cols_out, d2_out = np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n)
    for q in range(n):
        p = keep[q]
        at = count[j[p]]
        count[j[p]] += 1
        rows_out[at], cols_out[at], d2_out[at] = tracks[j[p]], cols[p], d2[q]
    return rows_out, cols_out, d2_out


def _cartesian_check(imm: IMM, mp: MeasurementPrediction, z: np.ndarray, by_track: np.ndarray,
                     estimate: tuple[np.ndarray, np.ndarray] | None, gated: Gated) -> Gated:
    """``gated`` without the pairs of poorly linearised tracks that fail the Cartesian test at their gate
    (``by_track``: one for all, or (K,))."""
    if estimate is None or not gated.rows.size or not imm.polar:
        return gated  # a position sensor is linear
    check = poor_pairs(mp.S, gated.rows, LINEARISATION_LIMIT_RAD**2)
    if not check.size:
        return gated
    x, P = estimate
    r = gated.rows[check]
    far = (cartesian_d2(imm.measurement, z[gated.cols[check]], x[r][:, 0:3:2], P[r][:, 0:3:2, 0:3:2])
           > (by_track[r] if by_track.ndim else by_track))
    keep = np.ones(gated.rows.size, bool)
    keep[check[far]] = False
    return Gated(gated.rows[keep], gated.cols[keep], gated.d2[keep])


def gate_tracks(imm: IMM, pred: IMMPrediction, z: np.ndarray, xy: np.ndarray, threshold: float, *,
                check: bool = True) -> tuple[MeasurementPrediction, Gated]:
    """The combined measurement prediction of K tracks' IMM prediction ``pred`` (the gating prediction,
    `IMM.combined_measurement`) and the pairs inside their gates (`gate`, with the Cartesian test of the
    poorly linearised tracks; ``check`` as there)."""
    g = pred.gating
    return g.measurement, gate(imm, g.measurement, z, xy, threshold, (g.x, g.P), check=check)


@numba.njit(cache=True, nogil=True)
def stage_pairs(confirmed, status, rows, cols, taken):
    """The gated pairs (rows, cols (P,)) of one stage of an association that lets confirmed tracks choose
    first: those of the confirmed tracks (``confirmed``; else of the others, by ``status`` (K,)) whose contact
    is not ``taken`` (N,) yet. Returns their indices (M,), in order."""
    keep = np.empty(rows.size, np.int64)
    m = 0
    for p in range(rows.size):
        if (status[rows[p]] == CONFIRMED) == confirmed and not taken[cols[p]]:
            keep[m] = p
            m += 1
    return keep[:m]
