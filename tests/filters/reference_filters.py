"""Single-track references for the filter tests (and the glue that lets filterpy run the same IMM).

Everything here is written per track, matrix by matrix, straight from the
IMM and polar EKF equations as Vargas Avila (2015) writes them, without nnda's batching or
padding. The tests compare nnda's batched filters with these and with
filterpy; benchmarks/bench_filters.py times filterpy's IMMEstimator through
`PolarEKF`.
"""

from __future__ import annotations

import math

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter

from nnda.data.sensor import wrap_angle

SIGMA_R = 30.0
SIGMA_THETA = 3e-3
R_POLAR = np.diag([SIGMA_R**2, SIGMA_THETA**2])  # eq. 5.25
OMEGA_MAX = math.radians(5.0)
P_OMEGA = 0.0076
TPM = np.array([[0.99, 0.01], [0.10, 0.90]])  # eq. 5.61


def cv_F(T: float) -> np.ndarray:
    """Eq. 5.8."""
    return np.array([[1, T, 0, 0], [0, 1, 0, 0], [0, 0, 1, T], [0, 0, 0, 1]], dtype=float)


def cv_Q(T: float, sigma_q: float = 3.5) -> np.ndarray:
    """Eqs. 5.9-5.10: sigma_q^2 Gamma Gamma^T."""
    G = np.array([[T**2 / 2, 0], [T, 0], [0, T**2 / 2], [0, T]])
    return sigma_q**2 * G @ G.T


def ct_f(X: np.ndarray, T: float, omega_max: float = OMEGA_MAX) -> np.ndarray:
    """Eq. 5.17 as printed, with the turn rate limited to omega_max."""
    x, vx, y, vy, w = X
    w = min(max(w, -omega_max), omega_max)
    return np.array([
        x + vx * T - vy * w * T**2 / 2,
        vx - vx * w**2 * T**2 / 2 - vy * w * T,
        y + vy * T + vx * w * T**2 / 2,
        vy - vy * w**2 * T**2 / 2 + vx * w * T,
        w,
    ])


def ct_F(X: np.ndarray, T: float, omega_max: float = OMEGA_MAX) -> np.ndarray:
    """Eq. 5.18 at X (turn rate limited as in ct_f)."""
    _, vx, _, vy, w = X
    w = min(max(w, -omega_max), omega_max)
    return np.array([
        [1, T, 0, -w * T**2 / 2, -vy * T**2 / 2],
        [0, 1 - w**2 * T**2 / 2, 0, -w * T, -vy * T - vx * w * T**2],
        [0, w * T**2 / 2, 1, T, vx * T**2 / 2],
        [0, w * T, 0, 1 - w**2 * T**2 / 2, vx * T - vy * w * T**2],
        [0, 0, 0, 0, 1],
    ])


def ct_Q(T: float, sigma_q: float = 5.0, sigma_w: float = 0.044, printed: bool = False) -> np.ndarray:
    """Gamma_CT diag(sq^2, sq^2, sw^2) Gamma_CT^T (eq. 5.14), or eq. 5.15 as printed."""
    if printed:
        q, w = sigma_q**2, sigma_w**2
        return np.array([
            [T**4 / 4 * q, T**3 / 2 * q, 0, 0, 0],
            [T**3 / 2 * q, T**2 / 2 * q, 0, 0, 0],
            [0, 0, T**4 / 4 * q, T**3 / 2 * q, 0],
            [0, 0, T**3 / 2 * q, T**2 / 2 * q, 0],
            [0, 0, 0, 0, T**2 / 2 * w],
        ])
    G = np.array([[T**2 / 2, 0, 0], [T, 0, 0], [0, T**2 / 2, 0], [0, T, 0], [0, 0, T]])
    return G @ np.diag([sigma_q**2, sigma_q**2, sigma_w**2]) @ G.T


def polar_h(X: np.ndarray) -> np.ndarray:
    """Eqs. 5.21-5.22 with atan2(x, y)."""
    return np.array([math.hypot(X[0], X[2]), math.atan2(X[0], X[2])])


def polar_H(X: np.ndarray) -> np.ndarray:
    """Eqs. 5.23-5.24, as many columns as X has entries."""
    x, y = X[0], X[2]
    r2 = x * x + y * y
    r = math.sqrt(r2)
    H = np.zeros((2, len(X)))
    H[0, 0], H[0, 2] = x / r, y / r
    H[1, 0], H[1, 2] = y / r2, -x / r2
    return H


def polar_residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = np.asarray(a, dtype=float) - b
    return np.array([d[0], float(wrap_angle(d[1]))])


