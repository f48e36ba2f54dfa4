"""State-space models for the particle filters, kept apart from the algorithms (`nnda.filters.particle.smc`).

A model holds R runs' observations y_1..y_K and answers, for particles x
(R, N, d) of every run at once, at step k = 1..K:

    x0 = model.sample_initial(N, rng, dtype)         # (R, N, d) from p(x_0)
    x1 = model.sample_transition(k, x0, rng)         # (R, N, d) from p(x_k | x_k-1)
    model.transition_log_density(k, x0, x1)          # (R, N) log p(x_k | x_k-1)
    model.log_likelihood(k, x1)                      # (R, N) log p(y_k | x_k)
    model.transition_mean(k, x0)                     # (R, N, d) E[x_k | x_k-1] (auxiliary look-ahead, moves)
    prop = model.optimal_proposal(k, x0)             # optional: p(x_k | x_k-1, y_k) and log p(y_k | x_k-1)
    prop.mean (R, N, d), prop.chol (R, d, d), prop.log_predictive (R, N)
    model.move(k, x1, rng)                           # optional: (R, N, d) a symmetric MH proposal (resample-move)
    model.estimate(W, x1)                            # optional: (R, e) the summary of weights W (R, N)

`AdditiveGaussianSSM` is the family of Pavlov & Bruno (2003) (and of the
linear-Gaussian check): x_k = g(x_k-1) + w_k, w_k ~ N(0, Q); y_k = H x_k +
v_k, v_k ~ N(0, R_k) with a known per-run, per-step R_k. Its optimal
proposal is one Kalman step per particle (their eqs. 16-22): S_k = H Q H^T + R_k,
K_k = Q H^T S_k^-1, Sigma_k = Q - K_k S_k K_k^T (= (Q^-1 + H^T R_k^-1
H)^-1), m^(j) = g^(j) + K_k (y_k - H g^(j)) and the predictive likelihood
p(y_k | x_k-1^(j)) = N(y_k; H g^(j), S_k); Sigma_k is shared by every
particle of a run, so there is one Cholesky factor per run and step.
Log-densities are float64 whatever the particles' dtype.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Protocol

import numpy as np

from nnda.errors import FilterError
from nnda.validation import check_array, check_covariance, check_finite

LOG_2PI = float(np.log(2.0 * np.pi))


@dataclass(frozen=True)
class GaussianProposal:
    """A Gaussian proposal per particle: ``mean`` (R, N, d), one lower Cholesky factor per run ``chol``
    (R, d, d) of the shared covariance, and ``log_predictive`` (R, N) log p(y_k | x_k-1) (the weight)."""

    mean: np.ndarray
    chol: np.ndarray
    log_predictive: np.ndarray


class StateSpaceModel(Protocol):
    """What the particle filters need of a model bound to R runs' observations of K steps (module docstring).

    ``optimal_proposal`` is optional (the "optimal" algorithm needs it), and
    so are ``move(k, x, rng) -> x'`` (resample-move's symmetric MH proposal
    in place of the Gaussian random walk) and ``estimate(W, x) -> (R, e)``
    (the filter's summary in place of the weighted mean); steps k run from 1
    to ``steps``.
    """

    dim: int
    runs: int
    steps: int

    def sample_initial(self, n: int, rng: np.random.Generator, dtype: type = np.float64) -> np.ndarray: ...

    def sample_transition(self, k: int, x: np.ndarray, rng: np.random.Generator) -> np.ndarray: ...

    def transition_mean(self, k: int, x: np.ndarray) -> np.ndarray: ...

    def transition_log_density(self, k: int, x_prev: np.ndarray, x: np.ndarray) -> np.ndarray: ...

    def log_likelihood(self, k: int, x: np.ndarray) -> np.ndarray: ...


def right(a: np.ndarray, dtype: np.dtype | type) -> np.ndarray:
    """``a`` as a C-contiguous array of ``dtype``: the right operand of a particles-times-small-matrix product
    (numpy's matmul takes a slow path for a transposed or otherwise strided small matrix)."""
    return np.ascontiguousarray(a, dtype=dtype)


def gaussian_log_density(e: np.ndarray, inv_chol_t: np.ndarray, log_det: np.ndarray | float) -> np.ndarray:
    """log N(e; 0, C) (R, N) of residuals e (R, N, m) given L^-T (R, m, m) or (m, m), L the Cholesky factor
    of C, and log |C| broadcasting against (R, N) ((R, 1) or a scalar); float64."""
    white = e @ right(inv_chol_t, e.dtype)
    d2 = np.einsum("...i,...i->...", white, white, dtype=np.float64)
    return -0.5 * (d2 + log_det + e.shape[-1] * LOG_2PI)


def _inv_chol_t(C: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray]:
    """(L^-T, log |C|) of stacked covariances C (..., m, m); FilterError if one is not positive definite."""
    try:
        L = np.linalg.cholesky(C)
    except np.linalg.LinAlgError:
        raise FilterError(f"{what}: a covariance is not positive definite") from None
    eye = np.broadcast_to(np.eye(C.shape[-1]), C.shape)
    inv_t = np.linalg.solve(L, eye).swapaxes(-1, -2)
    return inv_t, 2.0 * np.log(np.diagonal(L, axis1=-2, axis2=-1)).sum(axis=-1)


@dataclass(frozen=True)
class AdditiveGaussianSSM:
    """x_k = g(x_k-1) + w_k, w_k ~ N(0, Q); y_k = H x_k + v_k, v_k ~ N(0, R_k); x_0 ~ N(m0, P0).

    ``mean`` is g, mapping (..., d) to (..., d) in the input's dtype; ``Q``
    (d, d); ``H`` (m, d); ``y`` (R, K, m) the observations of steps 1..K and
    ``cov`` (R, K, m, m) their R_k; ``m0`` (d,), ``P0`` (d, d). Checked on
    construction (shapes, finite values, positive definite covariances).
    """

    mean: Callable[[np.ndarray], np.ndarray]
    Q: np.ndarray
    H: np.ndarray
    y: np.ndarray
    cov: np.ndarray
    m0: np.ndarray
    P0: np.ndarray

    def __post_init__(self) -> None:
        Q = check_array("AdditiveGaussianSSM.Q", self.Q, (None, None), error=FilterError)
        d = Q.shape[0]
        H = check_array("AdditiveGaussianSSM.H", self.H, (None, d), error=FilterError)
        m = H.shape[0]
        y = check_array("AdditiveGaussianSSM.y", self.y, (None, None, m), error=FilterError)
        cov = check_array("AdditiveGaussianSSM.cov", self.cov, (*y.shape, m), error=FilterError)
        m0 = check_array("AdditiveGaussianSSM.m0", self.m0, (d,), error=FilterError)
        P0 = check_array("AdditiveGaussianSSM.P0", self.P0, (d, d), error=FilterError)
        for name, a in (("H", H), ("y", y), ("m0", m0)):
            check_finite(f"AdditiveGaussianSSM.{name}", a, error=FilterError)
        for name, a in (("Q", Q), ("cov", cov), ("P0", P0)):
            check_covariance(f"AdditiveGaussianSSM.{name}", a, error=FilterError)
        if y.shape[0] < 1 or y.shape[1] < 1:
            raise FilterError(f"AdditiveGaussianSSM.y: need at least one run and one step, got shape {y.shape}")
        for name, a in (("Q", Q), ("H", H), ("y", y), ("cov", cov), ("m0", m0), ("P0", P0)):
            object.__setattr__(self, name, a)

    @property
    def dim(self) -> int:
        return self.Q.shape[0]

    @property
    def runs(self) -> int:
        return self.y.shape[0]

    @property
    def steps(self) -> int:
        return self.y.shape[1]

    @cached_property
    def _chol_Q(self) -> np.ndarray:
        return np.linalg.cholesky(self.Q)

    @cached_property
    def _Q_white(self) -> tuple[np.ndarray, np.ndarray]:
        return _inv_chol_t(self.Q, "AdditiveGaussianSSM.Q")

    @cached_property
    def _R_white(self) -> tuple[np.ndarray, np.ndarray]:
        """(L^-T (R, K, m, m), log |R_k| (R, K)) of every R_k."""
        return _inv_chol_t(self.cov, "AdditiveGaussianSSM.cov")

    @cached_property
    def _proposal_terms(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per run and step: gain K_k^T (R, K, m, d), chol Sigma_k (R, K, d, d), S_k's L^-T and log |S_k|."""
        Q, H = self.Q, self.H
        QHt = Q @ H.T
        S = H @ QHt + self.cov
        S_inv_t, log_det_S = _inv_chol_t(S, "optimal proposal: H Q H^T + R_k")
        S_inv = S_inv_t @ S_inv_t.swapaxes(-1, -2)  # L^-T L^-1 = S^-1
        gain = QHt @ S_inv  # (R, K, d, m)
        Sigma = Q - gain @ S @ gain.swapaxes(-1, -2)
        Sigma = 0.5 * (Sigma + Sigma.swapaxes(-1, -2))
        try:
            chol = np.linalg.cholesky(Sigma)
        except np.linalg.LinAlgError:
            raise FilterError("optimal proposal: Sigma_k is not positive definite") from None
        return gain.swapaxes(-1, -2), chol, S_inv_t, log_det_S

    def sample_initial(self, n: int, rng: np.random.Generator, dtype: type = np.float64) -> np.ndarray:
        """n particles per run from N(m0, P0), (R, n, d) of ``dtype``."""
        L = np.linalg.cholesky(self.P0)
        noise = rng.standard_normal((self.runs, n, self.dim), dtype=dtype)
        return self.m0.astype(dtype) + noise @ right(L.T, dtype)

    def transition_mean(self, k: int, x: np.ndarray) -> np.ndarray:
        """g(x) (R, N, d)."""
        return self.mean(x)

    def sample_transition(self, k: int, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """g(x) + w, w ~ N(0, Q), (R, N, d) in the dtype of x."""
        out = self.mean(x)
        out += rng.standard_normal(x.shape, dtype=x.dtype) @ right(self._chol_Q.T, x.dtype)
        return out

    def transition_log_density(self, k: int, x_prev: np.ndarray, x: np.ndarray) -> np.ndarray:
        """log N(x; g(x_prev), Q) (R, N)."""
        inv_t, log_det = self._Q_white
        return gaussian_log_density(x - self.mean(x_prev), inv_t, log_det)

    def log_likelihood(self, k: int, x: np.ndarray) -> np.ndarray:
        """log N(y_k; H x, R_k) (R, N) of particles x (R, N, d)."""
        inv_t, log_det = self._R_white
        e = self.y[:, None, k - 1].astype(x.dtype) - x @ right(self.H.T, x.dtype)
        return gaussian_log_density(e, inv_t[:, k - 1], log_det[:, k - 1, None])

    def optimal_proposal(self, k: int, x_prev: np.ndarray) -> GaussianProposal:
        """p(x_k | x_k-1, y_k) = N(m^(j), Sigma_k) and log p(y_k | x_k-1) for particles x_prev (R, N, d)."""
        gain_t, chol, S_inv_t, log_det_S = self._proposal_terms
        g = self.mean(x_prev)
        nu = self.y[:, None, k - 1].astype(g.dtype) - g @ right(self.H.T, g.dtype)  # (R, N, m)
        mean = g + nu @ right(gain_t[:, k - 1], g.dtype)
        log_predictive = gaussian_log_density(nu, S_inv_t[:, k - 1], log_det_S[:, k - 1, None])
        return GaussianProposal(mean, chol[:, k - 1], log_predictive)
