"""The additive-Gaussian state-space model: densities against scipy, the optimal proposal against a brute-force
Gaussian product and its predictive likelihood against the closed form and the seed's eq. 30."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from nnda.data.reentry import ReentryConfig, simulate
from nnda.errors import FilterError
from nnda.filters.particle.ssm import AdditiveGaussianSSM
from nnda.filters.reentry import reentry_ssm
from tolerances import RTOL, assert_cov, assert_state

LOG_2PI = np.log(2 * np.pi)


@pytest.fixture(scope="module")
def model():
    cfg = ReentryConfig(steps=12, sigma_r=5.0, sigma_eps=0.0005)  # precise: the proposal differs from the prior
    return reentry_ssm(simulate(cfg, 3, 2))


@pytest.fixture(scope="module")
def particles(model):
    return model.sample_initial(6, np.random.default_rng(1))


def test_optimal_proposal_is_the_gaussian_product(model, particles):
    k = 5
    prop = model.optimal_proposal(k, particles)
    Q, Hm = model.Q, model.H
    g = model.transition_mean(k, particles)
    for r in range(model.runs):
        Rk, y = model.cov[r, k - 1], model.y[r, k - 1]
        Sigma = np.linalg.inv(np.linalg.inv(Q) + Hm.T @ np.linalg.inv(Rk) @ Hm)  # (Q^-1 + H^T R^-1 H)^-1
        assert_cov(prop.chol[r] @ prop.chol[r].T, Sigma)
        for j in range(particles.shape[1]):
            m = Sigma @ (np.linalg.solve(Q, g[r, j]) + Hm.T @ np.linalg.solve(Rk, y))
            assert_state(prop.mean[r, j], m, Sigma)
            want = multivariate_normal(Hm @ g[r, j], Hm @ Q @ Hm.T + Rk).logpdf(y)
            assert prop.log_predictive[r, j] == pytest.approx(want, rel=RTOL)
            # eq. 30 of the seed: p(z | s_k-1) = (2 pi)^2 |Sigma|^1/2 C3, C3 = exp(-C2/2) / ((2 pi)^3 |Q|^1/2 |R|^1/2)
            C2 = g[r, j] @ np.linalg.solve(Q, g[r, j]) + y @ np.linalg.solve(Rk, y) - m @ np.linalg.solve(Sigma, m)
            eq30 = (2 * LOG_2PI + 0.5 * np.linalg.slogdet(Sigma)[1] - C2 / 2 - 3 * LOG_2PI
                    - 0.5 * np.linalg.slogdet(Q)[1] - 0.5 * np.linalg.slogdet(Rk)[1])
            assert eq30 == pytest.approx(want, rel=1e-6)  # C2 cancels large terms: rounding of ~1e10 m^2 / Q


def test_densities_against_scipy(model, particles):
    k = 3
    x = model.sample_transition(k, particles, np.random.default_rng(2))
    ll, lt = model.log_likelihood(k, x), model.transition_log_density(k, particles, x)
    g = model.transition_mean(k, particles)
    for r in range(model.runs):
        for j in range(x.shape[1]):
            assert ll[r, j] == pytest.approx(
                multivariate_normal(model.H @ x[r, j], model.cov[r, k - 1]).logpdf(model.y[r, k - 1]), rel=RTOL)
            assert lt[r, j] == pytest.approx(multivariate_normal(g[r, j], model.Q).logpdf(x[r, j]), rel=RTOL)


def test_float32_particles_stay_float32(model):
    x = model.sample_initial(10, np.random.default_rng(0), np.float32)
    assert x.dtype == np.float32
    assert model.sample_transition(1, x, np.random.default_rng(0)).dtype == np.float32
    assert model.optimal_proposal(1, x).mean.dtype == np.float32
    assert model.log_likelihood(1, x).dtype == np.float64


def test_construction_checks(model):
    with pytest.raises(FilterError, match="AdditiveGaussianSSM.cov: .*not positive definite"):
        AdditiveGaussianSSM(model.mean, model.Q, model.H, model.y, -model.cov, model.m0, model.P0)
    with pytest.raises(FilterError, match=r"AdditiveGaussianSSM.y: expected shape \(\*, \*, 2\)"):
        AdditiveGaussianSSM(model.mean, model.Q, model.H, model.y[..., :1], model.cov, model.m0, model.P0)
    with pytest.raises(FilterError, match="AdditiveGaussianSSM.y: non-finite"):
        AdditiveGaussianSSM(model.mean, model.Q, model.H, model.y * np.nan, model.cov, model.m0, model.P0)
