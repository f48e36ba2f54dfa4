"""The compiled passes the labelled trackers share (`nnda.tracking.labelled`), each held to the numpy
formulation it replaced, to the bit."""

from __future__ import annotations

import numpy as np

from nnda.tracking.labelled import _existence, _heaviest, _pruned, merged, n_scan_agrees, normalised
from nnda.tracking.output import NO_CONTACT


def test_merged_hypotheses_are_numpys():
    """Random integer rows with repeats and negative entries, 1 to 40 rows of 1 to 6 columns, with random
    log weights (some -inf, some equal): the distinct rows, in order, equal ``np.unique(axis=0)``, and each
    one's log weight equals numpy's ``logaddexp.reduceat`` over its rows in their order, to the bit."""
    rng = np.random.default_rng(0)
    for _ in range(300):
        a = rng.integers(-2, 3, (rng.integers(1, 40), rng.integers(1, 7)))
        a = a[rng.integers(0, len(a), len(a))]
        log_w = rng.normal(0.0, 3.0, len(a))
        log_w[rng.random(len(a)) < 0.1] = -np.inf
        log_w[rng.random(len(a)) < 0.1] = 0.5
        rows, w = merged(a, log_w)
        want, inverse = np.unique(a, axis=0, return_inverse=True)
        order = np.argsort(inverse.ravel(), kind="stable")
        starts = np.flatnonzero(np.r_[True, np.diff(inverse.ravel()[order]) != 0])
        np.testing.assert_array_equal(rows, want)
        np.testing.assert_array_equal(w, np.logaddexp.reduceat(log_w[order], starts))


def test_tentative_children_weighed_as_numpy_would():
    """Random tentative labels (1 to 30) with 0 to 60 gated pairs, some weights -inf and some tied: each label's
    summed weight equals numpy's ``logaddexp.at`` over its miss and its pairs, and its heaviest child is the
    first of a lexicographic sort by label, then weight descending (the form it replaced), with its contact."""
    rng = np.random.default_rng(1)
    for _ in range(300):
        T, Q = int(rng.integers(1, 30)), int(rng.integers(0, 60))
        owner = np.sort(rng.integers(0, T, Q)) if rng.random() < 0.5 else rng.integers(0, T, Q)
        log_w = rng.normal(0.0, 2.0, T + Q).round(int(rng.integers(0, 3)))  # rounded: ties
        log_w[rng.random(T + Q) < 0.1] = -np.inf
        pair = np.sort(rng.choice(3 * Q + 1, Q, replace=False))  # the kept pairs among all gated
        contact = rng.integers(0, 100, Q)
        total, chosen, taken = _heaviest(owner, log_w, pair, contact, T)
        everyone = np.concatenate([np.arange(T), owner])
        want_total = np.full(T, -np.inf)
        np.logaddexp.at(want_total, everyone, log_w)
        child = np.concatenate([np.arange(T), T + pair])
        order = np.lexsort((-log_w, everyone))
        first = np.r_[True, np.diff(everyone[order]) != 0]
        np.testing.assert_array_equal(total, want_total)
        np.testing.assert_array_equal(chosen, child[order[first]])
        np.testing.assert_array_equal(taken, np.concatenate([np.full(T, NO_CONTACT), contact])[order[first]])


def test_pruning_is_the_numpy_formulation():
    """Random mixtures (1-20 hypotheses, 0-8 labels over 30 rows), weight floors and caps: the compiled pruning
    keeps the hypotheses, weights, labels and rows of its numpy formulation, to the bit."""
    rng = np.random.default_rng(2)
    for _ in range(300):
        H, L, S = int(rng.integers(1, 20)), int(rng.integers(0, 8)), 30
        hyp = np.where(rng.random((H, L)) < 0.6, rng.integers(0, S, (H, L)), -1)
        log_w = rng.normal(0.0, 3.0, H)
        oldest = rng.integers(-1, 4, S)
        least = -np.inf if rng.random() < 0.3 else float(rng.normal(-2.0, 1.0))
        cap = int(rng.integers(1, 25))
        over, got, w, live, used = _pruned(hyp, log_w, oldest, least, cap)
        best = int(np.argmax(log_w))
        keep = (log_w >= least) & n_scan_agrees(hyp, oldest[np.maximum(hyp, 0)], best)
        keep[best] = True
        idx = np.flatnonzero(keep)
        assert over == max(idx.size - cap, 0)
        if idx.size > cap:
            idx = np.sort(idx[np.argsort(-log_w[idx], kind="stable")[:cap]])
        want_live = (hyp[idx] >= 0).any(axis=0)
        kept = hyp[idx][:, want_live]
        want_used = np.unique(kept[kept >= 0])
        remap = np.full(S, -1)
        remap[want_used] = np.arange(want_used.size)
        np.testing.assert_array_equal(got, np.where(kept >= 0, remap[np.maximum(kept, 0)], -1))
        np.testing.assert_array_equal(w, normalised(log_w[idx]))
        np.testing.assert_array_equal(live, want_live)
        np.testing.assert_array_equal(used, want_used)


def test_the_marginal_existence_is_numpys_sum_to_the_bit():
    """`_existence` sums the hypotheses as numpy sums a (H, L) array over its first axis: in turn, or for a single
    label (a contiguous column) pairwise, which differs from a loop in the last bits once H reaches 8."""
    rng = np.random.default_rng(0)
    for _ in range(300):
        H, L, S = int(rng.integers(1, 60)), int(rng.integers(1, 4)), 12
        hyp = np.where(rng.random((H, L)) < 0.2, -1, rng.integers(0, S, (H, L)))
        w, r = rng.random(H) * rng.random(H) ** 4, rng.random(S)
        rows, marginal = _existence(hyp, w, r)
        expected = np.where(hyp >= 0, r[np.maximum(hyp, 0)], 0.0)
        np.testing.assert_array_equal(rows, expected)
        np.testing.assert_array_equal(marginal, (w[:, None] * expected).sum(axis=0))
