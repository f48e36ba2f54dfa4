"""The pure JPDA event code (nnda.tracking.marginals) against brute-force enumeration, and its fallback."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from nnda.tracking.marginals import (
    Marginals,
    _event_weights,
    _listed,
    clusters,
    jpda_marginals,
    log_miss_weight,
    loopy_marginals,
)
from tolerances import RTOL


def brute_force(gate: np.ndarray, log_ratio: np.ndarray, log_miss: float) -> tuple[np.ndarray, np.ndarray]:
    """Marginals by listing every joint assignment of all tracks at once (no clusters)."""
    K, N = gate.shape
    beta, beta0, total = np.zeros((K, N)), np.zeros(K), 0.0
    for event in itertools.product(*[[-1, *np.flatnonzero(gate[t])] for t in range(K)]):
        used = [j for j in event if j >= 0]
        if len(used) != len(set(used)):
            continue
        w = np.exp(sum(log_miss if j < 0 else log_ratio[t, j] for t, j in enumerate(event)))
        total += w
        for t, j in enumerate(event):
            if j < 0:
                beta0[t] += w
            else:
                beta[t, j] += w
    return beta / total, beta0 / total


def gated(gate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pairs (track (P,), contact (P,)) where ``gate`` (K, N) is True, contiguous as the trackers' gating
    gives them (`np.nonzero`'s are strided views: the compiled code would be compiled again for them)."""
    return tuple(np.ascontiguousarray(a) for a in np.nonzero(gate))


def marginals(gate: np.ndarray, log_ratio: np.ndarray, log_miss: float, max_events: int
              ) -> tuple[Marginals, np.ndarray]:
    """`jpda_marginals` of the pairs where ``gate`` (K, N) is True; also returns its beta as (K, N)."""
    t, c = gated(gate)
    m = jpda_marginals(t, c, log_ratio[t, c], gate.shape[0], log_miss, max_events)
    dense = np.zeros(gate.shape)
    dense[t, c] = m.beta
    return m, dense


def loopy(gate: np.ndarray, log_ratio: np.ndarray, log_miss: float) -> tuple[np.ndarray, np.ndarray]:
    """`loopy_marginals` of the pairs where ``gate`` is True, beta as (K, N)."""
    t, c = gated(gate)
    beta, beta0 = loopy_marginals(t, c, log_ratio[t, c], gate.shape[0], log_miss)
    dense = np.zeros(gate.shape)
    dense[t, c] = beta
    return dense, beta0


def test_two_tracks_sharing_a_contact_match_brute_force():
    # track 0 gates contacts 0 and 1, track 1 gates 1 and 2: one cluster of two tracks
    gate = np.array([[1, 1, 0], [0, 1, 1]], bool)
    log_ratio = np.log(np.array([[4.0, 2.0, 1.0], [1.0, 6.0, 0.5]]))  # 1.0: outside the gate
    log_miss = np.log(0.1)
    m, got = marginals(gate, log_ratio, log_miss, max_events=10_000)
    beta, beta0 = brute_force(gate, log_ratio, log_miss)
    np.testing.assert_allclose(got, beta, rtol=RTOL, atol=RTOL)  # probabilities: atol on their scale, 1
    np.testing.assert_allclose(m.beta0, beta0, rtol=RTOL)
    # by hand: the 8 feasible events have weights
    # {miss,miss} .01, {0,miss} .4, {1,miss} .2, {miss,1} .6, {miss,2} .05, {0,1} 24, {0,2} 2, {1,2} 1
    total = 0.01 + 0.4 + 0.2 + 0.6 + 0.05 + 24 + 2 + 1
    assert got[0, 0] == pytest.approx((0.4 + 24 + 2) / total)
    assert got[1, 1] == pytest.approx((0.6 + 24) / total)
    assert m.beta0[1] == pytest.approx((0.01 + 0.4 + 0.2) / total)
    assert not m.approximated.any() and m.cluster.tolist() == [0, 0]


@pytest.mark.parametrize("seed", range(40))
def test_random_gates_match_brute_force(seed):
    rng = np.random.default_rng(seed)
    K, N = rng.integers(1, 6), rng.integers(1, 6)
    gate = rng.random((K, N)) < 0.5
    log_ratio = rng.normal(0.0, 2.0, (K, N))
    log_miss = float(rng.normal(-2.0, 1.0))
    m, got = marginals(gate, log_ratio, log_miss, max_events=10_000)
    beta, beta0 = brute_force(gate, log_ratio, log_miss)
    np.testing.assert_allclose(got, beta, atol=RTOL)
    np.testing.assert_allclose(m.beta0, beta0, atol=RTOL)
    np.testing.assert_allclose(got.sum(axis=1) + m.beta0, 1.0)


