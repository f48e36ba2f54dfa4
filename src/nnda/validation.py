"""Array checks shared by every package; a failure raises the caller's error type, naming the input.

Each check takes ``error``, the `nnda.errors.NndaError` subclass of the
calling package (`FilterError` in the filters, `ModelError` in the models),
so a message says what was wrong and the exception says where it came from.
The checks run at the boundaries (model construction, state construction,
measurements handed to an update), not inside the arithmetic of a step.
"""

from __future__ import annotations

import numpy as np

from nnda.errors import NndaError

#: relative tolerance on |P - P^T| (scaled by the largest |P| entry) for a symmetric covariance
SYMMETRY_RTOL = 1e-9


def check_array(name: str, a: object, shape: tuple[int | None, ...], *, error: type[NndaError]) -> np.ndarray:
    """``a`` as a float64 array of the given shape (None = any length); raises on mismatch."""
    arr = np.asarray(a, dtype=float)
    if arr.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, arr.shape)):
        want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise error(f"{name}: expected shape {want}, got {arr.shape}")
    return arr


def check_finite(name: str, a: np.ndarray, *, error: type[NndaError]) -> None:
    """Raise if ``a`` holds NaN or infinity; the message gives the first bad index."""
    bad = ~np.isfinite(a)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise error(f"{name}: non-finite value {a[where]} at index {where}")


def check_covariance(name: str, P: np.ndarray, *, error: type[NndaError]) -> None:
    """Raise unless every matrix of the stack ``P`` (..., n, n) is finite, symmetric and positive definite."""
    if P.ndim < 2 or P.shape[-1] != P.shape[-2]:
        raise error(f"{name}: expected square matrices (..., n, n), got shape {P.shape}")
    check_finite(name, P, error=error)
    if P.size == 0:
        return
    scale = np.abs(P).max(axis=(-2, -1), keepdims=True)
    asym = np.abs(P - np.swapaxes(P, -1, -2)) > SYMMETRY_RTOL * scale
    if asym.any():
        where = tuple(int(i) for i in np.argwhere(asym.any(axis=(-2, -1)))[0])
        raise error(f"{name}: matrix {where} is not symmetric")
    flat = P.reshape(-1, *P.shape[-2:])
    try:
        np.linalg.cholesky(flat)
    except np.linalg.LinAlgError:
        eig_min = np.linalg.eigvalsh(flat).min(axis=-1)
        worst = int(np.argmin(eig_min / np.maximum(scale.reshape(-1), np.finfo(float).tiny)))
        where = tuple(int(i) for i in np.unravel_index(worst, P.shape[:-2]))
        raise error(
            f"{name}: matrix {where} is not positive definite (smallest eigenvalue {eig_min[worst]:.3g})"
        ) from None


def check_nonnegative(name: str, value: float, *, error: type[NndaError]) -> None:
    """Raise unless ``value`` is a finite number >= 0."""
    if not np.isfinite(value) or value < 0:
        raise error(f"{name}: must be a finite number >= 0, got {value}")


def check_positive(name: str, value: float, *, error: type[NndaError]) -> None:
    """Raise unless ``value`` is a finite number > 0."""
    if not np.isfinite(value) or value <= 0:
        raise error(f"{name}: must be a finite number > 0, got {value}")
