"""Per-scan matching of reported tracks to true targets by position: CLEAR-MOT's rule.

The one position assignment of the study: ownership by position
(`nnda.study.metrics`) and the CLEAR-MOT measures (MOTA, MOTP, identity
switches; `nnda.study.measures`) both read it. Scan by scan, in time order
(Bernardin & Stiefelhagen, "Evaluating multiple object tracking
performance: the CLEAR MOT metrics", EURASIP JIVP 2008, Sec. 2.1):

1. a target keeps the track it was last matched to (in any earlier scan)
   when that track is reported in this scan and closer than the threshold;
   when two targets claim the same track, the lower target id keeps it;
2. the remaining targets and tracks get the assignment with the most pairs
   closer than the threshold and, among those, the least total distance
   (`scipy.optimize.linear_sum_assignment`; with hundreds of targets over
   the pairs closer than the threshold only); a pair at the threshold or
   beyond is no match;
3. a target matched in step 2 to another track than its last one is an
   identity switch.

This is py-motmetrics' ``MOTAccumulator.update`` rule (the test suite
checks the counts against it). Distances are Euclidean in the plane (m)::

    m = match_scans(truth_scan, truth_target, truth_xy, track_scan, track_index, track_xy,
                    n_scans=50, n_targets=4, n_tracks=9, threshold=1000.0)
    m.target, m.track, m.distance, m.switch      # (P,) one entry per matched pair, scan order
    m.scan                                       # (P,) its scan, 1..n_scans
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from nnda.study.gospa import DENSE_MAX_PAIRS, close_pairs, pair_values
from nnda.tracking.assignment import least_cost_assignment


@dataclass(frozen=True)
class Matches:
    """The matched (target, track) pairs of every scan, in scan order; arrays of shape (P,).

    ``target`` is a target id (0..n_targets-1), ``track`` a track index
    (0..n_tracks-1, the caller's numbering), ``distance`` (m) between the
    two positions, ``switch`` True where the pair is an identity switch.
    """

    scan: np.ndarray
    target: np.ndarray
    track: np.ndarray
    distance: np.ndarray
    switch: np.ndarray


def _bounds(scan: np.ndarray, n_scans: int) -> np.ndarray:
    return np.searchsorted(scan, np.arange(1, n_scans + 2))


def _best(d: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of the most pairs with ``valid`` and, among those, the least total ``d``."""
    if not valid.any():
        return np.empty(0, np.int64), np.empty(0, np.int64)
    # an invalid pair costs more than any set of valid ones can save (each valid d < threshold)
    penalty = (min(d.shape) + 1) * (float(d[valid].max()) + 1.0)
    rows, cols = linear_sum_assignment(np.where(valid, d, penalty))
    ok = valid[rows, cols]
    return rows[ok], cols[ok]


def _dense_scan(truth_xy: np.ndarray, track_xy: np.ndarray, last: np.ndarray, tracks: np.ndarray,
                threshold: float) -> tuple[np.ndarray, ...]:
    """One scan's matches (module docstring, steps 1 and 2) over the whole T x K distance matrix: the kept
    (row, column) pairs, the newly assigned ones and the distances (m) of all, kept first. ``last`` (T,) is
    each target's last matched track, ``tracks`` (K,) the scan's track indices."""
    d = cdist(truth_xy, track_xy)
    valid = d < threshold
    # 1. last matches kept: per track, the lowest-id target (targets are in id order) claiming it
    claim = valid & (last[:, None] == tracks[None, :])
    kept_col = np.flatnonzero(claim.any(axis=0))
    kept_row = np.argmax(claim[:, kept_col], axis=0)
    # 2. the rest by assignment
    fr, fc = _free(kept_row, kept_col, *d.shape)
    r, c = _best(d[np.ix_(fr, fc)], valid[np.ix_(fr, fc)])
    new_row, new_col = fr[r], fc[c]
    return kept_row, kept_col, new_row, new_col, d[np.concatenate([kept_row, new_row]),
                                                   np.concatenate([kept_col, new_col])]


def _close_scan(truth_xy: np.ndarray, track_xy: np.ndarray, last: np.ndarray, tracks: np.ndarray,
                threshold: float) -> tuple[np.ndarray, ...]:
    """`_dense_scan` over the pairs closer than the threshold only (`nnda.study.gospa.close_pairs`), for
    scans of hundreds of targets: the same rule (a pair at the threshold or beyond is never a match), so the
    same matches but where two assignments tie exactly in count and total distance."""
    i, j, d = close_pairs(truth_xy, track_xy, threshold)
    claim = last[i] == tracks[j]
    order = np.lexsort((i[claim], j[claim]))  # per claimed track, its claiming targets in id order
    ci, cj = i[claim][order], j[claim][order]
    first = np.ones(cj.size, bool)
    first[1:] = cj[1:] != cj[:-1]
    kept_row, kept_col = ci[first], cj[first]
    fr, fc = _free(kept_row, kept_col, len(truth_xy), len(track_xy))
    free = np.isin(i, fr) & np.isin(j, fc)
    new_row, new_col = np.empty(0, np.int64), np.empty(0, np.int64)
    if free.any():  # the most pairs first (each saves more than all distances together), then the least distance
        penalty = (min(fr.size, fc.size) + 1) * (float(d[free].max()) + 1.0)
        new_row, new_col = least_cost_assignment(i[free], j[free], d[free] - penalty, np.zeros(len(truth_xy)))
    rows, cols = np.concatenate([kept_row, new_row]), np.concatenate([kept_col, new_col])
    return kept_row, kept_col, new_row, new_col, pair_values(i, j, d, rows, cols, len(track_xy))


def _free(kept_row: np.ndarray, kept_col: np.ndarray, n_rows: int, n_cols: int) -> tuple[np.ndarray, np.ndarray]:
    """The rows and the columns not kept, ascending."""
    free_row, free_col = np.ones(n_rows, bool), np.ones(n_cols, bool)
    free_row[kept_row], free_col[kept_col] = False, False
    return np.flatnonzero(free_row), np.flatnonzero(free_col)


def match_scans(truth_scan: np.ndarray, truth_target: np.ndarray, truth_xy: np.ndarray, track_scan: np.ndarray,
                track_index: np.ndarray, track_xy: np.ndarray, n_scans: int, n_targets: int, n_tracks: int,
                threshold: float) -> Matches:
    """Match the tracks of each scan to the targets of that scan (module docstring).

    ``truth_scan`` (M,) sorted, ``truth_target`` (M,) ids, ``truth_xy`` (M, 2) m: the
    targets present per scan; ``track_scan`` (K,) sorted, ``track_index`` (K,) in
    0..n_tracks-1, ``track_xy`` (K, 2) m: the tracks reported per scan (each at most
    once a scan). ``threshold`` (m) > 0.
    """
    if not threshold > 0:
        raise ValueError(f"match_scans: the threshold must be > 0 m, got {threshold}")
    last_track = np.full(n_targets, -1, np.int64)  # each target's last matched track
    tb, kb = _bounds(truth_scan, n_scans), _bounds(track_scan, n_scans)
    parts = []
    for k in range(n_scans):
        targets = truth_target[tb[k]:tb[k + 1]]
        tracks = track_index[kb[k]:kb[k + 1]]
        if targets.size == 0 or tracks.size == 0:
            continue
        one = _dense_scan if targets.size * tracks.size <= DENSE_MAX_PAIRS else _close_scan
        kept_row, kept_col, new_row, new_col, distance = one(truth_xy[tb[k]:tb[k + 1]], track_xy[kb[k]:kb[k + 1]],
                                                             last_track[targets], tracks, threshold)
        switch = (last_track[targets[new_row]] >= 0) & (last_track[targets[new_row]] != tracks[new_col])
        rows, cols = np.concatenate([kept_row, new_row]), np.concatenate([kept_col, new_col])
        last_track[targets[rows]] = tracks[cols]
        order = np.argsort(targets[rows], kind="stable")
        parts.append((np.full(rows.size, k + 1), targets[rows][order], tracks[cols][order], distance[order],
                      np.concatenate([np.zeros(kept_row.size, bool), switch])[order]))
    if not parts:
        empty = np.empty(0, np.int64)
        return Matches(empty, empty, empty, np.empty(0), np.empty(0, bool))
    scan, target, track, dist, sw = (np.concatenate(p) for p in zip(*parts))
    return Matches(scan.astype(np.int64), target.astype(np.int64), track.astype(np.int64), dist, sw)
