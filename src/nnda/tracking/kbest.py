"""The k lowest-cost assignments of a rectangular cost matrix: Murty's ranking (Murty 1968).

    assignments, costs = k_best_assignments(cost, k)

``cost`` (R, C) float holds the cost of giving row i column j; ``np.inf`` forbids the pair. An
*assignment* is a set of min(R, C) pairs (i, j) of finite cost, no two sharing a row or a column: every
row has a column when R <= C, every column a row when R > C (scipy's `linear_sum_assignment` contract).
Returned, ascending by cost: ``assignments`` (m, R) int64, the column of each row (-1: a row left without
one, only when R > C), and ``costs`` (m,), each the sum of its pairs' entries in row order; m = min(k, the
number of feasible assignments). Ties keep the order in which the ranking meets them, which is fixed for a
given matrix. An empty matrix (R or C zero) has one assignment, the empty one, of cost 0.

Murty's partition: after an assignment of a subproblem (some pairs forced, some forbidden) is ranked, its
pairs (i_1, j_1), ..., (i_n, j_n) split the rest of the subproblem into n children, child t forcing pairs
1..t-1 and forbidding pair t; the pairs are split in order of the row's fewest allowed alternatives first
(Miller, Stone & Cox 1997). The first assignment is found with `linear_sum_assignment`; a child's best from
its parent's, which is optimal there and differs from the child's only along chains of rows through the
freed pair (Miller, Stone & Cox solve it from the parent's dual variables; here, without them, by two
shortest-path searches on the allowed pairs, Bellman-Ford with a queue, compiled: the best chain of rows
shifting into the freed column if it lowers the cost, then the shortest chain from the freed row to a free
column). A child's search touches only the pairs its chains reach, so a ranked assignment of a large sparse
matrix (a cluster of hundreds of tracks) costs R small searches, not R full solves; the full solver serves
where rounding keeps a search from settling (a cycle of zero cost). A child's forced and forbidden pairs are
built only when it is ranked. Each child's cost is summed in row order, as every assignment's.

A small problem (rows <= columns, at most `ENUMERATED` candidate assignments) is ranked by listing all its
assignments in one compiled pass and sorting them by cost: the partition's assignments and costs, without a
search per ranked assignment; only exact ties may come in another order.
"""

from __future__ import annotations

import heapq
import itertools
import math

import numba
import numpy as np
from scipy.optimize import linear_sum_assignment

from nnda.filters.imm_kernels import kernel_array
from nnda.tracking.exact import add_reduce

#: a problem of at most this many candidate assignments (the product of its rows' allowed columns, rows <=
#: columns) is ranked by listing every assignment, compiled, not by Murty's partition: a cluster of a few tracks
#: and contacts costs one call instead of a search per ranked assignment (the same assignments and costs; among
#: exactly equal costs the order may differ from the partition's)
ENUMERATED = 2048


