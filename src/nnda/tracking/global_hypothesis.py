"""MHT's global hypothesis: the best set of compatible leaves, at most one per track family, no contact twice.

    chosen, solved, greedy = global_hypothesis(family, hist, score, max_exact_leaves=5_000)

``family`` (L,) is each leaf's family id, ``hist`` (L, n) the contact it used in each of the last n scans
(a negative entry is a miss or unknown: no contact), ``score`` (L,) its log-likelihood ratio. Families that
share no contact with another family's leaves take their best leaf when its score is positive. The rest form
clusters (families linked by shared contacts, `nnda.tracking.marginals.clusters`): every cluster of
at most ``max_exact_leaves`` leaves is solved exactly, all of them in one binary program (`solve_clusters`,
HiGHS through `scipy.optimize.milp`: they are independent blocks), larger ones greedily by descending score
(`greedy_compatible`, as the thesis's global hypothesis). A leaf whose score is not positive is never chosen.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp
from scipy.sparse import coo_matrix

from nnda.tracking.marginals import clusters


def global_hypothesis(family: np.ndarray, hist: np.ndarray, score: np.ndarray, max_exact_leaves: int
                      ) -> tuple[np.ndarray, int, int]:
    """The chosen leaves' indices (ascending; module docstring), and the clusters of two or more families
    solved exactly and greedily."""
    if not family.size:
        return np.empty(0, np.int64), 0, 0
    fam_ids, fam = np.unique(family, return_inverse=True)
    F = fam_ids.size
    rows, cols = np.nonzero(hist >= 0)
    resource = (cols.astype(np.int64) << 32) | hist[rows, cols]
    res = np.unique(resource, return_inverse=True)[1]
    _, fam_label = clusters(fam[rows], res, F)  # families linked by a contact that leaves of both use
    cluster_size = np.bincount(fam_label)

    order = np.lexsort((-score, fam))
    best = order[np.r_[True, np.diff(fam[order]) != 0]]  # best leaf of each family, by family
    chosen = best[(cluster_size[fam_label] == 1) & (score[best] > 0)]
    leaf_cluster = fam_label[fam]
    leaves_in = np.bincount(leaf_cluster)[leaf_cluster]
    joint = cluster_size[leaf_cluster] > 1
    exact = joint & (leaves_in <= max_exact_leaves)
    solved = greedy = 0
    if exact.any():  # every such cluster in one binary program (they are independent blocks)
        chosen = np.concatenate([chosen, solve_clusters(np.flatnonzero(exact), fam, rows, res, score)])
        solved = int(np.unique(leaf_cluster[exact]).size)
    if (joint & ~exact).any():  # clusters too large to solve exactly: greedy, as the thesis's global hypothesis
        chosen = np.concatenate([chosen, greedy_compatible(np.flatnonzero(joint & ~exact), fam, rows, res, score)])
        greedy = int(np.unique(leaf_cluster[joint & ~exact]).size)
    return np.sort(chosen), solved, greedy


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
