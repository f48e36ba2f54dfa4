"""Filters of the ballistic re-entry study (Pavlov & Bruno 2003): its particle-filter model and the Gaussian
baselines.

All work on the R runs of a `nnda.data.reentry.ReentryData` at once:

    model = reentry_ssm(data)                    # AdditiveGaussianSSM for nnda.filters.particle.smc.run_smc
    est = ekf(data)                              # est.mean (R, K, 4), est.cov (R, K, 4, 4), est.log_likelihood (R,)
    est = ukf(data, UnscentedTransform())        # unscented prediction through g
    est = converted_kf(data, sigma_w=30.0)       # linear KF: constant velocity + gravity, drag unknown
    est = ekf(data, update=False)                # the prior alone, predicted (no measurement used)

Every baseline starts from N(m0, Sigma0), predicts with the model's g and
Q (EKF: linearised, eq. 4.39 with the Jacobian of g; UKF: sigma points
through g, `nnda.filters.unscented`; converted KF: Phi x + G [0, -g] with
its own process noise, the standard converted-measurement Kalman filter
that knows nothing of drag) and updates linearly with the converted
measurement z_k = H s_k + v_k and its R_k (the paper's eqs. 6-10), so the comparison
with the particle filters is on exactly the data they see. With drag off
and ``sigma_w`` equal to the model's, `converted_kf` is the exact Kalman
filter of the linear-Gaussian model (the particle filters' oracle).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from nnda.data.reentry import (
    GRAVITY,
    H,
    ReentryConfig,
    ReentryData,
    initial_distribution,
    process_noise,
    transition_jacobian,
    transition_matrices,
    transition_mean,
)
from nnda.errors import FilterError
from nnda.filters import kalman
from nnda.filters.particle.ssm import AdditiveGaussianSSM
from nnda.filters.unscented import UnscentedTransform
from nnda.validation import check_nonnegative

Predict = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def reentry_ssm(data: ReentryData) -> AdditiveGaussianSSM:
    """The state-space model of ``data``'s runs: g = `transition_mean`, Q, H and the measured z_k, R_k."""
    cfg = data.config
    m0, P0 = initial_distribution(cfg)
    return AdditiveGaussianSSM(lambda s: transition_mean(s, cfg), process_noise(cfg), H, data.z, data.cov, m0, P0)


@dataclass(frozen=True)
class GaussianEstimates:
    """A Gaussian filter's estimates of R runs: ``mean`` (R, K, 4), ``cov`` (R, K, 4, 4) and the log-likelihood
    of the measurements ``log_likelihood`` (R,) (sum of log N(nu_k; 0, S_k))."""

    mean: np.ndarray
    cov: np.ndarray
    log_likelihood: np.ndarray


def _filter(data: ReentryData, predict: Predict, update: bool = True) -> GaussianEstimates:
    """Run predict / linear update over the steps of every run; ``predict`` maps (x (R, 4), P (R, 4, 4));
    without ``update`` the measurements only enter the log-likelihood (the prior's predictions)."""
    m0, P0 = initial_distribution(data.config)
    R, K = data.z.shape[:2]
    x, P = np.tile(m0, (R, 1)), np.tile(P0, (R, 1, 1))
    mean, cov, ll = np.empty((R, K, 4)), np.empty((R, K, 4, 4)), np.zeros(R)
    Hs = np.broadcast_to(H, (R, 2, 4))
    for k in range(K):
        x, P = predict(x, P)
        PHt = P @ H.T
        mp = kalman.measurement_prediction(x @ H.T, H @ PHt + data.cov[:, k], Hs, PHt)
        nu = data.z[:, k] - mp.z
        ll += kalman.gaussian_log_likelihood(kalman.mahalanobis_2x2(nu, mp.S_inv), mp.log_det_S)
        if update:
            x, P = kalman.correct(x, P, nu, mp)
        mean[:, k], cov[:, k] = x, P
    return GaussianEstimates(mean, cov, ll)


def ekf(data: ReentryData, update: bool = True) -> GaussianEstimates:
    """Extended Kalman filter: x' = g(x), P' = J P J^T + Q with J = dg/ds at x. Without ``update``, the
    prior alone (m0, Sigma0 predicted to every step: the "prior only" reference, what a filter gains over
    ignoring the measurements)."""
    cfg = data.config
    Q = process_noise(cfg)

    def predict(x, P):
        return transition_mean(x, cfg), kalman.propagate_covariance(transition_jacobian(x, cfg), P, Q)

    return _filter(data, predict, update)


def ukf(data: ReentryData, transform: UnscentedTransform = UnscentedTransform()) -> GaussianEstimates:
    """Unscented Kalman filter: the sigma points of (x, P) through g, their weighted mean and covariance + Q."""
    cfg = data.config
    Q = process_noise(cfg)
    _, wm, wc = transform.weights(4)

    def predict(x, P):
        Y = transition_mean(transform.sigma_points(x, P), cfg)  # (R, 9, 4)
        m = np.einsum("s,rsi->ri", wm, Y)
        dY = Y - m[:, None, :]
        return m, kalman.symmetrise(np.einsum("s,rsi,rsj->rij", wc, dY, dY) + Q)

    return _filter(data, predict)


def converted_kf(data: ReentryData, sigma_w: float | None = None) -> GaussianEstimates:
    """Linear Kalman filter with Phi, gravity and Q of intensity ``sigma_w`` (default: the model's), no drag."""
    cfg: ReentryConfig = data.config
    Phi, G = transition_matrices(cfg.dt)
    if sigma_w is not None:
        check_nonnegative("converted_kf.sigma_w", sigma_w, error=FilterError)
        cfg = cfg.model_copy(update={"sigma_w": sigma_w})
    Q = process_noise(cfg)
    gravity = G @ np.array([0.0, -GRAVITY])

    def predict(x, P):
        return x @ Phi.T + gravity, kalman.propagate_covariance(Phi, P, Q)

    return _filter(data, predict)
