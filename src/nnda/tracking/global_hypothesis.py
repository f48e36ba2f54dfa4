"""MHT's global hypothesis: the best set of compatible leaves, at most one per track family, no contact twice.

    chosen, solved, greedy = global_hypothesis(family, hist, score, max_exact_leaves=5_000)

``family`` (L,) is each leaf's family id, ``hist`` (L, n) the contact it used in each of the last n scans
(a negative entry is a miss or unknown: no contact), ``score`` (L,) its log-likelihood ratio. Families that
share no contact with another family's leaves take their best leaf when its score is positive. The rest form
clusters (families linked by shared contacts, `nnda.tracking.marginals.clusters`): every cluster of
at most ``max_exact_leaves`` leaves is solved exactly, larger ones greedily by descending score
(`greedy_compatible`, as the thesis's global hypothesis). A leaf whose score is not positive is never chosen.

The exact clusters are searched first, all in one compiled call (`searched`: depth-first branch and bound over
the cluster's families, one leaf or none each, bounded by the sum of the remaining families' best scores).
Most clusters hold a few families and are settled in microseconds, where a call of a general solver costs a
millisecond or two. A cluster whose search would visit more than ``SEARCH_NODES`` nodes goes to a binary program
instead (`solve_clusters`, HiGHS through `scipy.optimize.milp`, all such clusters in one program: they are
independent blocks).
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp
from scipy.sparse import coo_matrix

from nnda.tracking.marginals import components


def global_hypothesis(family: np.ndarray, hist: np.ndarray, score: np.ndarray, max_exact_leaves: int
                      ) -> tuple[np.ndarray, int, int]:
    """The chosen leaves' indices (ascending; module docstring), and the clusters of two or more families
    solved exactly and greedily."""
    if not family.size:
        return np.empty(0, np.int64), 0, 0
    fam, rows, res, leaf_cluster, chosen, joint, exact, solved, greedy = _structure(family, hist, score,
                                                                                   max_exact_leaves)
    if solved:  # searched, and the clusters the search gives up on in one binary program
        members = np.flatnonzero(exact)
        found, hard = searched(members, leaf_cluster, fam, rows, res, score, SEARCH_NODES)
        chosen = np.concatenate([chosen, found, solve_clusters(members[hard], fam, rows, res, score)])
    if greedy:  # clusters too large to solve exactly: greedy, as the thesis's global hypothesis
        chosen = np.concatenate([chosen, greedy_compatible(np.flatnonzero(joint & ~exact), fam, rows, res, score)])
    return np.sort(chosen), solved, greedy


@numba.njit(cache=True, nogil=True)
def _structure(family, hist, score, max_exact_leaves):
    """`global_hypothesis`' view of L leaves in one compiled pass: each leaf's family index ``fam`` (L,) (families
    numbered by ascending id); its contact resources, pairs (``rows``, ``res``) with ``rows`` ascending and
    ``res`` numbering the distinct (scan, contact) entries of ``hist`` in ascending order; each leaf's cluster
    label (L,) (`nnda.tracking.marginals.clusters` of the families); the best leaf of each family alone in its
    cluster, where its score is positive (the first of equal scores; by family); which leaves lie in clusters
    of two or more families (``joint``) and of at most ``max_exact_leaves`` leaves (``exact``, among the joint
    ones); and the counts of such clusters solved exactly and greedily."""
    L, n = hist.shape
    order = np.argsort(family, kind="mergesort")
    fam = np.empty(L, np.int64)
    F = 0
    for i in range(L):
        if i == 0 or family[order[i]] != family[order[i - 1]]:
            F += 1
        fam[order[i]] = F - 1
    count = 0
    for k in range(L):
        for j in range(n):
            count += hist[k, j] >= 0
    rows, key = np.empty(count, np.int64), np.empty(count, np.int64)
    p = 0
    for k in range(L):
        for j in range(n):
            if hist[k, j] >= 0:
                rows[p], key[p] = k, (j << 32) | hist[k, j]
                p += 1
    res = np.empty(count, np.int64)
    by_key = np.argsort(key, kind="mergesort")
    distinct = 0
    for i in range(count):
        if i > 0 and key[by_key[i]] != key[by_key[i - 1]]:
            distinct += 1
        res[by_key[i]] = distinct
    label = components(fam[rows], res, F)[1] if count else np.arange(F)
    size = np.bincount(label, minlength=F)
    best = np.full(F, -1, np.int64)
    for k in range(L):
        if best[fam[k]] < 0 or score[k] > score[best[fam[k]]]:
            best[fam[k]] = k
    chosen = np.array([b for b in best if size[label[fam[b]]] == 1 and score[b] > 0], np.int64)
    leaf_cluster = label[fam]
    leaves_in = np.bincount(leaf_cluster, minlength=F)
    joint = size[leaf_cluster] > 1
    exact = joint & (leaves_in[leaf_cluster] <= max_exact_leaves)
    solved, greedy = 0, 0
    for c in range(F):
        if size[c] > 1:
            if leaves_in[c] <= max_exact_leaves:
                solved += 1
            else:
                greedy += 1
    return fam, rows, res, leaf_cluster, chosen, joint, exact, solved, greedy


#: nodes the branch and bound of one cluster may visit (`searched`) before the cluster goes to the binary program
SEARCH_NODES = 100_000


@numba.njit(cache=True, nogil=True)
def searched(members, cluster, fam, rows, res, score, budget):
    """The best compatible set of each cluster among the leaves ``members`` (ascending), by depth-first branch
    and bound: ``cluster`` (L,) each leaf's cluster label, ``fam`` (L,) its family index, (``rows``, ``res``) each
    (leaf, contact resource) pair with ``rows`` sorted, ``score`` (L,). Leaves whose score is not positive are
    left out (they never raise the sum). Within a cluster the families are taken by descending best score and
    each family's leaves by descending score, "none" last; a branch is cut when its score plus every remaining
    family's best cannot beat the best set found (of equal sums the first found is kept). Returns the chosen
    leaves (ascending) and which of ``members`` (bool) belong to clusters whose search passed ``budget`` nodes
    (left to `solve_clusters`)."""
    keep = members[score[members] > 0]
    n = keep.size
    hard = np.zeros(members.size, np.bool_)
    chosen = np.empty(n, np.int64)
    n_chosen = 0
    if n == 0:
        return chosen[:0], hard
    # by cluster, family and descending score (stable sorts, innermost key first)
    order = keep[np.argsort(-score[keep], kind="mergesort")]
    order = order[np.argsort(fam[order], kind="mergesort")]
    order = order[np.argsort(cluster[order], kind="mergesort")]
    first_pair = np.searchsorted(rows, np.arange(fam.size + 1))  # each leaf's resources: res[first[l]:first[l+1]]
    used = np.zeros(res.max() + 1 if res.size else 1, np.bool_)
    start = 0
    while start < n:
        end = start + 1
        while end < n and cluster[order[end]] == cluster[order[start]]:
            end += 1
        # the cluster's families: their runs of leaves in order[start:end], then ranked by best score
        heads = [start]
        for i in range(start + 1, end):
            if fam[order[i]] != fam[order[i - 1]]:
                heads.append(i)
        F = len(heads)
        head = np.empty(F + 1, np.int64)
        for f in range(F):
            head[f] = heads[f]
        head[F] = end
        best_of = np.empty(F)
        for f in range(F):
            best_of[f] = score[order[head[f]]]
        rank = np.argsort(-best_of, kind="mergesort")
        lo, hi = np.empty(F, np.int64), np.empty(F, np.int64)
        bound = np.zeros(F + 1)  # the best scores of the families from depth d on
        for d in range(F - 1, -1, -1):
            lo[d], hi[d] = head[rank[d]], head[rank[d] + 1]
            bound[d] = bound[d + 1] + best_of[rank[d]]
        pick = np.full(F, -1, np.int64)  # the option taken at each depth: a position in order, or hi (none)
        best_pick = np.full(F, -1, np.int64)
        best, total, nodes, d = 0.0, 0.0, 0, 0
        next_option = lo[0]
        gave_up = False
        while d >= 0:
            taken = -1
            if d == F:  # a complete set: kept if the best so far, then back up
                if total > best:
                    best = total
                    for e in range(F):
                        best_pick[e] = pick[e] if pick[e] < hi[e] else -1
            else:
                option = next_option
                while option <= hi[d]:
                    if option == hi[d]:  # none of the family's leaves
                        if total + bound[d + 1] > best:
                            taken = option
                        break
                    leaf = order[option]
                    if total + score[leaf] + bound[d + 1] <= best:  # nor any later leaf, nor none
                        break
                    if _free(leaf, first_pair, res, used):
                        taken = option
                        break
                    option += 1
            if taken < 0:  # back up: the option of the depth above undone, its next one to try
                d -= 1
                if d >= 0:
                    next_option, freed = _undone(d, pick, order, score, first_pair, res, used, hi)
                    total -= freed
                continue
            nodes += 1
            if nodes > budget:
                gave_up = True
                break
            pick[d] = taken
            if taken < hi[d]:
                leaf = order[taken]
                total += score[leaf]
                for q in range(first_pair[leaf], first_pair[leaf + 1]):
                    used[res[q]] = True
            d += 1
            if d < F:
                next_option = lo[d]
        if gave_up:
            used[:] = False
            for i in range(start, end):
                hard[np.searchsorted(members, order[i])] = True
        else:
            for f in range(F):
                if best_pick[f] >= 0:
                    chosen[n_chosen] = order[best_pick[f]]
                    n_chosen += 1
        start = end
    return np.sort(chosen[:n_chosen]), hard


@numba.njit(cache=True, nogil=True)
def _free(leaf, first_pair, res, used):
    """Whether none of ``leaf``'s contact resources is ``used``."""
    for q in range(first_pair[leaf], first_pair[leaf + 1]):
        if used[res[q]]:
            return False
    return True


