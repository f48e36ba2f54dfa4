"""Murty's k-best assignment against brute-force enumeration of every assignment."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from nnda.tracking import kbest
from nnda.tracking.kbest import k_best_assignments


def brute_force(cost: np.ndarray) -> list[tuple[float, tuple[int, ...]]]:
    """Every assignment of min(R, C) finite pairs, one per row (R <= C) or per column: (cost, column of each
    row, -1 none), ascending by cost."""
    R, C = cost.shape
    found = []
    if R <= C:
        for cols in itertools.permutations(range(C), R):
            c = [cost[i, j] for i, j in enumerate(cols)]
            if np.isfinite(c).all():
                found.append((float(np.sum(c)), tuple(cols)))
    else:
        for rows in itertools.permutations(range(R), C):
            assign = [-1] * R
            for j, i in enumerate(rows):
                assign[i] = j
            c = [cost[i, j] for j, i in enumerate(rows)]
            if np.isfinite(c).all():
                found.append((float(np.sum(c)), tuple(assign)))
    return sorted(found)


def random_matrix(rng: np.random.Generator) -> np.ndarray:
    R, C = rng.integers(1, 5), rng.integers(1, 5)
    cost = rng.integers(0, 4, (R, C)).astype(float) if rng.random() < 0.4 else rng.normal(0, 3, (R, C))
    cost[rng.random((R, C)) < rng.uniform(0, 0.5)] = np.inf
    return cost


@pytest.mark.parametrize("listed", [True, False], ids=["listed", "murty"])
@pytest.mark.parametrize("seed", range(6))
def test_murty_ranks_like_brute_force(seed, listed, monkeypatch):
    """Many random small matrices (forbidden entries, both rectangular shapes, integer costs with ties): the
    costs equal the enumeration's k smallest, each assignment is feasible, distinct and of its stated cost; by
    Murty's partition and by the compiled listing of small problems (`kbest.ENUMERATED`)."""
    if not listed:
        monkeypatch.setattr(kbest, "ENUMERATED", 0)
    rng = np.random.default_rng(seed)
    for _ in range(60):
        cost = random_matrix(rng)
        every = brute_force(cost)
        k = int(rng.integers(1, len(every) + 4))  # sometimes more than there are
        got, costs = k_best_assignments(cost, k)
        want = [c for c, _ in every[:k]]
        assert got.shape == (len(want), cost.shape[0])
        np.testing.assert_allclose(costs, want, rtol=0, atol=1e-9)
        assert len({tuple(a) for a in got.tolist()}) == len(want)  # distinct
        feasible = {a: c for c, a in every}
        for a, c in zip(got.tolist(), costs):
            assert tuple(a) in feasible and abs(feasible[tuple(a)] - c) < 1e-9


def test_more_asked_than_feasible_gives_all_of_them():
    cost = np.array([[1.0, np.inf, 3.0], [np.inf, 2.0, 0.5]])
    got, costs = k_best_assignments(cost, 10)
    assert got.tolist() == [[0, 2], [0, 1], [2, 1]] and costs.tolist() == [1.5, 3.0, 5.0]


def test_infeasible_and_empty_matrices():
    got, costs = k_best_assignments(np.array([[np.inf, np.inf], [1.0, 2.0]]), 3)
    assert got.shape == (0, 2) and costs.size == 0
    got, costs = k_best_assignments(np.array([[1.0], [np.inf]]).T, 3)  # one row, a forbidden column
    assert got.tolist() == [[0]]
    for shape in [(0, 0), (0, 3), (2, 0)]:
        got, costs = k_best_assignments(np.empty(shape), 4)
        assert got.tolist() == [[-1] * shape[0]] and costs.tolist() == [0.0]
    assert k_best_assignments(np.ones((2, 2)), 0)[0].shape == (0, 2)


def test_tall_matrices_leave_rows_unassigned():
    cost = np.array([[5.0], [1.0], [3.0]])
    got, costs = k_best_assignments(cost, 5)
    assert got.tolist() == [[-1, 0, -1], [-1, -1, 0], [0, -1, -1]] and costs.tolist() == [1.0, 3.0, 5.0]


def test_bad_matrices_are_refused():
    with pytest.raises(ValueError, match="2-D"):
        k_best_assignments(np.ones(3), 2)
    with pytest.raises(ValueError, match="NaN"):
        k_best_assignments(np.array([[np.nan, 1.0]]), 2)


def test_a_child_may_shift_another_row_into_the_freed_column():
    """Second best of a rectangular problem: row 0 leaves column 0 for column 2 and row 1 moves from column 1
    into column 0 (both in one child, found from the best assignment without a new solve)."""
    cost = np.array([[0.0, np.inf, 100.0], [0.0, 10.0, np.inf]])
    got, costs = k_best_assignments(cost, 3)
    assert got.tolist() == [[0, 1], [2, 0], [2, 1]] and costs.tolist() == [10.0, 100.0, 110.0]


def test_children_are_solved_from_their_parent_by_shortest_paths(monkeypatch):
    """A sparse 60-row problem, 20 best: only the first assignment calls the full solver (each child is its
    parent's assignment changed along shortest paths), and the ranking equals the one solving every child in
    full (same costs, same assignments: no ties)."""
    import nnda.tracking.kbest as kbest

    rng = np.random.default_rng(3)
    R = 60
    cost = np.full((R, 2 * R), np.inf)
    for i in range(R):  # each row: its own miss column (0) and two or three contacts near it
        cost[i, R + i] = 0.0
        cost[i, (i + rng.integers(0, 4, 3)) % R] = rng.normal(-2.0, 1.0, 3)
    calls = []
    solver = kbest.linear_sum_assignment
    monkeypatch.setattr(kbest, "linear_sum_assignment", lambda m: calls.append(1) or solver(m))
    got, costs = k_best_assignments(cost, 20)
    assert len(calls) == 1
    monkeypatch.setattr(kbest, "_reassigned", lambda cost, *a: (np.full(a[-1].size, -1), np.zeros(
        (a[-1].size, cost.shape[0]), np.int64)))  # every child by the full solver
    want, want_costs = k_best_assignments(cost, 20)
    assert len(calls) > 20 * R / 2
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(costs, want_costs)


def test_small_problems_listed_give_murtys_ranking_to_the_bit(monkeypatch):
    """Random matrices of 1-4 rows and up to 8 columns (forbidden entries, real costs: no ties): the compiled
    listing and Murty's partition give the same assignments in the same order and the same costs, bit for
    bit."""
    rng = np.random.default_rng(7)
    for _ in range(300):
        R = int(rng.integers(1, 5))
        C = int(rng.integers(R, 9))
        cost = rng.normal(0.0, 3.0, (R, C)) * 10.0 ** rng.integers(-3, 4, (R, C))
        cost[rng.random((R, C)) < 0.4] = np.inf
        k = int(rng.integers(1, 60))
        listed = k_best_assignments(cost, k)
        with monkeypatch.context() as m:
            m.setattr(kbest, "ENUMERATED", 0)
            ranked = k_best_assignments(cost, k)
        np.testing.assert_array_equal(listed[0], ranked[0])
        np.testing.assert_array_equal(listed[1], ranked[1])
