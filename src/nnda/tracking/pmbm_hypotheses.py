"""PMBM global hypotheses of one scan: Murty's k best data associations per cluster, combined, for every
global hypothesis of the mixture at once.

    children, log_gain, parent = scan_hypotheses(hyp, ks, pair_sth, pair_contact, pair_child, pair_gain)

Each of H global hypotheses before the scan picks, for each of L Bernoullis (track labels), one
single-target hypothesis (STH) by index, or -1 where the Bernoulli does not exist in it (``hyp`` (H, L)),
and asks for its ``ks[h]`` best data associations. Every STH s has a miss child (index s) and a detection
child per gated contact, given as pairs: STH (P,), contact (P,), child index (P,) and gain (P,), the log of
the detection's weight over the miss's, ln(r P_D l(z) / lambda_c(z)) - ln(1 - r P_D) (r the predicted
existence, l the IMM likelihood of the contact, lambda_c the clutter density in measurement space; a
contact left to clutter weighs 1 relative).

In each global hypothesis the Bernoullis present and the contacts their STHs gate form clusters (connected
components of the bipartite gating graph, by the compiled union-find `nnda.tracking.marginals.components`, one
graph for the whole mixture); a Bernoulli gating nothing misses. A cluster's data associations are ranked by
`nnda.tracking.kbest.k_best_assignments` on the (Bernoullis) x (contacts + one miss column per Bernoulli)
matrix of costs -gain (0 for the Bernoulli's own miss, +inf for pairs outside the gate and the other
Bernoullis' miss columns): each Bernoulli takes one contact or misses, each contact goes to at most one
Bernoulli, the rest to clutter (Williams 2015; García-Fernández, Williams, Granström & Svensson 2018 rank the
transposed matrix, contacts x (Bernoullis + one new-target column per contact); this form has fewer rows,
so fewer Murty subproblems, when the contacts outnumber the Bernoullis, and ranks the same associations).
A cluster depends only on its STHs, so one ranked for several global hypotheses (most of them share most
STHs) is ranked once, for the largest k asked (Murty's ranking yields the same first k for any larger k). A
cluster of one Bernoulli is ranked directly (its miss and its contacts by gain), all of them in one sort.

The clusters are independent, so a global hypothesis's k best associations are the k best sums of one
ranked option per cluster (`_combined`, every global hypothesis in one compiled pass). Only a few clusters
take part: with the deltas of each cluster's options from its best (<= 0), an option of delta below the
(k-1)-th largest delta of all clusters is in none of the k best sums (the best sum with any one of those
k - 1 deltas beats it), so the others keep their best.

Returns ``children`` (M, L), the child STH of every Bernoulli in each of the M associations (-1 where
absent), ``log_gain`` (M,), each one's summed gain (its log weight relative to the all-missed association,
summed in cluster order), and ``parent`` (M,), its global hypothesis: the ks[h] (or fewer) best of each
hypothesis h in turn, descending.
"""

from __future__ import annotations

import numba
import numpy as np

from nnda.tracking.kbest import k_best_assignments
from nnda.tracking.marginals import components


