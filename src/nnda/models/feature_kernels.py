"""The compiled per-scan feature path of the neural association (`nnda.models.features`, `.innovation` and
`.context` call them; the neural tracker and the training pairs go through those).

    ok = in_gate(px, py, t2, s2, cx, cy, tc, sc)                   # (N,) the sector and speed gates
    track, contact = candidates(last, t_last, az_last, xy, az, time)   # (P,) gated pairs of M x N
    kin, good = kinematic(p1, t1, p2, t2, c, tc)                        # (N, 3) [ΔV m/s, Δα deg/s, ΔT s]
    ext = innovation(kin, track, z, z_pred, S, S_inv, log_det, mu, ct, age, polar)   # (P, 9)
    track, contact, feat = scan_features(p1, t1, p2, t2, az2, xy, z, time, ...)   # the three above, one call
    context(track, contact, d2, cap, out)                               # out (P, 5) written

Positions are [x east, y north] in m, times in s, azimuths in rad clockwise
from north, sectors 0..15 (`N_SECTORS` wedges of 22.5 deg from north).

Why compiled: the neural tracker computes these every scan for ~15 tracks
and ~100 contacts, a handful of pairs; the numpy formulation spent its time
in the overhead of ~60 small calls per scan. Each kernel does its function's
arithmetic in one loop, with the formulas and their order of the numpy code
it replaced, so the results agree to rounding (numpy's SIMD arctan2 may
differ from libm's in the last bit; the tests hold the features to RTOL and
the pairs, ranks and counts to equality). No fastmath; ``cache=True`` keeps
the compiled code on disk beside this file.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from nnda.filters.imm_kernels import wrap_angle_kernel

N_SECTORS = 16
MIN_SPEED_M_S = 30.0
MAX_SPEED_M_S = 400.0
TWO_PI = 2.0 * math.pi
SECTOR_RAD = TWO_PI / N_SECTORS
RAD_TO_DEG = 180.0 / math.pi
#: the coarse distance tests of `candidates` widen the speed gate by this fraction, so that rounding in
#: their squared distances cannot drop a pair the exact gate keeps
REACH_MARGIN = 1e-9
#: and widen the search box of a track by this fraction of its coordinates (many ulps of them), so that
#: rounding in the box's edges cannot either
_BOX_SLACK = 1e-12
#: the search grid has at most this many cells per contact (plus `_MIN_CELLS`): memory grows with N
_CELLS_PER_CONTACT = 2
_MIN_CELLS = 64

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")  # x / 0 gives inf or NaN, as numpy


@_jit
def sector_of(azimuth):
    """Azimuth sector 0..15 of an azimuth (rad, clockwise from north)."""
    if not (0.0 <= azimuth < TWO_PI):  # the modulo changes nothing in [0, 2 pi), and costs
        azimuth = azimuth % TWO_PI
    return int(math.floor(azimuth / SECTOR_RAD)) % N_SECTORS


@_jit
def _neighbours(track_sector, contact_sector):
    """True if the contact's sector is the track's or one of its two neighbours (wrapping)."""
    return (contact_sector - track_sector + 1) % N_SECTORS <= 2


@_jit
def _speed(px, py, t2, cx, cy, tc):
    """Speed (m/s) needed to go from (px, py) at t2 to (cx, cy) at tc."""
    return math.hypot(cx - px, cy - py) / (tc - t2)


@_jit
def _passes(px, py, t2, s2, cx, cy, tc, sc):
    """The sector gate and the speed gate (bounds included) of one pair."""
    if not _neighbours(s2, sc):
        return False
    v = _speed(px, py, t2, cx, cy, tc)
    return v >= MIN_SPEED_M_S and v <= MAX_SPEED_M_S


@_jit
def sectors(azimuth):
    """`sector_of` of azimuths (N,) rad: (N,) int64."""
    out = np.empty(azimuth.shape[0], np.int64)
    for i in range(azimuth.shape[0]):
        out[i] = sector_of(azimuth[i])
    return out


@_jit
def speeds(px, py, t2, cx, cy, tc):
    """`_speed` of N pairs, each argument (N,): (N,) m/s."""
    out = np.empty(px.shape[0])
    for i in range(px.shape[0]):
        out[i] = _speed(px[i], py[i], t2[i], cx[i], cy[i], tc[i])
    return out


@_jit
def neighbours(track_sector, contact_sector):
    """`_neighbours` of N pairs of sectors (N,) int64: (N,) bool."""
    out = np.empty(track_sector.shape[0], np.bool_)
    for i in range(track_sector.shape[0]):
        out[i] = _neighbours(track_sector[i], contact_sector[i])
    return out


@_jit
def in_gate(px, py, t2, s2, cx, cy, tc, sc):
    """Both gates of N pairs: last track contact (px, py) m at t2 s in sector s2, candidate (cx, cy) at tc
    in sector sc, each (N,): (N,) bool."""
    out = np.empty(px.shape[0], np.bool_)
    for i in range(px.shape[0]):
        out[i] = _passes(px[i], py[i], t2[i], s2[i], cx[i], cy[i], tc[i], sc[i])
    return out


@_jit
def candidates(last, last_time, last_azimuth, contacts, contact_azimuth, time):
    """Gated (track, contact) pairs of M tracks and N contacts, ordered by track then contact.

    ``last`` (M, 2) m, ``last_time`` (M,) s (< ``time``) and ``last_azimuth``
    (M,) rad are each track's last contact; ``contacts`` (N, 2) m and
    ``contact_azimuth`` (N,) rad the scan's, at ``time`` s. Returns (P,)
    int64 track and contact indices of the pairs that pass `_passes`.

    The contacts are binned on a square grid whose cell is the least reach
    of the speed gate (400 m/s x the least time since a track's last
    contact), grown until there are at most 2 cells per contact. Each track
    visits the cells its own reach overlaps and tests their contacts: the
    sector gate, then the squared distance against the speed gate's bounds
    widened by `REACH_MARGIN`, then the exact gate; the contacts found are
    sorted. So the work grows with M x (contacts near each track), and the
    pairs are those of the exact gate over all M x N.
    """
    M, N = last.shape[0], contacts.shape[0]
    if M == 0 or N == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    track_sector = sectors(last_azimuth)
    contact_sector = sectors(contact_azimuth)
    lo2 = np.empty(M)
    hi2 = np.empty(M)
    reach = np.empty(M)
    least = math.inf
    for m in range(M):
        gap = time - last_time[m]
        lo, hi = (MIN_SPEED_M_S * (1.0 - REACH_MARGIN)) * gap, (MAX_SPEED_M_S * (1.0 + REACH_MARGIN)) * gap
        lo2[m], hi2[m], reach[m] = lo * lo, hi * hi, hi
        least = min(least, hi)
    x0, x1, y0, y1 = contacts[0, 0], contacts[0, 0], contacts[0, 1], contacts[0, 1]
    for j in range(1, N):
        x0, x1 = min(x0, contacts[j, 0]), max(x1, contacts[j, 0])
        y0, y1 = min(y0, contacts[j, 1]), max(y1, contacts[j, 1])
    cell = least if least > 0.0 else 1.0
    limit = _CELLS_PER_CONTACT * N + _MIN_CELLS
    while ((x1 - x0) / cell + 1.0) * ((y1 - y0) / cell + 1.0) > limit:
        cell *= 2.0
    nx, ny = int((x1 - x0) / cell) + 1, int((y1 - y0) / cell) + 1
    # counting sort of the contacts by cell (row-major, contacts in index order within a cell)
    start = np.zeros(nx * ny + 1, np.int64)
    where = np.empty(N, np.int64)
    for j in range(N):
        where[j] = min(int((contacts[j, 1] - y0) / cell), ny - 1) * nx + min(int((contacts[j, 0] - x0) / cell), nx - 1)
        start[where[j] + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    binned = np.empty(N, np.int64)  # contact indices, and their positions and sectors, cell by cell
    bx, by, bs = np.empty(N), np.empty(N), np.empty(N, np.int64)
    for j in range(N):
        q = fill[where[j]]
        binned[q], bx[q], by[q], bs[q] = j, contacts[j, 0], contacts[j, 1], contact_sector[j]
        fill[where[j]] += 1
    track = np.empty(max(16, 2 * M), np.int64)
    contact = np.empty(track.shape[0], np.int64)
    count = np.int64(0)  # typed int64 from the start: `_sort_small` then compiles for int64 alone, not literals
    for m in range(M):
        px, py, t2, s2 = last[m, 0], last[m, 1], last_time[m], track_sector[m]
        near = 0  # bit s set: sector s passes the sector gate
        for s in range(N_SECTORS):
            if _neighbours(s2, s):
                near |= 1 << s
        w = reach[m] + _BOX_SLACK * (abs(px) + abs(py))
        ix0 = max(0.0, math.floor((px - w - x0) / cell))
        ix1 = min(nx - 1.0, math.floor((px + w - x0) / cell))
        iy0 = max(0.0, math.floor((py - w - y0) / cell))
        iy1 = min(ny - 1.0, math.floor((py + w - y0) / cell))
        # the box's contacts: in each of its rows of cells, one run of the binned order
        rows = range(int(iy0), int(iy1) + 1)  # empty where the box misses the grid
        most = 0
        for iy in rows:
            most += start[iy * nx + int(ix1) + 1] - start[iy * nx + int(ix0)] if ix0 <= ix1 else 0
        if count + most > track.shape[0]:  # grown here, not in the loop below (which it would slow down)
            grown = max(2 * track.shape[0], count + most)
            track = np.concatenate((track, np.empty(grown - track.shape[0], np.int64)))
            contact = np.concatenate((contact, np.empty(grown - contact.shape[0], np.int64)))
        first = count
        for iy in rows:
            if ix0 > ix1:
                break
            for q in range(start[iy * nx + int(ix0)], start[iy * nx + int(ix1) + 1]):
                if not (near >> bs[q]) & 1:
                    continue
                dx, dy = bx[q] - px, by[q] - py
                d2 = dx * dx + dy * dy
                if d2 >= lo2[m] and d2 <= hi2[m] and _passes(px, py, t2, s2, bx[q], by[q], time, bs[q]):
                    track[count], contact[count] = m, binned[q]
                    count += 1
        _sort_small(contact, first, count)
    return track[:count].copy(), contact[:count].copy()


@_jit
def _sort_small(a, lo, hi):
    """Sort a[lo:hi] in place: insertion sort for a few entries (no allocation), else np.sort."""
    if hi - lo > 32:
        a[lo:hi] = np.sort(a[lo:hi])
        return
    for i in range(lo + 1, hi):
        x = a[i]
        k = i
        while k > lo and a[k - 1] > x:
            a[k] = a[k - 1]
            k -= 1
        a[k] = x


@_jit
def kinematic(p1, t1, p2, t2, c, tc):
    """The three kinematic features (N, 3) [ΔV m/s, Δα deg/s, ΔT s] of N pairs and whether all are good.

    ``p1``, ``p2``, ``c`` (N, 2) m are each pair's last-but-one and last track
    contact and its candidate, ``t1``, ``t2``, ``tc`` (N,) s their times.
    Good: every time gap positive and every feature and t2 - t1 finite
    (False asks the caller to look closer, `nnda.models.features._check_pairs`).
    """
    n = p1.shape[0]
    out = np.empty((n, 3))
    good = True
    for i in range(n):
        before, gap = t2[i] - t1[i], tc[i] - t2[i]
        lx, ly = p2[i, 0] - p1[i, 0], p2[i, 1] - p1[i, 1]
        sx, sy = c[i, 0] - p2[i, 0], c[i, 1] - p2[i, 1]
        out[i, 0] = math.hypot(sx, sy) / gap - math.hypot(lx, ly) / before
        turn = -wrap_angle_kernel(math.atan2(lx, ly) - math.atan2(sx, sy))  # course: bearing clockwise from north
        out[i, 1] = turn * RAD_TO_DEG / gap
        out[i, 2] = gap
        if not (before > 0.0 and gap > 0.0 and math.isfinite(before) and math.isfinite(out[i, 0])
                and math.isfinite(out[i, 1]) and math.isfinite(gap)):
            good = False
    return out, good


@_jit
def innovation(kin, track, z, z_pred, S, S_inv, log_det, mu, ct, age, polar):
    """The IMM-extended features (P, 9) of P pairs (`nnda.models.innovation`).

    ``kin`` (P, 3) the kinematic features, ``track`` (P,) each pair's row of the
    K-track prediction, ``z`` (P, 2) the candidates' measurements;
    ``z_pred`` (K, 2), ``S``, ``S_inv`` (K, 2, 2) and ``log_det`` (K,) the
    combined measurement prediction, ``mu`` (K, r) the predicted mode
    probabilities and ``ct`` the coordinated-turn model's column; ``age``
    (P,) s. The azimuth residual is wrapped to [-pi, pi) when ``polar``.
    """
    n = track.shape[0]
    out = np.empty((n, 9))
    for i in range(n):
        k = track[i]
        out[i, 0], out[i, 1], out[i, 2] = kin[i, 0], kin[i, 1], kin[i, 2]
        n0 = z[i, 0] - z_pred[k, 0]
        n1 = z[i, 1] - z_pred[k, 1]
        if polar:
            n1 = wrap_angle_kernel(n1)
        out[i, 3] = n0 / math.sqrt(S[k, 0, 0])
        out[i, 4] = n1 / math.sqrt(S[k, 1, 1])
        out[i, 5] = S_inv[k, 0, 0] * n0 * n0 + (S_inv[k, 0, 1] + S_inv[k, 1, 0]) * n0 * n1 + S_inv[k, 1, 1] * n1 * n1
        out[i, 6] = log_det[k]
        out[i, 7] = mu[k, ct]
        out[i, 8] = age[i]
    return out


@_jit
def scan_features(p1, t1, p2, t2, az2, xy, z, time, born, z_pred, S, S_inv, log_det, mu, ct, polar, extended):
    """The neural tracker's feature path of one scan in one call: `candidates`, then `kinematic` of the pairs
    and, if ``extended``, `innovation`, as the three separate calls compute them.

    K tracks: last-but-one and last contact ``p1``, ``p2`` (K, 2) m at ``t1``, ``t2`` (K,) s, the last one's
    azimuth ``az2`` (K,) rad and the time of the first contact ``born`` (K,) s; the scan's N contacts
    ``xy`` (N, 2) m and ``z`` (N, 2) [range m, azimuth rad] at ``time`` s; the tracks' combined measurement
    prediction ``z_pred``, ``S``, ``S_inv``, ``log_det``, mode probabilities ``mu`` and CT column ``ct``
    (read only if ``extended``). Returns the pairs' track and contact (P,) and their features (P, 3) or
    (P, 9).
    """
    track, contact = candidates(p2, t2, az2, xy, np.ascontiguousarray(z[:, 1]), time)  # C, as from Python
    n = track.shape[0]
    q1, q2, c = np.empty((n, 2)), np.empty((n, 2)), np.empty((n, 2))
    s1, s2, tc = np.empty(n), np.empty(n), np.full(n, time)
    for i in range(n):
        k, j = track[i], contact[i]
        q1[i, 0], q1[i, 1], q2[i, 0], q2[i, 1] = p1[k, 0], p1[k, 1], p2[k, 0], p2[k, 1]
        c[i, 0], c[i, 1], s1[i], s2[i] = xy[j, 0], xy[j, 1], t1[k], t2[k]
    kin = kinematic(q1, s1, q2, s2, c, tc)[0]
    if not extended:
        return track, contact, kin
    zc, age = np.empty((n, 2)), np.empty(n)
    for i in range(n):
        zc[i, 0], zc[i, 1], age[i] = z[contact[i], 0], z[contact[i], 1], time - born[track[i]]
    return track, contact, innovation(kin, track, zc, z_pred, S, S_inv, log_det, mu, ct, age, polar)


@_jit
def _ranked(key, v, by_value, cap):
    """Per pair, within the pairs of equal ``key`` (P,) ordered by ``v`` (P,) with ties by position
    (``by_value``: the pairs in that order of ``v``, a stable sort): its rank (0 best), the group's size and
    the least ``v`` of the group's other pairs (``cap`` if alone), (P,) each."""
    n = v.shape[0]
    order = by_value[np.argsort(key[by_value], kind="mergesort")]  # stable: by key, then v, then position
    rank = np.empty(n, np.int64)
    size = np.empty(n, np.int64)
    other = np.empty(n)
    s = 0
    while s < n:
        e = s + 1
        while e < n and key[order[e]] == key[order[s]]:
            e += 1
        for at in range(s, e):
            p = order[at]
            rank[p], size[p] = at - s, e - s
            other[p] = v[order[s]] if at > s else (v[order[s + 1]] if e - s > 1 else cap)
        s = e
    return rank, size, other


@_jit
def context(track, contact, d2, cap, out):
    """Write the context columns (`nnda.models.context.CONTEXT_NAMES`) of P pairs into ``out`` (P, 5).

    ``track``, ``contact`` (P,) int64 keys, ``d2`` (P,) squared Mahalanobis
    distances, capped at ``cap`` here (NaN stays NaN): rank, d2 margin and
    count among the track's pairs, count and least d2 of the contact's
    other pairs (`_ranked`).
    """
    n = d2.shape[0]
    v = np.empty(n)
    for p in range(n):
        v[p] = cap if d2[p] > cap else d2[p]
    by_value = np.argsort(v, kind="mergesort")
    rank, size, other = _ranked(track, v, by_value, cap)
    _, rivals, rival = _ranked(contact, v, by_value, cap)
    for p in range(n):
        out[p, 0] = rank[p]
        out[p, 1] = v[p] - other[p]
        out[p, 2] = size[p]
        out[p, 3] = rivals[p] - 1
        out[p, 4] = rival[p]
