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

import numba
import numpy as np

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
    return components(track, contact, K)


@numba.njit(cache=True, nogil=True)
def components(track, contact, K):
    """`clusters` by union-find over the pairs (P,, at least one): the count and the labels (K,); compiled, for
    compiled callers too."""
    parent = np.arange(K)
    owner = np.full(contact.max() + 1, -1)  # the first track seen with each contact
    for p in range(track.size):
        a, b = track[p], owner[contact[p]]
        if b < 0:
            owner[contact[p]] = a
            continue
        while parent[a] != a:  # the roots, halving the paths on the way
            parent[a] = parent[parent[a]]
            a = parent[a]
        while parent[b] != b:
            parent[b] = parent[parent[b]]
            b = parent[b]
        parent[max(a, b)] = min(a, b)
    label = np.empty(K, np.int64)
    n = 0
    for t in range(K):  # a root is its cluster's first track: clusters numbered in that order
        if parent[t] == t:
            label[t] = n
            n += 1
        else:
            label[t] = label[parent[t]]
    return n, label


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
    contacts, one track after the other (compiled and depth-first, in the
    order of a breadth-first listing: `_walk`). The work is bounded: once the
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
        return Marginals(*_alone(track, _odds(log_ratio, log_miss), K), label, np.zeros(K, bool))
    size = np.bincount(label, minlength=n_clusters)
    # a cluster of s >= 2 tracks lists at least s (s + 1) partial events (each track has a pair, so
    # depth d holds at least d + 1 events of at least 2 options each): too big ones skip the listing
    exact = (size < 2) | (size * (size + 1) <= max_events)
    order = np.argsort(label, kind="stable")  # tracks grouped by cluster: the d-th of cluster c is
    start = np.cumsum(size) - size  # order[start[c] + d], for d < size[c]
    n_gated = np.bincount(track, minlength=K)
    first_gated = np.cumsum(n_gated) - n_gated
    listing = np.flatnonzero(exact)
    ev_cluster, ev_logw, over = _event_weights(listing, order, start, size, n_gated, first_gated, contact,
                                               log_ratio, log_miss, max_events)
    exact[listing[over]] = False
    beta, beta0 = np.zeros(P), np.zeros(K)
    if ev_cluster.size:  # the events again, each adding its normalised weight to its pairs' (tracks') marginals
        _event_sums(listing[~over], order, start, size, n_gated, first_gated, contact,
                    _normalised(ev_cluster, ev_logw), beta, beta0)
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


@numba.njit(cache=True, nogil=True)
def _event_weights(listing, order, start, size, n_gated, first_gated, contact, log_ratio, log_miss, max_events):
    """The joint events of the clusters ``listing`` (ascending): the cluster (E,) and log weight (E,) of each
    (`_walk`), cluster by cluster, and which of ``listing`` were given up (over ``max_events``, `_listed`)."""
    used = np.zeros(contact.max() + 1 if contact.size else 1, np.bool_)
    over = np.zeros(listing.size, np.bool_)
    ev_cluster = np.empty(0, np.int64)
    ev_logw = np.empty(0)
    E = 0
    depth_max = size[listing].max() if listing.size else 0
    option, chosen = np.empty(depth_max, np.int64), np.empty(depth_max, np.int64)
    logw = np.zeros(depth_max + 1)
    no_weights = np.empty(0)
    for i in range(listing.size):
        c = listing[i]
        tracks = order[start[c]:start[c] + size[c]]
        listed = _listed(tracks, n_gated, first_gated, contact, used, option, chosen, max_events)
        if listed > max_events:
            over[i] = True
            continue
        if E + listed > ev_logw.size:  # a cluster has fewer events than it lists partial ones
            ev_logw = _grown(ev_logw, max(2 * ev_logw.size, E + listed))
        n = _walk(tracks, n_gated, first_gated, contact, log_ratio, log_miss, used, option, chosen, logw,
                  ev_logw[E:], no_weights, no_weights, no_weights)
        if E + n > ev_cluster.size:
            ev_cluster = _grown(ev_cluster, ev_logw.size)
        ev_cluster[E:E + n] = c
        E += n
    return ev_cluster[:E], ev_logw[:E], over


