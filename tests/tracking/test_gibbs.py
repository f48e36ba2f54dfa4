"""The Gibbs sampler of the GLMB joint prediction-update against brute-force enumeration."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from nnda.tracking.gibbs import _sampled, all_assignments, gibbs_assignments


def random_cost(rng: np.random.Generator, n: int, m: int) -> np.ndarray:
    """n tracks x (2 + m): death and miss always allowed, each contact gated with probability 0.7."""
    cost = rng.uniform(-3.0, 3.0, (n, 2 + m))
    cost[:, 2:][rng.random((n, m)) > 0.7] = np.inf
    return cost


def brute_force(cost: np.ndarray, group=None) -> dict[tuple, float]:
    n, C = cost.shape
    group = [-1] * n if group is None else list(group)
    out = {}
    for pick in itertools.product(range(C), repeat=n):
        contacts = [c for c in pick if c >= 2]
        held = [g for g, c in zip(group, pick) if g >= 0 and c > 0]
        total = sum(cost[i, c] for i, c in enumerate(pick))
        if len(contacts) == len(set(contacts)) and len(held) == len(set(held)) and np.isfinite(total):
            out[pick] = -total
    return out


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("grouped", [False, True])
def test_the_sampler_finds_the_k_best_with_their_exact_weights(seed, grouped):
    """Random problems (some rows in exclusive groups when ``grouped``): the distinct assignments of 3,000
    draws include the 5 best of the enumeration, each with its exact weight."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5))
    cost = random_cost(rng, n, int(rng.integers(0, 4)))
    group = rng.integers(-1, 2, n) if grouped else None
    want = brute_force(cost, group)
    best = sorted(want, key=lambda a: -want[a])[:5]
    found, log_w = gibbs_assignments(cost, 3_000, int(rng.integers(2**32)), group)
    got = {tuple(a): w for a, w in zip(found.tolist(), log_w)}
    assert set(best) <= set(got) <= set(want)
    for a, w in got.items():
        assert w == pytest.approx(want[a], abs=1e-9)
    assert np.all(np.diff(log_w) <= 0)


def test_the_contact_free_start_and_its_neighbours_are_always_returned_and_the_seed_repeats():
    """One draw: the start (each row its better of death and miss) and the four assignments one row away from
    it, whatever their weight; more draws repeat with the seed."""
    rng = np.random.default_rng(7)
    cost = random_cost(rng, 4, 3)
    cost[0, :2] = [0.0, 30.0]  # a miss of weight e^-30 next to the death
    start = tuple(np.where(cost[:, 1] < cost[:, 0], 1, 0))
    a, wa = gibbs_assignments(cost, 1, 11)
    flipped = {tuple(int(c) ^ (i == k) for i, c in enumerate(start)) for k in range(4)}
    assert {tuple(r) for r in a.tolist()} == {start} | flipped
    grouped, _ = gibbs_assignments(np.zeros((2, 2)), 1, 11, np.array([0, 0]))  # equal costs: both start absent
    assert {tuple(r) for r in grouped.tolist()} == {(0, 0), (1, 0), (0, 1)}  # never both present
    b, wb = gibbs_assignments(cost, 200, 11)
    c, wc = gibbs_assignments(cost, 200, 11)
    np.testing.assert_array_equal(b, c)
    np.testing.assert_array_equal(wb, wc)
    assert start in {tuple(r) for r in b.tolist()} and len(b) > 1


@pytest.mark.parametrize("seed", range(6))
def test_a_margin_leaves_out_only_the_assignments_that_much_lighter(seed):
    """With a margin, the result is the margin-free one without the assignments lighter than its heaviest by
    more than the margin, in the same order and with the same weights; 40 tracks whose contacts are far
    likelier than their misses make the contact-free start and its neighbours hundreds of nats lighter."""
    rng = np.random.default_rng(seed)
    cost = random_cost(rng, 40, 45)
    cost[:, 2:] -= 25.0  # every gated contact e^25 likelier than the miss
    cost[:, :2] += 10.0
    every, w_every = gibbs_assignments(cost, 30, seed)
    some, w_some = gibbs_assignments(cost, 30, seed, margin=50.0)
    kept = w_every >= w_every[0] - 50.0
    assert 0 < kept.sum() < kept.size - 40  # the start and most of its 40 neighbours are left out
    np.testing.assert_array_equal(some, every[kept])
    np.testing.assert_array_equal(w_some, w_every[kept])


