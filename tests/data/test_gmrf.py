"""The GMRF clutter of seed 003: the exact sampler against the dense covariance, the differential filter,
the positive-definite bound and the pseudo-likelihood estimator."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.tolerances import RTOL

from nnda.data import gmrf
from nnda.errors import ConfigError


def dense_A(shape, beta_h, beta_v):
    """A = I - beta_h (I_L x T_M) - beta_v (T_L x I_M), row-stacked (the oracle)."""
    L, M = shape
    T = lambda n: np.eye(n, k=1) + np.eye(n, k=-1)  # noqa: E731
    return np.eye(L * M) - beta_h * np.kron(np.eye(L), T(M)) - beta_v * np.kron(T(L), np.eye(M))


def test_sampler_covariance_is_sigma2_A_inverse_and_innovations_are_white():
    shape, bh, bv, sc = (4, 5), 0.22, 0.2, 1.7
    V = gmrf.sample(shape, bh, bv, sc, np.random.default_rng(3), (100_000,)).reshape(100_000, -1)
    C = sc**2 * np.linalg.inv(dense_A(shape, bh, bv))
    emp = V.T @ V / V.shape[0]
    sd = np.sqrt(np.diag(C))
    assert np.abs(emp - C).max() / sd.max() ** 2 < 0.03
    assert np.all(np.abs(np.diag(emp) / np.diag(C) - 1) < 0.03)
    eps = gmrf.differential(V.reshape(-1, *shape), bh, bv).reshape(V.shape)
    cross = V.T @ eps / V.shape[0]  # E[V eps^T] = sigma_c^2 I
    assert np.abs(cross - sc**2 * np.eye(cross.shape[0])).max() < 0.03 * sc**2


def test_marginal_variance_matches_the_spec_example():
    """sigma_c^2 = 4, beta = (0.22, 0.2): the marginal pixel variance is larger than sigma_c^2 (spec: 5.31)."""
    C = 4.0 * np.linalg.inv(dense_A((32, 32), 0.22, 0.2))
    assert 5.0 < C[16 * 32 + 16, 16 * 32 + 16] < 5.6


@settings(max_examples=25, deadline=None)
@given(st.integers(2, 7), st.integers(2, 7), st.floats(-0.24, 0.24), st.floats(-0.24, 0.24))
def test_differential_filter_is_A_times_y(L, M, bh, bv):
    Y = np.random.default_rng(L * 10 + M).standard_normal((3, L, M))
    d = gmrf.differential(Y, bh, bv).reshape(3, -1)
    want = Y.reshape(3, -1) @ dense_A((L, M), bh, bv).T
    np.testing.assert_allclose(d, want, rtol=RTOL, atol=RTOL * np.abs(Y).max())


def test_eigenvalues_are_those_of_A():
    shape = (5, 6)
    mu = np.sort(gmrf.eigenvalues(shape, 0.3, -0.1).ravel())
    np.testing.assert_allclose(mu, np.linalg.eigvalsh(dense_A(shape, 0.3, -0.1)), rtol=RTOL, atol=RTOL)
    assert gmrf.smallest_eigenvalue(shape, 0.3, -0.1) == pytest.approx(mu[0], rel=RTOL)


def test_outside_the_positive_definite_region_is_refused_with_the_bound():
    with pytest.raises(ConfigError, match=r"positive-definite region.*< 1"):
        gmrf.check_gmrf(0.3, 0.25, 1.0, (64, 64))
    with pytest.raises(ConfigError, match="sigma_c > 0"):
        gmrf.check_gmrf(0.1, 0.1, 0.0, (8, 8))
    with pytest.raises(ConfigError, match="positive-definite"):
        gmrf.sample((8, 8), 0.4, 0.4, 1.0, np.random.default_rng(0))


def test_pseudo_likelihood_estimate_recovers_the_parameters():
    V = gmrf.sample((128, 128), 0.22, 0.2, 2.0, np.random.default_rng(5), (4,))
    bh, bv, sc = gmrf.estimate(V)
    assert bh.shape == (4,)
    np.testing.assert_allclose(bh, 0.22, atol=0.02)
    np.testing.assert_allclose(bv, 0.2, atol=0.02)
    np.testing.assert_allclose(sc, 2.0, rtol=0.03)


def test_estimate_stays_in_the_positive_definite_region():
    """A frame that is almost constant (neighbour regression near 1/4 each way) is shrunk inside the bound."""
    Y = np.ones((16, 16)) + 0.01 * np.random.default_rng(0).standard_normal((16, 16))
    bh, bv, sc = gmrf.estimate(Y)
    assert gmrf.smallest_eigenvalue((16, 16), float(bh), float(bv)) > 0 and sc > 0
