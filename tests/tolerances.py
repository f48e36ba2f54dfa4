"""How closely two code paths of the filters must agree (architecture.md, "Habits").

Results of different summation orders (batched against per track, nnda
against filterpy or the spec's loop, one BLAS kernel or SIMD width against
another) agree to about 1e-9 relative, not to the last bit. Relative means:
a covariance entry P_ij within RTOL of sqrt(P_ii P_jj), a state entry within
RTOL of its own size or of its standard deviation, whichever is larger, so
that entries near zero are held to the rounding of the quantities they come
from. Entries whose variance is exactly zero (a smaller model's padding)
must be equal.
"""

from __future__ import annotations

import numpy as np

RTOL = 1e-9


def assert_cov(actual, desired, rtol: float = RTOL) -> None:
    """Covariances (..., n, n): each entry within rtol sqrt(P_ii P_jj) of ``desired``'s."""
    desired = np.asarray(desired)
    sd = np.sqrt(np.diagonal(desired, axis1=-2, axis2=-1))
    bound = rtol * sd[..., :, None] * sd[..., None, :]
    np.testing.assert_array_less(np.abs(actual - desired), bound + 1e-300)


def assert_state(actual, desired, P, rtol: float = RTOL) -> None:
    """States (..., n): entries within rtol max(|desired|, sqrt(P_ii)), P (..., n, n) their covariance."""
    desired = np.asarray(desired)
    sd = np.sqrt(np.diagonal(P, axis1=-2, axis2=-1))
    np.testing.assert_array_less(np.abs(actual - desired), rtol * np.maximum(np.abs(desired), sd) + 1e-300)