@pytest.mark.parametrize("group", [None, [4, -1, 4]])
def test_enumeration_is_the_brute_force(group):
    rng = np.random.default_rng(3)
    cost = random_cost(rng, 3, 3)
    want = brute_force(cost, group)
    found, log_w = all_assignments(cost, group)
    assert {tuple(a): w for a, w in zip(found.tolist(), log_w)} == pytest.approx(want, abs=1e-12)
    assert len(found) == len(want)


def test_no_tracks_has_the_one_empty_assignment():
    for found, log_w in (gibbs_assignments(np.zeros((0, 4)), 10, 1), all_assignments(np.zeros((0, 4)))):
        assert found.shape == (1, 0) and log_w.tolist() == [0.0]


def test_bad_costs_are_refused():
    with pytest.raises(ValueError, match="column 0"):
        gibbs_assignments(np.array([[np.inf, 0.0]]), 5, 1)
    with pytest.raises(ValueError, match="shape"):
        all_assignments(np.zeros((2, 1)))
    with pytest.raises(ValueError, match="one per row"):
        gibbs_assignments(np.zeros((2, 3)), 5, 1, np.array([0]))


def dense_draws(cost: np.ndarray, group: np.ndarray, n_samples: int, seed: int) -> np.ndarray:
    """The module docstring's sampler, every column of every row visited, with the same generator (numpy's
    legacy Mersenne Twister, as numba's): the reference of the compiled one."""
    rand = np.random.RandomState(seed)
    n, C = cost.shape
    pick = np.zeros(n, np.int64)
    for i in range(n):
        free = group[i] < 0 or not any(pick[r] > 0 for r in range(i) if group[r] == group[i])
        pick[i] = 1 if free and cost[i, 1] < cost[i, 0] else 0
    out = [pick.copy()]
    for _ in range(1, n_samples):
        for i in range(n):
            held = {pick[r] for r in range(n) if r != i and pick[r] >= 2}
            only_absent = group[i] >= 0 and any(pick[r] > 0 for r in range(n) if r != i and group[r] == group[i])
            ok = np.array([(j < 2 or j not in held) and not (only_absent and j > 0) for j in range(C)])
            low = cost[i][ok].min()
            w = np.where(ok, np.exp(low - cost[i]), 0.0)
            u, acc, j = rand.random_sample() * w.sum(), w[0], 0
            while acc <= u and j < C - 1:
                j += 1
                acc += w[j]
            while w[j] == 0.0:
                j -= 1
            pick[i] = j
        out.append(pick.copy())
    return np.array(out)


@pytest.mark.parametrize("seed", range(4))
def test_the_compiled_sampler_visits_only_the_allowed_columns_and_draws_the_same(seed):
    """Wide sparse problems (12 tracks, 30 contacts, a few gated each; some rows in groups): the compiled
    sampler, which visits each row's allowed columns only, draws exactly what visiting every column draws."""
    rng = np.random.default_rng(seed)
    cost = random_cost(rng, 12, 30)
    cost[:, 2:][rng.random((12, 30)) > 0.1] = np.inf
    group = rng.integers(-1, 3, 12)
    rows, cols = np.nonzero(np.isfinite(cost))
    start = np.searchsorted(rows, np.arange(13))
    got = _sampled(cost, start, cols, cost[rows, cols], group, 40, 1234 + seed)
    np.testing.assert_array_equal(got, dense_draws(cost, group, 40, 1234 + seed))
