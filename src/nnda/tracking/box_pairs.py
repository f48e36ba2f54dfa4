"""Pairs of points lying within boxes about other points, found by binning: `candidates`.

    j, i = candidates(Contacts(z, period), centre, half_width)   # (P,) box and point indices

The points z (N, 2) are binned in cells (`nnda.tracking.clutter_density.sorted_cells`), and each box,
``centre`` (J, 2) +- ``half_width`` (J, 2), examines only the points of the cells it overlaps, so the cost
grows with the points near each box, not with J x N. The second coordinate may be periodic (an azimuth:
``Contacts.period`` 2 pi). The PHD filters' gate (`nnda.tracking.phd.gmphd`) and the contact trackers' gate
on many tracks (`nnda.tracking.gating`) both start from these pairs, then apply their exact test.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from nnda.tracking.clutter_density import MAX_CELLS_PER_AXIS, key_range, sorted_cells


class Contacts(NamedTuple):
    """A scan's contacts as `candidates` bins them: z (N, 2) and the period of their second coordinate (2 pi: an
    azimuth, whose residual is wrapped; 0: none)."""

    z: np.ndarray
    period: float


#: `candidates` widens the second coordinate's windows by this part (and 1e-12 absolute), so that rounding never
#: leaves out a pair the exact gate keeps (the first coordinate's window is the one the gate was always applied in)
_MARGIN = 1e-9


def candidates(contacts: Contacts, centre: np.ndarray, half_width: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (j, i) with |z_i0 - centre_j0| <= half_width_j0 and |z_i1 - centre_j1| <= half_width_j1 (the
    second difference wrapped when ``contacts.period``), up to the margin `_MARGIN` on the second: the
    ``contacts`` (N, 2) binned in cells of three quarters of the components' median window (`_box_pairs`; the
    fastest of the sizes tried), each component ``centre`` (J, 2) examining only the contacts of the cells its
    window ``half_width`` (J, 2) overlaps. Returns component and contact indices (P,), by contact, then component."""
    z = np.ascontiguousarray(contacts.z, float)
    J, N = len(centre), len(z)
    if not J or not N:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    extent = np.array([np.ptp(z[:, 0]), contacts.period or np.ptp(z[:, 1])])
    cell = np.maximum(np.median(1.5 * half_width, axis=0), extent / (4 * N + 64))
    cell = np.where(np.isfinite(cell) & (cell > 0), cell, 1.0)
    return _box_pairs(z, float(contacts.period), np.ascontiguousarray(centre, float),
                      np.ascontiguousarray(half_width, float), float(cell[0]), float(cell[1]))


#: `_box_pairs` keeps a table of where each cell's contacts start when the grid has at most this many cells per
#: contact (plus 1,024); above, it bisects the sorted cell keys
_CELLS_PER_CONTACT = 8


@numba.njit(cache=True, nogil=True)
def _cell_run(keys, first, column, a1, b1, n1):
    """`clutter_density.key_range`, read from the table ``first`` of each cell's start in ``keys`` when it has one
    (else by bisection)."""
    if not first.size:
        return key_range(keys, column, a1, b1, n1)
    a1, b1 = max(a1, 0), min(b1, n1 - 1)
    if a1 > b1:
        return 0, 0
    return first[column * n1 + a1], first[column * n1 + b1 + 1]