@numba.njit(cache=True, nogil=True)
def _undone(d, pick, order, score, first_pair, res, used, hi):
    """Undo the option taken at depth ``d``: free its leaf's resources (none: nothing). Returns the next option
    to try there and the score the option had added (0 for none)."""
    if pick[d] == hi[d]:
        return pick[d] + 1, 0.0
    leaf = order[pick[d]]
    for q in range(first_pair[leaf], first_pair[leaf + 1]):
        used[res[q]] = False
    return pick[d] + 1, score[leaf]


def solve_clusters(members: np.ndarray, fam: np.ndarray, rows: np.ndarray, res: np.ndarray,
                   score: np.ndarray) -> np.ndarray:
    """Exact best compatible set among the leaves ``members`` (binary program, HiGHS): ``fam`` (L,) each leaf's
    family index, (``rows``, ``res``) each (leaf, contact resource) pair with ``rows`` sorted, ``score`` (L,).
    A leaf whose score is not positive is never chosen (taking it never raises the summed score): the program
    holds the others only."""
    members = members[score[members] > 0]
    n = members.size
    if not n:
        return members
    local = np.full(fam.size, -1)
    local[members] = np.arange(n)
    in_c = local[rows] >= 0
    r_leaf, r_res = local[rows[in_c]], res[in_c]
    res_u, r_idx = np.unique(r_res, return_inverse=True)
    fam_u, f_idx = np.unique(fam[members], return_inverse=True)
    A_res = coo_matrix((np.ones(r_leaf.size), (r_idx, r_leaf)), shape=(res_u.size, n))
    A_fam = coo_matrix((np.ones(n), (f_idx, np.arange(n))), shape=(fam_u.size, n))
    constraints = [LinearConstraint(A_fam, 0, 1), LinearConstraint(A_res, 0, 1)]
    result = milp(-score[members], constraints=constraints, integrality=np.ones(n), bounds=Bounds(0, 1))
    if not result.success:  # pragma: no cover - the all-zero point is always feasible
        raise RuntimeError(f"MHT global hypothesis: {result.message}")
    return members[result.x > 0.5]


def greedy_compatible(members: np.ndarray, fam: np.ndarray, rows: np.ndarray, res: np.ndarray,
                      score: np.ndarray) -> np.ndarray:
    """Leaves ``members`` taken by descending score when compatible with those taken before
    (one per family, no shared contact); leaves with a score <= 0 are never taken (arguments as
    `solve_clusters`')."""
    bounds = np.searchsorted(rows, np.arange(fam.size + 1))  # rows is sorted: leaf of each resource
    res_list = res.tolist()
    used_fam, used_res, chosen = set(), set(), []
    for leaf in members[np.argsort(-score[members], kind="stable")].tolist():
        if score[leaf] <= 0:
            break
        mine = res_list[bounds[leaf]:bounds[leaf + 1]]
        if fam[leaf] in used_fam or any(r in used_res for r in mine):
            continue
        chosen.append(leaf)
        used_fam.add(fam[leaf])
        used_res.update(mine)
    return np.array(chosen, dtype=np.int64)
