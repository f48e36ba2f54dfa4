"""GOSPA and OSPA distances between a set of true positions and a set of track estimates.

GOSPA (Rahmathullah, Garcia-Fernandez & Svensson, FUSION 2017) with alpha = 2
splits into a localisation part (assigned pairs closer than the cut-off c), a
missed-target part and a false-track part, each c^p / 2 per unassigned
element. OSPA (Schuhmacher, Vo & Vo 2008) is the older, normalised metric;
for m <= n elements (either set the larger) it splits into a localisation
part ((1/n) sum of the assigned cut distances min(d, c)^p)^(1/p) and a
cardinality part (c^p (n - m) / n)^(1/p), both in m, with OSPA^p = loc^p +
card^p. The study uses the same c and p for both metrics (its GOSPA cut-off,
default 1000 m, and p = 2; `nnda.study.metrics`). Distances are Euclidean in
the plane (m). Inputs are (n, 2) position arrays.

Over a run, GOSPA with a switching penalty gamma (m) also charges each scan's
changes of the truths' assigned tracks (`switching_counts`: 1 from one track
to another, 0.5 between a track and none), after the trajectory metric of
Garcia-Fernandez, Rahmathullah & Svensson (2020):
(GOSPA_k^2 + gamma^2 n_k^(2/p))^(1/2) (`gospa_switching`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial import cKDTree
from scipy.spatial.distance import cdist

from nnda.tracking.assignment import least_cost_assignment


@dataclass(frozen=True)
class Gospa:
    """GOSPA of one scan: ``distance`` = (localisation + missed + false)^(1/p).

    The three parts are in units of m^p (they add up before the root);
    ``n_missed`` and ``n_false`` count unassigned truths and estimates.
    """

    distance: float
    localisation: float
    missed: float
    false: float
    n_missed: int
    n_false: int


#: problems of n truths x m estimates up to this many pairs are solved densely; larger ones (hundreds of
#: targets) over their pairs closer than the cut-off only (`_close_assignment`), so the cost grows with the
#: close pairs, not with n x m (benchmarks/bench_scoring.py)
DENSE_MAX_PAIRS = 40_000


def _assignment(truth: np.ndarray, estimates: np.ndarray, c: float, p: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The optimally assigned pairs closer than c (with alpha = 2 a pair at c or beyond costs the same as
    leaving both unassigned, so it counts as missed + false): their rows in truth and in estimates and their
    distances (m), (P,) each."""
    if len(truth) * len(estimates) > DENSE_MAX_PAIRS:
        return _close_assignment(truth, estimates, c, p)
    d = np.minimum(cdist(truth, estimates), c)
    rows, cols = linear_sum_assignment(d**p)
    pair = d[rows, cols]
    close = pair < c
    return rows[close], cols[close], pair[close]


