"""Sampled and enumerated assignments of the GLMB joint prediction-update (Vo, Vo & Hoang 2017).

    assignments, log_weight = gibbs_assignments(cost, n_samples, seed, group)
    assignments, log_weight = all_assignments(cost, group)

``cost`` (n, 2 + m) float holds minus the log weight of each of n tracks' options in one scan: column 0
the track dies (or, a birth, is absent), column 1 it survives and is missed, column 2 + j it survives and
takes contact j of m; ``np.inf`` forbids an option (a contact outside the gate, a miss of weight 0). An
*assignment* gives every track one column, no contact (column >= 2) to two tracks; its log weight is minus
the sum of its entries. Column 0 must be finite in every row (a track can always die), so every problem has
an assignment. ``group`` (n,) int64, optional, ties rows that exclude each other: of the rows of one group
(>= 0; -1 none) at most one takes a column other than 0 (the births of one contact: one target made it).

`gibbs_assignments` draws ``n_samples`` assignments by the Gibbs sampler of Vo, Vo & Hoang (2017): each
sample sweeps the rows in order and redraws row i's column from its weights given the other rows' columns
(a contact another row holds has weight 0, and so has every column but 0 of a row whose group another row
holds). The chain starts at the contact-free assignment, every track its better of columns 0 and 1 (in
row order, column 0 for a row whose group is held already), which is the first sample; it and its
contact-free neighbours (one row switched between columns 0 and 1, where allowed) are always returned, so a
track of low existence keeps both its death and its miss however few draws leave the start. The draws come from
numba's generator seeded with ``seed`` (an int in [0, 2^32), e.g. drawn from a numpy Generator): the same
seed gives the same samples. With ``margin`` (nats), the assignments lighter than the heaviest found by more
than it are left out before they are ranked: at 800 (`NEGLIGIBLE`) their weights are below what a double
adds to the heaviest's, so a mixture that normalises and prunes them loses exactly nothing (the GLMB's many
contact-free neighbours, thousands of rows of thousands of tracks when the targets are many, are such).
Returned: the distinct assignments sampled, ``assignments`` (A, n) int64 the
column of each track, and their ``log_weight`` (A,), descending (ties in lexicographic order of the
assignment). The chain is stationary on the assignments' weights, so with enough samples the heavy ones are
all found; their weights are exact, not estimates.

`all_assignments` enumerates every assignment (the exact GLMB update of small problems: tests, and the
tracker's ``sampler = "exhaustive"``), in the same form.
"""

from __future__ import annotations

import itertools
import math

import numba
import numpy as np

#: nats: an assignment this much lighter than another adds nothing to it in double precision (e^-800 is below
#: the smallest double), the ``margin`` of `gibbs_assignments` that changes no normalised weight
NEGLIGIBLE = 800.0


def gibbs_assignments(cost: np.ndarray, n_samples: int, seed: int, group: np.ndarray | None = None,
                      margin: float | None = None, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The distinct assignments of ``n_samples`` Gibbs draws on ``cost`` (n, 2 + m) with the exclusive
    ``group`` of each row, and their log weights, without those lighter than the heaviest by more than
    ``margin`` nats (None: all; module docstring). ``check`` False skips the cost's checks (a caller that
    built it)."""
    cost = _checked(cost) if check else cost
    if not cost.shape[0]:
        return _ranked(cost, np.zeros((1, 0), np.int64))
    drawn = _drawn(cost, _groups(group, cost.shape[0]), max(int(n_samples), 1), int(seed),
                   math.inf if margin is None else float(margin))
    return _ranked(cost, drawn)


def all_assignments(cost: np.ndarray, group: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Every assignment of ``cost`` (n, 2 + m) with the exclusive ``group`` of each row and its log weight
    (module docstring), by enumeration."""
    cost = _checked(cost)
    group = _groups(group, cost.shape[0])
    options = [np.flatnonzero(np.isfinite(row)) for row in cost]
    found = []
    for pick in itertools.product(*options):
        held = [g for g, c in zip(group, pick) if g >= 0 and c > 0]
        if len({c for c in pick if c >= 2}) == sum(c >= 2 for c in pick) and len(set(held)) == len(held):
            found.append(pick)
    return _ranked(cost, np.array(found, np.int64).reshape(len(found), cost.shape[0]))


