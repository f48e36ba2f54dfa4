"""PMBM global hypotheses of one scan: Murty's k best data associations per cluster, combined.

    children, log_gain = scan_hypotheses(parents, pair_sth, pair_contact, pair_child, pair_gain, k)

One global hypothesis before the scan picks, for each of L Bernoullis (track labels), one single-target
hypothesis (STH) by index, or -1 where the Bernoulli does not exist in it (``parents`` (L,)). Every STH s
has a miss child (index s) and a detection child per gated contact, given as ``pairs``: STH (P,), contact
(P,), child index (P,) and gain (P,), the log of the detection's weight over the miss's,
ln(r P_D l(z) / lambda_c(z)) - ln(1 - r P_D) (r the predicted existence, l the IMM likelihood of the
contact, lambda_c the clutter density in measurement space; a contact left to clutter weighs 1 relative).

The Bernoullis present and the contacts their STHs gate form clusters (connected components of the
bipartite gating graph, `scipy.sparse.csgraph.connected_components`); a Bernoulli gating nothing misses.
Each cluster's data associations are ranked by `nnda.tracking.kbest.k_best_assignments` on the
(Bernoullis) x (contacts + one miss column per Bernoulli) matrix of costs -gain (0 for the Bernoulli's own
miss, +inf for pairs outside the gate and the other Bernoullis' miss columns): each Bernoulli takes one
contact or misses, each contact goes to at most one Bernoulli, the rest to clutter (Williams 2015;
García-Fernández, Williams, Granström & Svensson 2018 rank the transposed matrix, contacts x (Bernoullis +
one new-target column per contact); this form has fewer rows, so fewer Murty subproblems, when the contacts
outnumber the Bernoullis, and ranks the same associations). A cluster of one Bernoulli is ranked directly
(its miss and its contacts by gain). The clusters are independent, so the k best
associations of the whole scan are the k best sums of one ranked assignment per cluster (`best_sums`).

Returns ``children`` (m, L), the child STH of every Bernoulli in each of the m <= k best associations
(-1 where absent), and ``log_gain`` (m,), each one's summed gain: its log weight relative to the
all-missed association, descending.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from nnda.tracking.kbest import k_best_assignments


def scan_hypotheses(parents: np.ndarray, pair_sth: np.ndarray, pair_contact: np.ndarray, pair_child: np.ndarray,
                    pair_gain: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The k best data associations of one global hypothesis (module docstring)."""
    base = parents.copy()  # every present Bernoulli missed (its miss child has its own index)
    owner = np.full(int(max(parents.max(initial=-1), pair_sth.max(initial=-1))) + 1, -1, np.int64)
    present = np.flatnonzero(parents >= 0)
    owner[parents[present]] = present
    mine = owner[pair_sth] >= 0 if pair_sth.size else np.zeros(0, bool)
    label, contact = owner[pair_sth[mine]], pair_contact[mine]
    child, gain = pair_child[mine], pair_gain[mine]
    if not label.size:
        return base[None, :], np.zeros(1)
    c_ids, c_at = np.unique(contact, return_inverse=True)
    l_ids, l_at = np.unique(label, return_inverse=True)
    nl, nc = l_ids.size, c_ids.size
    graph = coo_matrix((np.ones(label.size), (l_at, nl + c_at)), shape=(nl + nc,) * 2)
    _, comp = connected_components(graph, directed=False)
    ranked = []
    by_label, by_pair, by_contact = (np.argsort(a, kind="stable") for a in (comp[:nl], comp[l_at], comp[nl:]))
    clusters = np.unique(comp[:nl])
    label_at, pair_at, contact_at = (np.searchsorted(a[o], np.r_[clusters, clusters[-1] + 1]) for a, o in
                                     ((comp[:nl], by_label), (comp[l_at], by_pair), (comp[nl:], by_contact)))
    for n in range(clusters.size):
        cl = by_label[label_at[n]:label_at[n + 1]]  # local label indices
        sel = by_pair[pair_at[n]:pair_at[n + 1]]  # its pairs
        if cl.size == 1:  # one Bernoulli: a miss or one of its contacts, no assignment problem
            gains = np.concatenate([[0.0], gain[sel]])
            order = np.argsort(-gains, kind="stable")[:k]
            options = np.concatenate([base[l_ids[cl]], child[sel]])[order][:, None]
            ranked.append((l_ids[cl], options, gains[order]))
            continue
        cc = np.sort(by_contact[contact_at[n]:contact_at[n + 1]])  # local contact indices
        col_of = np.full(nc, -1, np.int64)
        col_of[cc] = np.arange(cc.size)
        row_of = np.full(nl, -1, np.int64)
        row_of[cl] = np.arange(cl.size)
        cost = np.full((cl.size, cc.size + cl.size), np.inf)  # Bernoullis x (contacts + one miss each)
        cost[row_of[l_at[sel]], col_of[c_at[sel]]] = -gain[sel]
        cost[np.arange(cl.size), cc.size + np.arange(cl.size)] = 0.0
        assign, costs = k_best_assignments(cost, k)
        pick = np.full((cl.size, cc.size), -1, np.int64)  # the pair of each (Bernoulli, contact)
        pick[row_of[l_at[sel]], col_of[c_at[sel]]] = sel
        options = np.tile(base[l_ids[cl]], (len(costs), 1))
        m, i = np.nonzero(assign < cc.size)  # ranked assignment, Bernoulli given a contact
        options[m, i] = child[pick[i, assign[m, i]]]
        ranked.append((l_ids[cl], options, -costs))
    return best_sums(base, ranked, k)


def best_sums(base: np.ndarray, ranked: list[tuple[np.ndarray, np.ndarray, np.ndarray]], k: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """The k best combinations of one option per cluster: ``ranked`` holds each cluster's labels (n,),
    options (m, n) (child STH per label) and gains (m,), descending. Returns (children (k', L), gains (k',))."""
    children = np.tile(base, (min(k, math.prod(len(g) for _, _, g in ranked)), 1))
    if k == 1:  # the best option of every cluster
        for labels, options, _ in ranked:
            children[0, labels] = options[0]
        return children, np.array([sum(g[0] for _, _, g in ranked)])
    total = np.zeros(1)
    steps = []  # per cluster: the row of the previous combinations and the option each new one extends
    for _, _, gains in ranked:
        sums = (total[:, None] + gains[None, :]).ravel()
        keep = np.argsort(-sums, kind="stable")[:k]
        steps.append((keep // gains.size, keep % gains.size))
        total = sums[keep]
    row = np.arange(total.size)
    for (labels, options, _), (parent, option) in zip(reversed(ranked), reversed(steps)):
        children[:, labels] = options[option[row]]
        row = parent[row]
    return children, total
