"""The exact gate of the PHD filters' candidate pairs in one compiled pass (`nnda.tracking.phd.gmphd`).

    keep, nu, log_likelihood = shared_gate(j, i, z, z_pred, S_inv, log_det, gate, every, period)
    keep, nu, log_likelihood = per_contact_gate(j, i, z, z_pred, S, contact_R, gate, every)

The candidates (j, i) (P,) come from the gate's bounding boxes (`nnda.tracking.box_pairs`). For each pair the
kernel computes the innovation nu = z_i - z_pred_j (its second coordinate wrapped to [-pi, pi) when ``period``
> 0, an azimuth), the squared Mahalanobis distance d^2 and log N(nu; 0, S), and keeps the pairs with d^2 <=
``gate``, in their order (``every``: all of them, the ungated update). `shared_gate` takes each component's S^-1
and ln|S| (the EKF and the unscented transform: the contacts' noise is in S). `per_contact_gate` adds each
contact's own noise R_i to the component's noise-free S_j (Cartesian fixes converted from a radar) and inverts
S_ji in closed form. Both follow the arithmetic of `nnda.filters.kalman` (`inverse_2x2`, `mahalanobis_2x2`,
`gaussian_log_likelihood`) operation by operation, so the results agree to the last bit on S1-S6 (hashed) and to
1e-9 in the tests. One pass over the pairs replaces a dozen array operations of P values each: at thousands of
contacts a scan, that was most of the filters' update.

Shapes: j, i (P,) int64; z (N, 2); z_pred (J, 2); S_inv, S (J, 2, 2); log_det (J,); contact_R (N, 2, 2).
Returned: keep (K,) the indices of the kept pairs, nu (K, 2), log_likelihood (K,).
"""

from __future__ import annotations

import math

import numba
import numpy as np

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")  # x / 0 gives inf or NaN, as numpy

#: ln(2 pi), as `nnda.filters.kalman.LOG_2PI`
_LOG_2PI = math.log(2.0 * math.pi)


@_jit
def _d2(a00, a01, a10, a11, n0, n1):
    """nu^T A nu for A = [[a00, a01], [a10, a11]], in `kalman.mahalanobis_2x2`'s order of operations."""
    return a00 * n0 * n0 + (a01 + a10) * n0 * n1 + a11 * n1 * n1


@_jit
def shared_gate(j, i, z, z_pred, S_inv, log_det, gate, every, period):
    """The candidate pairs (j, i) inside the chi-square ``gate`` (``every``: all of them) of components with their
    own S^-1 and ln|S| (module docstring); ``period`` > 0 wraps the second coordinate's innovation to [-pi, pi)."""
    P = j.size
    keep = np.empty(P, np.int64)
    nu = np.empty((P, 2))
    ll = np.empty(P)
    k = 0
    for p in range(P):
        c, m = j[p], i[p]
        n0 = z[m, 0] - z_pred[c, 0]
        n1 = z[m, 1] - z_pred[c, 1]
        if period > 0:
            n1 = (n1 + math.pi) % period - math.pi
        d2 = _d2(S_inv[c, 0, 0], S_inv[c, 0, 1], S_inv[c, 1, 0], S_inv[c, 1, 1], n0, n1)
        if every or d2 <= gate:
            keep[k] = p
            nu[k, 0], nu[k, 1] = n0, n1
            ll[k] = -0.5 * (d2 + log_det[c]) - _LOG_2PI
            k += 1
    return keep[:k], nu[:k], ll[:k]


@_jit
def per_contact_gate(j, i, z, z_pred, S, contact_R, gate, every):
    """The candidate pairs (j, i) inside the chi-square ``gate`` (``every``: all of them) when S_ji = S_j + R_i
    (module docstring)."""
    P = j.size
    keep = np.empty(P, np.int64)
    nu = np.empty((P, 2))
    ll = np.empty(P)
    k = 0
    for p in range(P):
        c, m = j[p], i[p]
        s00 = S[c, 0, 0] + contact_R[m, 0, 0]
        s01 = S[c, 0, 1] + contact_R[m, 0, 1]
        s10 = S[c, 1, 0] + contact_R[m, 1, 0]
        s11 = S[c, 1, 1] + contact_R[m, 1, 1]
        det = s00 * s11 - s01 * s10
        n0 = z[m, 0] - z_pred[c, 0]
        n1 = z[m, 1] - z_pred[c, 1]
        d2 = _d2(s11 / det, -s01 / det, -s10 / det, s00 / det, n0, n1)
        if every or d2 <= gate:
            keep[k] = p
            nu[k, 0], nu[k, 1] = n0, n1
            ll[k] = -0.5 * (d2 + np.log(det)) - _LOG_2PI
            k += 1
    return keep[:k], nu[:k], ll[:k]
