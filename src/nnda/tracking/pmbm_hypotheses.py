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
ranked option per cluster (`best_sums`). Only a few clusters take part: with the deltas of each cluster's
options from its best (<= 0), an option of delta below the (k-1)-th largest delta of all clusters is in none
of the k best sums (the best sum with any one of those k - 1 deltas beats it), so the others keep their best.

Returns ``children`` (M, L), the child STH of every Bernoulli in each of the M associations (-1 where
absent), ``log_gain`` (M,), each one's summed gain (its log weight relative to the all-missed association,
summed in cluster order), and ``parent`` (M,), its global hypothesis: the ks[h] (or fewer) best of each
hypothesis h in turn, descending.
"""

from __future__ import annotations

import numpy as np

from nnda.tracking.kbest import k_best_assignments
from nnda.tracking.marginals import components


def scan_hypotheses(hyp: np.ndarray, ks: np.ndarray, pair_sth: np.ndarray, pair_contact: np.ndarray,
                    pair_child: np.ndarray, pair_gain: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``ks[h]`` best data associations of every global hypothesis h of ``hyp`` (module docstring)."""
    H = hyp.shape[0]
    pairs = _Pairs(pair_sth, pair_contact, pair_child, pair_gain, int(hyp.max(initial=-1)) + 1)
    h, col = np.nonzero(hyp >= 0)  # the present Bernoullis (nodes), by hypothesis then label
    sth = hyp[h, col]
    has = pairs.count[sth] > 0
    h, col, sth = h[has], col[has], sth[has]
    comp = _clusters(h, sth, pairs, H)  # (V,) cluster of each node, numbered by hypothesis, then first label
    node_order = np.argsort(comp, kind="stable")  # by cluster, each by label
    node_at = np.searchsorted(comp[node_order], np.arange(comp.max(initial=-1) + 2))
    first = node_order[node_at[:-1]]
    cl_at = np.searchsorted(h[first], np.arange(H + 1))  # the clusters of hypothesis g: cl_at[g]:cl_at[g + 1]
    node_at_h = np.searchsorted(h, np.arange(H + 1))
    # each cluster's gains in one flat array (offset, length): a single Bernoulli's options, then the ranked
    off, length = pairs.opt_start[sth[first]], pairs.count[sth[first]] + 1
    child0 = pairs.opt_child[pairs.opt_start[sth]]  # (V,) each node's child in its cluster's best option
    keys, want = {}, {}
    for c in np.flatnonzero(np.diff(node_at) > 1):
        nodes = node_order[node_at[c]:node_at[c + 1]]
        keys[c] = key = sth[nodes].tobytes()
        want[key] = (sth[nodes], max(int(ks[h[nodes[0]]]), want.get(key, (None, 0))[1]))
    done = {key: pairs.ranked(s, k) for key, (s, k) in want.items()}
    ranked_gains = [gains for _, gains in done.values()]
    at = dict(zip(done, pairs.opt_gain.size + np.cumsum([0, *(g.size for g in ranked_gains)])))
    for c, key in keys.items():
        off[c], length[c] = at[key], done[key][1].size
        child0[node_order[node_at[c]:node_at[c + 1]]] = done[key][0][0]
    flat_gain = np.concatenate([pairs.opt_gain, *ranked_gains])

    def options(c: int) -> tuple[np.ndarray, np.ndarray]:
        """Cluster c's labels (n,) and options (m, n)."""
        labels = col[node_order[node_at[c]:node_at[c + 1]]]
        return labels, done[keys[c]][0] if c in keys else pairs.opt_child[off[c]:off[c] + length[c], None]

    out = []
    for g in range(H):
        cs, ns = slice(cl_at[g], cl_at[g + 1]), slice(node_at_h[g], node_at_h[g + 1])
        out.append(best_sums(hyp[g], int(ks[g]), flat_gain, off[cs], length[cs], col[ns], child0[ns],
                             lambda c, g=g: options(cl_at[g] + c)))
    return (np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out]),
            np.repeat(np.arange(H), [o[1].size for o in out]))


