"""Input checks shared by the filters; every failure raises `FilterError` naming the input.

The checks run at the boundaries (model construction, state construction,
measurements handed to an update), not inside the arithmetic of a step.
"""

from __future__ import annotations

import numpy as np

from nnda.errors import FilterError

#: relative tolerance on |P - P^T| (scaled by the largest |P| entry) for a symmetric covariance
SYMMETRY_RTOL = 1e-9


def as_array(name: str, a: object, shape: tuple[int | None, ...]) -> np.ndarray:
    """``a`` as a float64 array of the given shape (None = any length); raises on mismatch."""
    arr = np.asarray(a, dtype=float)
    if arr.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, arr.shape)):
        want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise FilterError(f"{name}: expected shape {want}, got {arr.shape}")
    return arr


def check_finite(name: str, a: np.ndarray) -> None:
    """Raise if ``a`` holds NaN or infinity; the message gives the first bad index."""
    bad = ~np.isfinite(a)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise FilterError(f"{name}: non-finite value {a[where]} at index {where}")


def check_covariance(name: str, P: np.ndarray) -> None:
    """Raise unless every matrix of the stack ``P`` (..., n, n) is finite, symmetric and positive definite."""
    if P.ndim < 2 or P.shape[-1] != P.shape[-2]:
        raise FilterError(f"{name}: expected square matrices (..., n, n), got shape {P.shape}")
    check_finite(name, P)
    if P.size == 0:
        return
    scale = np.abs(P).max(axis=(-2, -1), keepdims=True)
    asym = np.abs(P - np.swapaxes(P, -1, -2)) > SYMMETRY_RTOL * scale
    if asym.any():
        where = tuple(int(i) for i in np.argwhere(asym.any(axis=(-2, -1)))[0])
        raise FilterError(f"{name}: matrix {where} is not symmetric")
    flat = P.reshape(-1, *P.shape[-2:])
    try:
        np.linalg.cholesky(flat)
    except np.linalg.LinAlgError:
        eig_min = np.linalg.eigvalsh(flat).min(axis=-1)
        worst = int(np.argmin(eig_min / np.maximum(scale.reshape(-1), np.finfo(float).tiny)))
        where = tuple(int(i) for i in np.unravel_index(worst, P.shape[:-2]))
        raise FilterError(
            f"{name}: matrix {where} is not positive definite (smallest eigenvalue {eig_min[worst]:.3g})"
        ) from None


def check_nonnegative(name: str, value: float) -> None:
    """Raise unless ``value`` is a finite number >= 0."""
    if not np.isfinite(value) or value < 0:
        raise FilterError(f"{name}: must be a finite number >= 0, got {value}")


def check_positive(name: str, value: float) -> None:
    """Raise unless ``value`` is a finite number > 0."""
    if not np.isfinite(value) or value <= 0:
        raise FilterError(f"{name}: must be a finite number > 0, got {value}")