@numba.njit(cache=True, nogil=True)
def _event_sums(listing, order, start, size, n_gated, first_gated, contact, weight, beta, beta0):
    """Add each joint event's normalised ``weight`` (E,) (the events of `_event_weights` for the clusters
    ``listing``, none given up) to ``beta`` (P,) at its pairs and ``beta0`` (K,) at its tracks without one, in
    the events' order."""
    used = np.zeros(contact.max() + 1 if contact.size else 1, np.bool_)
    depth_max = size[listing].max() if listing.size else 0
    option, chosen = np.empty(depth_max, np.int64), np.empty(depth_max, np.int64)
    logw = np.zeros(depth_max + 1)
    no_log_ratio = np.zeros(0)
    E = 0
    for c in listing:
        E += _walk(order[start[c]:start[c] + size[c]], n_gated, first_gated, contact, no_log_ratio, 0.0, used,
                   option, chosen, logw, no_log_ratio, weight[E:], beta, beta0)


@numba.njit(cache=True, nogil=True)
def _walk(tracks, n_gated, first_gated, contact, log_ratio, log_miss, used, option, chosen, logw, out_logw,
          weight, beta, beta0):
    """List the joint events of one cluster of ``tracks`` (s,) depth-first, one track after the other (option
    0 of track t is no contact, then its pairs ``first_gated[t] ..`` in order), an option that reuses a contact
    dropped; returns their number E. The events come in lexicographic order of their options, the order of a
    breadth-first listing that extends every event by each option of the next track.

    Without ``weight`` (size 0), writes each event's log weight (summed depth by depth from 0: log_ratio of
    a pair, ``log_miss`` for none) to ``out_logw`` (>= E,); with it (>= E,), adds the event's weight to
    ``beta`` at its pairs and ``beta0`` at its tracks without one. ``used`` (contacts,) all False comes back so;
    ``option``, ``chosen`` (>= s,) and ``logw`` (> s,) are scratch.
    """
    s, summing = tracks.size, weight.size > 0
    E = d = 0
    option[0] = -1
    while d >= 0:
        option[d] += 1
        t = tracks[d]
        if option[d] > n_gated[t]:  # every option of this depth tried: back up one track
            d -= 1
            if d >= 0 and chosen[d] >= 0:
                used[contact[chosen[d]]] = False
            continue
        pair = -1
        if option[d] > 0:
            pair = first_gated[t] + option[d] - 1
            if used[contact[pair]]:
                continue
        chosen[d] = pair
        if not summing:
            logw[d + 1] = logw[d] + (log_ratio[pair] if pair >= 0 else log_miss)
        if d + 1 < s:  # a partial event: go one track deeper
            if pair >= 0:
                used[contact[pair]] = True
            d += 1
            option[d] = -1
            continue
        if summing:
            for k in range(s):
                if chosen[k] >= 0:
                    beta[chosen[k]] += weight[E]
                else:
                    beta0[tracks[k]] += weight[E]
        else:
            out_logw[E] = logw[s]
        E += 1
    return E


