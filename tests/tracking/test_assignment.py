"""`least_cost_assignment`: the dense and the sparse path against each other and against brute force."""

from __future__ import annotations

import numpy as np
import pytest

import nnda.tracking.assignment as assignment
from nnda.tracking.assignment import least_cost_assignment


def random_problem(rng: np.random.Generator, n_rows: int, n_cols: int, density: float, negative: bool = False):
    """Candidate pairs over scattered row and column ids (gaps, unsorted), their costs and a miss cost per row id."""
    row_ids = np.sort(rng.choice(3 * n_rows, n_rows, replace=False))
    col_ids = np.sort(rng.choice(5 * n_cols, n_cols, replace=False))
    mask = rng.random((n_rows, n_cols)) < density
    mask[rng.integers(n_rows), rng.integers(n_cols)] = True  # at least one pair
    r, c = np.nonzero(mask)
    order = rng.permutation(r.size)
    rows, cols = row_ids[r[order]], col_ids[c[order]]
    low = -5.0 if negative else 0.0
    cost = rng.uniform(low, 10.0, rows.size)
    miss_cost = rng.uniform(low + 3.0, 9.0, 3 * n_rows)
    return rows, cols, cost, miss_cost


def total(rows, cols, cost, miss_cost, got_rows, got_cols) -> float:
    """Cost of an assignment: its pairs' costs plus every other row's miss cost."""
    pair_cost = {(int(a), int(b)): float(w) for a, b, w in zip(rows, cols, cost)}
    taken = sum(pair_cost[int(a), int(b)] for a, b in zip(got_rows, got_cols))
    missed = set(np.unique(rows).tolist()) - set(np.asarray(got_rows).tolist())
    return taken + sum(float(miss_cost[i]) for i in missed)


def brute_force(rows, cols, cost, miss_cost) -> tuple[float, dict]:
    """Least total cost and its assignment {row: col} by enumerating every one-to-one choice (small problems)."""
    options = {}
    for a, b, w in zip(rows.tolist(), cols.tolist(), cost.tolist()):
        options.setdefault(a, []).append((b, w))
    order = sorted(options)
    best = [np.inf, {}]

    def walk(i, used, acc, picks):
        if i == len(order):
            if acc < best[0]:
                best[0], best[1] = acc, dict(picks)
            return
        row = order[i]
        walk(i + 1, used, acc + float(miss_cost[row]), picks)
        for col, w in options[row]:
            if col not in used:
                picks[row] = col
                walk(i + 1, used | {col}, acc + w, picks)
                del picks[row]

    walk(0, frozenset(), 0.0, {})
    return best[0], best[1]


def solve_both(monkeypatch, *problem):
    dense = least_cost_assignment(*problem)
    with monkeypatch.context() as m:
        m.setattr(assignment, "DENSE_MAX_ENTRIES", -1)
        sparse = least_cost_assignment(*problem)
    return dense, sparse


@pytest.mark.parametrize("seed", range(40))
def test_dense_and_sparse_paths_match_brute_force(seed, monkeypatch):
    rng = np.random.default_rng(seed)
    problem = random_problem(rng, int(rng.integers(1, 7)), int(rng.integers(1, 7)), float(rng.uniform(0.2, 0.9)),
                             negative=bool(seed % 2))
    best, picks = brute_force(*problem)
    dense, sparse = solve_both(monkeypatch, *problem)
    for got_rows, got_cols in (dense, sparse):
        assert np.all(np.diff(got_rows) > 0)  # one pair per row, sorted by row
        assert np.unique(got_cols).size == got_cols.size
        assert total(*problem, got_rows, got_cols) == pytest.approx(best, abs=1e-9)
        assert dict(zip(got_rows.tolist(), got_cols.tolist())) == picks  # continuous costs: a unique optimum
    np.testing.assert_array_equal(dense[0], sparse[0])
    np.testing.assert_array_equal(dense[1], sparse[1])


@pytest.mark.parametrize("seed", range(5))
def test_dense_and_sparse_paths_agree_on_gnn_sized_problems(seed, monkeypatch):
    """At the sizes of 1,000 clutter points a scan (about a hundred rows, sparse pairs) both paths give one answer."""
    rng = np.random.default_rng(100 + seed)
    problem = random_problem(rng, 100, 110, 0.02)
    dense, sparse = solve_both(monkeypatch, *problem)
    np.testing.assert_array_equal(dense[0], sparse[0])
    np.testing.assert_array_equal(dense[1], sparse[1])


def test_small_problems_go_dense_and_large_ones_sparse(monkeypatch):
    calls = []
    real = assignment.linear_sum_assignment
    monkeypatch.setattr(assignment, "linear_sum_assignment", lambda block: calls.append(block.shape) or real(block))
    rng = np.random.default_rng(7)
    least_cost_assignment(*random_problem(rng, 3, 4, 0.6))
    assert len(calls) == 1 and calls[0][0] * calls[0][1] <= assignment.DENSE_MAX_ENTRIES
    big = random_problem(rng, 300, 300, 0.01)
    rows, cols = least_cost_assignment(*big)
    assert len(calls) == 1  # the sparse path: no dense block built
    assert total(*big, rows, cols) <= total(*big, np.empty(0, int), np.empty(0, int)) + 1e-9


def test_forbidden_entries_are_never_taken_and_a_miss_can_win():
    # row 0 may take only column 4, row 1 only columns 4 and 9; row 2 misses more cheaply than any pair
    rows, cols = np.array([0, 1, 1, 2]), np.array([4, 4, 9, 9])
    cost, miss = np.array([1.0, 0.5, 3.0, 8.0]), np.array([5.0, 5.0, 2.0])
    got_rows, got_cols = least_cost_assignment(rows, cols, cost, miss)
    assert got_rows.tolist() == [0, 1] and got_cols.tolist() == [4, 9]  # 1 + 3 + 2 < 0.5 + 5 + 2


def test_no_pairs_assign_nothing():
    got_rows, got_cols = least_cost_assignment(np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0), np.zeros(3))
    assert got_rows.size == got_cols.size == 0


def test_rows_alone_in_their_component_skip_the_sparse_solver(monkeypatch):
    """Row 0 alone: column 10 given twice weighs 1 + 1.5, more than column 11's 2; row 1 alone, its one pair dearer
    than its miss; rows 2 and 3 share column 20, which only the sparse solver sees (2 rows, their 2 columns + 2
    misses)."""
    seen = []
    real = assignment.min_weight_full_bipartite_matching
    monkeypatch.setattr(assignment, "min_weight_full_bipartite_matching", lambda g: seen.append(g.shape) or real(g))
    rows, cols = np.array([0, 0, 0, 1, 2, 3, 3]), np.array([10, 10, 11, 12, 20, 20, 21])
    problem = rows, cols, np.array([1.0, 1.5, 2.0, 9.0, 1.0, 2.0, 5.0]), np.full(4, 4.0)
    dense, sparse = solve_both(monkeypatch, *problem)
    assert dict(zip(sparse[0].tolist(), sparse[1].tolist())) == {0: 11, 2: 20}
    np.testing.assert_array_equal(dense[0], sparse[0])
    np.testing.assert_array_equal(dense[1], sparse[1])
    assert seen == [(2, 4)]
