"""Two-point initialisation of a CV state from a track's first two position fixes (Vargas Avila 2015,
eqs. 5.26-5.56)."""

from __future__ import annotations

import numpy as np


def two_point(
    p1: np.ndarray, p2: np.ndarray, cov2: np.ndarray, dt: np.ndarray | float
) -> tuple[np.ndarray, np.ndarray]:
    """CV state [x, vx, y, vy] (K, 4) and covariance (K, 4, 4) from two fixes.

    ``p1``, ``p2`` (K, 2) are Cartesian positions (m) at times t1 and t2 =
    t1 + dt (s, scalar or (K,)); ``cov2`` (K, 2, 2) is the covariance of the
    second fix. The state is the second position and the difference velocity
    (eqs. 5.28-5.30); the covariance is the thesis's analytic P(0|0) (eq. 5.54):
    with Sigma = cov2, the position block is Sigma, position-velocity
    Sigma / T and velocity 2 Sigma / T^2 (both fixes taken as having the
    second one's covariance, as the thesis does).
    """
    T = np.asarray(dt, dtype=float)
    if T.ndim:
        T = T[..., None]
    # positions are the even entries of [x, vx, y, vy] (models.POS), velocities the odd ones (VEL)
    x = np.empty((*p2.shape[:-1], 4))
    x[..., 0::2] = p2
    x[..., 1::2] = (p2 - p1) / T
    T = T[..., None]
    P = np.empty((*p2.shape[:-1], 4, 4))
    P[..., 0::2, 0::2] = cov2
    P[..., 0::2, 1::2] = P[..., 1::2, 0::2] = cov2 / T
    P[..., 1::2, 1::2] = 2.0 * cov2 / (T * T)
    return x, P