def test_clusters_join_tracks_through_shared_contacts():
    gate = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [1, 1, 0, 0], [0, 0, 1, 1], [0, 0, 0, 0]], bool)
    n, label = clusters(*gated(gate), 5)
    assert n == 3 and label.tolist() == [0, 1, 0, 1, 2]
    n, label = clusters(*gated(np.eye(3, dtype=bool)), 3)  # nothing shared
    assert n == 3 and label.tolist() == [0, 1, 2]
    # contact indices need not be compact: the same graph with contacts 1000 apart
    t, c = gated(gate)
    assert clusters(t, 1000 * c + 7, 5)[1].tolist() == [0, 1, 0, 1, 2]


def test_cap_falls_back_to_belief_propagation():
    # a chain (no cycle): belief propagation is exact there
    gate = np.array([[1, 1, 0, 0], [0, 1, 1, 0], [0, 0, 1, 1]], bool)
    rng = np.random.default_rng(7)
    log_ratio = rng.normal(1.0, 1.5, gate.shape)
    exact = brute_force(gate, log_ratio, -2.0)
    m, got = marginals(gate, log_ratio, -2.0, max_events=5)
    assert m.approximated.tolist() == [True]
    np.testing.assert_allclose(got, exact[0], atol=1e-9)
    np.testing.assert_allclose(m.beta0, exact[1], atol=1e-9)
    # with a cycle (two tracks, two shared contacts) it is an approximation, close to the truth
    gate = np.ones((2, 2), bool)
    log_ratio = np.log(np.array([[3.0, 1.0], [1.0, 2.0]]))
    beta, beta0 = loopy(gate, log_ratio, np.log(0.2))
    exact = brute_force(gate, log_ratio, np.log(0.2))
    np.testing.assert_allclose(beta.sum(axis=1) + beta0, 1.0)
    np.testing.assert_allclose(beta, exact[0], atol=0.1)


def test_only_oversized_clusters_are_approximated():
    gate = np.zeros((3, 5), bool)
    gate[0, 0] = True  # small cluster: 2 events
    gate[1:, 1:] = True  # two tracks over four contacts: 1 + 8 + 12 = 21 events
    log_ratio = np.zeros(gate.shape)
    m, got = marginals(gate, log_ratio, np.log(0.1), max_events=20)
    assert m.approximated.tolist() == [False, True]
    exact = brute_force(gate, log_ratio, np.log(0.1))
    assert got[0, 0] == pytest.approx(exact[0][0, 0], rel=RTOL)


@pytest.mark.parametrize("seed", range(20))
def test_capped_random_gates_stay_exact_below_the_cap(seed):
    rng = np.random.default_rng(100 + seed)
    K, N = rng.integers(2, 7), rng.integers(2, 7)
    gate = rng.random((K, N)) < 0.4
    gate[0] = False  # a track with nothing in its gate: its cluster assigns no contact at all
    log_ratio = rng.normal(1.0, 2.0, (K, N))
    m, got = marginals(gate, log_ratio, -2.2, max_events=int(rng.integers(2, 30)))
    beta, beta0 = brute_force(gate, log_ratio, -2.2)
    exact = ~m.approximated[m.cluster]
    np.testing.assert_allclose(got[exact], beta[exact], atol=RTOL)
    np.testing.assert_allclose(m.beta0[exact], beta0[exact], atol=RTOL)
    np.testing.assert_allclose(got.sum(axis=1) + m.beta0, 1.0)
    assert m.beta0[0] == 1.0


def listed_events(gate: np.ndarray, log_ratio: np.ndarray, log_miss: float, tracks: list[int], cap: int
                  ) -> tuple[bool, np.ndarray | None]:
    """Enumerate a cluster's joint events track by track, as `jpda_marginals` does.

    Returns whether the partial events listed (every option of every event,
    counted before dropping those that reuse a contact) stay within ``cap``
    and, if so, the exact beta (K, N) of the cluster's tracks.
    """
    events, listed = [((), 0.0)], 0
    for t in tracks:
        options = [-1, *np.flatnonzero(gate[t])]
        listed += len(events) * len(options)
        if listed > cap:
            return False, None
        events = [(e + (j,), w + (log_miss if j < 0 else log_ratio[t, j]))
                  for e, w in events for j in options if j < 0 or j not in e]
    beta = np.zeros(gate.shape)
    for e, w in events:
        for t, j in zip(tracks, e):
            if j >= 0:
                beta[t, j] += np.exp(w)
    return True, beta / sum(np.exp(w) for _, w in events)