def _groups(group: np.ndarray | None, n: int) -> np.ndarray:
    """The rows' groups (n,) int64, renumbered 0..G-1 (-1: none)."""
    if group is None:
        return np.full(n, -1, np.int64)
    group = np.asarray(group, np.int64)
    if group.shape != (n,):
        raise ValueError(f"assignment groups must be one per row, shape ({n},), got {group.shape}")
    return _renumbered(group)


@numba.njit(cache=True, nogil=True)
def _renumbered(group):
    """``group`` (n,) int64 renumbered 0..G-1 in ascending order of its values >= 0 (-1 kept for the rest)."""
    values = np.unique(group[group >= 0])
    out = np.full(group.size, -1, np.int64)
    for i in range(group.size):
        if group[i] >= 0:
            out[i] = np.searchsorted(values, group[i])
    return out


def _checked(cost: np.ndarray) -> np.ndarray:
    cost = np.asarray(cost, np.float64)
    if cost.ndim != 2 or cost.shape[1] < 2:
        raise ValueError(f"assignment cost must be (n tracks, 2 + m contacts), got shape {cost.shape}")
    if np.isnan(cost).any() or (cost == -np.inf).any() or not np.isfinite(cost[:, 0]).all():
        raise ValueError("assignment cost: entries must be finite or +inf (forbidden), column 0 (death) finite")
    return cost


