"""Resampling schemes: unbiased offspring counts (a z-test at a fixed seed), the schemes' count bounds, errors."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.errors import FilterError
from nnda.filters.particle.resampling import RESAMPLERS, resample, resampler

#: uneven weights with a tiny one and two equal ones
WEIGHTS = np.array([0.31, 0.002, 0.15, 0.15, 0.0, 0.088, 0.2, 0.1])
#: the z bound of the unbiasedness test: 5 standard errors for each of 8 particles x 4 schemes
#: (two-sided p ~ 6e-7 per comparison)
Z_BOUND = 5.0


def counts(A: np.ndarray, n: int) -> np.ndarray:
    """Offspring counts (B, n) of ancestor rows A (B, M)."""
    B = A.shape[0]
    return np.bincount((A + np.arange(B)[:, None] * n).ravel(), minlength=B * n).reshape(B, n)


@pytest.mark.parametrize("name", sorted(RESAMPLERS))
@pytest.mark.parametrize("M", [8, 13])
def test_expected_offspring_is_M_times_the_weight(name, M):
    B = 20000  # independent replications, as rows of one batched call
    A = resample(name, np.tile(WEIGHTS, (B, 1)), M, np.random.default_rng(17))
    assert A.shape == (B, M) and A.dtype.kind == "i"
    assert (np.diff(A, axis=1) >= 0).all() and A.min() >= 0 and A.max() < WEIGHTS.size
    c = counts(A, WEIGHTS.size)
    assert (c.sum(axis=1) == M).all()
    assert (c[:, WEIGHTS == 0] == 0).all()
    se = c.std(axis=0, ddof=1) / np.sqrt(B)
    z = np.abs(c.mean(axis=0) - M * WEIGHTS) / np.maximum(se, 1e-12)
    assert (z < Z_BOUND).all(), f"{name}: z = {z.round(2)}"


@pytest.mark.parametrize("name, bound", [("systematic", 1.0), ("stratified", 2.0)])
def test_low_variance_schemes_keep_the_counts_near_M_w(name, bound):
    """Systematic: every count is floor or ceil of M w (|c - M w| < 1). Stratified: a particle's interval
    can touch one more stratum at each end, so |c - M w| < 2 (e.g. M w = 0.5 straddling a stratum border
    gets 2 with probability 1/16)."""
    rng = np.random.default_rng(5)
    W = rng.dirichlet(np.full(50, 0.3), size=2000)
    c = counts(resample(name, W, 50, rng), 50)
    assert (np.abs(c - 50 * W) < bound).all()


def test_residual_keeps_the_deterministic_copies():
    rng = np.random.default_rng(6)
    W = rng.dirichlet(np.ones(30), size=500)
    c = counts(resample("residual", W, 45, rng), 30)
    assert (c >= np.floor(45 * W)).all() and (c.sum(axis=1) == 45).all()


def test_leading_shape_and_a_single_row():
    W = np.full((2, 3, 5), 0.2)
    assert resample("systematic", W, 7, np.random.default_rng(0)).shape == (2, 3, 7)
    np.testing.assert_array_equal(resample("stratified", np.full(4, 0.25), 4, np.random.default_rng(0)), [0, 1, 2, 3])


def test_bad_input():
    with pytest.raises(FilterError, match="unknown resampling scheme 'sytematic'; choose one of multinomial"):
        resampler("sytematic")
    with pytest.raises(FilterError, match="M must be >= 1"):
        resample("multinomial", WEIGHTS, 0, np.random.default_rng(0))
    with pytest.raises(FilterError, match="non-empty last axis"):
        resample("multinomial", np.ones((3, 0)), 2, np.random.default_rng(0))
