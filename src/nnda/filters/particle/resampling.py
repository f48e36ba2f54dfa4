"""Resampling schemes: pure functions (weights, M, rng) -> ancestor indices, chosen by name.

Every scheme takes normalised weights W (..., N) (each row sums to one; any
leading batch shape, e.g. R runs) and returns M ancestor indices per row,
(..., M) int64 in [0, N), sorted within a row. Each is unbiased: the
expected number of copies of particle i is M W_i. Systematic and stratified
resampling also keep every count within one of M W_i (systematic:
floor or ceil of M W_i exactly; stratified: within one), residual
resampling copies floor(M W_i) deterministically and draws the rest
multinomially:

    A = resample("systematic", W, N, rng)   # W (R, N) -> A (R, N)
    x = np.take_along_axis(x, A[..., None], axis=1)

The inverse CDF of all rows is one `numpy.searchsorted` over the rows'
cumulative weights laid end to end (row r offset by r), so there is no
Python loop over rows or particles; the offset costs r * 2^-52 of
resolution in row r, far below any weight that matters for R up to 10^6.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from nnda.errors import FilterError

Resampler = Callable[[np.ndarray, int, np.random.Generator], np.ndarray]


def _inverse_cdf(W: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Indices i with C_{i-1} <= u < C_i of each row, C the rows' cumulative weights; W (B, N), u (B, M) in
    [0, 1), sorted within a row for speed (any order is correct)."""
    B, N = W.shape
    offset = np.arange(B, dtype=float)[:, None]
    C = np.cumsum(W, axis=1)
    C[:, -1] = 1.0  # rounding must not leave u above the last bin
    C += offset
    idx = np.searchsorted(C.ravel(), (u + offset).ravel(), side="right").reshape(u.shape)
    idx -= np.arange(B)[:, None] * N
    return np.minimum(idx, N - 1)  # r + u can round up to r + 1 for u just below 1


def _rows(W: np.ndarray, M: int) -> tuple[np.ndarray, tuple[int, ...]]:
    """W as a 2-D float array (B, N) and its leading shape; raises on a bad M or an empty weight axis."""
    if M < 1:
        raise FilterError(f"resampling: the number of draws M must be >= 1, got {M}")
    W = np.asarray(W, dtype=float)
    if W.ndim == 0 or W.shape[-1] == 0:
        raise FilterError(f"resampling: weights need a non-empty last axis, got shape {W.shape}")
    return W.reshape(-1, W.shape[-1]), W.shape[:-1]


def multinomial(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """M i.i.d. draws from each row's categorical distribution W (..., N); sorted uniforms from exponential
    spacings (O(M), no sort)."""
    W2, lead = _rows(W, M)
    E = np.cumsum(rng.standard_exponential((W2.shape[0], M + 1)), axis=1)
    u = E[:, :-1] / E[:, -1:]
    return _inverse_cdf(W2, u).reshape(*lead, M)


def systematic(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """One uniform per row: points (j + u) / M, j = 0..M-1."""
    W2, lead = _rows(W, M)
    u = (np.arange(M) + rng.random((W2.shape[0], 1))) / M
    return _inverse_cdf(W2, u).reshape(*lead, M)


def stratified(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """One uniform per stratum: points (j + u_j) / M, j = 0..M-1."""
    W2, lead = _rows(W, M)
    u = (np.arange(M) + rng.random((W2.shape[0], M))) / M
    return _inverse_cdf(W2, u).reshape(*lead, M)


def residual(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """floor(M W_i) copies of each particle, the remaining M - sum floor(M W_i) drawn multinomially from the
    residual weights M W_i - floor(M W_i) (normalised)."""
    W2, lead = _rows(W, M)
    B, N = W2.shape
    scaled = M * W2
    counts = np.floor(scaled).astype(np.int64)
    rest = M - counts.sum(axis=1)  # (B,) draws left per row, in [0, N)
    most = int(rest.max())
    if most > 0:
        res = scaled - counts
        total = res.sum(axis=1, keepdims=True)
        res = np.divide(res, total, out=np.full_like(res, 1.0 / N), where=total > 0)
        draws = _inverse_cdf(res, rng.random((B, most)))
        keep = np.arange(most) < rest[:, None]
        flat = (draws + np.arange(B)[:, None] * N)[keep]
        counts += np.bincount(flat, minlength=B * N).reshape(B, N)
    A = np.repeat(np.tile(np.arange(N), B), counts.ravel()).reshape(B, M)
    return A.reshape(*lead, M)


#: the schemes by name
RESAMPLERS: dict[str, Resampler] = {
    "multinomial": multinomial,
    "systematic": systematic,
    "stratified": stratified,
    "residual": residual,
}


def resampler(name: str) -> Resampler:
    """The scheme called ``name``; raises FilterError naming the choices for an unknown one."""
    try:
        return RESAMPLERS[name]
    except KeyError:
        raise FilterError(f"unknown resampling scheme {name!r}; choose one of {', '.join(RESAMPLERS)}") from None


def resample(name: str, W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """Ancestors (..., M) of weights W (..., N) by the scheme called ``name``."""
    return resampler(name)(W, M, rng)
