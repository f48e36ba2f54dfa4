"""The compiled steps of the IMM cycle over K tracks x r models (`nnda.filters.imm.IMM` calls them).

    xp, Pp, mu_p = mix_predict(x, P, mu, dt, tpm, kinds, dims, omega_max, basis, augment)   # eqs. 4.46-4.49
    z, S, S_inv, log_det, H, PHt, bad = measure(xp2, Pp2, polar, origin, R)              # (B, n) states
    xp, Pp, mu_p, z, S, ..., bad, xc, Pc, zc, Sc, ..., bad_c = predict(x, P, mu, dt, ..., R, d)   # one call:
                                                       # both, and the combined (gating) prediction measured
    x, P, mu = update(xp, Pp, mu_p, z, mask, z_pred, S_inv, log_det, PHt, polar)        # eqs. 4.50-4.53
    x, P, mu = pda_update(x, P, mu, z_pred, S_inv, log_det, PHt, rows, track, Z, beta, beta0, polar)  # JPDA's
    xc, Pc = estimate(x, P, mu, d)                                                     # eqs. 4.54-4.55
    d2 = mahalanobis(z_pred, S_inv, Z, polar)                                           # (B, N) gate distances
    r, c, d2 = gated_pairs(z_pred, S_inv, rows, Z, threshold, polar)                   # (P,) pairs inside a gate
    ll = pair_log_likelihood(z_pred, S_inv, log_det, mu, rows, Z, polar)               # (P,) eqs. 4.50, 4.53
    x, P, mu = start(p1, p2, cov2, dt, x_rest, P_rest, mu0)                            # two-point starts

Shapes: x (K, r, n), P (K, r, n, n) in the IMM's padded layout (model j's
state in its first ``dims[j]`` entries, zeros beyond), mu (K, r), dt (K,) s;
``kinds`` (r,) names each model's transition (`CV` or `CT`, Vargas Avila (2015),
eqs. 5.7-5.18, or `CT_EXACT`, the turn of `exact_turn`; a turn's rate limited to
``omega_max[j]`` rad/s), ``basis`` (4, r, n, n) the process-noise matrices of Q(T) = T B0 + T^2 B1 + T^3 B2 + T^4 B3 and
``augment`` (r, n, n) the variance added to a model's padding before mixing.
The measurement is polar (range m, azimuth rad clockwise from north, from
``origin``; azimuth residuals wrapped to [-pi, pi)) or, with ``polar``
False, the Cartesian position (x, y); R (2, 2) its noise.

Why compiled: at the tracking scale (tens of tracks, two models, n = 5) the
numpy formulation spends its time in per-call overhead, about 60 small calls
per IMM cycle; these loops do the same arithmetic per track in one call.
The formulas and their order are those of the batched numpy version, so the
results agree to rounding (the tests hold them to RTOL against per-track
references); numba compiles without fastmath, and the same inputs give the
same bits on one machine. ``cache=True`` keeps the compiled code on disk
beside this file, so only the first import after an install pays the compile.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from nnda.filters.motion import exact_turn

#: transition kinds of `mix_predict`: nearly constant velocity (dim 4), coordinated turn (dim 5)
CV, CT, CT_EXACT = 0, 1, 2
#: added to probabilities before a division or a log (as `nnda.filters.imm`)
TINY = 1e-300
LOG_2PI = math.log(2.0 * math.pi)
TWO_PI = 2.0 * math.pi

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")  # x / 0 gives inf or NaN, as numpy


def kernel_array(a: np.ndarray | float, dtype: type = np.float64) -> np.ndarray:
    """``a`` as the compiled kernels take every array: of ``dtype``, C-contiguous and writeable. A copy only
    where it is not (a column view, a transpose, a read-only broadcast, another dtype), so that a kernel
    compiles for one signature, whoever calls it; the copy costs O(size), once per call, in the caller's
    Python wrapper (an array that is already so is returned as it is, in ~0.15 us: the scan loop calls this)."""
    flags = getattr(a, "flags", None)
    if flags is not None and flags.c_contiguous and flags.writeable and a.dtype == dtype:
        return a
    return np.array(a, dtype, order="C")  # a copy (np.require's checks cost ~1 us more a call)


@_jit
def quadratic_2x2(a00, a01, a10, a11, n0, n1):
    """nu^T A nu for nu = (n0, n1) and A = [[a00, a01], [a10, a11]], in `nnda.filters.kalman.mahalanobis_2x2`'s
    order of operations (so the compiled and the numpy paths agree to the bit)."""
    return a00 * n0 * n0 + (a01 + a10) * n0 * n1 + a11 * n1 * n1


@_jit
def wrap_angle_kernel(a):
    """An angle (rad) wrapped to [-pi, pi), as `nnda.data.sensor.wrap_angle`."""
    return (a + math.pi) % TWO_PI - math.pi


@_jit
def _product(A, B, d, transpose_b, out):
    """out[:d, :d] = A[:d, :d] B[:d, :d] (B transposed if ``transpose_b``)."""
    for a in range(d):
        for b in range(d):
            s = 0.0
            for c in range(d):
                s += A[a, c] * (B[b, c] if transpose_b else B[c, b])
            out[a, b] = s


@_jit
def mix_predict(x, P, mu, dt, tpm, kinds, dims, omega_max, basis, augment):
    """Mixing (eqs. 4.46-4.49) and every model's EKF prediction over dt (K,): x (K, r, n), P (K, r, n, n),
    mu (K, r) -> predicted xp, Pp (symmetrised, padding zero) and mu_pred (K, r)."""
    K, r, n = x.shape
    xp = np.zeros((K, r, n))
    Pp = np.zeros((K, r, n, n))
    mu_pred = np.zeros((K, r))
    w = np.empty(r)
    x0 = np.empty(n)
    P0 = np.empty((n, n))
    F = np.empty((n, n))
    FP = np.empty((n, n))
    FPF = np.empty((n, n))
    for k in range(K):
        T = dt[k]
        T2 = T * T
        T3, T4 = T2 * T, T2 * T2
        half_T2 = 0.5 * T2
        for j in range(r):
            mp = 0.0
            for i in range(r):
                mp += mu[k, i] * tpm[i, j]
            mu_pred[k, j] = mp
        for j in range(r):
            for i in range(r):  # mu_{i|j}, eq. 4.46
                w[i] = (tpm[i, j] * mu[k, i] + (TINY if i == j else 0.0)) / (mu_pred[k, j] + TINY)
            for a in range(n):  # eq. 4.48
                s = 0.0
                for i in range(r):
                    s += w[i] * x[k, i, a]
                x0[a] = s
            for a in range(n):  # eq. 4.49
                for b in range(n):
                    s = 0.0
                    for i in range(r):
                        s += w[i] * (P[k, i, a, b] + augment[i, a, b])
                    for i in range(r):
                        s += w[i] * (x[k, i, a] - x0[a]) * (x[k, i, b] - x0[b])
                    P0[a, b] = s
            d = dims[j]
            for a in range(d):
                for b in range(d):
                    F[a, b] = 1.0 if a == b else 0.0
            F[0, 1] = T
            F[2, 3] = T
            om = wT = 0.0
            if kinds[j] == CT:  # eqs. 5.17-5.18: F(w) X with the limited w, then df/dw in the last column
                om = min(max(x0[4], -omega_max[j]), omega_max[j])
                wT = om * T
                c = 1.0 - 0.5 * wT * wT
                F[0, 3] = -om * half_T2
                F[1, 1] = c
                F[1, 3] = -wT
                F[2, 1] = om * half_T2
                F[3, 1] = wT
                F[3, 3] = c
            elif kinds[j] == CT_EXACT:
                om = min(max(x0[4], -omega_max[j]), omega_max[j])
                exact_turn(om, T, x0[1], x0[3], F)
            if kinds[j] == CT_EXACT:  # f(x) = F x on the CV part (F's last column is df/dw), the limited w
                for a in range(4):
                    s = 0.0
                    for b in range(4):
                        s += F[a, b] * x0[b]
                    xp[k, j, a] = s
                xp[k, j, 4] = om
            else:
                for a in range(d):
                    s = 0.0
                    for b in range(d):
                        s += F[a, b] * x0[b]
                    xp[k, j, a] = s
            if kinds[j] == CT:
                xp[k, j, 4] = om
                vx, vy = x0[1], x0[3]
                wT2 = wT * T
                F[0, 4] = -vy * half_T2
                F[1, 4] = -vy * T - vx * wT2
                F[2, 4] = vx * half_T2
                F[3, 4] = vx * T - vy * wT2
            _product(F, P0, d, False, FP)  # F P0 F^T + Q, symmetrised (eq. 4.39)
            _product(FP, F, d, True, FPF)
            for a in range(d):
                for b in range(d):
                    Pp[k, j, a, b] = FPF[a, b] + (T * basis[0, j, a, b] + T2 * basis[1, j, a, b]
                                                  + T3 * basis[2, j, a, b] + T4 * basis[3, j, a, b])
            for a in range(d):
                for b in range(a + 1, d):
                    m = 0.5 * (Pp[k, j, a, b] + Pp[k, j, b, a])
                    Pp[k, j, a, b] = m
                    Pp[k, j, b, a] = m
    return xp, Pp, mu_pred


@_jit
def measure(x, P, polar, origin, R):
    """Measurement predictions of B states x (B, n), P (B, n, n): z (B, 2), S (exactly symmetric), S_inv
    (B, 2, 2), log |S| (B,), H (B, 2, n), P H^T (B, n, 2), and the first index whose S is not positive
    definite (-1: none)."""
    B, n = x.shape
    z = np.empty((B, 2))
    S = np.empty((B, 2, 2))
    S_inv = np.empty((B, 2, 2))
    log_det = np.empty(B)
    H = np.zeros((B, 2, n))
    PHt = np.empty((B, n, 2))
    bad = -1
    for b in range(B):
        if polar:
            px, py = x[b, 0] - origin[0], x[b, 2] - origin[1]
            rng = math.hypot(px, py)
            z[b, 0] = rng
            z[b, 1] = math.atan2(px, py) % TWO_PI
            r2 = rng * rng
            H[b, 0, 0], H[b, 0, 2] = px / rng, py / rng
            H[b, 1, 0], H[b, 1, 2] = py / r2, -px / r2
        else:
            z[b, 0], z[b, 1] = x[b, 0], x[b, 2]
            H[b, 0, 0], H[b, 1, 2] = 1.0, 1.0
        for a in range(n):  # H has columns 0 and 2 only
            PHt[b, a, 0] = P[b, a, 0] * H[b, 0, 0] + P[b, a, 2] * H[b, 0, 2]
            PHt[b, a, 1] = P[b, a, 0] * H[b, 1, 0] + P[b, a, 2] * H[b, 1, 2]
        for u in range(2):
            for v in range(u, 2):
                S[b, u, v] = H[b, u, 0] * PHt[b, 0, v] + H[b, u, 2] * PHt[b, 2, v] + R[u, v]
        S[b, 1, 0] = S[b, 0, 1]
        det = S[b, 0, 0] * S[b, 1, 1] - S[b, 0, 1] * S[b, 1, 0]
        S_inv[b, 0, 0], S_inv[b, 1, 1] = S[b, 1, 1] / det, S[b, 0, 0] / det
        S_inv[b, 0, 1] = S_inv[b, 1, 0] = -S[b, 0, 1] / det
        if not (min(det, S[b, 0, 0]) > 0):
            if bad < 0:
                bad = b
            log_det[b] = np.nan
        else:
            log_det[b] = math.log(det)
    return z, S, S_inv, log_det, H, PHt, bad


@_jit
def predict(x, P, mu, dt, tpm, kinds, dims, omega_max, basis, augment, polar, origin, R, d):
    """A scan's prediction in one call: `mix_predict`, then `measure` of every model's prediction, then the
    combined prediction on the first ``d`` entries (`estimate`) and its `measure`. Returns xp (K, r, n), Pp
    (K, r, n, n), mu_pred (K, r), `measure`'s outputs over the K r predictions with (K, r) leading (its
    ``bad`` a flat index over them), xc (K, d), Pc (K, d, d) and `measure`'s outputs over those K."""
    xp, Pp, mu_pred = mix_predict(x, P, mu, dt, tpm, kinds, dims, omega_max, basis, augment)
    K, r, n = xp.shape
    z, S, S_inv, log_det, H, PHt, bad = measure(xp.reshape(K * r, n), Pp.reshape(K * r, n, n), polar, origin, R)
    xc, Pc = estimate(xp, Pp, mu_pred, d)
    zc, Sc, Sc_inv, log_det_c, Hc, PHtc, bad_c = measure(xc, Pc, polar, origin, R)
    return (xp, Pp, mu_pred, z.reshape(K, r, 2), S.reshape(K, r, 2, 2), S_inv.reshape(K, r, 2, 2),
            log_det.reshape(K, r), H.reshape(K, r, 2, n), PHt.reshape(K, r, n, 2), bad,
            xc, Pc, zc, Sc, Sc_inv, log_det_c, Hc, PHtc, bad_c)


