"""The initiation's window pairs by cells (`lifecycle.window_pairs`, `free_window_pairs`, `sweep_pairs` with
`fast_lines`' pairs) against a brute-force oracle, and the shared cell buckets (`clutter_density.sorted_cells`,
`key_range`)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from nnda.tracking.clutter_density import key_range, sorted_cells
from nnda.tracking.lifecycle import fast_lines, free_window_pairs, no_lines, sweep_pairs, window_pairs

D_MIN, D_MAX = 50.0, 490.0


def oracle(initiators: np.ndarray, contacts: np.ndarray, d_min: float, d_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Every (initiator, contact) pair with d^2 in [d_min^2, d_max^2], d^2 = dx dx + dy dy as the kernel forms it,
    sorted by initiator then contact: the I x N distances, all formed."""
    dx = initiators[:, None, 0] - contacts[None, :, 0]
    dy = initiators[:, None, 1] - contacts[None, :, 1]
    d2 = dx * dx + dy * dy
    return np.nonzero((d2 >= d_min * d_min) & (d2 <= d_max * d_max))


def check(initiators, contacts, d_min=D_MIN, d_max=D_MAX) -> int:
    """window_pairs equals the oracle, array for array; returns the number of pairs."""
    initiators = np.asarray(initiators, float).reshape(-1, 2)
    contacts = np.asarray(contacts, float).reshape(-1, 2)
    i, j = window_pairs(initiators, contacts, d_min, d_max)
    ei, ej = oracle(initiators, contacts, d_min, d_max)
    assert i.dtype == j.dtype == np.int64
    np.testing.assert_array_equal(i, ei)
    np.testing.assert_array_equal(j, ej)
    return len(i)