def two_point(z1: np.ndarray, z2: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """Eqs. 5.26-5.31 and 5.44-5.54 with the math angle phi = 90 deg - theta."""
    phi1, phi2 = math.pi / 2 - z1[1], math.pi / 2 - z2[1]
    x1, y1 = z1[0] * math.cos(phi1), z1[0] * math.sin(phi1)
    x2, y2 = z2[0] * math.cos(phi2), z2[0] * math.sin(phi2)
    d, c, s = z2[0], math.cos(phi2), math.sin(phi2)
    sx = SIGMA_R**2 * c**2 + SIGMA_THETA**2 * d**2 * s**2
    sy = SIGMA_R**2 * s**2 + SIGMA_THETA**2 * d**2 * c**2
    sxy = (SIGMA_R**2 - SIGMA_THETA**2 * d**2) * c * s
    P = np.array([
        [sx, sx / T, sxy, sxy / T],
        [sx / T, 2 * sx / T**2, sxy / T, 2 * sxy / T**2],
        [sxy, sxy / T, sy, sy / T],
        [sxy / T, 2 * sxy / T**2, sy / T, 2 * sy / T**2],
    ])
    return np.array([x2, (x2 - x1) / T, y2, (y2 - y1) / T]), P


def gauss_loglik(nu: np.ndarray, S: np.ndarray) -> float:
    return float(-0.5 * (nu @ np.linalg.solve(S, nu) + math.log(np.linalg.det(S))) - math.log(2 * math.pi))


class LoopIMM:
    """The CV (4-D) / CT (5-D) IMM of Vargas Avila (2015) for one track, every step written out.

    CV is extended with omega = 0 and variance ``aug_var`` for mixing; the
    mixed CV state drops the omega row and column. ``update(None)`` is a
    missed scan: the per-model predictions and predicted mode
    probabilities are kept.
    """

    def __init__(self, x_cv, P_cv, aug_var=0.0, sq_cv=3.5, sq_ct=5.0, sw=0.044, mu=(0.5, 0.5)):
        self.x = [np.array(x_cv, float), np.append(x_cv, 0.0)]
        P_ct = np.zeros((5, 5))
        P_ct[:4, :4] = P_cv
        P_ct[4, 4] = P_OMEGA
        self.P = [np.array(P_cv, float), P_ct]
        self.mu = np.array(mu, float)
        self.aug_var, self.sq_cv, self.sq_ct, self.sw = aug_var, sq_cv, sq_ct, sw

    def predict(self, T: float) -> None:
        c = self.mu @ TPM
        w = TPM * self.mu[:, None] / c[None, :]  # w[i, j] = mu_{i|j}
        x5 = [np.append(self.x[0], 0.0), self.x[1]]
        P5 = [np.zeros((5, 5)), self.P[1]]
        P5[0][:4, :4] = self.P[0]
        P5[0][4, 4] = self.aug_var
        new_x, new_P = [], []
        for j in range(2):
            x0 = sum(w[i, j] * x5[i] for i in range(2))
            P0 = sum(w[i, j] * (P5[i] + np.outer(x5[i] - x0, x5[i] - x0)) for i in range(2))
            if j == 0:
                x0, P0 = x0[:4], P0[:4, :4]
                F = cv_F(T)
                new_x.append(F @ x0)
                new_P.append(F @ P0 @ F.T + cv_Q(T, self.sq_cv))
            else:
                F = ct_F(x0, T)
                new_x.append(ct_f(x0, T))
                new_P.append(F @ P0 @ F.T + ct_Q(T, self.sq_ct, self.sw))
        self.x, self.P, self.mu = new_x, new_P, c

    def measurement(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """Predicted measurement and innovation covariance of model j."""
        H = polar_H(self.x[j])
        return polar_h(self.x[j]), H @ self.P[j] @ H.T + R_POLAR

    def update(self, z) -> None:
        if z is None:
            return
        lik = np.empty(2)
        for j in range(2):
            zhat, S = self.measurement(j)
            H = polar_H(self.x[j])
            nu = polar_residual(z, zhat)
            K = self.P[j] @ H.T @ np.linalg.inv(S)
            self.x[j] = self.x[j] + K @ nu
            self.P[j] = (np.eye(len(self.x[j])) - K @ H) @ self.P[j]
            lik[j] = math.exp(gauss_loglik(nu, S))
        self.mu = self.mu * lik / (self.mu @ lik)

    def combined(self) -> tuple[np.ndarray, np.ndarray]:
        """Eqs. 4.54-4.55 on [x, vx, y, vy]."""
        xs = [self.x[0], self.x[1][:4]]
        Ps = [self.P[0], self.P[1][:4, :4]]
        x = sum(m * xi for m, xi in zip(self.mu, xs))
        P = sum(m * (Pi + np.outer(xi - x, xi - x)) for m, xi, Pi in zip(self.mu, xs, Ps))
        return x, P


class PolarEKF(ExtendedKalmanFilter):
    """filterpy EKF with the spec's polar measurement and a CV or CT motion model, for IMMEstimator.

    IMMEstimator calls ``predict()`` and ``update(z)`` without arguments; the
    interval is the attribute ``dt``. ``model="cv5"`` is CV written in the
    CT state [x, vx, y, vy, omega] with omega forced to 0 and no omega noise,
    which is how filterpy (equal state sizes only) runs the spec's CV/CT IMM
    with augmentation variance 0.
    """

    def __init__(self, model: str, x: np.ndarray, P: np.ndarray, sigma_q: float, sigma_w: float = 0.044):
        super().__init__(dim_x=len(x), dim_z=2)
        self.model, self.sigma_q, self.sigma_w = model, sigma_q, sigma_w
        self.x, self.P, self.R = np.array(x, float), np.array(P, float), R_POLAR.copy()
        self.dt = 2.0

    def predict(self, u=0) -> None:
        T = self.dt
        if self.model == "ct":
            self.F = ct_F(self.x, T)
            self.Q = ct_Q(T, self.sigma_q, self.sigma_w)
            self.x = ct_f(self.x, T)
        else:
            F = cv_F(T)
            Q = cv_Q(T, self.sigma_q)
            if self.model == "cv5":
                F = np.pad(F, ((0, 1), (0, 1)))
                Q = np.pad(Q, ((0, 1), (0, 1)))
            self.F, self.Q = F, Q
            self.x = F @ self.x
        self.P = self.F @ self.P @ self.F.T + self.Q
        self.x_prior, self.P_prior = self.x.copy(), self.P.copy()

    def update(self, z, *_args, **_kw) -> None:
        super().update(np.asarray(z, float), polar_H, polar_h, residual=polar_residual)