@_jit
def update(x, P, mu, z, mask, z_pred, S_inv, log_det, PHt, polar):
    """Kalman correction of every model (eqs. 4.40-4.42) and the mode probabilities (eqs. 4.50-4.53) of K
    tracks with measurements z (K, 2) where ``mask`` (K,); other tracks keep x, P, mu. The measurement
    prediction's arrays have leading shape (K, r)."""
    K, r, n = x.shape
    xu = x.copy()
    Pu = P.copy()
    mu_u = mu.copy()
    gain = np.empty((n, 2))
    log_post = np.empty(r)
    for k in range(K):
        if not mask[k]:
            continue
        for j in range(r):
            nu0 = z[k, 0] - z_pred[k, j, 0]
            nu1 = z[k, 1] - z_pred[k, j, 1]
            if polar:
                nu1 = wrap_angle_kernel(nu1)
            Si = S_inv[k, j]
            for a in range(n):
                gain[a, 0] = PHt[k, j, a, 0] * Si[0, 0] + PHt[k, j, a, 1] * Si[1, 0]
                gain[a, 1] = PHt[k, j, a, 0] * Si[0, 1] + PHt[k, j, a, 1] * Si[1, 1]
                xu[k, j, a] = x[k, j, a] + (gain[a, 0] * nu0 + gain[a, 1] * nu1)
            for a in range(n):
                for b in range(a, n):
                    u = P[k, j, a, b] - (gain[a, 0] * PHt[k, j, b, 0] + gain[a, 1] * PHt[k, j, b, 1])
                    v = P[k, j, b, a] - (gain[b, 0] * PHt[k, j, a, 0] + gain[b, 1] * PHt[k, j, a, 1])
                    m = 0.5 * (u + v)
                    Pu[k, j, a, b] = m
                    Pu[k, j, b, a] = m
            d2 = quadratic_2x2(Si[0, 0], Si[0, 1], Si[1, 0], Si[1, 1], nu0, nu1)
            log_post[j] = math.log(mu[k, j] + TINY) + (-0.5 * (d2 + log_det[k, j]) - LOG_2PI)
        top = log_post.max()
        total = 0.0
        for j in range(r):
            log_post[j] = math.exp(log_post[j] - top)
            total += log_post[j]
        for j in range(r):
            mu_u[k, j] = log_post[j] / total
    return xu, Pu, mu_u