@pytest.mark.parametrize("seed", range(6))
def test_random_scans_give_the_oracle_pairs_in_its_order(seed):
    rng = np.random.default_rng(seed)
    extent = [2_000.0, 20_000.0, 200_000.0][seed % 3]  # cells in a table of the grid (2, 20 km), hashed (200 km)
    n_init, n_contacts = rng.integers(0, 400, 2)
    offset = rng.uniform(-1e6, 1e6, 2)  # anywhere, not only around the origin
    a = offset + rng.uniform(0, extent, (n_init, 2))
    b = offset + rng.uniform(0, extent, (n_contacts, 2))
    b = np.concatenate([b, a[: n_init // 3] + rng.normal(0, 300, (n_init // 3, 2))])  # pairs near the window
    check(a, b)


def test_empty_inputs_and_one_contact():
    rng = np.random.default_rng(1)
    a = rng.uniform(0, 1000, (20, 2))
    assert check(np.empty((0, 2)), a) == 0
    assert check(a, np.empty((0, 2))) == 0
    assert check(np.empty((0, 2)), np.empty((0, 2))) == 0
    assert check(a, [[500.0, 500.0]]) > 0
    assert check([[0.0, 0.0]], [[300.0, 0.0]]) == 1
    assert check([[0.0, 0.0]], [[10.0, 0.0]]) == 0  # inside d_min


def test_all_contacts_in_one_cell_and_all_on_one_point():
    rng = np.random.default_rng(2)
    a = rng.uniform(0, 400, (50, 2))
    b = rng.uniform(100, 300, (200, 2))  # one cell of ~490 m
    assert check(a, b) > 0
    same = np.full((30, 2), 534.5)
    assert check(a, same) > 0
    assert check(same, same) == 0  # every distance 0 < d_min
    assert check(same, same, 0.0, D_MAX) == 30 * 30  # [0, d_max]: each with each, itself included


def test_pairs_exactly_at_the_window_edges_and_on_cell_borders():
    """Contacts on a lattice of spacing d_max (and of the cells' side, d_max plus its margin): distances of exactly
    d_min and d_max, and contacts on the cells' borders, where one rounding step decides the cell."""
    reach = D_MAX + 1e-6 * (1.0 + D_MAX)
    for spacing in (D_MAX, reach, D_MAX / 2, D_MIN):
        g = np.arange(-4, 5) * spacing
        lattice = np.column_stack([np.repeat(g, len(g)), np.tile(g, len(g))])
        assert (check(lattice, lattice) > 0) == (spacing <= D_MAX)
        check(lattice + 0.5 * spacing, lattice)
    edge = np.array([[D_MAX, 0.0], [0.0, -D_MAX], [D_MIN, 0.0], [0.0, D_MIN], [D_MAX * 0.6, D_MAX * 0.8],
                     [np.nextafter(D_MAX, np.inf), 0.0], [np.nextafter(D_MIN, 0.0), 0.0]])
    i, j = window_pairs(np.zeros((1, 2)), edge, D_MIN, D_MAX)
    assert j.tolist() == [0, 1, 2, 3, 4]  # the ends of [d_min, d_max] are in, a step beyond is out
    check(np.zeros((1, 2)), edge)
    far = 1e7 + np.array([[0.0, 0.0], [D_MAX, 0.0], [0.0, D_MAX], [-D_MAX, -1e-9]])  # far from the origin
    assert check(far, far) >= 4  # d_max along the axes, both ways


def test_initiators_outside_the_contacts_cells():
    b = np.array([[0.0, 0.0], [1000.0, 1000.0]])
    a = np.array([[-400.0, 0.0], [1000.0, 1480.0], [-5e6, 3e6], [1300.0, 1300.0], [0.0, -490.0]])
    assert check(a, b) == 4


def test_free_window_pairs_index_the_free_contacts():
    rng = np.random.default_rng(3)
    a, b = rng.uniform(0, 3000, (40, 2)), rng.uniform(0, 3000, (60, 2))
    used = rng.random(60) < 0.3
    free, i, j = free_window_pairs(a, b, used, D_MIN, D_MAX)
    np.testing.assert_array_equal(free, np.flatnonzero(~used))
    ei, ej = oracle(a, b[free], D_MIN, D_MAX)
    np.testing.assert_array_equal(i, ei)
    np.testing.assert_array_equal(j, ej)


def test_sorted_cells_and_key_range_find_each_cells_points():
    rng = np.random.default_rng(4)
    p = rng.uniform(0, 10, (500, 2))
    order, keys = sorted_cells(p, 0.0, 0.0, 1.0, 10)
    ix, iy = np.floor(p).astype(int).T
    np.testing.assert_array_equal(keys, (ix * 10 + iy)[order])
    assert np.all(np.diff(keys) >= 0) and sorted(order.tolist()) == list(range(500))
    assert all(np.all(np.diff(order[keys == k]) > 0) for k in np.unique(keys))  # stable within a cell
    start, stop = key_range(keys, 3, 2, 5, 10)
    np.testing.assert_array_equal(np.sort(order[start:stop]), np.flatnonzero((ix == 3) & (iy >= 2) & (iy <= 5)))
    assert key_range(keys, 3, 7, 5, 10) == (0, 0)
    assert key_range(keys, 3, -4, 20, 10) == (np.searchsorted(keys, 30), np.searchsorted(keys, 40))


def test_contacts_along_one_line_cost_their_cells_only():
    """100,000 contacts 1 km apart on one vertical line, an initiator beside each: an x-strip would hold every one
    of them (10^10 distances); the cells hold a few each."""
    y = np.arange(100_000) * 1000.0
    b = np.column_stack([np.zeros_like(y), y])
    a = b + [300.0, 0.0]
    window_pairs(a[:10], b[:10], D_MIN, D_MAX)  # compiled before timing
    t0 = time.perf_counter()
    i, j = window_pairs(a, b, D_MIN, D_MAX)
    assert time.perf_counter() - t0 < 2.0
    np.testing.assert_array_equal(i, np.arange(100_000))
    np.testing.assert_array_equal(j, np.arange(100_000))


D_FAST = 890.0


def test_sweep_pairs_split_one_search_at_d_max():
    """The window's pairs and the fast annulus' (d_max, d_fast] from one search, each as the oracle gives it: a pair at
    exactly d_max is the window's, a step beyond it the annulus', d_fast itself in, a step beyond out."""
    rng = np.random.default_rng(5)
    a, b = rng.uniform(0, 4000, (60, 2)), rng.uniform(0, 4000, (90, 2))
    edge = np.array([[D_MAX, 0.0], [np.nextafter(D_MAX, np.inf), 0.0], [0.0, D_FAST], [0.0, np.nextafter(D_FAST, 0)],
                     [np.nextafter(D_FAST, np.inf), 0.0], [D_MIN, 0.0]])
    for initiators, contacts in ((a, b), (np.zeros((1, 2)), edge)):
        used = rng.random(len(contacts)) < 0.2
        free, i, j, fi, fj = sweep_pairs(initiators, contacts, used, D_MIN, D_MAX, D_FAST)
        np.testing.assert_array_equal(free, np.flatnonzero(~used))
        for (got_i, got_j), (want_i, want_j) in (((i, j), oracle(initiators, contacts[free], D_MIN, D_MAX)),
                                                 ((fi, fj), fast_oracle(initiators, contacts[free]))):
            np.testing.assert_array_equal(got_i, want_i)
            np.testing.assert_array_equal(got_j, want_j)
        np.testing.assert_array_equal(free_window_pairs(initiators, contacts, used, D_MIN, D_MAX)[1], i)
    free, i, j, fi, fj = sweep_pairs(np.zeros((1, 2)), edge, np.zeros(len(edge), bool), D_MIN, D_MAX, D_FAST)
    assert j.tolist() == [0, 5] and fj.tolist() == [1, 2, 3]


def fast_oracle(initiators: np.ndarray, contacts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pairs with d^2 in (d_max^2, d_fast^2], as `oracle`."""
    dx = initiators[:, None, 0] - contacts[None, :, 0]
    dy = initiators[:, None, 1] - contacts[None, :, 1]
    d2 = dx * dx + dy * dy
    return np.nonzero((d2 > D_MAX * D_MAX) & (d2 <= D_FAST * D_FAST))


def test_fast_lines_read_the_same_from_sweep_pairs_as_searched():
    """A line of contacts 700 m apart a scan in clutter: `fast_lines` given `sweep_pairs`' annulus pairs counts and
    continues the same lines as when it searches them itself, scan by scan."""
    rng = np.random.default_rng(6)
    lines = {True: no_lines(), False: no_lines()}
    counted = {True: 0, False: 0}
    before = rng.uniform(-8000, 8000, (20, 2))
    for k in range(12):
        now = np.vstack([rng.uniform(-8000, 8000, (20, 2)), [[700.0 * k, 0.0]]])
        used = np.append(rng.random(20) < 0.1, False)
        free, i, j, *fast = sweep_pairs(before, now, used, D_MIN, D_MAX, D_FAST)
        spoken = np.zeros(free.size, bool)
        spoken[j] = True
        for given in (True, False):
            n, lines[given] = fast_lines(before, now, free, spoken, lines[given], D_MAX, D_FAST, 100.0, 2.0,
                                         fast if given else None)
            counted[given] += n
        for a, b in zip(lines[True], lines[False]):
            np.testing.assert_array_equal(a, b)
        before = now[free[~spoken]]
    assert counted[True] == counted[False] >= 1
