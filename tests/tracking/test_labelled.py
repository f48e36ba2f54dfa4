"""The compiled passes the labelled trackers share (`nnda.tracking.labelled`), each held to the numpy
formulation it replaced, to the bit."""

from __future__ import annotations

import numpy as np

from nnda.tracking.labelled import _heaviest, merged


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
    first of a lexicographic sort by label, then weight descending (the form it replaced)."""
    rng = np.random.default_rng(1)
    for _ in range(300):
        T, Q = int(rng.integers(1, 30)), int(rng.integers(0, 60))
        owner = np.sort(rng.integers(0, T, Q)) if rng.random() < 0.5 else rng.integers(0, T, Q)
        log_w = rng.normal(0.0, 2.0, T + Q).round(int(rng.integers(0, 3)))  # rounded: ties
        log_w[rng.random(T + Q) < 0.1] = -np.inf
        pair = np.sort(rng.choice(3 * Q + 1, Q, replace=False))  # the kept pairs among all gated
        total, chosen = _heaviest(owner, log_w, pair, T)
        everyone = np.concatenate([np.arange(T), owner])
        want_total = np.full(T, -np.inf)
        np.logaddexp.at(want_total, everyone, log_w)
        child = np.concatenate([np.arange(T), T + pair])
        order = np.lexsort((-log_w, everyone))
        first = np.r_[True, np.diff(everyone[order]) != 0]
        np.testing.assert_array_equal(total, want_total)
        np.testing.assert_array_equal(chosen, child[order[first]])