@_jit
def model_likelihood(Z, p, z_pred, S_inv, log_det, k, j, polar):
    """Measurement ``p`` of Z (P, 2) against model ``j`` of track ``k``'s prediction (z_pred (K, r, 2), S_inv
    (K, r, 2, 2), log_det (K, r)): its innovation (azimuth wrapped if ``polar``) and log N(nu; 0, S)
    (eq. 4.50), as (nu0, nu1, log-likelihood)."""
    nu0 = Z[p, 0] - z_pred[k, j, 0]
    nu1 = Z[p, 1] - z_pred[k, j, 1]
    if polar:
        nu1 = wrap_angle_kernel(nu1)
    d2 = quadratic_2x2(S_inv[k, j, 0, 0], S_inv[k, j, 0, 1], S_inv[k, j, 1, 0], S_inv[k, j, 1, 1], nu0, nu1)
    return nu0, nu1, -0.5 * (d2 + log_det[k, j]) - LOG_2PI


@_jit
def pda_update(x, P, mu, z_pred, S_inv, log_det, PHt, rows, track, Z, beta, beta0, polar):
    """IMM-PDA correction (JPDA's soft update: each model weighs every gated contact by its association
    probability, the spread of the innovations widens P) of the K tracks ``rows`` (K,) of a prediction x
    (B, r, n), P, mu (B, r) measured as z_pred (B, r, 2), S_inv, log_det, PHt (leading (B, r)); from P gated
    pairs of ``track`` (P,), sorted, indexing ``rows``, with contacts Z (P, 2) and association probabilities
    ``beta`` (P,), and each track's probability of no contact ``beta0`` (K,). A pair's probability splits over
    the models by their responsibility for its contact (mu times the model's likelihood, normalised), which
    gives the new mode probabilities; each model is then corrected by its own association probabilities.
    Returns x (K, r, n), P (symmetrised), mu (K, r)."""
    K, n_pairs = rows.size, track.size
    r, n = mu.shape[1], x.shape[2]
    xu = np.empty((K, r, n))
    Pu = np.empty((K, r, n, n))
    mu_u = np.empty((K, r))
    nu = np.empty((n_pairs, r, 2))
    joint = np.empty((n_pairs, r))  # P(the pair's contact is the track's, model j)
    for p in range(n_pairs):
        k = rows[track[p]]
        top = -np.inf
        for j in range(r):
            nu[p, j, 0], nu[p, j, 1], log_lik = model_likelihood(Z, p, z_pred, S_inv, log_det, k, j, polar)
            joint[p, j] = math.log(mu[k, j] + TINY) + log_lik
            top = max(top, joint[p, j])
        total = 0.0
        for j in range(r):
            joint[p, j] = math.exp(joint[p, j] - top)
            total += joint[p, j]
        for j in range(r):
            joint[p, j] = beta[p] * (joint[p, j] / total)
    mu_j = np.empty(r)
    combined = np.empty(2)
    spread = np.empty((2, 2))
    gain = np.empty((n, 2))
    first = 0
    for t in range(K):
        last = first
        while last < n_pairs and track[last] == t:
            last += 1
        k = rows[t]
        for j in range(r):
            s = 0.0
            for p in range(first, last):
                s += joint[p, j]
            mu_j[j] = beta0[t] * mu[k, j] + s
        norm = 0.0
        for j in range(r):
            norm += mu_j[j]
        for j in range(r):
            mu_u[t, j] = mu_j[j] / norm
            b0 = beta0[t] * mu[k, j] / (mu_j[j] + TINY)
            combined[0] = combined[1] = 0.0
            spread[0, 0] = spread[0, 1] = spread[1, 0] = spread[1, 1] = 0.0
            for p in range(first, last):
                b = joint[p, j] / (mu_j[j] + TINY)
                w0, w1 = b * nu[p, j, 0], b * nu[p, j, 1]
                combined[0] += w0
                combined[1] += w1
                spread[0, 0] += w0 * nu[p, j, 0]
                spread[0, 1] += w0 * nu[p, j, 1]
                spread[1, 0] += w1 * nu[p, j, 0]
                spread[1, 1] += w1 * nu[p, j, 1]
            for u in range(2):
                for v in range(2):
                    spread[u, v] -= combined[u] * combined[v]
            Si = S_inv[k, j]
            H = PHt[k, j]
            for a in range(n):
                gain[a, 0] = H[a, 0] * Si[0, 0] + H[a, 1] * Si[1, 0]
                gain[a, 1] = H[a, 0] * Si[0, 1] + H[a, 1] * Si[1, 1]
                xu[t, j, a] = x[k, j, a] + (gain[a, 0] * combined[0] + gain[a, 1] * combined[1])
            for a in range(n):
                g0 = gain[a, 0] * spread[0, 0] + gain[a, 1] * spread[1, 0]  # (gain spread)[a]
                g1 = gain[a, 0] * spread[0, 1] + gain[a, 1] * spread[1, 1]
                for c in range(n):
                    Pu[t, j, a, c] = (P[k, j, a, c] - (1.0 - b0) * (gain[a, 0] * H[c, 0] + gain[a, 1] * H[c, 1])
                                      + (g0 * gain[c, 0] + g1 * gain[c, 1]))
            for a in range(n):
                for c in range(a, n):
                    m = 0.5 * (Pu[t, j, a, c] + Pu[t, j, c, a])
                    Pu[t, j, a, c] = m
                    Pu[t, j, c, a] = m
        first = last
    return xu, Pu, mu_u


