"""The k lowest-cost assignments of a rectangular cost matrix: Murty's ranking (Murty 1968).

    assignments, costs = k_best_assignments(cost, k)

``cost`` (R, C) float holds the cost of giving row i column j; ``np.inf`` forbids the pair. An
*assignment* is a set of min(R, C) pairs (i, j) of finite cost, no two sharing a row or a column: every
row has a column when R <= C, every column a row when R > C (scipy's `linear_sum_assignment` contract).
Returned, ascending by cost: ``assignments`` (m, R) int64, the column of each row (-1: a row left without
one, only when R > C), and ``costs`` (m,), each the sum of its pairs' entries in row order; m = min(k, the
number of feasible assignments). Ties keep the order in which the ranking meets them, which is fixed for a
given matrix. An empty matrix (R or C zero) has one assignment, the empty one, of cost 0.

Murty's partition: the best assignment of a subproblem (some pairs forced, some forbidden) is found with
`linear_sum_assignment`; after it is ranked, its pairs (i_1, j_1), ..., (i_n, j_n) split the rest of the
subproblem into n children, child t forcing pairs 1..t-1 and forbidding pair t. Of the optimisations of
Miller, Stone & Cox (1997) the cheap ones are used: a child solves only the rows and columns its forced
pairs leave free (the smaller matrix), a child whose free rows include one with no allowed column is not
solved, and the pairs are split in order of the row's fewest allowed alternatives first, so the later, more
constrained children are the smaller ones. Each ranked assignment costs at most R solves.
"""

from __future__ import annotations

import heapq
import itertools

import numpy as np
from scipy.optimize import linear_sum_assignment


def k_best_assignments(cost: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` lowest-cost assignments of ``cost`` (R, C) and their costs (module docstring)."""
    cost = np.asarray(cost, np.float64)
    if cost.ndim != 2:
        raise ValueError(f"k_best_assignments: cost must be a 2-D matrix, got shape {cost.shape}")
    if np.isnan(cost).any() or (cost == -np.inf).any():
        raise ValueError("k_best_assignments: cost entries must be finite or +inf (forbidden), not NaN or -inf")
    R, C = cost.shape
    if k <= 0:
        return np.empty((0, R), np.int64), np.empty(0)
    if R == 0 or C == 0:
        return np.full((1, R), -1, np.int64), np.zeros(1)
    flipped = R > C
    work = cost.T if flipped else cost  # rows <= columns: every row of ``work`` is assigned
    found = list(_ranked(work, k))
    if not found:
        return np.empty((0, R), np.int64), np.empty(0)
    out = np.full((len(found), R), -1, np.int64)
    for n, (cols, _) in enumerate(found):
        if flipped:
            out[n, cols] = np.arange(C)
        else:
            out[n] = cols
    costs = np.array([_total(cost, row) for row in out])
    return out, costs


def _total(cost: np.ndarray, cols: np.ndarray) -> float:
    """Sum of the entries of one assignment (the column of each row, -1 none) in row order."""
    rows = np.flatnonzero(cols >= 0)
    return float(cost[rows, cols[rows]].sum())


def _solve(cost: np.ndarray, forced: np.ndarray, banned: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Best assignment of ``cost`` (R <= C) with the rows' ``forced`` columns (R,) (-1: free) and the
    ``banned`` (R, C) pairs, or None when none is feasible: (column of each row (R,), cost)."""
    free_rows = np.flatnonzero(forced < 0)
    taken = np.zeros(cost.shape[1], bool)
    taken[forced[forced >= 0]] = True
    free_cols = np.flatnonzero(~taken)
    sub = np.where(banned[np.ix_(free_rows, free_cols)], np.inf, cost[np.ix_(free_rows, free_cols)])
    if free_rows.size and (~np.isfinite(sub)).all(axis=1).any():
        return None
    cols = forced.copy()
    if free_rows.size:
        try:
            r, c = linear_sum_assignment(sub)
        except ValueError:  # no assignment of finite cost
            return None
        cols[free_rows[r]] = free_cols[c]
    return cols, _total(cost, cols)


def _ranked(cost: np.ndarray, k: int):
    """Murty's ranking of ``cost`` (R <= C): yields (column of each row (R,), cost), ascending, at most k."""
    R, C = cost.shape
    allowed = np.isfinite(cost).sum(axis=1)
    first = _solve(cost, np.full(R, -1, np.int64), np.zeros((R, C), bool))
    if first is None:
        return
    tie = itertools.count()  # equal costs leave the heap in the order they entered it
    heap = [(first[1], next(tie), first[0], np.full(R, -1, np.int64), np.zeros((R, C), bool))]
    for _ in range(k):
        if not heap:
            return
        total, _, cols, forced, banned = heapq.heappop(heap)
        yield cols, total
        free = np.flatnonzero(forced < 0)
        order = free[np.argsort(allowed[free] - banned[free].sum(axis=1), kind="stable")]
        child_forced = forced.copy()
        for t, row in enumerate(order):
            if t == order.size - 1 and R == C:
                break  # the last free row of a square problem has no other column left
            child_banned = banned.copy()
            child_banned[row, cols[row]] = True
            solved = _solve(cost, child_forced, child_banned)
            if solved is not None:
                heapq.heappush(heap, (solved[1], next(tie), solved[0], child_forced.copy(), child_banned))
            child_forced[row] = cols[row]