@numba.njit(cache=True, nogil=True)
def _listed(tracks, n_gated, first_gated, contact, used, option, chosen, cap):
    """Whether a cluster of ``tracks`` (s,) lists more than ``cap`` partial events (`jpda_marginals`: each
    partial event of depth d < s counts the 1 + n_gated options of track d): a number above ``cap`` if so,
    else one at most ``cap``. ``used`` (contacts,) all False comes back so; ``option`` and ``chosen`` (>= s,)
    are scratch.

    A bound that takes every option as valid settles most clusters; the others are walked depth-first up
    to depth s - 1 until past ``cap`` (the complete events need no walk: their count is not needed).
    """
    s = tracks.size
    bound, events = 0.0, 1.0
    for d in range(s):
        bound += events * (1 + n_gated[tracks[d]])
        events *= 1 + n_gated[tracks[d]]
        if bound > cap:
            break
    if bound <= cap:
        return int(bound)
    listed = 1 + n_gated[tracks[0]]
    d = 0
    option[0] = -1
    while d >= 0 and listed <= cap and s > 1:
        option[d] += 1
        t = tracks[d]
        if option[d] > n_gated[t]:
            d -= 1
            if d >= 0 and chosen[d] >= 0:
                used[contact[chosen[d]]] = False
            continue
        pair = -1
        if option[d] > 0:
            pair = first_gated[t] + option[d] - 1
            if used[contact[pair]]:
                continue
        listed += 1 + n_gated[tracks[d + 1]]  # a valid partial event of depth d + 1 < s
        if d + 2 < s:  # its own options only matter below depth s - 1
            chosen[d] = pair
            if pair >= 0:
                used[contact[pair]] = True
            d += 1
            option[d] = -1
    for k in range(max(d, 0)):  # stopped past the cap: free the contacts still held
        if chosen[k] >= 0:
            used[contact[chosen[k]]] = False
    return listed


@numba.njit(cache=True, nogil=True)
def _grown(a, n):
    """``a`` copied into a new array of length ``n`` >= its own."""
    out = np.empty(n, a.dtype)
    out[:a.size] = a
    return out


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
    return _alone(track, psi * _messages(track, j.astype(np.int64), psi, K, BP_MAX_SWEEPS, BP_TOLERANCE), K)


@numba.njit(cache=True, nogil=True)
def _alone(track, weight, K):
    """Marginals of K tracks each alone with its P pairs (``track`` (P,) in [0, K)) of odds ``weight`` (P,)
    against its miss: beta = weight / (1 + the track's sum) (P,), beta0 = 1 / (1 + that sum) (K,); the sums in
    numpy's bincount order."""
    total = np.zeros(K)
    for p in range(track.size):
        total[track[p]] += weight[p]
    for t in range(K):
        total[t] = 1.0 + total[t]
    beta = np.empty(track.size)
    for p in range(track.size):
        beta[p] = weight[p] / total[track[p]]
    return beta, 1.0 / total


@numba.njit(cache=True, nogil=True)
def _messages(track, j, psi, K, sweeps, tolerance):
    """`loopy_marginals`' message passing over P pairs of ``track`` (P,) in [0, K) and contact number ``j`` (P,)
    (0, 1, ... in order of contact), with weights ``psi`` (P,): at most ``sweeps`` sweeps, until no message
    moves by more than ``tolerance``. Returns the messages contact -> track (P,). Each sum runs over the pairs
    in order, as numpy's bincount adds them."""
    P = track.size
    n_contacts = j.max() + 1 if P else 0
    to_track = np.ones(P)  # messages contact j -> track t
    to_contact = np.empty(P)
    weighted = np.empty(P)  # each pair's weight times its contact's message
    by_track, by_contact = np.empty(K), np.empty(n_contacts)
    for _ in range(sweeps):
        by_track[:] = 0.0
        for p in range(P):
            weighted[p] = psi[p] * to_track[p]
            by_track[track[p]] += weighted[p]
        by_contact[:] = 0.0
        for p in range(P):
            to_contact[p] = psi[p] / (1.0 + by_track[track[p]] - weighted[p])  # track t -> contact j
            by_contact[j[p]] += to_contact[p]
        moved = 0.0
        for p in range(P):
            new = 1.0 / (1.0 + by_contact[j[p]] - to_contact[p])
            moved = max(moved, abs(new - to_track[p]))
            to_track[p] = new
        if moved <= tolerance:
            break
    return to_track


def _odds(log_ratio: np.ndarray, log_miss: float) -> np.ndarray:
    """Weight of each pair relative to its track's miss, exp(log_ratio - log_miss), kept finite."""
    return np.exp(np.minimum(log_ratio - log_miss, _MAX_LOG_RATIO))
