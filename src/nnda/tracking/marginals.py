"""The pure event code of JPDA: clusters of gated pairs and their marginal association probabilities.

Functions over flat arrays of gated (track, contact) pairs, with no filter
or tracker state: `clusters` (connected components of the gate graph),
`jpda_marginals` (exact enumeration of the joint events per cluster, with
`loopy_marginals` as the fallback past a cap) and `log_miss_weight`. The
tests check both against brute-force enumeration. `nnda.tracking.jpda`
turns the marginals into IMM-PDA updates; its module docstring gives the
event weights.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

#: loopy belief propagation stops when no message (a probability ratio in (0, 1]) moves by more than this ...
BP_TOLERANCE = 1e-10
#: ... or after this many sweeps
BP_MAX_SWEEPS = 500
#: bound on log(P_D l / lambda) - log(1 - P_D P_G) where it is exponentiated, keeps exp() finite
_MAX_LOG_RATIO = 700.0


def log_miss_weight(pd: float, gate: float) -> float:
    """log(1 - P_D P_G), P_G = 1 - exp(-gate / 2) the probability mass of a 2-dof chi-square gate."""
    return float(np.logaddexp(np.log1p(-pd) if pd < 1 else -np.inf, np.log(pd) - gate / 2))


def clusters(track: np.ndarray, contact: np.ndarray, n_tracks: int) -> tuple[int, np.ndarray]:
    """Clusters of tracks linked by shared gated contacts.

    The gated pairs are given by their ``track`` (P,) in [0, K), K =
    ``n_tracks``, and ``contact`` (P,) (any non-negative contact indices).
    Returns the number of clusters and each track's cluster label (K,),
    labels numbered in order of each cluster's first track; a track without
    pairs is a cluster of its own.
    """
    K = n_tracks
    if contact.size == 0 or np.bincount(contact).max() <= 1:  # no shared contact: one cluster per track
        return K, np.arange(K)
    used, c = np.unique(contact, return_inverse=True)
    graph = csr_matrix((np.ones(track.size, bool), (track, K + c)), shape=(K + used.size, K + used.size))
    labels = connected_components(graph, directed=False)[1][:K]
    found, first = np.unique(labels, return_index=True)
    rank = np.empty(found.size, np.int64)
    rank[np.argsort(first)] = np.arange(found.size)
    return found.size, rank[np.searchsorted(found, labels)]


@dataclass(frozen=True)
class Marginals:
    """Association probabilities of K tracks over P gated (track, contact) pairs in one scan.

    ``beta`` (P,) holds each pair's probability and ``beta0`` (K,) each
    track's probability of no contact: per track, beta0 plus the betas of
    its pairs sum to 1. ``cluster`` (K,) labels each track's cluster and
    ``approximated`` (C,) marks the clusters solved by belief propagation
    instead of enumeration.
    """

    beta: np.ndarray
    beta0: np.ndarray
    cluster: np.ndarray
    approximated: np.ndarray


def jpda_marginals(track: np.ndarray, contact: np.ndarray, log_ratio: np.ndarray, n_tracks: int,
                   log_miss: float, max_events: int) -> Marginals:
    """Marginal association probabilities of K = ``n_tracks`` tracks over P gated pairs.

    The pairs are given by ``track`` (P,) in [0, K), sorted (each track's
    pairs together), ``contact`` (P,) non-negative contact indices and
    ``log_ratio`` (P,) = log(P_D l_tj / lambda); ``log_miss`` is
    log(1 - P_D P_G). Memory and time grow with the pairs and the events
    listed, never with tracks x contacts.

    Joint events are enumerated exactly per cluster of tracks sharing
    contacts, one track after the other. The work is bounded: once the
    partial events listed for a cluster, summed over its tracks (and counted
    before dropping those that reuse a contact), would exceed ``max_events``,
    the cluster gets its marginals from `loopy_marginals` instead. Since a
    cluster of s >= 2 tracks lists at least s (s + 1) partial events, this
    also bounds the cluster size (99 tracks for 10,000), and larger
    clusters go to belief propagation without listing anything.
    """
    K, P = n_tracks, track.size
    n_clusters, label = clusters(track, contact, K)
    if n_clusters == K:  # every track alone: the PDA closed form
        odds = _odds(log_ratio, log_miss)
        total = 1.0 + np.bincount(track, odds, minlength=K)
        return Marginals(odds / total[track], 1.0 / total, label, np.zeros(K, bool))
    size = np.bincount(label, minlength=n_clusters)
    # a cluster of s >= 2 tracks lists at least s (s + 1) partial events (each track has a pair, so
    # depth d holds at least d + 1 events of at least 2 options each): too big ones skip the listing
    exact = (size < 2) | (size * (size + 1) <= max_events)
    order = np.argsort(label, kind="stable")  # tracks grouped by cluster: the d-th of cluster c is
    start = np.cumsum(size) - size  # order[start[c] + d], for d < size[c]
    n_gated = np.bincount(track, minlength=K)
    first_gated = np.cumsum(n_gated) - n_gated
    pair_contact = np.append(contact, -1)  # a sentinel keeps the look-ups below in range
    pair_ratio = np.append(log_ratio, 0.0)

    # events of the clusters being enumerated, grouped by cluster (in label order): their pair and
    # contact per depth (-1: none) and log weight; a cluster's events leave once its last track is done
    ev_cluster = np.flatnonzero(exact)
    ev_pair = np.empty((ev_cluster.size, 0), np.int64)  # both grow by one column per depth
    ev_contact = np.empty((ev_cluster.size, 0), np.int64)
    ev_logw = np.zeros(ev_cluster.size)
    listed = np.zeros(n_clusters)  # partial events listed so far per cluster, all depths together
    complete = []  # (tracks (E, d), pairs (E, d), weights (E,)) of the events of finished clusters
    d = 0
    while ev_cluster.size:
        done = size[ev_cluster] == d
        if done.any():
            tracks = order[start[ev_cluster[done], None] + np.arange(d)]
            complete.append((tracks, ev_pair[done], _normalised(ev_cluster[done], ev_logw[done])))
            live = ~done
            ev_cluster, ev_pair, ev_contact, ev_logw = (a[live] for a in (ev_cluster, ev_pair, ev_contact, ev_logw))
        at = order[start[ev_cluster] + d]  # each event's cluster's track at this depth
        n_options = 1 + n_gated[at]  # option 0: no contact for this track
        listed += np.bincount(ev_cluster, n_options, minlength=n_clusters)
        over = exact & (listed > max_events)
        if over.any():  # give up on these clusters before listing their events
            exact &= ~over
            alive = ~over[ev_cluster]
            ev_cluster, ev_pair, ev_contact, ev_logw, at, n_options = (
                a[alive] for a in (ev_cluster, ev_pair, ev_contact, ev_logw, at, n_options))
        parent = np.repeat(np.arange(ev_cluster.size), n_options)
        option = np.arange(parent.size) - np.repeat(np.cumsum(n_options) - n_options, n_options)
        pair = np.where(option > 0, first_gated[at[parent]] + option - 1, P)  # P: no pair
        c = pair_contact[pair]
        keep = (c < 0) | ~(ev_contact[parent] == c[:, None]).any(axis=1)  # drop a contact used twice
        parent = parent[keep]
        ev_cluster = ev_cluster[parent]
        ev_pair = np.column_stack([ev_pair[parent], np.where(pair < P, pair, -1)[keep]])
        ev_contact = np.column_stack([ev_contact[parent], c[keep]])
        ev_logw = ev_logw[parent] + np.where(option > 0, pair_ratio[pair], log_miss)[keep]
        d += 1

    beta, beta0 = np.zeros(P), np.zeros(K)
    if complete:
        tracks = np.concatenate([t.ravel() for t, _, _ in complete])  # event by event, depth by depth
        pairs = np.concatenate([p.ravel() for _, p, _ in complete])
        w = np.concatenate([np.repeat(w, t.shape[1]) for t, _, w in complete])
        hit = pairs >= 0
        beta = np.bincount(pairs[hit], w[hit], minlength=P).astype(float, copy=False)
        beta0 = np.bincount(tracks[~hit], w[~hit], minlength=K).astype(float, copy=False)
    if not exact.all():
        sel = ~exact[label[track]]
        rows = np.flatnonzero(~exact[label])
        beta[sel], loopy0 = loopy_marginals(track[sel], contact[sel], log_ratio[sel], K, log_miss)
        beta0[rows] = loopy0[rows]
    return Marginals(beta, beta0, label, ~exact)


def _normalised(cluster: np.ndarray, log_weight: np.ndarray) -> np.ndarray:
    """Event weights normalised per cluster; ``cluster`` (E,) groups the events (sorted)."""
    first, group = runs(cluster)
    w = np.exp(log_weight - np.maximum.reduceat(log_weight, first)[group])
    return w / np.add.reduceat(w, first)[group]


def runs(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Runs of equal values in ``a`` (P,), e.g. sorted labels: where each run starts, and the run
    number of each entry (P,)."""
    new = np.empty(a.size, bool)
    new[:1] = True
    np.not_equal(a[1:], a[:-1], out=new[1:])
    return np.flatnonzero(new), np.cumsum(new) - 1