def _ranked(cost: np.ndarray, assignments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``assignments`` (A, n) and their log weights, descending by weight (stable on the given order)."""
    if not cost.shape[0]:
        return np.zeros((1, 0), np.int64), np.zeros(1)
    log_weight = -cost[np.arange(cost.shape[0]), assignments].sum(axis=1)
    order = np.argsort(-log_weight, kind="stable")
    return assignments[order], log_weight[order]


@numba.njit(cache=True, nogil=True)
def row_order(a):
    """The stable lexicographic order (A,) of the rows of ``a`` (A, n) int64, by merge sort."""
    A, n = a.shape
    idx = np.arange(A)
    tmp = np.empty(A, np.int64)
    width = 1
    while width < A:
        for lo in range(0, A, 2 * width):
            mid, hi = min(lo + width, A), min(lo + 2 * width, A)
            i, j = lo, mid
            for k in range(lo, hi):
                take_j = i >= mid
                if not take_j and j < hi:
                    c = 0
                    while c < n and a[idx[j], c] == a[idx[i], c]:
                        c += 1
                    take_j = c < n and a[idx[j], c] < a[idx[i], c]
                if take_j:
                    tmp[k] = idx[j]
                    j += 1
                else:
                    tmp[k] = idx[i]
                    i += 1
        idx, tmp = tmp, idx
        width *= 2
    return idx


@numba.njit(cache=True, nogil=True)
def run_heads(a, order):
    """Which places q of ``order`` (A,), a sort of the rows of ``a`` (A, n) that puts equal rows together
    (`row_order`), start a run of equal rows, (A,) bool: the first, and each row that differs from the one before."""
    A, n = a.shape
    head = np.ones(A, np.bool_)
    for q in range(1, A):
        same = True
        for i in range(n):
            if a[order[q], i] != a[order[q - 1], i]:
                same = False
                break
        head[q] = not same
    return head


@numba.njit(cache=True, nogil=True)
def _drawn(cost, group, n_samples, seed, margin):
    """The distinct assignments (A, n) of `gibbs_assignments`, in lexicographic order: ``n_samples`` draws
    (`_sampled`) on ``cost`` (n, 2 + m) with the renumbered ``group`` (n,), then the start's contact-free
    neighbours (one row switched between columns 0 and 1: to 0 always, to 1 where the row's group has no other
    row off column 0), less those whose cost exceeds the least found by more than ``margin`` (inf: none). One
    compiled pass."""
    n, C = cost.shape
    start = np.zeros(n + 1, np.int64)  # each row's allowed entries, ascending columns
    for i in range(n):
        k = 0
        for j in range(C):
            k += math.isfinite(cost[i, j])
        start[i + 1] = start[i] + k
    cols, vals = np.empty(start[n], np.int64), np.empty(start[n])
    e = 0
    for i in range(n):
        for j in range(C):
            if math.isfinite(cost[i, j]):
                cols[e], vals[e] = j, cost[i, j]
                e += 1
    samples = _sampled(cost, start, cols, vals, group, n_samples, seed)
    first = samples[0]
    held = np.zeros(max(group.max() + 1, 1), np.int64)  # rows of each group off column 0 at the start
    base = 0.0
    for i in range(n):
        base += cost[i, first[i]]
        if group[i] >= 0 and first[i] > 0:
            held[group[i]] += 1
    switch, switch_cost = np.empty(n, np.int64), np.empty(n)
    k = 0
    for i in range(n):
        other = 1 - first[i]
        if math.isfinite(cost[i, other]) and (group[i] < 0 or other == 0 or held[group[i]] == 0):
            switch[k], switch_cost[k] = i, base - cost[i, first[i]] + cost[i, other]
            k += 1
    sample_cost = np.zeros(n_samples)
    for t in range(n_samples):
        for i in range(n):
            sample_cost[t] += cost[i, samples[t, i]]
    limit = sample_cost.min()
    for q in range(k):
        limit = min(limit, switch_cost[q])
    limit += margin
    found = np.empty((n_samples + k, n), np.int64)
    a = 0
    for t in range(n_samples):
        if sample_cost[t] <= limit:
            found[a] = samples[t]
            a += 1
    for q in range(k):
        if switch_cost[q] <= limit:
            found[a] = first
            found[a, switch[q]] = 1 - first[switch[q]]
            a += 1
    found = found[:a]
    order = row_order(found)
    return found[order[run_heads(found, order)]]


@numba.njit(cache=True, nogil=True)
def _sampled(cost, start, cols, vals, group, n_samples, seed):
    """``n_samples`` Gibbs draws (n_samples, n) on ``cost`` (n, 2 + m), its allowed entries by row (row i's
    columns ``cols[start[i]:start[i + 1]]``, ascending, of costs ``vals``: a forbidden entry weighs 0 in
    every draw, so only the allowed are visited), with the rows' exclusive ``group`` (n,) (0..G-1, -1 none),
    the first the contact-free start."""
    np.random.seed(seed)
    n, C = cost.shape
    out = np.empty((n_samples, n), np.int64)
    held = np.zeros(C, np.int64)  # rows holding each column (only contacts' counts are read)
    taken = np.zeros(max(group.max() + 1, 1), np.int64)  # rows of each group off column 0
    pick = np.empty(n, np.int64)
    for i in range(n):
        free = group[i] < 0 or taken[group[i]] == 0
        pick[i] = 1 if (free and cost[i, 1] < cost[i, 0]) else 0
        held[pick[i]] += 1
        if group[i] >= 0 and pick[i] > 0:
            taken[group[i]] += 1
    w = np.empty(C)
    out[0] = pick
    for t in range(1, n_samples):
        for i in range(n):
            held[pick[i]] -= 1
            if group[i] >= 0 and pick[i] > 0:
                taken[group[i]] -= 1
            only_absent = group[i] >= 0 and taken[group[i]] > 0
            a, b = start[i], start[i + 1]
            low = math.inf
            for e in range(a, b):
                j = cols[e]
                if (j < 2 or held[j] == 0) and not (only_absent and j > 0):
                    low = min(low, vals[e])
            total = 0.0
            for e in range(a, b):
                j = cols[e]
                ok = (j < 2 or held[j] == 0) and not (only_absent and j > 0)
                w[e - a] = math.exp(low - vals[e]) if ok else 0.0
                total += w[e - a]
            u = np.random.random() * total
            e = 0
            acc = w[0]
            while acc <= u and e < b - a - 1:
                e += 1
                acc += w[e]
            while w[e] == 0.0:  # rounding past the last option of weight: step back to it
                e -= 1
            j = cols[a + e]
            pick[i] = j
            held[j] += 1
            if group[i] >= 0 and j > 0:
                taken[group[i]] += 1
        out[t] = pick
    return out
