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
   (`scipy.optimize.linear_sum_assignment`); a pair at the threshold or
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
        d = cdist(truth_xy[tb[k]:tb[k + 1]], track_xy[kb[k]:kb[k + 1]])
        valid = d < threshold
        # 1. last matches kept: per track, the lowest-id target (targets are in id order) claiming it
        claim = valid & (last_track[targets][:, None] == tracks[None, :])
        kept_col = np.flatnonzero(claim.any(axis=0))
        kept_row = np.argmax(claim[:, kept_col], axis=0)
        # 2. the rest by assignment
        free_row = np.ones(targets.size, bool)
        free_row[kept_row] = False
        free_col = np.ones(tracks.size, bool)
        free_col[kept_col] = False
        fr, fc = np.flatnonzero(free_row), np.flatnonzero(free_col)
        r, c = _best(d[np.ix_(fr, fc)], valid[np.ix_(fr, fc)])
        new_row, new_col = fr[r], fc[c]
        switch = (last_track[targets[new_row]] >= 0) & (last_track[targets[new_row]] != tracks[new_col])
        rows, cols = np.concatenate([kept_row, new_row]), np.concatenate([kept_col, new_col])
        last_track[targets[rows]] = tracks[cols]
        order = np.argsort(targets[rows], kind="stable")
        parts.append((np.full(rows.size, k + 1), targets[rows][order], tracks[cols][order], d[rows, cols][order],
                      np.concatenate([np.zeros(kept_row.size, bool), switch])[order]))
    if not parts:
        empty = np.empty(0, np.int64)
        return Matches(empty, empty, empty, np.empty(0), np.empty(0, bool))
    scan, target, track, dist, sw = (np.concatenate(p) for p in zip(*parts))
    return Matches(scan.astype(np.int64), target.astype(np.int64), track.astype(np.int64), dist, sw)