@numba.njit(cache=True, nogil=True)
def _box_pairs(z, period, centre, half_width, cell0, cell1):
    """`candidates`' loop. The contacts z (N, 2) go into the cells of `clutter_density.sorted_cells`, the second
    coordinate (taken modulo ``period`` when > 0) scaled by cell0 / cell1 so that one side ``cell0`` serves both
    axes (doubled while an axis would have more than `clutter_density.MAX_CELLS_PER_AXIS`); each component tests
    the contacts of the cells its window [centre - half_width, centre + half_width] overlaps (on a period, its one
    or two runs of rows; the whole period from half a period on): the first coordinate exactly as
    `nnda.tracking.phd.gmphd.window_counts`' window, the second's difference (wrapped) against
    half_width (1 + `_MARGIN`) + 1e-12; the pairs found component by component are then ordered by contact (a
    stable counting sort). Costs O(N log N)
    plus, per component, its cells' bisections and contacts, plus O(N) for the order."""
    N, J = z.shape[0], centre.shape[0]
    k = cell0 / cell1
    pts = np.empty((N, 2))
    for i in range(N):
        pts[i, 0] = z[i, 0]
        pts[i, 1] = (z[i, 1] % period if period > 0 else z[i, 1]) * k
    lo0, hi0, lo1, hi1 = pts[0, 0], pts[0, 0], pts[0, 1], pts[0, 1]
    for i in range(1, N):
        lo0, hi0 = min(lo0, pts[i, 0]), max(hi0, pts[i, 0])
        lo1, hi1 = min(lo1, pts[i, 1]), max(hi1, pts[i, 1])
    if period > 0:
        lo1, hi1 = 0.0, period * k
    cell = cell0
    while max(hi0 - lo0, hi1 - lo1) / cell > MAX_CELLS_PER_AXIS:
        cell *= 2.0
    n0, n1 = int((hi0 - lo0) // cell) + 1, int((hi1 - lo1) // cell) + 1
    order, keys = sorted_cells(pts, lo0, lo1, cell, n1)
    # where each cell's points start in ``keys``: a table when the grid has no more cells than a few per contact
    # (its cost then follows the contacts, not the coverage), else a bisection per run of cells
    first = np.empty(0, np.int64)
    if n0 * n1 <= _CELLS_PER_CONTACT * N + 1024:
        first = np.zeros(n0 * n1 + 1, np.int64)
        for t in range(N):
            first[keys[t] + 1] += 1
        for key in range(n0 * n1):
            first[key + 1] += first[key]
    # per component: its columns [runs 0, runs 1] and up to two runs of rows, [runs 2, runs 3] and [runs 4, runs 5]
    # (none: an end below its start)
    runs = np.full((J, 6), -1, np.int64)
    runs[:, 0] = 0
    wide = np.empty(J)
    most = 0
    for j in range(J):
        a, b = centre[j, 0] - half_width[j, 0], centre[j, 0] + half_width[j, 0]
        u0, u1 = (a - lo0) // cell, (b - lo0) // cell  # as `contact_cells`
        w = half_width[j, 1] * (1.0 + _MARGIN) + 1e-12
        wide[j] = w
        if not (u1 >= 0.0 and u0 <= n0 - 1.0 and w >= 0.0):  # also NaN
            continue
        runs[j, 0], runs[j, 1] = int(max(u0, 0.0)), int(min(u1, n0 - 1.0))
        if period > 0 and w >= 0.5 * period:
            runs[j, 2], runs[j, 3] = 0, n1 - 1
        else:
            c = centre[j, 1] % period if period > 0 else centre[j, 1]
            y0, y1 = c - w, c + w
            at_end = period > 0 and y0 < 0.0  # the window's wrapped part: at the period's end, or its start
            if at_end:
                runs[j, 4], runs[j, 5] = int(min((y0 + period) * k // cell, n1 - 1.0)), n1 - 1
                y0 = 0.0
            elif period > 0 and y1 > period:
                runs[j, 4], runs[j, 5] = 0, int(max((y1 - period) * k // cell, 0.0))
                y1 = period
            r0, r1 = (y0 * k - lo1) // cell, (y1 * k - lo1) // cell
            if r1 >= 0.0 and r0 <= n1 - 1.0:
                runs[j, 2], runs[j, 3] = int(max(r0, 0.0)), int(min(r1, n1 - 1.0))
                if at_end:  # a row holding both parts is examined once, in the first run
                    runs[j, 4] = max(runs[j, 4], runs[j, 3] + 1)
                else:
                    runs[j, 5] = min(runs[j, 5], runs[j, 2] - 1)
        for column in range(runs[j, 0], runs[j, 1] + 1):
            for r in (2, 4):
                start, stop = _cell_run(keys, first, column, runs[j, r], runs[j, r + 1], n1)
                most += stop - start
    jj = np.empty(most + 1, np.int64)
    ii = np.empty(most + 1, np.int64)
    m = 0
    half = 0.5 * period
    # the contacts' coordinates in cell order, as the tests read them: no indirection, and a test without branches
    # (a pair is written at m, and m moves on only if it passes), which a coin-flip test would mispredict
    first0 = np.empty(N)
    second = np.empty(N)
    for t in range(N):
        i = order[t]
        first0[t] = z[i, 0]
        second[t] = pts[i, 1] / k if period > 0 else z[i, 1]
    for j in range(J):
        a, b = centre[j, 0] - half_width[j, 0], centre[j, 0] + half_width[j, 0]
        c = centre[j, 1] % period if period > 0 else centre[j, 1]
        for column in range(runs[j, 0], runs[j, 1] + 1):
            for r in (2, 4):
                start, stop = _cell_run(keys, first, column, runs[j, r], runs[j, r + 1], n1)
                for t in range(start, stop):
                    d = second[t] - c
                    if period > 0 and d > half:
                        d -= period
                    elif period > 0 and d < -half:
                        d += period
                    jj[m], ii[m] = j, order[t]
                    m += (a <= first0[t]) & (first0[t] <= b) & (abs(d) <= wide[j])
    start = np.zeros(N + 1, np.int64)  # by contact: a counting sort, stable, so by component within a contact
    for p in range(m):
        start[ii[p] + 1] += 1
    for i in range(N):
        start[i + 1] += start[i]
    j_out, i_out = np.empty(m, np.int64), np.empty(m, np.int64)
    for p in range(m):
        q = start[ii[p]]
        j_out[q], i_out[q] = jj[p], ii[p]
        start[ii[p]] += 1
    return j_out, i_out
