"""The statistics leaf against independent oracles: scipy's distributions, brute-force sums and loops."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import beta, binom, hypergeom, t

from nnda.study.stats import (
    bootstrap_indices,
    clopper_pearson,
    fisher_p,
    mean_ci,
    percentile_interval,
    root_mean_square,
    sign_test_p,
)
from tolerances import RTOL


def test_mean_ci_is_the_t_interval_without_undefined_values_and_clipped():
    values = [1.0, None, 2.5, float("nan"), 3.0, 0.5]
    got = mean_ci(values, 0.9)
    x = np.array([1.0, 2.5, 3.0, 0.5])
    low, high = t.interval(0.9, 3, loc=x.mean(), scale=x.std(ddof=1) / 2)
    assert got["n"] == 4 and got["mean"] == pytest.approx(x.mean(), rel=RTOL)
    assert (got["ci_low"], got["ci_high"]) == pytest.approx((low, high), rel=RTOL)
    assert mean_ci(values, 0.9, low=1.0)["ci_low"] == 1.0
    assert mean_ci([2.0]) == {"mean": 2.0, "ci_low": None, "ci_high": None, "n": 1}
    assert mean_ci([None])["mean"] is None


def test_clopper_pearson_is_the_beta_quantile_interval():
    for count, n in ((0, 10), (3, 100), (10, 10), (7, 20)):
        low, high = clopper_pearson(count, n, 0.95)
        want_low = 0.0 if count == 0 else beta.ppf(0.025, count, n - count + 1)
        want_high = 1.0 if count == n else beta.ppf(0.975, count + 1, n - count)
        assert (low, high) == pytest.approx((want_low, want_high), rel=1e-6, abs=1e-12)


def test_fisher_p_sums_the_tables_no_more_likely_than_the_observed_one():
    a, b = (3, 20), (11, 25)
    total = a[0] + b[0]
    pmf = hypergeom(a[1] + b[1], total, a[1]).pmf
    observed = pmf(a[0])
    want = sum(pmf(k) for k in range(max(0, total - b[1]), min(total, a[1]) + 1) if pmf(k) <= observed * (1 + 1e-7))
    assert fisher_p(a, b) == pytest.approx(want, rel=1e-6)


def test_sign_test_leaves_ties_out():
    d = np.array([1.0, 2.0, -1.0, 0.0, 3.0, 0.0, 4.0])
    positive, n = 4, 5  # two ties left out
    want = min(1.0, 2 * min(binom.cdf(positive, n, 0.5), binom.sf(positive - 1, n, 0.5)))
    assert sign_test_p(d) == pytest.approx(want, rel=1e-9)
    assert sign_test_p(np.zeros(4)) == 1.0


def test_root_mean_square_by_loops():
    rng = np.random.default_rng(1)
    sq = rng.uniform(0, 4, (5, 3))
    counts = rng.integers(0, 3, (5, 3))
    counts[:, 1] = 0
    got = root_mean_square(sq, counts, axis=0)
    for j in range(3):
        c = counts[:, j].sum()
        want = math.sqrt(sq[:, j].sum() / c) if c else math.nan
        assert got[j] == pytest.approx(want, rel=RTOL, nan_ok=True)
    assert root_mean_square(sq) == pytest.approx(math.sqrt(sq.mean()), rel=RTOL)
    np.testing.assert_allclose(root_mean_square(sq, axis=1), np.sqrt(sq.mean(axis=1)), rtol=RTOL)


def test_bootstrap_indices_are_seeded_draws_and_the_percentile_interval_brackets():
    a, b = bootstrap_indices([3, 1], 7, 50), bootstrap_indices([3, 1], 7, 50)
    np.testing.assert_array_equal(a, b)
    assert a.shape == (50, 7) and a.min() >= 0 and a.max() <= 6
    samples = np.arange(1001.0)
    assert percentile_interval(samples, 0.9) == pytest.approx((50.0, 950.0))
    assert percentile_interval(samples, 0.5) == pytest.approx((250.0, 750.0))


def test_clip_interval_cuts_a_saved_record_to_the_measures_range_and_keeps_the_rest():
    from nnda.study.stats import clip_interval

    record = mean_ci([0.1, 6.0], 0.95)                  # two runs: the t-interval reaches far below 0
    assert record["ci_low"] < 0
    cut = clip_interval(record, 0.0)
    assert cut["ci_low"] == 0.0 and cut["ci_high"] == record["ci_high"] and cut["mean"] == record["mean"]
    assert record["ci_low"] < 0                          # a copy: the saved record is untouched
    assert clip_interval({"mean": 0.5, "ci_low": -0.2, "ci_high": 1.3, "n": 3}, 0.0, 1.0) == \
        {"mean": 0.5, "ci_low": 0.0, "ci_high": 1.0, "n": 3}
    assert clip_interval({"mean": 2.0, "ci_low": None, "ci_high": None, "n": 1}, 0.0) == \
        {"mean": 2.0, "ci_low": None, "ci_high": None, "n": 1}
    assert clip_interval(None, 0.0) is None
    assert clip_interval(record, 0.0) == mean_ci([0.1, 6.0], 0.95, low=0.0)   # the same cut mean_ci makes
