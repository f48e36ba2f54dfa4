"""One-to-one assignment of tracks to contacts over sparse candidate pairs.

`least_cost_assignment` is exact, with a miss option per track (global nearest
neighbour; the neural tracker's ``association = "global"``); `greedy_matching`
takes pairs by descending score (the neural method's conflict rule: each contact to
the track that scores it highest).
Both take pairs as flat (rows, cols) arrays, so their cost grows with the
candidate pairs rather than with tracks x contacts (`least_cost_assignment`
solves a small problem as a dense block, where that is faster). `given` marks the
contacts that tracks' picks (K,) took (compiled: the trackers' scan end and
the neural tracker's stages call it).
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import min_weight_full_bipartite_matching

from nnda.tracking.marginals import clusters
from nnda.tracking.output import NO_CONTACT

#: problems of R rows and C columns with R x (C + R) up to this many entries are solved densely
#: (`linear_sum_assignment` on the block of `dense_block`), larger ones on the sparse graph. Measured on
#: GNN's problems at 1,000 and 5,000 clutter points a scan (S3, S6): the sparse solver's set-up costs
#: ~130 us a call whatever the size, the dense one ~3 us at the usual few x few and ~120 us at 20,000-40,000
#: entries; past ~40,000 the sparse graph is faster.
DENSE_MAX_ENTRIES = 30_000


def least_cost_assignment(rows: np.ndarray, cols: np.ndarray, cost: np.ndarray, miss_cost: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Least-cost one-to-one assignment over sparse candidate pairs (P,); returns assigned (rows, cols).

    ``cost`` (P,) is the cost of each pair; row ``i`` may instead stay
    unassigned at ``miss_cost[i]`` (``miss_cost`` is indexed by row, so it
    covers every row that occurs). A column may stay unassigned for free.
    The pairs' R distinct rows and C distinct columns form an R x (C + R)
    problem, a miss column per row. Up to `DENSE_MAX_ENTRIES` entries it is
    solved as a dense block (scipy's `linear_sum_assignment`, forbidden entries
    infinite), beyond exactly on the sparse graph (scipy's
    `min_weight_full_bipartite_matching`), so memory grows with the pairs,
    not with rows x columns. Both see the same weights (costs shifted to be
    positive, which moves no optimum: every full matching has R edges).
    The assigned pairs come sorted by row.
    """
    rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
    cost, miss_cost = np.asarray(cost, np.float64), np.asarray(miss_cost, np.float64)
    if rows.size == 0:
        return rows, cols
    track, ti, cont, ci, weight, block = compressed(rows, cols, cost, miss_cost, DENSE_MAX_ENTRIES)
    R, C = track.size, cont.size
    if block.size:
        r, c = linear_sum_assignment(block)
    else:
        r, c = _sparse_solution(ti, ci, weight, R, C)
    real = c < C
    return track[r[real]], cont[c[real]]