@_jit
def start(p1, p2, cov2, dt, x_rest, P_rest, mu0):
    """IMM states of K tracks started from two fixes p1, p2 (K, 2) m, dt (K,) s apart (or (1,): one interval
    for all), cov2 (K, 2, 2) the second one's covariance: `nnda.filters.two_point.two_point`'s CV state and
    covariance (the same arithmetic) in every model's first four entries, the rest from ``x_rest`` (r, n),
    ``P_rest`` (r, n, n) (what each model appends to a CV estimate), and the mode probabilities ``mu0``
    (r,)."""
    K = p1.shape[0]
    r, n = x_rest.shape
    x = np.empty((K, r, n))
    P = np.empty((K, r, n, n))
    mu = np.empty((K, r))
    cv_x = np.empty(4)
    cv_P = np.empty((4, 4))
    for k in range(K):
        T = dt[0] if dt.shape[0] == 1 else dt[k]
        for a in range(2):  # positions at the even entries of [x, vx, y, vy], velocities at the odd ones
            cv_x[2 * a] = p2[k, a]
            cv_x[2 * a + 1] = (p2[k, a] - p1[k, a]) / T
            for b in range(2):
                c = cov2[k, a, b]
                cv_P[2 * a, 2 * b] = c
                cv_P[2 * a, 2 * b + 1] = cv_P[2 * a + 1, 2 * b] = c / T
                cv_P[2 * a + 1, 2 * b + 1] = 2.0 * c / (T * T)
        for j in range(r):
            x[k, j] = x_rest[j]
            P[k, j] = P_rest[j]
            x[k, j, :4] = cv_x
            P[k, j, :4, :4] = cv_P
            mu[k, j] = mu0[j]
    return x, P, mu


