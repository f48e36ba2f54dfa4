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

Systematic and stratified resampling count the points below each
cumulative weight in O(N) and repeat the indices (no search). Multinomial
and residual resampling invert the CDF of all rows with one
`numpy.searchsorted` over the rows' cumulative weights laid end to end (row
r offset by r), so there is no Python loop over rows or particles; the
offset costs r * 2^-52 of resolution in row r, far below any weight that
matters for R up to 10^6.
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
    C = np.cumsum(W, axis=1)
    C[:, -1] = 1.0  # rounding must not leave u above the last bin
    if B == 1:
        return np.minimum(np.searchsorted(C[0], u[0], side="right"), N - 1)[None]
    offset = np.arange(B, dtype=float)[:, None]
    C += offset
    idx = np.searchsorted(C.ravel(), (u + offset).ravel(), side="right").reshape(u.shape)
    idx -= np.arange(B)[:, None] * N
    return np.minimum(idx, N - 1)  # r + u can round up to r + 1 for u just below 1


def _ancestors(counts: np.ndarray) -> np.ndarray:
    """Sorted ancestor rows (B, M) from offspring counts (B, N) summing to M in every row."""
    B, N = counts.shape
    flat = np.repeat(np.arange(B * N), counts.ravel()).reshape(B, -1)
    if B > 1:
        flat -= np.arange(B)[:, None] * N
    return flat


def _counts_below(below: np.ndarray, M: int) -> np.ndarray:
    """Offspring counts (B, N) from the number of points below each cumulative weight C_i (B, N), clipped to
    [0, M], the last forced to M (rounding)."""
    np.clip(below, 0, M, out=below)
    below[:, -1] = M
    return np.diff(below, axis=1, prepend=0)


def _rows(W: np.ndarray, M: int) -> tuple[np.ndarray, tuple[int, ...]]:
    """W as a 2-D float array (B, N) and its leading shape; raises on a bad M or an empty weight axis."""
    if M < 1:
        raise FilterError(f"resampling: the number of draws M must be >= 1, got {M}")
    W = np.asarray(W, dtype=float)
    if W.ndim == 0 or W.shape[-1] == 0:
        raise FilterError(f"resampling: weights need a non-empty last axis, got shape {W.shape}")
    return W.reshape(-1, W.shape[-1]), W.shape[:-1]


def _sorted_uniforms(rng: np.random.Generator, B: int, M: int, n: np.ndarray) -> np.ndarray:
    """(B, M) with the first n_b (<= M) entries of row b the sorted values of n_b i.i.d. uniforms on [0, 1)
    (exponential spacings: E_1..E_n / E_n+1 are uniform order statistics); the rest of a row is beyond."""
    E = np.cumsum(rng.standard_exponential((B, M + 1)), axis=1)
    return E[:, :M] / np.take_along_axis(E, n[:, None], axis=1)


def multinomial(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """M i.i.d. draws from each row's categorical distribution W (..., N); sorted uniforms from exponential
    spacings (O(M), no sort)."""
    W2, lead = _rows(W, M)
    u = _sorted_uniforms(rng, W2.shape[0], M, np.full(W2.shape[0], M))
    return _inverse_cdf(W2, u).reshape(*lead, M)


def systematic(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """One uniform U per row: points (j + U) / M, j = 0..M-1. Counted in O(N) (no search): the points below
    C_i number ceil(M C_i - U)."""
    W2, lead = _rows(W, M)
    C = np.cumsum(W2, axis=1)
    below = np.ceil(M * C - rng.random((W2.shape[0], 1))).astype(np.int64)
    return _ancestors(_counts_below(below, M)).reshape(*lead, M)


def stratified(W: np.ndarray, M: int, rng: np.random.Generator) -> np.ndarray:
    """One uniform u_j per stratum: points (j + u_j) / M, j = 0..M-1. Counted in O(N): with t = M C_i and
    f = floor(t), the points below C_i are the f whole strata plus stratum f's if u_f < t - f."""
    W2, lead = _rows(W, M)
    B = W2.shape[0]
    u = rng.random((B, M))
    t = M * np.cumsum(W2, axis=1)
    f = np.floor(t).astype(np.int64)
    np.clip(f, 0, M, out=f)
    partial = np.take_along_axis(u, np.minimum(f, M - 1), axis=1) < t - f
    return _ancestors(_counts_below(f + (partial & (f < M)), M)).reshape(*lead, M)


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
        draws = _inverse_cdf(res, _sorted_uniforms(rng, B, most, rest))
        keep = np.arange(most) < rest[:, None]
        flat = (draws + np.arange(B)[:, None] * N)[keep]
        counts += np.bincount(flat, minlength=B * N).reshape(B, N)
    return _ancestors(counts).reshape(*lead, M)


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