def _close_assignment(truth: np.ndarray, estimates: np.ndarray, c: float, p: float
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`_assignment` over the pairs closer than c only (`close_pairs`): a pair at c or beyond
    costs c^p, as leaving both of its points unassigned does, so an optimal assignment of the whole n x m
    problem is one of these pairs' optimal partial assignments, each pair gaining c^p - d^p over leaving its
    points out (exact, `nnda.tracking.assignment.least_cost_assignment`). The same optimum as the dense
    problem; its sum may differ in the last bits."""
    i, j, d = close_pairs(truth, estimates, c)
    if not d.size:
        return i, j, d
    rows, cols = least_cost_assignment(i, j, d**p - c**p, np.zeros(len(truth)))
    return rows, cols, pair_values(i, j, d, rows, cols, len(estimates))


def close_pairs(a: np.ndarray, b: np.ndarray, c: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pairs of points of a (n, 2) and b (m, 2) closer than c (m): their rows in a and b and their
    distances (m), (P,) each, sorted by row of a, then of b. Found by k-d trees: the cost grows with the
    points and the close pairs, not with n x m."""
    pairs = cKDTree(a).sparse_distance_matrix(cKDTree(b), c, output_type="ndarray")
    pairs = pairs[pairs["v"] < c]
    pairs = pairs[np.lexsort((pairs["j"], pairs["i"]))]
    return pairs["i"].astype(np.int64), pairs["j"].astype(np.int64), pairs["v"].astype(np.float64)


def pair_values(i: np.ndarray, j: np.ndarray, v: np.ndarray, rows: np.ndarray, cols: np.ndarray, m: int
                ) -> np.ndarray:
    """The values v of the pairs (rows, cols), each one of the pairs (i, j) sorted as `close_pairs` gives
    them, with j < m."""
    return v[np.searchsorted(i * m + j, np.asarray(rows, np.int64) * m + np.asarray(cols, np.int64))]


def gospa(truth: np.ndarray, estimates: np.ndarray, c: float, p: float = 2.0) -> Gospa:
    """GOSPA (alpha = 2) between true positions (m, 2) and estimated positions (n, 2), in m."""
    return gospa_assignment(truth, estimates, c, p)[0]


def gospa_assignment(truth: np.ndarray, estimates: np.ndarray, c: float, p: float = 2.0
                     ) -> tuple[Gospa, np.ndarray]:
    """`gospa` and the assignment it is the cost of: for each truth row (m,) the estimate row assigned to it,
    or -1 (unassigned, or assigned at c or beyond)."""
    truth, estimates = _as_points("truth", truth), _as_points("estimates", estimates)
    if c <= 0 or p < 1:
        raise ValueError(f"GOSPA needs c > 0 and p >= 1, got c={c}, p={p}")
    assigned = np.full(len(truth), -1, np.int64)
    if len(truth) and len(estimates):
        rows, cols, d = _assignment(truth, estimates, c, p)
        assigned[rows] = cols
    else:
        d = np.empty(0)
    n_missed, n_false = len(truth) - d.size, len(estimates) - d.size
    loc = float(np.sum(d**p))
    missed, false = c**p / 2 * n_missed, c**p / 2 * n_false
    return Gospa(float((loc + missed + false) ** (1 / p)), loc, missed, false, n_missed, n_false), assigned


def switching_counts(scan: np.ndarray, truth_id: np.ndarray, assigned: np.ndarray, n_scans: int) -> np.ndarray:
    """Per scan (n_scans,) the track switches of the GOSPA assignments of a run (the switching cost of
    Garcia-Fernandez, Rahmathullah & Svensson (2020)'s trajectory metric, per scan as MATLAB's
    ``trackGOSPAMetric`` and Stone Soup's ``GOSPAMetric(switching_penalty=...)`` count it): each truth's
    assigned track is compared with its assignment at its previous scan of existence; a change from one track
    to another counts 1, from a track to none or from none to a track 0.5. A truth counts from its first scan
    with a track (the scans before, unassigned, count nothing); after that its last assignment is kept, none
    included. A scan without any estimate leaves its truths unassigned, so they count too (Stone Soup 1.9.1
    leaves such a scan out of its count, keeping the assignments before it).

    One entry per truth per scan of existence, (M,) each: ``scan`` (1-based), ``truth_id``, ``assigned`` (the
    assigned track's id, or -1 for none). Scan k's GOSPA with switching penalty gamma (m) is
    (GOSPA_k^2 + gamma^2 n_k^(2/p))^(1/2), n_k this function's count (`gospa_switching`).
    """
    scan, truth_id, assigned = (np.asarray(a, np.int64) for a in (scan, truth_id, assigned))
    if not scan.size:
        return np.zeros(n_scans)
    order = np.lexsort((scan, truth_id))
    scan, truth_id, assigned = scan[order], truth_id[order], assigned[order]
    group_start = np.r_[True, truth_id[1:] != truth_id[:-1]]
    first_row = np.maximum.accumulate(np.where(group_start, np.arange(scan.size), 0))  # of each row's truth
    ever = np.cumsum(assigned >= 0)  # rows assigned so far (all truths), up to and including each row
    before_group = np.where(first_row > 0, ever[first_row - 1], 0)
    started = ever > before_group  # the truth has had a track at this row or before
    prev, cur = assigned[:-1], assigned[1:]
    change = started[:-1] & ~group_start[1:] & (prev != cur)
    count = np.where(change, np.where((prev >= 0) & (cur >= 0), 1.0, 0.5), 0.0)
    return np.bincount(scan[1:] - 1, weights=count, minlength=n_scans)


def gospa_switching(distance: np.ndarray, switches: np.ndarray, gamma: float, p: float = 2.0) -> np.ndarray:
    """GOSPA with switching penalty ``gamma`` (m), per scan: (distance^2 + (gamma switches^(1/p))^2)^(1/2) (alpha
    = 2), from the scans' GOSPA ``distance`` (m) and `switching_counts`, (n_scans,) each."""
    return np.sqrt(np.asarray(distance) ** 2 + (gamma * np.asarray(switches) ** (1 / p)) ** 2)


@dataclass(frozen=True)
class Ospa:
    """OSPA of one scan (m): ``distance`` and its ``localisation`` and ``cardinality`` parts, each in m,
    with distance^p = localisation^p + cardinality^p (module docstring)."""

    distance: float
    localisation: float
    cardinality: float


def ospa_parts(truth: np.ndarray, estimates: np.ndarray, c: float, p: float = 2.0) -> Ospa:
    """OSPA (m) between two position sets with its localisation and cardinality parts; all 0 when both
    sets are empty, (c, 0, c) when exactly one is."""
    truth, estimates = _as_points("truth", truth), _as_points("estimates", estimates)
    m, n = sorted((len(truth), len(estimates)))
    if n == 0:
        return Ospa(0.0, 0.0, 0.0)
    if m == 0:
        return Ospa(float(c), 0.0, float(c))
    if m * n > DENSE_MAX_PAIRS:  # every point of the smaller set is assigned: far pairs at c^p each
        close = _close_assignment(truth, estimates, c, p)[2]
        loc, card = float(np.sum(close**p)) + c**p * (m - close.size), c**p * (n - m)
        return Ospa(float(((loc + card) / n) ** (1 / p)), float((loc / n) ** (1 / p)), float((card / n) ** (1 / p)))
    d = np.minimum(cdist(truth, estimates), c) ** p
    rows, cols = linear_sum_assignment(d)
    loc, card = d[rows, cols].sum(), c**p * (n - m)
    return Ospa(float(((loc + card) / n) ** (1 / p)), float((loc / n) ** (1 / p)), float((card / n) ** (1 / p)))


def ospa(truth: np.ndarray, estimates: np.ndarray, c: float, p: float = 2.0) -> float:
    """OSPA distance (m) between two position sets; 0 when both are empty."""
    return ospa_parts(truth, estimates, c, p).distance


def _as_points(name: str, a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, dtype=float).reshape(-1, 2) if np.size(a) == 0 else np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[1] != 2:
        raise ValueError(f"{name}: expected an (n, 2) array of positions, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name}: positions must be finite")
    return a
