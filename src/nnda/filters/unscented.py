"""The scaled unscented transform (Julier 2002; van der Merwe 2004) for K Gaussian states at once.

It gives a measurement prediction of the same shape as the EKF's
(`nnda.filters.kalman.MeasurementPrediction`), so a filter swaps the two
linearisations without changing anything else:

    ut = UnscentedTransform(alpha=1.0, beta=2.0, kappa=0.0)
    X = ut.sigma_points(x, P)                  # (K, 2n+1, n) from x (K, n), P (K, n, n)
    mp = predict_measurement(x, P, radar, ut)  # mp.z (K, 2), mp.S (K, 2, 2), mp.PHt (K, n, 2)
    x_new, P_new = kalman.correct(x, P, nu, mp)  # the ordinary Kalman correction
    x1, P1 = predict(x, P, motion, dt, ut)     # the unscented prediction through a motion model

Sigma points X_0 = x, X_i = x +/- sqrt(n + lambda) L_i (L the Cholesky
factor of P, columns L_i), lambda = alpha^2 (n + kappa) - n; mean weights
W_0 = lambda / (n + lambda), covariance weight W_0 + 1 - alpha^2 + beta,
and 1 / (2 (n + lambda)) for the others. The measurement noise is additive:
S = sum_i Wc_i (Z_i - z)(Z_i - z)^T + R with Z_i = h(X_i), and the cross
covariance C = sum_i Wc_i (X_i - x)(Z_i - z)^T plays P H^T's part. The
``H`` of the prediction is the statistical linearisation C^T P^-1, the
measurement Jacobian a linear model has (there the transform is exact and
equals the EKF). Measurement differences go through the model's
``residual``, so azimuths wrap (the mean is taken around the central
point's prediction).

The defaults (alpha 1, beta 2, kappa 0: lambda = 0, central mean weight 0)
keep every covariance weight non-negative, so S stays positive definite
for any state; a negative central weight (Julier's kappa = 3 - n, or a
small alpha) can make a valid polar covariance indefinite far from the
radar, which `predict_measurement` reports as a FilterError. Frencl
(2014)'s W_0 = 2/3 is kappa = 2 n (alpha 1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnda.errors import FilterError
from nnda.filters.kalman import MeasurementPrediction, measurement_prediction, symmetrise
from nnda.filters.measurement import MeasurementModel
from nnda.filters.motion import MotionModel
from nnda.validation import check_finite, check_positive


@dataclass(frozen=True)
class UnscentedTransform:
    """Scaled sigma-point parameters: spread ``alpha`` (> 0), prior-knowledge ``beta`` (2 for a Gaussian),
    secondary scaling ``kappa`` (n + kappa must be > 0 for the state size n used)."""

    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0

    def __post_init__(self) -> None:
        check_positive("UnscentedTransform.alpha", self.alpha, error=FilterError)
        check_finite("UnscentedTransform.beta", np.asarray(self.beta), error=FilterError)
        check_finite("UnscentedTransform.kappa", np.asarray(self.kappa), error=FilterError)

    def check_dim(self, n: int) -> None:
        """Raise FilterError unless the transform is defined for states of size n (n + kappa > 0)."""
        if not n + self.kappa > 0:
            raise FilterError(f"UnscentedTransform.kappa: n + kappa must be > 0 for states of size {n}, "
                              f"got kappa = {self.kappa}")

    def weights(self, n: int) -> tuple[float, np.ndarray, np.ndarray]:
        """(n + lambda, mean weights (2n+1,), covariance weights (2n+1,)) for states of size n."""
        self.check_dim(n)
        spread = self.alpha**2 * (n + self.kappa)  # n + lambda
        wm = np.full(2 * n + 1, 0.5 / spread)
        wc = wm.copy()
        wm[0] = (spread - n) / spread
        wc[0] = wm[0] + 1.0 - self.alpha**2 + self.beta
        return spread, wm, wc

    def sigma_points(self, x: np.ndarray, P: np.ndarray) -> np.ndarray:
        """Sigma points (K, 2n+1, n) of means x (K, n) and covariances P (K, n, n); raises FilterError
        if a covariance has no Cholesky factor."""
        n = x.shape[-1]
        spread, _, _ = self.weights(n)
        try:
            L = np.linalg.cholesky(P)
        except np.linalg.LinAlgError:
            raise FilterError("unscented transform: a covariance is not positive definite") from None
        offsets = np.sqrt(spread) * L.swapaxes(-1, -2)  # rows = the scaled columns L_i, (K, n, n)
        X = np.empty((*x.shape[:-1], 2 * n + 1, n))
        X[..., 0, :] = x
        X[..., 1:n + 1, :] = x[..., None, :] + offsets
        X[..., n + 1:, :] = x[..., None, :] - offsets
        return X


def predict_measurement(x: np.ndarray, P: np.ndarray, measurement: MeasurementModel,
                        transform: UnscentedTransform = UnscentedTransform()) -> MeasurementPrediction:
    """Unscented measurement prediction of K states x (K, n), P (K, n, n) under ``measurement``.

    Returns z (K, 2), S (K, 2, 2) with R added, its inverse and log det,
    H = C^T P^-1 (K, 2, n) and the cross covariance C (K, n, 2) in ``PHt``;
    raises FilterError if an S is not positive definite.
    """
    n = x.shape[-1]
    _, wm, wc = transform.weights(n)
    X = transform.sigma_points(x, P)
    Z, _ = measurement.predict(X)  # (K, 2n+1, 2)
    z = Z[..., 0, :] + np.einsum("s,ksi->ki", wm, measurement.residual(Z, Z[..., :1, :]))
    dZ = measurement.residual(Z, z[..., None, :])
    S = np.einsum("s,ksi,ksj->kij", wc, dZ, dZ)
    S += measurement.R
    C = np.einsum("s,ksi,ksj->kij", wc, X - x[..., None, :], dZ)
    H = np.linalg.solve(P, C).swapaxes(-1, -2)  # P symmetric: (P^-1 C)^T = C^T P^-1
    return measurement_prediction(z, S, H, C)


def predict(x: np.ndarray, P: np.ndarray, motion: MotionModel, dt: np.ndarray | float,
            transform: UnscentedTransform = UnscentedTransform()) -> tuple[np.ndarray, np.ndarray]:
    """Unscented prediction of K states x (K, n), P (K, n, n) over ``dt`` s (a number or (K,)): the sigma
    points through ``motion.transition`` (its Jacobian unused), mean sum_i Wm_i f(X_i), covariance
    sum_i Wc_i (f(X_i) - m)(f(X_i) - m)^T + Q (additive noise, symmetrised). Exact, as the EKF, for a
    linear model."""
    n = x.shape[-1]
    _, wm, wc = transform.weights(n)
    dt = np.asarray(dt, dtype=float)
    X = transform.sigma_points(x, P)
    fX, _ = motion.transition(X, dt[..., None] if dt.ndim else dt)
    m = np.einsum("s,ksi->ki", wm, fX)
    d = fX - m[..., None, :]
    Q = motion.noise(dt)
    return m, symmetrise(np.einsum("s,ksi,ksj->kij", wc, d, d) + Q)
