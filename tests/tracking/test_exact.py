"""The compiled replicas of numpy's float reductions (`nnda.tracking.exact`) give numpy's bits."""

from __future__ import annotations

import numpy as np

from nnda.tracking.exact import add_reduce, logaddexp


def test_add_reduce_is_numpys_sum_to_the_bit():
    """Arrays of 0 to 300 terms and a few long ones (numpy's pairwise blocks of 8 and 128 and its halving),
    of magnitudes 1e-5 to 1e5 with some -0.0, and the rows of a C-ordered matrix: np.sum's bits."""
    rng = np.random.default_rng(0)
    for n in [*range(301), 1000, 1023, 1024, 1025, 5000]:
        for _ in range(20):
            a = rng.normal(0.0, 1.0, n) * 10.0 ** rng.integers(-5, 6, n)
            a[rng.random(n) < 0.1] = -0.0
            assert np.float64(add_reduce(a)).tobytes() == np.sum(a).tobytes()
    m = rng.normal(0.0, 1.0, (40, 37)) * 10.0 ** rng.integers(-5, 6, (40, 37))
    np.testing.assert_array_equal([add_reduce(row) for row in m], m.sum(axis=1))


def test_logaddexp_is_numpys_to_the_bit():
    """Random pairs, equal pairs, infinities and NaN: np.logaddexp's bits."""
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.normal(0.0, 30.0, 5000), [0.0, 1.0, -np.inf, np.inf, -np.inf, np.nan, 3.0]])
    y = np.concatenate([rng.normal(0.0, 30.0, 5000), [0.0, 1.0, -np.inf, np.inf, 2.0, 1.0, np.nan]])
    y[:500] = x[:500]
    got = np.array([logaddexp(a, b) for a, b in zip(x, y)])
    with np.errstate(invalid="ignore"):  # inf - inf and the NaNs
        want = np.logaddexp(x, y)
    np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