class _Pairs:
    """The gated pairs by STH (``count`` (S,) pairs of each of S STHs, S past every STH a pair or ``n_sth``
    names) and each STH's options alone: its miss (gain 0) and its pairs, descending by gain (ties: the miss,
    then the pairs' order)."""

    def __init__(self, sth: np.ndarray, contact: np.ndarray, child: np.ndarray, gain: np.ndarray, n_sth: int):
        S = max(n_sth, int(sth.max(initial=-1)) + 1)
        self.contact, self.child, self.gain = contact, child, gain
        self.by_sth = np.argsort(sth, kind="stable")
        self.start = np.searchsorted(sth[self.by_sth], np.arange(S + 1))
        self.count = np.diff(self.start)
        own = np.flatnonzero(self.count)  # the miss, then the pairs in their order, per STH
        e_sth = np.concatenate([own, sth])
        e_gain = np.concatenate([np.zeros(own.size), gain])
        e_child = np.concatenate([own, child])
        order = np.lexsort((np.arange(e_sth.size), -e_gain, e_sth))
        self.opt_child, self.opt_gain = e_child[order], e_gain[order]
        self.opt_start = np.searchsorted(e_sth[order], np.arange(S + 1))

    def of(self, sths: np.ndarray) -> np.ndarray:
        """The pairs (indices) of ``sths`` (n,), STH by STH, each in the pairs' order."""
        n = self.count[sths]
        offset = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
        return self.by_sth[np.repeat(self.start[sths], n) + offset]

    def single(self, s: int) -> tuple[np.ndarray, np.ndarray]:
        """STH ``s`` alone: its options (m, 1) child STHs and gains (m,), descending."""
        at = slice(self.opt_start[s], self.opt_start[s + 1])
        return self.opt_child[at, None], self.opt_gain[at]

    def ranked(self, sths: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """The k best associations of the cluster of ``sths`` (n,) (module docstring): child STHs (m, n) and
        gains (m,), descending."""
        sel = self.of(sths)
        row = np.repeat(np.arange(sths.size), self.count[sths])
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


def _clusters(h: np.ndarray, sth: np.ndarray, pairs: _Pairs, H: int) -> np.ndarray:
    """The cluster (V,) of each of V present Bernoullis with pairs, hypothesis ``h`` (V,), STH ``sth`` (V,)
    (sorted by hypothesis, then label): connected components of the gating graph of every hypothesis,
    numbered by hypothesis, then by first Bernoulli."""
    V = h.size
    if not V:
        return np.empty(0, np.int64)
    sel = pairs.of(sth)
    node = np.repeat(np.arange(V), pairs.count[sth])
    N = int(pairs.contact.max()) + 1
    return components(node, h[node] * N + pairs.contact[sel], V)[1]  # union-find, numbered by first node


def best_sums(base: np.ndarray, k: int, flat_gain: np.ndarray, off: np.ndarray, length: np.ndarray,
              cols: np.ndarray, child0: np.ndarray, options) -> tuple[np.ndarray, np.ndarray]:
    """The k best combinations of one option per cluster of one global hypothesis: ``base`` (L,) the STH of
    each label before the scan; C clusters, in order, with gains descending ``flat_gain[off[c]:off[c] +
    length[c]]``; ``cols`` (V,) the labels of their Bernoullis and ``child0`` (V,) each one's child in its
    cluster's best option; ``options(c)`` cluster c's labels (n,) and options (m, n) (child STH per label).
    Only the clusters with an option of delta at or above the (k-1)-th largest take part (module docstring);
    each sum is over every cluster, in order. Returns (children (k', L), gains (k',)), descending."""
    if not off.size:
        return base[None, :], np.zeros(1)
    m = np.minimum(length, k)
    best = flat_gain[off]
    part = np.empty(0, np.int64)
    low = -np.inf
    if k > 1:
        n = m - 1
        delta = flat_gain[np.repeat(off + 1, n) + np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)] - np.repeat(
            best, n)
        if delta.size >= k - 1:
            low = np.partition(delta, delta.size - k + 1)[delta.size - k + 1]
        two = m > 1
        part = np.flatnonzero(two & (flat_gain[off + two] - best >= low))
    total = np.zeros(1)
    steps = []  # per cluster taking part: the row of the previous combinations and the option each extends
    for c in part:
        gains = flat_gain[off[c]:off[c] + m[c]]
        gains = gains[:1 + int(np.count_nonzero(gains[1:] - gains[0] >= low))]
        sums = (total[:, None] + gains[None, :]).ravel()
        keep = np.argsort(-sums, kind="stable")[:k]
        steps.append((keep // gains.size, keep % gains.size))
        total = sums[keep]
    pick = np.zeros((total.size, off.size), np.int64)  # the option of each cluster in each combination
    row = np.arange(total.size)
    for c, (parent, option) in zip(part[::-1], steps[::-1]):
        pick[:, c] = option[row]
        row = parent[row]
    sums = np.cumsum(flat_gain[off + pick], axis=1)[:, -1]  # in cluster order
    order = np.argsort(-sums, kind="stable")
    children = np.tile(base, (total.size, 1))
    children[:, cols] = child0
    for c in part:
        labels, opts = options(c)
        children[:, labels] = opts[pick[order, c]]
    return children, sums[order]