@pytest.mark.parametrize("seed", range(10))
def test_exactly_the_clusters_over_the_cap_are_approximated(seed):
    # random chains and blobs of 1-9 tracks, caps around the listing sizes (some clusters are
    # dropped before any listing, others part-way)
    rng = np.random.default_rng(300 + seed)
    K, N = 24, 30
    gate = np.zeros((K, N), bool)
    t = 0
    while t < K:
        s = min(int(rng.integers(1, 10)), K - t)
        c = int(rng.integers(0, N - s))
        for i in range(s):
            gate[t + i, c + i: c + i + int(rng.integers(1, 4))] = True
        t += s
    gate &= rng.random(gate.shape) < 0.9
    log_ratio = rng.normal(0.0, 1.0, gate.shape)
    max_events = int(rng.integers(10, 300))
    m, got = marginals(gate, log_ratio, -2.0, max_events)
    for c in range(m.approximated.size):
        tracks = np.flatnonzero(m.cluster == c)
        within, beta = listed_events(gate, log_ratio, -2.0, tracks.tolist(), max_events)
        assert m.approximated[c] != within
        if within:
            np.testing.assert_allclose(got[tracks], beta[tracks], atol=RTOL)
    assert m.approximated.any() and not m.approximated.all()


def breadth_first(gate: np.ndarray, log_ratio: np.ndarray, log_miss: float, tracks: np.ndarray
                  ) -> tuple[int, list[float]]:
    """The partial events a cluster of ``tracks`` lists (every option of every event, counted before
    dropping those that reuse a contact) and the log weights of its complete events, summed depth by depth
    from 0, in the order of a breadth-first listing."""
    events, listed = [((), 0.0)], 0
    for t in tracks:
        options = [-1, *np.flatnonzero(gate[t])]
        listed += len(events) * len(options)
        events = [(e + (j,), w + (log_miss if j < 0 else log_ratio[t, j]))
                  for e, w in events for j in options if j < 0 or j not in e]
    return listed, [w for _, w in events]


def random_cluster(rng: np.random.Generator, K: int = 6, N: int = 6):
    """A random gate (K, N), its log ratios and the pairs in `jpda_marginals`' form, for `_listed` and
    `_event_weights`: track, contact, n_gated, first_gated."""
    gate = rng.random((K, N)) < rng.uniform(0.2, 0.8)
    log_ratio = rng.normal(0.0, 1.0, (K, N))
    t, c = gated(gate)
    n_gated = np.bincount(t, minlength=K)
    return gate, log_ratio, t, c, n_gated, np.cumsum(n_gated) - n_gated


@pytest.mark.parametrize("seed", range(10))
def test_listed_decides_the_cap_as_the_breadth_first_count(seed):
    # caps below, at and above each cluster's count: the depth-first walk, stopped past the cap, agrees
    # with the breadth-first count, and every contact it held is free again afterwards
    rng = np.random.default_rng(500 + seed)
    for _ in range(5):
        gate, log_ratio, t, c, n_gated, first = random_cluster(rng)
        tracks = rng.permutation(gate.shape[0])
        count, _ = breadth_first(gate, log_ratio, -2.0, tracks)
        used = np.zeros(gate.shape[1], bool)
        scratch = np.empty((2, tracks.size), np.int64)
        for cap in (count // 3, count - 1, count, count + 1, 10 * count):
            got = _listed(tracks, n_gated, first, c, used, scratch[0], scratch[1], cap)
            assert (got > cap) == (count > cap)
            assert not used.any()


@pytest.mark.parametrize("seed", range(10))
def test_events_are_listed_in_breadth_first_order(seed):
    # the order (and so the rounding) of every sum over events is the breadth-first listing's
    rng = np.random.default_rng(700 + seed)
    gate, log_ratio, t, c, n_gated, first = random_cluster(rng)
    K = gate.shape[0]
    order = rng.permutation(K)
    count, expected = breadth_first(gate, log_ratio, -2.0, order)
    one = np.array([0])
    ev_cluster, ev_logw, over = _event_weights(one, order, one, np.array([K]), n_gated, first, c,
                                               log_ratio[t, c], -2.0, count)
    assert not over.any() and (ev_cluster == 0).all()
    assert ev_logw.tolist() == expected  # equal, not close
    assert _event_weights(one, order, one, np.array([K]), n_gated, first, c, log_ratio[t, c], -2.0,
                          count - 1)[2].tolist() == [True]


@pytest.mark.parametrize("seed", range(5))
def test_clusters_are_the_connected_components_of_the_gate_graph(seed):
    rng = np.random.default_rng(900 + seed)
    K, N = 40, 50
    gate = rng.random((K, N)) < 0.04
    t, c = gated(gate)
    n, label = clusters(t, c, K)
    graph = coo_matrix((np.ones(t.size), (t, K + c)), shape=(K + N, K + N))
    expected = connected_components(graph, directed=False)[1][:K]
    first = {}
    for lab in expected:  # numbered in order of each cluster's first track
        first.setdefault(lab, len(first))
    assert n == len(first) and label.tolist() == [first[lab] for lab in expected]


def test_miss_weight():
    assert np.exp(log_miss_weight(0.9, 9.21)) == pytest.approx(1 - 0.9 * (1 - np.exp(-9.21 / 2)))
    assert np.isfinite(log_miss_weight(1.0, 2000.0))  # 1 - P_D P_G underflows in the naive form