def scan_hypotheses(hyp: np.ndarray, ks: np.ndarray, pair_sth: np.ndarray, pair_contact: np.ndarray,
                    pair_child: np.ndarray, pair_gain: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``ks[h]`` best data associations of every global hypothesis h of ``hyp`` (module docstring)."""
    (by_sth, start, opt_child, opt_gain, sth, h, col, node_order, node_at, cl_at, node_at_h, off, length,
     child0) = _layout(hyp, pair_sth, pair_contact, pair_child, pair_gain)
    ks, child_off = np.asarray(ks, np.int64), off.copy()
    several = np.flatnonzero(np.diff(node_at) > 1)  # the clusters of several Bernoullis, each ranked once
    if several.size:
        opt_gain, opt_child = _ranked_several(several, _Pairs(pair_contact, pair_child, pair_gain, by_sth, start),
                                              sth, h, ks, node_order, node_at, off, length, child_off, child0,
                                              opt_gain, opt_child)
    return _combined(hyp, ks, opt_gain, off, length, opt_child, child_off, col[node_order], node_at, cl_at, col,
                     child0, node_at_h)


def _ranked_several(several: np.ndarray, pairs: _Pairs, sth: np.ndarray, h: np.ndarray, ks: np.ndarray,
                    node_order: np.ndarray, node_at: np.ndarray, off: np.ndarray, length: np.ndarray,
                    child_off: np.ndarray, child0: np.ndarray, opt_gain: np.ndarray, opt_child: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The clusters ``several`` of several Bernoullis ranked (`_Pairs.ranked`; a cluster of the same STHs in
    several global hypotheses once, for the largest k asked), their options appended to the single Bernoullis'
    gains ``opt_gain`` and children ``opt_child``, which are returned; their places written into ``off``,
    ``length`` and ``child_off``, and each node's child in its cluster's best option into ``child0`` (`_layout`'s
    arrays)."""
    keys, want = {}, {}
    for c in several:
        nodes = node_order[node_at[c]:node_at[c + 1]]
        keys[c] = key = sth[nodes].tobytes()
        want[key] = (sth[nodes], max(int(ks[h[nodes[0]]]), want.get(key, (None, 0))[1]))
    done = {key: pairs.ranked(s, k) for key, (s, k) in want.items()}
    ranked_gains = [gains for _, gains in done.values()]
    at = dict(zip(done, opt_gain.size + np.cumsum([0, *(g.size for g in ranked_gains)])))
    # each cluster's options (m, n) flat, by option then node: a single Bernoulli's own, then the ranked
    ranked_children = [children.ravel() for children, _ in done.values()]
    child_at = dict(zip(done, opt_child.size + np.cumsum([0, *(c.size for c in ranked_children)])))
    for c, key in keys.items():
        off[c], length[c], child_off[c] = at[key], done[key][1].size, child_at[key]
        child0[node_order[node_at[c]:node_at[c + 1]]] = done[key][0][0]
    return np.concatenate([opt_gain, *ranked_gains]), np.concatenate([opt_child, *ranked_children])


class _Pairs:
    """The gated pairs (contact, child and gain (P,) each) by STH: ``by_sth`` (P,) the pairs in STH order,
    STH s's from ``start[s]`` to ``start[s + 1]``."""

    def __init__(self, contact: np.ndarray, child: np.ndarray, gain: np.ndarray, by_sth: np.ndarray,
                 start: np.ndarray):
        self.contact, self.child, self.gain, self.by_sth, self.start = contact, child, gain, by_sth, start

    def ranked(self, sths: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """The k best associations of the cluster of ``sths`` (n,) (module docstring): child STHs (m, n) and
        gains (m,), descending."""
        count = self.start[sths + 1] - self.start[sths]  # the pairs of each STH, STH by STH
        sel = self.by_sth[np.repeat(self.start[sths] - (np.cumsum(count) - count), count) + np.arange(count.sum())]
        row = np.repeat(np.arange(sths.size), count)
        contacts, col = np.unique(self.contact[sel], return_inverse=True)
        n, C = sths.size, contacts.size
        cost = np.full((n, C + n), np.inf)  # Bernoullis x (contacts + one miss each)
        cost[row, col] = -self.gain[sel]
        cost[np.arange(n), C + np.arange(n)] = 0.0
        assign, costs = k_best_assignments(cost, k)
        pick = np.full((n, C), -1, np.int64)  # the pair of each (Bernoulli, contact)
        pick[row, col] = sel
        options = np.tile(sths, (len(costs), 1))
        m, i = np.nonzero(assign < C)  # ranked assignment, Bernoulli given a contact
        options[m, i] = self.child[pick[i, assign[m, i]]]
        return options, -costs


@numba.njit(cache=True, nogil=True)
def _layout(hyp, pair_sth, pair_contact, pair_child, pair_gain):
    """Everything `scan_hypotheses` needs before it ranks the clusters of several Bernoullis, in one compiled
    pass. The pairs by STH: ``by_sth`` (P,) in STH order (stable), STH s's from ``start[s]`` to ``start[s +
    1]``; each STH's options alone, its miss (gain 0) and its pairs, by gain descending (ties: the miss, then
    the pairs' order), children ``opt_child`` and gains ``opt_gain`` (STH s's from ``opt_start[s]``). The
    nodes, the present Bernoullis with pairs, by hypothesis then label: STH ``sth``, hypothesis ``h`` and label
    ``col`` (V,); their clusters (connected components of the gating graph of each hypothesis, by
    `nnda.tracking.marginals.components`, numbered by hypothesis, then first Bernoulli): the nodes by cluster,
    ``node_order`` (V,), cluster c's from ``node_at[c]``; hypothesis g's clusters from ``cl_at[g]`` and its
    nodes from ``node_at_h[g]``; each cluster's options as a single Bernoulli's (``off``, ``length`` into the
    options; the caller replaces those of the clusters it ranks) and each node's child in its cluster's best
    option, ``child0`` (V,)."""
    H, L = hyp.shape
    S = max(hyp.max() + 1 if hyp.size else 0, pair_sth.max() + 1 if pair_sth.size else 0)
    by_sth = np.argsort(pair_sth, kind="mergesort")
    start = np.searchsorted(pair_sth[by_sth], np.arange(S + 1))
    count = start[1:] - start[:-1]
    own = np.flatnonzero(count)  # the miss, then the pairs in their order, per STH
    e_sth = np.concatenate((own, pair_sth))
    e_gain = np.concatenate((np.zeros(own.size), pair_gain))
    e_child = np.concatenate((own, pair_child))
    by_gain = np.argsort(-e_gain, kind="mergesort")
    order = by_gain[np.argsort(e_sth[by_gain], kind="mergesort")]  # by STH, gain descending, then entry
    opt_child, opt_gain = e_child[order], e_gain[order]
    opt_start = np.searchsorted(e_sth[order], np.arange(S + 1))
    V = 0
    for g in range(H):
        for j in range(L):
            V += hyp[g, j] >= 0 and count[hyp[g, j]] > 0
    sth, h, col = np.empty(V, np.int64), np.empty(V, np.int64), np.empty(V, np.int64)
    v = 0
    for g in range(H):
        for j in range(L):
            if hyp[g, j] >= 0 and count[hyp[g, j]] > 0:
                sth[v], h[v], col[v] = hyp[g, j], g, j
                v += 1
    comp = np.empty(0, np.int64)
    if V:
        n_pairs = count[sth]
        node = np.repeat(np.arange(V), n_pairs)
        key = np.empty(node.size, np.int64)
        N = pair_contact.max() + 1
        e = 0
        for v in range(V):
            for q in range(start[sth[v]], start[sth[v] + 1]):
                key[e] = h[v] * N + pair_contact[by_sth[q]]
                e += 1
        comp = components(node, key, V)[1]
    node_order = np.argsort(comp, kind="mergesort")  # by cluster, each by label
    node_at = np.searchsorted(comp[node_order], np.arange((comp.max() + 2) if V else 1))
    first = node_order[node_at[:-1]]
    cl_at = np.searchsorted(h[first], np.arange(H + 1))
    node_at_h = np.searchsorted(h, np.arange(H + 1))
    off, length = opt_start[sth[first]], count[sth[first]] + 1
    child0 = opt_child[opt_start[sth]]
    return (by_sth, start, opt_child, opt_gain, sth, h, col, node_order, node_at, cl_at, node_at_h, off, length,
            child0)


@numba.njit(cache=True, nogil=True)
def _combined(hyp, ks, flat_gain, off, length, flat_child, child_off, cluster_cols, node_at, cl_at, cols, child0,
              node_at_h):
    """The ``ks[g]`` best combinations of one option per cluster of every global hypothesis g of ``hyp`` (H, L),
    in turn (module docstring). The C clusters, numbered by hypothesis (hypothesis g's are ``cl_at[g]`` to
    ``cl_at[g + 1]``), have their gains descending at ``flat_gain[off[c]:off[c] + length[c]]`` and their
    options (m, n), the child STH of each of their n Bernoullis (labels ``cluster_cols[node_at[c]:node_at[c +
    1]]``), by option then Bernoulli at ``flat_child[child_off[c]:]``; ``cols`` (V,) the labels of every
    hypothesis's Bernoullis with pairs and ``child0`` (V,) each one's child in its cluster's best option
    (hypothesis g's nodes ``node_at_h[g]`` to ``node_at_h[g + 1]``). Only the clusters with an option of delta
    at or above the (k-1)-th largest of the hypothesis take part; each sum is over every cluster, in order.
    Returns the children (M, L), the sums (M,) (descending per hypothesis) and each one's hypothesis (M,).
    One compiled pass."""
    H, L = hyp.shape
    bound = np.ones(H, np.int64)  # combinations of each hypothesis at most: k, and the product of its options
    for g in range(H):
        for c in range(cl_at[g], cl_at[g + 1]):
            bound[g] = int(min(float(bound[g]) * min(length[c], ks[g]), float(ks[g])))  # no overflow
    cap = bound.sum()
    out = np.empty((cap, L), np.int64)
    out_gain = np.empty(cap)
    out_parent = np.empty(cap, np.int64)
    row0 = 0
    for g in range(H):
        k = ks[g]
        c0, C = cl_at[g], cl_at[g + 1] - cl_at[g]
        if C == 0:
            out[row0] = hyp[g]
            out_gain[row0], out_parent[row0] = 0.0, g
            row0 += 1
            continue
        m = np.minimum(length[c0:c0 + C], k)
        low = -np.inf
        part = np.empty(0, np.int64)
        if k > 1:
            delta = np.empty((m - 1).sum())
            d = 0
            for c in range(C):
                for i in range(1, m[c]):
                    delta[d] = flat_gain[off[c0 + c] + i] - flat_gain[off[c0 + c]]
                    d += 1
            if delta.size >= k - 1:
                low = np.partition(delta, delta.size - k + 1)[delta.size - k + 1]
            takes = np.zeros(C, np.bool_)
            for c in range(C):
                takes[c] = m[c] > 1 and flat_gain[off[c0 + c] + 1] - flat_gain[off[c0 + c]] >= low
            part = np.flatnonzero(takes)
        total = np.zeros(1)
        parents = np.empty((part.size, bound[g]), np.int64)  # per cluster taking part: the previous combination
        options = np.empty((part.size, bound[g]), np.int64)  # and the option each extends
        for q in range(part.size):
            c = c0 + part[q]
            G = 1
            while G < m[part[q]] and flat_gain[off[c] + G] - flat_gain[off[c]] >= low:
                G += 1
            sums = np.empty(total.size * G)
            for t in range(total.size):
                for j in range(G):
                    sums[t * G + j] = total[t] + flat_gain[off[c] + j]
            keep = np.argsort(-sums, kind="mergesort")[:k]
            parents[q, :keep.size] = keep // G
            options[q, :keep.size] = keep % G
            total = sums[keep]
        T = total.size
        pick = np.zeros((T, C), np.int64)  # the option of each cluster in each combination
        row = np.arange(T)
        for q in range(part.size - 1, -1, -1):
            pick[:, part[q]] = options[q][row]
            row = parents[q][row]
        sums = np.empty(T)
        for t in range(T):  # in cluster order, as a cumulative sum would
            acc = flat_gain[off[c0] + pick[t, 0]]
            for c in range(1, C):
                acc += flat_gain[off[c0 + c] + pick[t, c]]
            sums[t] = acc
        order = np.argsort(-sums, kind="mergesort")
        for t in range(T):
            out[row0 + t] = hyp[g]
            for v in range(node_at_h[g], node_at_h[g + 1]):
                out[row0 + t, cols[v]] = child0[v]
            for q in range(part.size):
                c = c0 + part[q]
                n = node_at[c + 1] - node_at[c]
                option = pick[order[t], part[q]]
                for j in range(n):
                    out[row0 + t, cluster_cols[node_at[c] + j]] = flat_child[child_off[c] + option * n + j]
            out_gain[row0 + t], out_parent[row0 + t] = sums[order[t]], g
        row0 += T
    return out[:row0], out_gain[:row0], out_parent[:row0]
