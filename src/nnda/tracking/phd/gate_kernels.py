"""The exact gate of the PHD filters' candidate pairs in one compiled pass (`nnda.tracking.phd.gmphd`).

    keep, nu, log_likelihood = gated_pairs(j, i, z, z_pred, S, S_inv, log_det, NONE, gate, every, period)
    keep, nu, log_likelihood = gated_pairs(j, i, z, z_pred, S, S_inv, log_det, contact_R, gate, every, 0.0)

The candidates (j, i) (P,) come from the gate's bounding boxes (`nnda.tracking.box_pairs`). For each pair the
kernel computes the innovation nu = z_i - z_pred_j (its second coordinate wrapped to [-pi, pi) when ``period``
> 0, an azimuth), the squared Mahalanobis distance d^2 and log N(nu; 0, S), and keeps the pairs with d^2 <=
``gate``, in their order (``every``: all of them, the ungated update). Without the contacts' own noise (``NONE``)
it takes each component's S^-1 and ln|S| (the EKF and the unscented transform: the contacts' noise is in S);
with it, it adds each contact's R_i to the component's noise-free S_j (Cartesian fixes converted from a radar)
and inverts S_ji in closed form. Both follow the arithmetic of `nnda.filters.kalman` (`inverse_2x2`, `mahalanobis_2x2`,
`gaussian_log_likelihood`) operation by operation, so the results agree to the last bit on S1-S6 (hashed) and to
1e-9 in the tests. One pass over the pairs replaces a dozen array operations of P values each: at thousands of
contacts a scan, that was most of the filters' update.

Shapes: j, i (P,) int64; z (N, 2); z_pred (J, 2); S_inv, S (J, 2, 2); log_det (J,); contact_R (N, 2, 2).
Returned: keep (K,) the indices of the kept pairs, nu (K, 2), log_likelihood (K,).
"""

from __future__ import annotations

import numba
import numpy as np

from nnda.filters.imm_kernels import LOG_2PI, quadratic_2x2, wrap_angle_kernel

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")  # x / 0 gives inf or NaN, as numpy

#: no contact noise of their own: `gated_pairs` reads each component's S^-1 and ln|S|
NONE = np.empty((0, 2, 2))


@_jit
def gated_pairs(j, i, z, z_pred, S, S_inv, log_det, contact_R, gate, every, period):
    """The candidate pairs (j, i) inside the chi-square ``gate`` (``every``: all of them), module docstring. With
    ``contact_R`` (N, 2, 2), each contact's own noise, S_ji = S_j + R_i, inverted in closed form (``S_inv`` and
    ``log_det`` unread); with an empty one (0, 2, 2), each component's ``S_inv`` and ``log_det`` (``S`` unread).
    ``period`` > 0 wraps the second coordinate's innovation to [-pi, pi)."""
    own = contact_R.shape[0] > 0
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
            n1 = wrap_angle_kernel(n1)
        det = 0.0
        if own:
            s00 = S[c, 0, 0] + contact_R[m, 0, 0]
            s01 = S[c, 0, 1] + contact_R[m, 0, 1]
            s10 = S[c, 1, 0] + contact_R[m, 1, 0]
            s11 = S[c, 1, 1] + contact_R[m, 1, 1]
            det = s00 * s11 - s01 * s10
            d2 = quadratic_2x2(s11 / det, -s01 / det, -s10 / det, s00 / det, n0, n1)
        else:
            d2 = quadratic_2x2(S_inv[c, 0, 0], S_inv[c, 0, 1], S_inv[c, 1, 0], S_inv[c, 1, 1], n0, n1)
        if every or d2 <= gate:
            keep[k] = p
            nu[k, 0], nu[k, 1] = n0, n1
            ll[k] = -0.5 * (d2 + (np.log(det) if own else log_det[c])) - LOG_2PI
            k += 1
    return keep[:k], nu[:k], ll[:k]
