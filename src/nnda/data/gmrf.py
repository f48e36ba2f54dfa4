"""Gauss-Markov random field clutter (Bruno, Araújo & Pavlov's eq. 8): the exact sampler, the
differential (whitening) filter and a per-frame parameter estimator.

A first-order GMRF on an L x M frame with zero boundary: every pixel is
beta_h times its left and right neighbours plus beta_v times those above and
below, plus an innovation of variance sigma_c^2 (sigma_c: the innovation
std, not the marginal pixel std, which is larger). Row-stacked, the
precision is Sigma_v^-1 = A / sigma_c^2 with A = I - beta_h (I_L x T_M) -
beta_v (T_L x I_M), T_N the N x N matrix of ones beside the diagonal:

    check_gmrf(0.22, 0.2, 1.0, (L, M))                 # ConfigError outside the positive-definite region
    mu = eigenvalues((L, M), 0.22, 0.2)                # (L, M) eigenvalues of A on the 2-D DST-I basis
    V = sample((L, M), 0.22, 0.2, 1.0, rng, (R, K))    # (R, K, L, M) clutter, Cov = sigma_c^2 A^-1 exactly
    d = differential(Y, beta_h, beta_v)                # (..., L, M) d = A y (zero padding); beta (...,) or scalars
    bh, bv, sc = estimate(Y)                           # (...,) pseudo-likelihood estimates per frame

The sampler is exact: the orthonormal 2-D DST-I S diagonalises A (A = S
diag(mu) S, S = S^T = S^-1), so V = sigma_c S (W / sqrt(mu)) with W i.i.d.
N(0, 1) has covariance sigma_c^2 A^-1. A is positive definite iff its
smallest eigenvalue 1 - 2|beta_v| cos(pi / (L+1)) - 2|beta_h| cos(pi / (M+1))
is positive (for large frames, |beta_h| + |beta_v| < 1/2).

The estimator maximises the pseudo-likelihood (the product of every
pixel's conditional density given its four neighbours, N(beta_h n_h +
beta_v n_v, sigma_c^2) with n_h, n_v the horizontal and vertical neighbour
sums, zero outside the frame): least squares of the pixels on (n_h, n_v),
one 2 x 2 solve per frame, and sigma_c^2 the mean squared residual. An
estimate outside the positive-definite region is shrunk towards zero to
`ESTIMATE_MARGIN` of the bound.
"""

from __future__ import annotations

import numpy as np
import scipy.fft

from nnda.errors import ConfigError, NndaError

#: an estimate outside the positive-definite region is scaled to this fraction of the bound
ESTIMATE_MARGIN = 0.99


def smallest_eigenvalue(shape: tuple[int, int], beta_h: float, beta_v: float) -> float:
    """The smallest eigenvalue of A on an L x M frame (``shape`` (L, M)); A is positive definite iff > 0."""
    L, M = shape
    return 1.0 - 2.0 * abs(beta_v) * np.cos(np.pi / (L + 1)) - 2.0 * abs(beta_h) * np.cos(np.pi / (M + 1))


def check_gmrf(beta_h: float, beta_v: float, sigma_c: float, shape: tuple[int, int],
               error: type[NndaError] = ConfigError, where: str = "GMRF") -> None:
    """Raise ``error`` unless the parameters are finite, sigma_c > 0 and A is positive definite on ``shape``
    (the message gives the bound)."""
    if not all(np.isfinite(v) for v in (beta_h, beta_v, sigma_c)) or sigma_c <= 0:
        raise error(f"{where}: beta_h, beta_v must be finite and sigma_c > 0, got {beta_h}, {beta_v}, {sigma_c}")
    L, M = shape
    if smallest_eigenvalue(shape, beta_h, beta_v) <= 0:
        cv, ch = 2 * np.cos(np.pi / (L + 1)), 2 * np.cos(np.pi / (M + 1))
        raise error(f"{where}: beta_h = {beta_h}, beta_v = {beta_v} are outside the positive-definite region on "
                    f"a {L} x {M} frame: need {cv:.6f} |beta_v| + {ch:.6f} |beta_h| < 1 (about |beta_h| + "
                    f"|beta_v| < 0.5)")


