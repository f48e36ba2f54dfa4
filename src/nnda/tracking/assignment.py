"""One-to-one assignment of tracks to contacts over sparse candidate pairs.

`least_cost_assignment` is exact, with a miss option per track (global nearest
neighbour; the neural tracker's ``association = "global"``); `greedy_matching`
takes pairs by descending score (the neural method's conflict rule: each contact to
the track that scores it highest).
Both take pairs as flat (rows, cols) arrays, so their cost grows with the
candidate pairs rather than with tracks x contacts. `given` marks the
contacts that tracks' picks (K,) took (compiled: the trackers' scan end and
the neural tracker's stages call it).
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import min_weight_full_bipartite_matching

from nnda.tracking.output import NO_CONTACT


def least_cost_assignment(rows: np.ndarray, cols: np.ndarray, cost: np.ndarray, miss_cost: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Least-cost one-to-one assignment over sparse candidate pairs (P,); returns assigned (rows, cols).

    ``cost`` (P,) is the cost of each pair; row ``i`` may instead stay
    unassigned at ``miss_cost[i]`` (``miss_cost`` is indexed by row, so it
    covers every row that occurs). A column may stay unassigned for free.
    Solved exactly on the sparse graph (scipy's
    `min_weight_full_bipartite_matching`), so memory grows with the pairs,
    not with rows x columns.
    """
    track, ti = np.unique(rows, return_inverse=True)
    cont, ci = np.unique(cols, return_inverse=True)
    R, C = track.size, cont.size
    weight = np.concatenate([cost, miss_cost[track]])
    weight = weight - weight.min() + 1.0  # positive weights; every full matching has R edges, so no optimum moves
    graph = csr_matrix((weight, (np.concatenate([ti, np.arange(R)]), np.concatenate([ci, C + np.arange(R)]))),
                       shape=(R, C + R))
    r, c = min_weight_full_bipartite_matching(graph)
    real = c < C
    return track[r[real]], cont[c[real]]


def greedy_matching(rows: np.ndarray, cols: np.ndarray, score: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Greedy one-to-one matching of candidate pairs by descending score.

    ``rows``, ``cols`` (P,) non-negative ints index the two sides of each
    pair (e.g. track and contact), ``score`` (P,) its finite value. The
    result equals taking the pairs in order of descending score (ties: lower
    row, then lower column first) and keeping each whose row and column are
    both still free. Returns the kept (rows, cols), sorted by row.

    Compiled (`greedy_kernel`: two stable sorts and one pass): the neural tracker
    matches a few times a scan on tens of pairs, where the vectorised rounds
    it replaced spent their time in numpy's per-call overhead.
    """
    rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
    if rows.size == 0:
        return rows, cols
    return greedy_kernel(rows, cols, np.asarray(score, np.float64))


@numba.njit(cache=True, nogil=True)
def greedy_kernel(rows, cols, score):
    """`greedy_matching` of P >= 1 pairs, int64 rows and cols, float64 scores (callable from compiled code)."""
    n_rows, n_cols = rows.max() + 1, cols.max() + 1
    by_pair = np.argsort(rows * n_cols + cols, kind="mergesort")  # ties of score: lower row, then column
    order = by_pair[np.argsort(-score[by_pair], kind="mergesort")]
    pick = np.full(n_rows, -1, np.int64)
    col_taken = np.zeros(n_cols, np.bool_)
    for i in order:
        r, c = rows[i], cols[i]
        if pick[r] < 0 and not col_taken[c]:
            pick[r] = c
            col_taken[c] = True
    kept = np.flatnonzero(pick >= 0)
    return kept, pick[kept]


@numba.njit(cache=True, nogil=True)
def given(contact, n):
    """(n,) True for the contacts some track of ``contact`` (K,) took."""
    taken = np.zeros(n, np.bool_)
    for c in contact:
        if c != NO_CONTACT:
            taken[c] = True
    return taken
