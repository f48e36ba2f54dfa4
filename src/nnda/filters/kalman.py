"""Batched (extended) Kalman filter steps (Vargas Avila (2015), eqs. 4.1-4.42).

Every function works on stacks of Gaussian states: means x (..., n) and
covariances P (..., n, n), with any leading batch shape (K tracks, or K
tracks x r models inside the IMM). A linear model is the special case whose
Jacobians are constant, so the same functions run the CV Kalman filter and
the polar / coordinated-turn EKFs.

Measurements are 2-D, so innovation covariances are inverted with the
explicit 2 x 2 formula (cheaper than `numpy.linalg.inv` on small stacks).
The covariance update is P - K S K^T = P - K (P H^T)^T, which equals
(I - K H) P (eq. 4.24 / 4.42) for the optimal gain. Predicted and updated
covariances are symmetrised, innovation covariances made exactly symmetric.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nnda.errors import FilterError
from nnda.filters.batch import Batch
from nnda.filters.measurement import MeasurementModel
from nnda.filters.motion import MotionModel

LOG_2PI = float(np.log(2.0 * np.pi))

#: chi-square gate on a 2-D innovation with P_G = 0.99 (ours: the thesis gives no gate size)
GATE_99 = 9.21


def gate_probability(gate: float) -> float:
    """P_G, the probability that a 2-D innovation falls inside the chi-square ``gate``: 1 - exp(-gate / 2)."""
    return -math.expm1(-gate / 2.0)

#: sign pattern of the 2 x 2 adjugate
_ADJ_SIGN = np.array([[1.0, -1.0], [-1.0, 1.0]])


@dataclass(frozen=True)
class MeasurementPrediction(Batch):
    """Predicted measurement of a stack of states (leading shape (...)).

    ``z`` (..., 2) is h(x) (eq. 4.38), ``S`` (..., 2, 2) the innovation
    covariance H P H^T + R (eq. 4.23), ``S_inv`` its inverse, ``log_det_S``
    (...) log |S|, ``H`` (..., 2, n) the measurement Jacobian (eq. 4.30) and
    ``PHt`` (..., n, 2) the cross covariance P H^T.
    """

    z: np.ndarray
    S: np.ndarray
    S_inv: np.ndarray
    log_det_S: np.ndarray
    H: np.ndarray
    PHt: np.ndarray


def symmetrise(P: np.ndarray) -> np.ndarray:
    """(P + P^T) / 2 over the last two axes (a new array)."""
    S = P + P.swapaxes(-1, -2)
    S *= 0.5
    return S


def propagate_covariance(F: np.ndarray, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """F P F^T + Q (eq. 4.39), symmetrised, for stacks F, P, Q (..., n, n)."""
    # a contiguous F^T keeps numpy's stacked matmul on its fast path
    P_new = F @ P @ np.ascontiguousarray(F.swapaxes(-1, -2))
    P_new += Q
    return symmetrise(P_new)


def predict(x: np.ndarray, P: np.ndarray, model: MotionModel, dt: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """EKF prediction (eqs. 4.37, 4.39): x' = f(x), P' = F P F^T + Q (symmetrised).

    ``dt`` (s) is a scalar or has the batch shape of ``x`` without its last axis.
    """
    dt = np.asarray(dt, dtype=float)
    fx, F = model.transition(x, dt)
    return fx, propagate_covariance(F, P, model.noise(dt))


def inverse_2x2(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses (..., 2, 2) and determinants (...) of a stack of 2 x 2 matrices."""
    det = S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]
    inv = S[..., ::-1, ::-1].swapaxes(-1, -2) * _ADJ_SIGN  # the adjugate
    inv /= det[..., None, None]
    return inv, det


def predict_measurement(x: np.ndarray, P: np.ndarray, measurement: MeasurementModel) -> MeasurementPrediction:
    """Measurement prediction, Jacobian and innovation covariance of states (..., n).

    Raises FilterError if an innovation covariance is not positive definite
    (for example a state at the radar's position, or a covariance gone bad).
    """
    z, H = measurement.predict(x)
    PHt = P @ H.swapaxes(-1, -2)
    S = H @ PHt
    S += measurement.R
    return measurement_prediction(z, S, H, PHt)


def measurement_prediction(z: np.ndarray, S: np.ndarray, H: np.ndarray, PHt: np.ndarray) -> MeasurementPrediction:
    """The `MeasurementPrediction` of z (..., 2), S (..., 2, 2), H (..., 2, n) and P H^T (..., n, 2).

    S is made exactly symmetric in place and inverted in closed form; raises
    FilterError unless every S is positive definite. Shared by the EKF
    (`predict_measurement`) and the unscented transform (`nnda.filters.unscented`).
    """
    S[..., 1, 0] = S[..., 0, 1]  # equal up to rounding; make S exactly symmetric
    S_inv, det = inverse_2x2(S)
    if not (np.minimum(det, S[..., 0, 0]) > 0).all():
        bad = ~((det > 0) & (S[..., 0, 0] > 0))
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise FilterError(f"innovation covariance at batch index {where} is not positive definite: {S[where].tolist()}")
    return MeasurementPrediction(z, S, S_inv, np.log(det), H, PHt)


def innovation(z: np.ndarray, mp: MeasurementPrediction, measurement: MeasurementModel) -> np.ndarray:
    """Innovations nu = z - h(x) (eq. 4.14), azimuths wrapped; z broadcasts against ``mp.z``."""
    return measurement.residual(z, mp.z)


def correct(x: np.ndarray, P: np.ndarray, nu: np.ndarray, mp: MeasurementPrediction) -> tuple[np.ndarray, np.ndarray]:
    """Kalman correction with innovations nu (..., 2) (eqs. 4.13, 4.22, 4.24 / 4.40-4.42)."""
    gain = mp.PHt @ mp.S_inv
    x_new = x + (gain @ nu[..., None])[..., 0]
    P_new = P - gain @ np.ascontiguousarray(mp.PHt.swapaxes(-1, -2))
    return x_new, symmetrise(P_new)


def update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray, mp: MeasurementPrediction, measurement: MeasurementModel
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Checked EKF update of states (..., n) with measurements z (..., 2).

    Returns the updated means and covariances and the innovations.
    """
    z = np.asarray(z, dtype=float)
    if z.shape[-1:] != (2,):
        raise FilterError(f"z: expected measurements of shape (..., 2), got {z.shape}")
    measurement.validate("z", z)
    nu = innovation(z, mp, measurement)
    return (*correct(x, P, nu, mp), nu)


def mahalanobis_2x2(nu: np.ndarray, S_inv: np.ndarray) -> np.ndarray:
    """Squared Mahalanobis distances nu^T S^-1 nu (eq. 4.51) for nu (..., 2), S_inv (..., 2, 2)."""
    n0, n1 = nu[..., 0], nu[..., 1]
    return S_inv[..., 0, 0] * n0 * n0 + (S_inv[..., 0, 1] + S_inv[..., 1, 0]) * n0 * n1 + S_inv[..., 1, 1] * n1 * n1


def gaussian_log_likelihood(d2: np.ndarray, log_det_S: np.ndarray) -> np.ndarray:
    """log N(nu; 0, S) of 2-D innovations from d2 = nu^T S^-1 nu and log |S| (eq. 4.50)."""
    return -0.5 * (d2 + log_det_S) - LOG_2PI
