"""One-to-one assignment of tracks to contacts over sparse candidate pairs.

`least_cost_assignment` is exact, with a miss option per track (global nearest
neighbour; the neural tracker's ``association = "global"``); `greedy_matching`
takes pairs by descending score (the neural method's conflict rule, spec A10).
Both take pairs as flat (rows, cols) arrays, so their cost grows with the
candidate pairs rather than with tracks x contacts.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import min_weight_full_bipartite_matching


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
    pair (e.g. track and contact), ``score`` (P,) its value. The result
    equals taking the pairs in order of descending score (ties: lower row,
    then lower column first) and keeping each whose row and column are both
    still free. Returns the kept (rows, cols), sorted by row.

    Vectorised by rounds: every pair that comes first among the remaining
    pairs of both its row and its column is one the sequential rule keeps;
    take them all, drop the pairs they block, repeat (a round keeps at least
    the best remaining pair; one round suffices when nothing conflicts).
    """
    rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
    if rows.size == 0:
        return rows, cols
    if np.bincount(rows).max() == 1 and np.bincount(cols).max() == 1:  # no conflict: keep every pair
        by_row = np.argsort(rows)
        return rows[by_row], cols[by_row]
    order = np.lexsort((cols, rows, -np.asarray(score)))
    r, c = rows[order], cols[order]
    row_taken = np.zeros(r.max() + 1, bool)
    col_taken = np.zeros(c.max() + 1, bool)
    kept = np.zeros(r.size, bool)
    live = np.arange(r.size)
    while live.size:
        win = live[_first_occurrence(r[live]) & _first_occurrence(c[live])]
        kept[win] = True
        row_taken[r[win]] = True
        col_taken[c[win]] = True
        live = live[~(row_taken[r[live]] | col_taken[c[live]])]
    r, c = r[kept], c[kept]
    by_row = np.argsort(r, kind="stable")
    return r[by_row], c[by_row]


def _first_occurrence(a: np.ndarray) -> np.ndarray:
    """Mask of the entries of ``a`` (P,) whose value does not occur earlier in ``a``."""
    s = np.argsort(a, kind="stable")
    sorted_a = a[s]
    first = np.empty(a.size, bool)
    first[s] = np.concatenate(([True], sorted_a[1:] != sorted_a[:-1]))
    return first