def eigenvalues(shape: tuple[int, int], beta_h: float, beta_v: float) -> np.ndarray:
    """mu_kl = 1 - 2 beta_v cos(k pi / (L+1)) - 2 beta_h cos(l pi / (M+1)), k = 1..L, l = 1..M: (L, M)."""
    L, M = shape
    cr = np.cos(np.arange(1, L + 1) * np.pi / (L + 1))
    cc = np.cos(np.arange(1, M + 1) * np.pi / (M + 1))
    return 1.0 - 2.0 * beta_v * cr[:, None] - 2.0 * beta_h * cc[None, :]


def sample(shape: tuple[int, int], beta_h: float, beta_v: float, sigma_c: float, rng: np.random.Generator,
           size: tuple[int, ...] = ()) -> np.ndarray:
    """Clutter frames (*size, L, M) with covariance sigma_c^2 A^-1 (exact: one 2-D DST-I per frame)."""
    check_gmrf(beta_h, beta_v, sigma_c, shape)
    W = rng.standard_normal((*size, *shape))
    W /= np.sqrt(eigenvalues(shape, beta_h, beta_v))
    return sigma_c * scipy.fft.dstn(W, type=1, axes=(-2, -1), norm="ortho")


def _per_frame(beta: np.ndarray | float) -> np.ndarray:
    """beta (...,) or a scalar as an array broadcasting against frames (..., L, M)."""
    b = np.asarray(beta, dtype=float)
    return b.reshape(b.shape + (1, 1)) if b.ndim else b


def neighbour_sums(Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n_h, n_v) (..., L, M): the sums of each pixel's left + right and upper + lower neighbours (zero
    outside the frame)."""
    nh = np.zeros_like(Y)
    nh[..., :, 1:] += Y[..., :, :-1]
    nh[..., :, :-1] += Y[..., :, 1:]
    nv = np.zeros_like(Y)
    nv[..., 1:, :] += Y[..., :-1, :]
    nv[..., :-1, :] += Y[..., 1:, :]
    return nh, nv


def differential(Y: np.ndarray, beta_h: np.ndarray | float, beta_v: np.ndarray | float) -> np.ndarray:
    """d = A y of frames Y (..., L, M): d(r, j) = Y(r, j) - beta_h [Y(r, j-1) + Y(r, j+1)] - beta_v [Y(r-1, j)
    + Y(r+1, j)], zero outside the frame; beta_h, beta_v scalars or one per frame (...,)."""
    nh, nv = neighbour_sums(Y)
    return Y - _per_frame(beta_h) * nh - _per_frame(beta_v) * nv


def estimate(Y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pseudo-likelihood estimates (beta_h, beta_v, sigma_c), each (...,), of frames Y (..., L, M) (module
    docstring); zero-mean clutter assumed (subtract a known background first)."""
    Y = np.asarray(Y, dtype=float)
    nh, nv = neighbour_sums(Y)
    axes = (-2, -1)
    hh, hv, vv = (nh * nh).sum(axes), (nh * nv).sum(axes), (nv * nv).sum(axes)
    yh, yv = (Y * nh).sum(axes), (Y * nv).sum(axes)
    det = hh * vv - hv * hv
    det = np.where(det > 0, det, np.finfo(float).tiny)
    bh = (vv * yh - hv * yv) / det
    bv = (hh * yv - hv * yh) / det
    L, M = Y.shape[-2:]
    load = 2 * np.abs(bv) * np.cos(np.pi / (L + 1)) + 2 * np.abs(bh) * np.cos(np.pi / (M + 1))
    shrink = np.where(load >= 1, ESTIMATE_MARGIN / np.maximum(load, 1.0), 1.0)
    bh, bv = bh * shrink, bv * shrink
    resid = Y - bh[..., None, None] * nh - bv[..., None, None] * nv
    return bh, bv, np.sqrt((resid**2).mean(axes))