@_jit
def estimate(x, P, mu, d):
    """Combined estimate (eqs. 4.54-4.55) of K tracks on the first d entries: x (K, d), P (K, d, d)."""
    K, r = mu.shape
    xc = np.zeros((K, d))
    Pc = np.zeros((K, d, d))
    for k in range(K):
        for a in range(d):
            s = 0.0
            for j in range(r):
                s += mu[k, j] * x[k, j, a]
            xc[k, a] = s
        for a in range(d):
            for b in range(d):
                s = 0.0
                for j in range(r):
                    s += mu[k, j] * ((x[k, j, a] - xc[k, a]) * (x[k, j, b] - xc[k, b]) + P[k, j, a, b])
                Pc[k, a, b] = s
    return xc, Pc


@_jit
def squared_distance(z_pred, S_inv, b, Z, m, polar):
    """Squared Mahalanobis distance of measurement m of Z (N, 2) from prediction b of z_pred (B, 2), S_inv
    (B, 2, 2) (eq. 4.51; the azimuth residual wrapped when ``polar``)."""
    n0 = Z[m, 0] - z_pred[b, 0]
    n1 = Z[m, 1] - z_pred[b, 1]
    if polar:
        n1 = wrap_angle_kernel(n1)
    return quadratic_2x2(S_inv[b, 0, 0], S_inv[b, 0, 1], S_inv[b, 1, 0], S_inv[b, 1, 1], n0, n1)