def _sparse_solution(ti: np.ndarray, ci: np.ndarray, weight: np.ndarray, R: int, C: int
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The least-weight full matching of a compressed problem too large for a dense block (`compressed`: P pairs
    (ti, ci), their weights then the R rows' miss weights, C columns), as (row, column) index arrays, a miss
    column C + i for row i. The rows linked by shared columns form components solved apart: a row alone in its
    component takes its lightest column (summed over a pair given twice) when lighter than its miss
    (`_lone_rows`), the others together on the sparse graph (scipy's `min_weight_full_bipartite_matching`).
    In dense clutter most rows are alone, and the sparse solver's cost grew faster than the pairs."""
    P = ti.size
    _, label = clusters(ti, ci, R)
    alone = np.bincount(label, minlength=R)[label] == 1  # (R,)
    r1, c1 = _lone_rows(ti, ci, weight, alone, C)
    rest = np.flatnonzero(~alone)
    if not rest.size:
        return r1, c1
    keep = ~alone[ti]
    n = rest.size
    sub = np.full(R, -1, np.int64)
    sub[rest] = np.arange(n)
    used, col = np.unique(ci[keep], return_inverse=True)  # the columns of these rows, renumbered
    graph = csr_matrix((np.concatenate([weight[:P][keep], weight[P:][rest]]),
                        (np.concatenate([sub[ti[keep]], np.arange(n)]),
                         np.concatenate([col.ravel(), used.size + np.arange(n)]))), shape=(n, used.size + n))
    r2, c2 = min_weight_full_bipartite_matching(graph)
    c2 = np.where(c2 < used.size, used[np.minimum(c2, used.size - 1)], C + rest[r2])  # back to the full problem's
    r = np.concatenate([r1, rest[r2]])
    order = np.argsort(r, kind="stable")
    return r[order], np.concatenate([c1, c2])[order]


@numba.njit(cache=True, nogil=True)
def _lone_rows(ti, ci, weight, alone, C):
    """`_sparse_solution`'s rows ``alone`` (R,) in their components: each takes the column of least summed weight
    of its pairs (P,; the first such column of its pairs) when lighter than its miss weight (``weight[P + i]``),
    else its miss column C + i. Returns (rows, columns), by row."""
    P, R = ti.size, alone.size
    total = np.zeros(C)
    best = np.full(R, -1, np.int64)
    for p in range(P):
        if alone[ti[p]]:
            total[ci[p]] += weight[p]
    for p in range(P):
        i = ti[p]
        if alone[i] and (best[i] < 0 or total[ci[p]] < total[best[i]]):
            best[i] = ci[p]
    rows = np.flatnonzero(alone)
    cols = np.empty(rows.size, np.int64)
    for k in range(rows.size):
        i = rows[k]
        cols[k] = best[i] if best[i] >= 0 and total[best[i]] < weight[P + i] else C + i
    return rows, cols


@numba.njit(cache=True, nogil=True)
def compressed(rows, cols, cost, miss_cost, dense_max):
    """The distinct rows (R,) and columns (C,) of P >= 1 pairs, ascending, each pair's index into them (P,)
    (as `np.unique(..., return_inverse=True)`), the weights (P + R,): the pairs' costs, then the rows'
    miss costs, shifted so that the least is 1; and the problem's `dense_block` where it has at most
    ``dense_max`` entries, R x (C + R), else a (0, 0) block (in the same call: GNN solves a problem or two a
    scan)."""
    row_at = np.full(rows.max() + 1, -1, np.int64)
    col_at = np.full(cols.max() + 1, -1, np.int64)
    for r in rows:
        row_at[r] = 0
    for c in cols:
        col_at[c] = 0
    track = np.flatnonzero(row_at == 0)
    cont = np.flatnonzero(col_at == 0)
    row_at[track] = np.arange(track.size)
    col_at[cont] = np.arange(cont.size)
    P, R = rows.size, track.size
    weight = np.empty(P + R)
    weight[:P] = cost
    weight[P:] = miss_cost[track]
    weight = weight - weight.min() + 1.0
    ti, ci, C = row_at[rows], col_at[cols], cont.size
    block = dense_block(ti, ci, weight, C) if R * (C + R) <= dense_max else np.empty((0, 0))
    return track, ti, cont, ci, weight, block


@numba.njit(cache=True, nogil=True)
def dense_block(ti, ci, weight, C):
    """The R x (C + R) cost block of a compressed problem: the pairs' weights at (ti, ci) (a pair given twice
    weighs the sum, as in a sparse matrix), row i's miss weight at column C + i, every other entry infinite."""
    P = ti.size
    R = weight.size - P
    block = np.full((R, C + R), np.inf)
    for k in range(P):
        w = block[ti[k], ci[k]]
        block[ti[k], ci[k]] = weight[k] if w == np.inf else w + weight[k]
    for i in range(R):
        block[i, C + i] = weight[P + i]
    return block


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