def k_best_assignments(cost: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` lowest-cost assignments of ``cost`` (R, C) and their costs (module docstring)."""
    cost = kernel_array(cost)  # C order and writeable, as the kernels take it
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
    allowed = np.isfinite(cost).sum(axis=1)
    if not flipped and float(np.prod(allowed.astype(float))) <= ENUMERATED:
        return _enumerated(cost, k, allowed)
    # rows <= columns: every row of ``work`` is assigned; C order, as the kernels take it (one signature)
    work = kernel_array(cost.T) if flipped else cost
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


@numba.njit(cache=True, nogil=True)
def _enumerated(cost, k, allowed):
    """`k_best_assignments` of a small ``cost`` (R <= C, R > 0; ``allowed`` (R,) each row's finite entries): every
    assignment listed (depth first, each row's columns ascending), then the k of least cost (summed in row
    order as `_total` sums it, `exact.add_reduce`; ties in the listing's order). One compiled pass."""
    R, C = cost.shape
    cap = 1
    for i in range(R):
        cap *= allowed[i]
    found = np.empty((cap, R), np.int64)
    total = np.empty(cap)
    pick = np.full(R, -1, np.int64)
    taken = np.zeros(C, np.bool_)
    terms = np.empty(R)
    m, i = 0, 0
    while i >= 0:  # row i tries its next free column of finite cost; past its last, back to row i - 1
        if pick[i] >= 0:
            taken[pick[i]] = False
        j = pick[i] + 1
        while j < C and (taken[j] or not math.isfinite(cost[i, j])):
            j += 1
        if j == C:
            pick[i] = -1
            i -= 1
            continue
        pick[i] = j
        taken[j] = True
        if i < R - 1:
            i += 1
            continue
        for r in range(R):
            terms[r] = cost[r, pick[r]]
        found[m], total[m] = pick, add_reduce(terms)
        m += 1
    order = np.argsort(total[:m], kind="mergesort")[:k]
    return found[order], total[order]


def _total(cost: np.ndarray, cols: np.ndarray) -> float:
    """Sum of the entries of one assignment (the column of each row, -1 none) in row order."""
    rows = np.flatnonzero(cols >= 0)
    return float(cost[rows, cols[rows]].sum())


def _solve(cost: np.ndarray, forced: np.ndarray, banned: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Best assignment of ``cost`` (R <= C) with the rows' ``forced`` columns (R,) (-1: free) and the
    ``banned`` pairs (row * C + column), or None when none is feasible: (column of each row (R,), cost)."""
    free_rows = np.flatnonzero(forced < 0)
    taken = np.zeros(cost.shape[1], bool)
    taken[forced[forced >= 0]] = True
    free_cols = np.flatnonzero(~taken)
    if banned.size:
        cost = cost.copy()
        cost.flat[banned] = np.inf
    sub = cost if free_rows.size == cost.shape[0] else cost[np.ix_(free_rows, free_cols)]
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
    rows, adjacent = np.nonzero(np.isfinite(cost))  # each row's allowed columns
    adjacent = np.ascontiguousarray(adjacent)  # np.nonzero's outputs of a matrix are strided views
    start = np.searchsorted(rows, np.arange(R + 1))
    allowed = np.diff(start)
    first = _solve(cost, np.full(R, -1, np.int64), np.empty(0, np.int64))
    if first is None:
        return
    tie = itertools.count()  # equal costs leave the heap in the order they entered it
    heap = [(first[1], next(tie), first[0], (np.full(R, -1, np.int64), np.empty(0, np.int64)))]
    for n in range(k):
        if not heap:
            return
        total, _, cols, made = heapq.heappop(heap)
        yield cols, total
        if n == k - 1:
            return  # the k-th: its subproblems would not be ranked
        forced, banned = _constraints(made, C)
        free = np.flatnonzero(forced < 0)
        order = free[np.argsort(allowed[free] - np.bincount(banned // C, minlength=R)[free], kind="stable")]
        if R == C:
            order = order[:-1]  # the last free row of a square problem has no other column left
        found, kids = _reassigned(cost, start, adjacent, cols, forced, banned, order)
        totals = cost[np.arange(R), kids].sum(axis=1) if found.size else found
        for t in np.flatnonzero(found != 0):
            made = (cols, forced, banned, order, t)
            solved = (kids[t], float(totals[t])) if found[t] > 0 else _solve(cost, *_constraints(made, C))
            if solved is not None:
                heapq.heappush(heap, (solved[1], next(tie), solved[0], made))


def _constraints(made: tuple, C: int) -> tuple[np.ndarray, np.ndarray]:
    """A subproblem's forced columns (R,) and banned pairs (keys row * C + column) from how it was made: the
    root's (forced, banned), or a child's (its parent's columns, forced and banned, the order of the parent's
    rows and the child's place t in it: rows order[:t] forced to their columns, row order[t]'s pair banned),
    built only when the child is ranked."""
    if len(made) == 2:
        return made
    cols, forced, banned, order, t = made
    forced = forced.copy()
    forced[order[:t]] = cols[order[:t]]
    return forced, np.append(banned, order[t] * C + cols[order[t]])


@numba.njit(cache=True, nogil=True)
def _reassigned(cost, start, adjacent, cols, forced, banned, order):
    """The best assignment of each child from the parent's optimal ``cols`` (R,): child t of ``order`` (n,)
    bans row order[t]'s pair and forces the rows order[:t] (and ``forced``) (Miller, Stone & Cox 1997 use the
    parent's dual variables; here, without them, two shortest-path searches on the residual graph, by
    Bellman-Ford with a queue): with the row's column freed, first the best chain of rows shifting into it
    (each row to another allowed column, the last one's column freed) if it lowers the cost, then the
    shortest chain from the row to a free column. A path moves only rows not forced and uses no banned pair.
    Returns each child's outcome (n,), 1 solved, 0 infeasible (the row reaches no free column), -1 a search
    did not settle (rounding in a cycle of zero cost), and its columns (n, R)."""
    R, C = cost.shape
    n = order.size
    found = np.zeros(n, np.int64)
    kids = np.empty((n, R), np.int64)
    now = forced.copy()
    bans = np.append(banned, 0)
    for t in range(n):
        row = order[t]
        bans[-1] = row * C + cols[row]
        found[t] = _one_child(cost, start, adjacent, cols, now, bans, row, kids[t])
        now[row] = cols[row]
    return found, kids


@numba.njit(cache=True, nogil=True)
def _one_child(cost, start, adjacent, cols, forced, banned, row, col):
    """One child of `_reassigned`: its columns into ``col`` (R,); returns 1, 0 or -1 as there."""
    R, C = cost.shape
    col[:] = cols
    owner = np.full(C, -1, np.int64)
    for i in range(R):
        owner[col[i]] = i
    freed = col[row]
    col[row] = -1
    owner[freed] = -1
    dist = np.full(C, np.inf)
    prev = np.full(C, -1, np.int64)
    for j in range(C):
        if owner[j] >= 0 and forced[owner[j]] < 0:
            dist[j] = 0.0
    if not _settled(cost, start, adjacent, forced, banned, owner, dist, prev):
        return -1
    if dist[freed] < 0.0:  # a chain of rows into the freed column, the first one's column freed
        _shift(col, owner, prev, freed)
    dist[:] = np.inf
    prev[:] = -1
    for e in range(start[row], start[row + 1]):
        j = adjacent[e]
        if not _is_banned(banned, row * C + j) and (owner[j] < 0 or forced[owner[j]] < 0):
            dist[j] = cost[row, j]
    if not _settled(cost, start, adjacent, forced, banned, owner, dist, prev):
        return -1
    end, low = np.int64(-1), np.inf  # int64, not a literal: `_shift` compiles once
    for j in range(C):
        if owner[j] < 0 and dist[j] < low:
            end, low = j, dist[j]
    if end < 0:
        return 0
    first = _shift(col, owner, prev, end)
    col[row] = first
    owner[first] = row
    return 1


@numba.njit(cache=True, nogil=True)
def _settled(cost, start, adjacent, forced, banned, owner, dist, prev):
    """Bellman-Ford with a queue over the columns from the finite ``dist`` (C,): column j's row (``owner``,
    not forced) moves to another allowed column j' at cost[i, j'] - cost[i, j]; a free column ends a path.
    Fills ``dist`` and ``prev`` (the column each was reached from, -1 a start); False if it does not settle
    within C passes per column."""
    C = dist.size
    queue = np.empty(C, np.int64)
    waiting = np.zeros(C, np.bool_)
    passes = np.zeros(C, np.int64)
    head = tail = size = 0
    for j in range(C):
        if dist[j] < np.inf:
            queue[tail] = j
            tail = (tail + 1) % C
            size += 1
            waiting[j] = True
    while size:
        j = queue[head]
        head = (head + 1) % C
        size -= 1
        waiting[j] = False
        i = owner[j]
        if i < 0 or forced[i] >= 0:
            continue
        passes[j] += 1
        if passes[j] > C:
            return False
        for e in range(start[i], start[i + 1]):
            to = adjacent[e]
            if to == j or _is_banned(banned, i * C + to) or (owner[to] >= 0 and forced[owner[to]] >= 0):
                continue
            d = dist[j] + cost[i, to] - cost[i, j]
            if d < dist[to]:
                dist[to] = d
                prev[to] = j
                if not waiting[to]:
                    queue[tail] = to
                    tail = (tail + 1) % C
                    size += 1
                    waiting[to] = True
    return True


@numba.njit(cache=True, nogil=True)
def _shift(col, owner, prev, end):
    """Moves the rows of the path ending at column ``end`` (``prev``) one column on; returns its first column,
    now free."""
    to = end
    frm = prev[to]
    while frm >= 0:
        i = owner[frm]
        col[i] = to
        owner[to] = i
        to = frm
        frm = prev[to]
    owner[to] = -1
    return to


@numba.njit(cache=True, nogil=True)
def _is_banned(banned, key):
    """Whether the pair ``key`` (row * C + column) is in ``banned`` (a few keys: one per ranked ancestor)."""
    for b in banned:
        if b == key:
            return True
    return False
