"""Gaussian mixtures as batched records, and their reduction: prune, merge, cap (Vo & Ma 2006, Table II).

A mixture of J weighted Gaussians in an n-dimensional state space is one
`Mixture` record of arrays with the component axis first, so selecting,
reordering and concatenating components are `Batch.take` / `Batch.concat`:

    mix = Mixture.make(w, m, P, labels)   # w (J,), m (J, n), P (J, n, n), labels (J,) int64, checked
    mix = prune(mix, 1e-5)                 # drop w <= T                       (J' <= J components)
    mix = merge(mix, 4.0)                  # greedy Mahalanobis merge, U = 4   (heaviest first)
    mix = cap(mix, 100)                    # keep the J_max heaviest
    n_hat = mix.weights.sum()              # a PHD's expected number of targets

Each reduction is a pure function (a new record; the input is not
modified) with its contract in its docstring; the tests hold each against a
slow, loop-per-component reference. Weights are any non-negative numbers
(a PHD's intensity integrates to the expected target count, not to one);
labels are the track tags a PHD filter propagates (Clark, Panta & Vo 2006).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numba
import numpy as np

from nnda.data.sensor import wrap_angle
from nnda.errors import FilterError
from nnda.filters.batch import Batch
from nnda.filters.imm_kernels import wrap_angle_kernel
from nnda.filters.kalman import symmetrise
from nnda.validation import check_array, check_covariance, check_finite, check_nonnegative


@dataclass(frozen=True)
class Mixture(Batch):
    """J weighted Gaussian components: ``weights`` (J,) >= 0, ``means`` (J, n), ``covariances`` (J, n, n)
    symmetric positive definite, ``labels`` (J,) int64 track tags. Build a checked one with `make`."""

    weights: np.ndarray
    means: np.ndarray
    covariances: np.ndarray
    labels: np.ndarray

    @classmethod
    def make(cls, weights, means, covariances, labels) -> Mixture:
        """A checked mixture: shapes agree, values finite, weights >= 0, covariances SPD; raises FilterError."""
        m = check_array("Mixture.means", means, (None, None), error=FilterError)
        j, n = m.shape
        w = check_array("Mixture.weights", weights, (j,), error=FilterError)
        P = check_array("Mixture.covariances", covariances, (j, n, n), error=FilterError)
        labels = np.asarray(labels)
        if labels.shape != (j,) or not np.issubdtype(labels.dtype, np.integer):
            raise FilterError(f"Mixture.labels: expected {j} integers, got {labels.dtype} of shape {labels.shape}")
        check_finite("Mixture.weights", w, error=FilterError)
        check_finite("Mixture.means", m, error=FilterError)
        if (w < 0).any():
            raise FilterError(f"Mixture.weights: must be >= 0, got {w[w < 0][0]} at index {int(np.argmax(w < 0))}")
        check_covariance("Mixture.covariances", P, error=FilterError)
        return cls(w, m, P, labels.astype(np.int64))

    @classmethod
    def empty(cls, n: int) -> Mixture:
        """No components in an n-dimensional state space."""
        return cls(np.empty(0), np.empty((0, n)), np.empty((0, n, n)), np.empty(0, np.int64))

    @property
    def dim(self) -> int:
        """State size n."""
        return self.means.shape[1]


def prune(mixture: Mixture, threshold: float) -> Mixture:
    """The components with weight > ``threshold`` (T, >= 0), in their order; the dropped weight is not
    redistributed (Vo & Ma, Table II, step 1), so the total weight falls by what was dropped."""
    check_nonnegative("prune threshold", threshold, error=FilterError)
    keep = mixture.weights > threshold
    return mixture if keep.all() else mixture.take(keep)


def cap(mixture: Mixture, j_max: int) -> Mixture:
    """At most ``j_max`` (>= 1) components: the heaviest, in decreasing weight (ties: the earlier
    component first); a mixture already that small is returned unchanged, in its order."""
    if j_max < 1:
        raise FilterError(f"cap: j_max must be >= 1, got {j_max}")
    w = mixture.weights
    if len(w) <= j_max:
        return mixture
    v = w[np.argpartition(-w, j_max - 1)[j_max - 1]]  # the j_max-th largest weight
    above = np.flatnonzero(w > v)
    top = np.concatenate([above, np.flatnonzero(w == v)[:j_max - len(above)]])  # ties at v: earliest
    return mixture.take(top[np.lexsort((top, -w[top]))])


def merge_groups(mixture: Mixture, threshold: float, covariance: Literal["heaviest", "candidate"] = "heaviest",
                 angles: tuple[int, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
    """The groups `merge` forms: each component's group (J,), numbered 0..G-1 in greedy order, and the
    heaviest component of each group (G,) (`merge`'s leaders, in that order); differences of the state
    entries ``angles`` (rad) are wrapped to [-pi, pi)."""
    check_nonnegative("merge threshold", threshold, error=FilterError)
    if covariance not in ("heaviest", "candidate"):
        raise FilterError(f"merge: covariance must be 'heaviest' or 'candidate', got {covariance!r}")
    J = len(mixture)
    if J < 2:
        return np.zeros(J, np.int64), np.arange(J)
    w, m, P = mixture.weights, mixture.means, mixture.covariances
    order = np.lexsort((np.arange(J), -w))  # greedy order: heaviest first, ties by index
    rank = np.empty(J, np.int64)
    rank[order] = np.arange(J)
    k = np.arange(m.shape[1])
    diag = P[:, k, k]  # (J, n)
    angle = np.zeros(m.shape[1], np.bool_)
    angle[list(angles)] = True
    j, i = _coordinate_pairs(np.ascontiguousarray(m, float), np.ascontiguousarray(diag, float), rank,
                             float(threshold), covariance == "candidate", _sweep_entries(m, diag, angle), angle)
    c = i if covariance == "candidate" else j
    d = m[i] - m[j]
    if angles:
        d[:, angles] = wrap_angle(d[:, angles])
    near = np.einsum("ki,ki->k", d, np.linalg.solve(P[c], d[..., None])[..., 0]) <= threshold
    j, i = j[near], i[near]
    if not len(j):
        return rank, order
    # candidates of each heavier component, as CSR rows in greedy order
    by_rank = np.lexsort((rank[i], rank[j]))
    j, i = j[by_rank], i[by_rank]
    rj = rank[j]
    group = _greedy_groups(order, rj, np.searchsorted(rj, np.arange(J + 1)), i)
    leaders = order[group[order] == order]  # the heaviest of each group, in greedy order
    slot = np.empty(J, np.int64)
    slot[leaders] = np.arange(len(leaders))
    return slot[group], leaders


def _sweep_entries(m: np.ndarray, diag: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """The state entries in the order `_coordinate_pairs` tests them (n,): by how much the means spread in units
    of the components' typical window, most first (the likeliest to tell two components apart), the sweep's
    entry, the one that spreads most among the entries that are not angles, last (its window holds them)."""
    width = np.sqrt(np.median(diag, axis=0))
    spread = np.ptp(m, axis=0) / np.where(width > 0, width, np.inf)
    if angle.all():
        raise FilterError("merge: every state entry is an angle; at least one must not be")
    axis = int(np.argmax(np.where(angle, -1.0, spread)))
    rest = [k for k in np.argsort(-spread, kind="stable").tolist() if k != axis]
    return np.array([*rest, axis], np.int64)


@numba.njit(cache=True, nogil=True)
def _coordinate_pairs(m, diag, rank, threshold, candidate, entries, angle):
    """The pairs (j heavier, i lighter) (P,) of components that pass `merge`'s coordinate test: every entry k's
    difference d_k = m_ik - m_jk (wrapped to [-pi, pi) where ``angle``) has d_k^2 <= U C_kk, with C = P_i
    (``candidate``) or P_j, ``diag`` (J, n) the covariances' diagonals, ``rank`` (J,) each component's place in
    the greedy order (0: heaviest). A sweep along the last of ``entries`` (`_sweep_entries`, no angle), the
    components sorted by it: each component c whose C it is examines only those whose entry lies within its
    window sqrt(U C_kk) (widened by 1e-9 so that rounding never leaves one out), testing the entries in that
    order. Pairs in no particular order (`merge_groups` sorts them)."""
    J, n = m.shape
    axis = entries[n - 1]
    order = np.argsort(m[:, axis], kind="mergesort")
    ms, ds, rs = m[order], diag[order], rank[order]  # sorted, so that a window's rows are contiguous
    xs = ms[:, axis].copy()
    first = entries[0]
    screen = not angle[first]  # (a - b)^2 is (b - a)^2 to the bit: the first entry's test needs no orientation
    pj = np.empty(4 * J + 1, np.int64)
    pi = np.empty(4 * J + 1, np.int64)
    found = 0
    for c in range(J):
        w = math.sqrt(threshold * ds[c, axis]) * (1.0 + 1e-9) + 1e-300
        for q in range(np.searchsorted(xs, xs[c] - w, "left"), np.searchsorted(xs, xs[c] + w, "right")):
            if screen:
                d = ms[q, first] - ms[c, first]
                if not d * d <= threshold * ds[c, first]:
                    continue
            if q == c or (rs[c] > rs[q]) != candidate:  # c must be the lighter (candidate) or the heavier
                continue
            j, i = (q, c) if candidate else (c, q)
            ok = True
            for e in range(n):
                k = entries[e]
                d = ms[i, k] - ms[j, k]
                if angle[k]:
                    d = wrap_angle_kernel(d)
                if not d * d <= threshold * ds[c, k]:
                    ok = False
                    break
            if ok:
                if found == pj.size:
                    pj = np.concatenate((pj, np.empty(pj.size, np.int64)))
                    pi = np.concatenate((pi, np.empty(pi.size, np.int64)))
                pj[found], pi[found] = order[j], order[i]
                found += 1
    return pj[:found], pi[:found]


@numba.njit(cache=True, nogil=True)
def _greedy_groups(order, rj, starts, i):
    """`merge_groups`' greedy pass: the heaviest member of each component's group (J,). ``order`` (J,) are the
    components heaviest first, and the candidate pairs (P,) of the component of rank ``rj`` with the lighter
    component ``i`` are sorted by rank, rank r's in ``starts[r]:starts[r + 1]``. Each possible leader, heaviest
    first, still free takes its free candidates."""
    J = order.size
    group = np.arange(J)  # itself until merged
    free = np.ones(J, np.bool_)
    for p in range(rj.size):
        r = rj[p]
        if p and r == rj[p - 1]:
            continue
        leader = order[r]
        if not free[leader]:
            continue
        for q in range(starts[r], starts[r + 1]):
            if free[i[q]]:
                group[i[q]] = leader
                free[i[q]] = False
        free[leader] = False
    return group


def merge(mixture: Mixture, threshold: float, covariance: Literal["heaviest", "candidate"] = "heaviest",
          angles: tuple[int, ...] = ()) -> Mixture:
    """Greedy Mahalanobis merge in Vo & Ma's order (Table II, steps 2-4), with U = ``threshold``.

    Repeatedly take the heaviest remaining component j (ties: the earlier
    one), gather every remaining i with (m_i - m_j)^T C^-1 (m_i - m_j) <= U,
    where C is the heaviest's covariance P_j (``covariance="heaviest"``) or
    each candidate's own P_i (``"candidate"``, as Vo & Ma's Table II and
    Stone Soup write it: a wide component near a tight one then joins it),
    and replace the group L by one
    component: w = sum_L w_i, m = sum_L w_i m_i / w,
    P = sum_L w_i (P_i + (m - m_i)(m - m_i)^T) / w, carrying j's label. The
    result lists the merged components in the order their heaviest was
    taken (decreasing weight of the heaviest). Groups with one member are
    returned as they are. Total weight, and each group's weighted mean, are
    kept exactly; weights are not capped at one.

    Compiled and vectorised: the pairs with some (m_i - m_j)_k^2 / C_kk > U
    are out (for a positive definite C the Mahalanobis distance is at least
    each coordinate's), found by a sweep along one state entry
    (`_coordinate_pairs`: each component examines only those within its
    window there), and only the rest get the exact distance, all at once.
    The greedy pass then visits each possible leader once, heaviest first
    (`_greedy_groups`). The moments of all groups are summed at once.

    State entries ``angles`` (rad, e.g. a heading) are compared and
    averaged on the circle: their differences wrapped to [-pi, pi), each
    member's angle taken within pi of its group's heaviest before the mean.
    """
    g, leaders = merge_groups(mixture, threshold, covariance, angles)
    if len(leaders) == len(mixture):
        return mixture.take(leaders)
    return combine_groups(mixture, g, leaders, angles)


def combine_groups(mixture: Mixture, g: np.ndarray, leaders: np.ndarray, angles: tuple[int, ...] = ()) -> Mixture:
    """One moment-matched component per group: ``g`` (J,) each component's group 0..G-1, ``leaders`` (G,)
    the component whose label each group carries (and whose moments a group of zero weight keeps):
    w = sum_L w_i, m = sum_L w_i m_i / w, P = sum_L w_i (P_i + (m - m_i)(m - m_i)^T) / w (symmetrised);
    a group of one member is that member unchanged. Entries ``angles`` (rad) of each member are first
    taken within pi of its leader's."""
    w, m, P = mixture.weights, mixture.means, mixture.covariances
    by_group = np.argsort(g, kind="stable")
    first = np.searchsorted(g[by_group], np.arange(len(leaders)))
    ws, ms, Ps = w[by_group], m[by_group], P[by_group]
    if angles:
        ms = ms.copy()
        ref = m[leaders[g[by_group]]][:, angles]
        ms[:, angles] = ref + wrap_angle(ms[:, angles] - ref)
    W = np.add.reduceat(ws, first)
    safe = np.where(W > 0, W, 1.0)  # a group of zero weight keeps its heaviest's moments (below)
    mean = np.add.reduceat(ws[:, None] * ms, first) / safe[:, None]
    d = mean[g[by_group]] - ms
    cov = np.add.reduceat(ws[:, None, None] * (Ps + d[:, :, None] * d[:, None, :]), first) / safe[:, None, None]
    alone = (np.bincount(g) == 1) | (W == 0)
    mean[alone] = m[leaders[alone]]
    cov = symmetrise(cov)
    cov[alone] = P[leaders[alone]]
    return Mixture(W, mean, cov, mixture.labels[leaders])