@_jit
def mahalanobis(z_pred, S_inv, Z, polar):
    """Squared Mahalanobis distances (B, N) of N measurements Z (N, 2) from B predictions z_pred (B, 2),
    S_inv (B, 2, 2) (`squared_distance`)."""
    B, N = z_pred.shape[0], Z.shape[0]
    d2 = np.empty((B, N))
    for b in range(B):
        for m in range(N):
            d2[b, m] = squared_distance(z_pred, S_inv, b, Z, m, polar)
    return d2


@_jit
def gated_pairs(z_pred, S_inv, rows, Z, threshold, polar):
    """The pairs of predictions ``rows`` (R,) of z_pred (B, 2), S_inv (B, 2, 2) and measurements Z (N, 2)
    whose `squared_distance` is at most the row's ``threshold`` ((R,), or (1,) for every row), in the order of
    ``rows``, then of Z: their prediction and measurement indices and d2, (P,) each.

    A measurement whose first residual alone puts it outside the gate is passed over before `squared_distance`
    (and its angle wrap, most of the cost): with S^-1 = [[a, b], [b, c]], d2 >= n0^2 (a c - b^2) / c, the least
    d2 over the second residual. The bound is used with a margin of 1e-6 that covers its rounding, and only
    where it is well conditioned (a c - b^2 >= 1e-6 a c, c > 0), so exactly the pairs of the full test are
    kept, with the same d2."""
    R, N = rows.shape[0], Z.shape[0]
    out_rows, out_cols, out_d2 = np.empty(R * N, np.int64), np.empty(R * N, np.int64), np.empty(R * N)
    n = 0
    for i in range(R):
        b = rows[i]
        gate = threshold[i if threshold.size > 1 else 0]
        far = gate * (1.0 + 1e-6)
        a, c, off = S_inv[b, 0, 0], S_inv[b, 1, 1], 0.5 * (S_inv[b, 0, 1] + S_inv[b, 1, 0])
        det = a * c - off * off
        least = det / c if c > 0.0 and det >= 1e-6 * a * c else 0.0  # d2 >= least n0^2
        for m in range(N):
            n0 = Z[m, 0] - z_pred[b, 0]
            if least * n0 * n0 > far:
                continue
            d2 = squared_distance(z_pred, S_inv, b, Z, m, polar)
            if d2 <= gate:
                out_rows[n], out_cols[n], out_d2[n] = b, m, d2
                n += 1
    return out_rows[:n].copy(), out_cols[:n].copy(), out_d2[:n].copy()


@_jit
def pair_log_likelihood(z_pred, S_inv, log_det, mu, rows, Z, polar):
    """The IMM mixture likelihood log sum_j mu_j N(z; z_j, S_j) (eqs. 4.50 and 4.53) of P (track,
    measurement) pairs: track ``rows`` (P,) of the model predictions z_pred (K, r, 2), S_inv (K, r, 2, 2),
    log |S| log_det (K, r) and predicted mode probabilities mu (K, r); measurements Z (P, 2). The sum is
    taken about its largest term (no underflow to -inf far from every model). Its exp and log are libm's,
    which differ from numpy's vectorised ones in the last bit of a few per cent of values. Returns (P,)."""
    P, r = rows.shape[0], mu.shape[1]
    out = np.empty(P)
    terms = np.empty(r)
    for p in range(P):
        k = rows[p]
        top = -np.inf
        for j in range(r):
            terms[j] = model_likelihood(Z, p, z_pred, S_inv, log_det, k, j, polar)[2] + math.log(mu[k, j] + TINY)
            top = max(top, terms[j])
        s = 0.0
        for j in range(r):
            s += math.exp(terms[j] - top)
        out[p] = top + math.log(s)
    return out