def loopy_marginals(track: np.ndarray, contact: np.ndarray, log_ratio: np.ndarray, n_tracks: int,
                    log_miss: float) -> tuple[np.ndarray, np.ndarray]:
    """Approximate marginal association probabilities by loopy belief propagation.

    Same inputs as `jpda_marginals` (without the cap; the pairs need not be
    sorted); returns beta (P,) per pair and beta0 (K,) per track (1 for a
    track without pairs). The message passing of Williams & Lau
    ("Approximate evaluation of marginal association probabilities with
    belief propagation", IEEE T-AES 2014) on the weights psi_tj =
    exp(log_ratio - log_miss): exact when the gate graph has no cycle, and
    convergent.
    """
    K = n_tracks
    _, j = np.unique(contact, return_inverse=True)
    psi = _odds(log_ratio, log_miss)
    to_track = np.ones(track.size)  # messages contact j -> track t
    for _ in range(BP_MAX_SWEEPS):
        weighted = psi * to_track
        to_contact = psi / (1.0 + np.bincount(track, weighted, K)[track] - weighted)  # track t -> contact j
        new = 1.0 / (1.0 + np.bincount(j, to_contact)[j] - to_contact)
        moved = np.abs(new - to_track).max(initial=0.0)
        to_track = new
        if moved <= BP_TOLERANCE:
            break
    weighted = psi * to_track
    total = 1.0 + np.bincount(track, weighted, K)
    return weighted / total[track], 1.0 / total


def _odds(log_ratio: np.ndarray, log_miss: float) -> np.ndarray:
    """Weight of each pair relative to its track's miss, exp(log_ratio - log_miss), kept finite."""
    return np.exp(np.minimum(log_ratio - log_miss, _MAX_LOG_RATIO))
