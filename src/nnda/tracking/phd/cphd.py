"""The cardinalised PHD update (Vo, Vo & Cantoni 2007) for Gaussian mixtures, in the log domain.

Beside the intensity, the CPHD filter carries the distribution p(n) of the
number of targets on the capped support n = 0..N_max. Per scan, with J
predicted components and N contacts:

    p = predict_cardinality(p, ps, birth_mean)          # binomial thinning (*) Poisson births   (N_max+1,)
    pairs = EKF(radar).pairs(pred, z, gate=50.0)        # as the GM-PHD (`nnda.tracking.phd.gmphd`)
    det, missed, p = cphd_weights(pred.weights, pairs, pd, clutter_rate, log_c, p)
    post = gmphd.posterior(pred, pairs, missed, det, prune_above=1e-5)

With Poisson clutter of mean lambda and spatial density c(z) (per unit of
measurement space), Lambda_z = p_D sum_j w_j q_j(z) / c(z) and, for u = 0, 1,

    Upsilon^u[Z](n) = sum_{k=0}^{min(|Z|, n-u)} e^-lambda lambda^(|Z|-k) n! / (n-k-u)!
                      ((1 - p_D) W)^(n-k-u) / W^n  e_k(Lambda(Z)),      W = sum_j w_j
                    = W^-u sum_k ... (1 - p_D)^(n-k-u) e_k(Lambda(Z) / W)     (computed so)

(the GM-CPHD update of Vo, Vo & Cantoni, "Analytic implementations of the
cardinalized probability hypothesis density filter", IEEE TSP 55(7), 2007,
Sec. IV-B, with the Poisson clutter cardinality's (|Z|-k)! p_K(|Z|-k)
written out). Then

    p'(n) = Upsilon^0[Z](n) p(n) / <Upsilon^0[Z], p>,

missed copies weigh ``(1 - p_D) w_j <Upsilon^1[Z], p> / <Upsilon^0[Z], p>``
and the copy of component j updated by z weighs
``p_D w_j q_j(z) / c(z) <Upsilon^1[Z \\ {z}], p> / <Upsilon^0[Z], p>``.

Numerics. The elementary symmetric functions e_k span hundreds of orders
of magnitude, and at a thousand contacts more than a float's range between
degrees of one contact set, so every sum runs on logarithms. e_k(Lambda)
comes from Vieta's recursion in the log domain; the N values
``<Upsilon^1[Z \\ {z}], p>`` come from one forward pass (prefix ESFs) and one
backward pass (the prefix's partner, a correlation of the Upsilon^1
coefficients with the suffix ESFs), both sums of non-negative terms only
(no subtraction, so no cancellation), compiled (numba). Only the N_g
contacts with a gated pair enter them (a contact without one has Lambda =
0: it counts in |Z| only): O(N_g min(N_g, N_max)) work.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numba
import numpy as np
from scipy.special import gammaln, xlogy
from scipy.stats import poisson

from nnda.errors import TrackingError
from nnda.tracking.phd.gmphd import Pairs, per_contact_logsumexp

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


def predict_cardinality(p: np.ndarray, ps: float, birth_mean: float) -> np.ndarray:
    """Predicted cardinality (N_max+1,) of ``p`` (N_max+1,): each target survives with probability
    ``ps`` (binomial thinning), then a Poisson number of mean ``birth_mean`` is born (a convolution);
    the mass past N_max is cut and the rest renormalised."""
    out = np.convolve(_thinning(len(p), ps) @ p, poisson.pmf(np.arange(len(p)), birth_mean))[:len(p)]
    return out / out.sum()


def support_for(p: np.ndarray, minimum: int, per_target: float, births: float = 0.0) -> np.ndarray:
    """``p`` (N_max+1,) on a support 0..N' that holds ``per_target`` times its mean plus the ``births`` expected
    before the next update: ``p`` itself when N_max does, else padded with zeros to the smallest N' =
    ``minimum`` x 2^k that does (doubling keeps the few support sizes `_thinning` caches)."""
    need = per_target * (float(np.arange(len(p)) @ p) + births)
    size = len(p) - 1
    if size >= need:
        return p
    size = minimum * 2 ** int(np.ceil(np.log2(need / minimum)))
    return np.pad(p, (0, size + 1 - len(p)))


@lru_cache(maxsize=8)
def _thinning(size: int, ps: float) -> np.ndarray:
    """(size, size) matrix of P(j survivors | l targets) = C(l, j) ps^j (1 - ps)^(l - j), row j, column l."""
    return _binomial_columns(size, ps)


@_jit
def _binomial_columns(size: int, ps: float) -> np.ndarray:
    """`_thinning` by Pascal's rule over the columns, P(j | l) = ps P(j-1 | l-1) + (1 - ps) P(j | l-1): a convex
    combination per entry (relative error below l x 1e-16), O(size^2), where scipy's binomial pmf took 0.8 s
    at size 1,600 (a CPHD following 1,000 targets)."""
    out = np.zeros((size, size))
    out[0, 0] = 1.0
    q = 1.0 - ps
    for col in range(1, size):
        out[0, col] = q * out[0, col - 1]
        for row in range(1, col + 1):
            out[row, col] = ps * out[row - 1, col - 1] + q * out[row, col - 1]
    return out


def _logsumexp(a: np.ndarray, axis: int | None = None) -> np.ndarray:
    """log sum exp of ``a`` along ``axis`` (all -inf: -inf), shifted by the maximum."""
    top = np.max(a, axis=axis, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.sum(np.exp(a - top), axis=axis, keepdims=True)) + top
    return out.squeeze(axis) if axis is not None else out.reshape(())


@_jit
def _log_add(a: float, b: float) -> float:
    """log(e^a + e^b), either of them -inf (a zero)."""
    if a < b:
        a, b = b, a
    if b == -np.inf:
        return a
    return a + math.log1p(math.exp(b - a))


@_jit
def _log_prefix(log_lam: np.ndarray, degree: int) -> np.ndarray:
    """Prefix ESFs of Lambda = exp(``log_lam``) (m,), truncated at ``degree``, as logarithms: rows (m+1, degree+1),
    row z log e_k(Lambda[:z]) (Vieta's recursion e_k += Lambda_z e_(k-1); -inf where e_k = 0, as for k > z)."""
    m = len(log_lam)
    rows = np.full((m + 1, degree + 1), -np.inf)
    rows[0, 0] = 0.0
    for z in range(m):
        rows[z + 1, 0] = 0.0
        for k in range(1, min(z + 1, degree) + 1):
            rows[z + 1, k] = _log_add(rows[z, k], log_lam[z] + rows[z, k - 1])
    return rows


def log_esf(log_lam: np.ndarray, degree: int) -> np.ndarray:
    """log e_k(Lambda), k = 0..degree, of Lambda = exp(``log_lam``) (m,) (-inf entries are zeros);
    e_k = 0 (log -inf) for k > m."""
    return _log_prefix(np.asarray(log_lam, np.float64), degree)[-1]


def log_leave_one_out(log_lam: np.ndarray, log_b: np.ndarray) -> np.ndarray:
    """log sum_k b_k e_k(Lambda without Lambda_z) for every z: (m,) from ``log_lam`` (m,) and the
    coefficients ``log_b`` (L+1,) (degrees past L are not needed: their b is 0)."""
    log_lam = np.asarray(log_lam, np.float64)
    return _leave_one_out(_log_prefix(log_lam, len(log_b) - 1), log_lam, np.asarray(log_b, np.float64))


@_jit
def _leave_one_out(pre: np.ndarray, log_lam: np.ndarray, log_b: np.ndarray) -> np.ndarray:
    """`log_leave_one_out` from `_log_prefix`'s rows of Lambda (at least len(log_b) columns).

    Backward over the contacts: g[a] = sum_c b[a + c] (ESFs of the contacts after z)[c], so that
    sum_k b_k e_k(Lambda without z) = sum_a (prefix ESFs before z)[a] g[a]; taking z into the suffix is
    g[a] += Lambda_z g[a + 1]. Every term is non-negative, and every value a logarithm.
    """
    m, degree = len(log_lam), len(log_b) - 1
    g = log_b.copy()
    out = np.empty(m)
    for z in range(m - 1, -1, -1):
        top = -np.inf
        for a in range(degree + 1):
            top = max(top, pre[z, a] + g[a])
        if top == -np.inf:
            out[z] = -np.inf
        else:
            total = 0.0
            for a in range(degree + 1):
                total += math.exp(pre[z, a] + g[a] - top)
            out[z] = top + math.log(total)
        for a in range(degree):
            g[a] = _log_add(g[a], log_lam[z] + g[a + 1])
    return out


@lru_cache(maxsize=64)
def _falling(u: int, n_lo: int, n_hi: int, degree: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The parts of Upsilon^u's factor that depend on (n, k) only, (n_hi-n_lo+1, degree+1) each, rows n = n_lo..n_hi:
    where k + u <= n, log n! / (n-k-u)!, and r = n - k - u (0 elsewhere)."""
    log_factorial = gammaln(np.arange(n_hi + 1) + 1.0)  # log n!, gathered below (the same values, far faster)
    n = np.arange(n_lo, n_hi + 1)[:, None]
    k = np.arange(degree + 1)[None, :]
    r = n - k - u
    ok = r >= 0
    rr = np.maximum(r, 0)
    return ok, np.where(ok, log_factorial[n] - log_factorial[rr], 0.0), rr


def _log_coefficients(u: int, m: int, rows: slice, degree: int, clutter_rate: float, miss: float, W: float
                      ) -> np.ndarray:
    """log of Upsilon^u's factor (rows, degree+1) at (n, k), n in ``rows`` (a slice of 0..N_max), for ESFs of the
    normalised Lambda / W: e^-lambda lambda^(m-k) n! / (n-k-u)! q^(n-k-u) W^-u for k <= m and k + u <= n, else
    -inf, with ``miss`` q = <1 - p_D, v> / <1, v> (1 - p_D for a constant p_D):
    (<1 - p_D, v>^(n-k-u) / W^n e_k(Lambda) = q^(n-k-u) W^-u e_k(Lambda / W))."""
    ok, log_falling, r = _falling(u, rows.start, rows.stop - 1, degree)
    k = np.arange(degree + 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        clutter = np.where(k <= m, -clutter_rate + xlogy(m - k, clutter_rate), -np.inf)
        v = clutter[None, :] + log_falling + xlogy(r, miss) - u * np.log(W)
    return np.where(ok, v, -np.inf)


def cphd_weights(weights: np.ndarray, pairs: Pairs, pd: float | np.ndarray, clutter_rate: float, log_c: np.ndarray,
                 cardinality: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """GM-CPHD update weights: of the detection copies (P,), of the missed copies (J,), and the posterior
    cardinality (N_max+1,).

    ``weights`` (J,) predicted weights, ``pairs`` the gated pairs
    (`nnda.tracking.phd.gmphd.Pairs`), ``pd`` detection probability (a
    number, or one per component (J,): state-dependent p_D at the means),
    ``clutter_rate`` lambda (mean false contacts per scan), ``log_c`` (N,)
    log clutter spatial density at each contact, ``cardinality`` the
    predicted p(n). A contact without a pair has Lambda = 0 and enters only
    through the count |Z|, so the symmetric functions run over the others.
    Raises TrackingError when no n <= N_max explains the scan (more
    contacts than N_max targets and no clutter).
    """
    n_max = len(cardinality) - 1
    J, m = len(weights), pairs.n_contacts
    W = float(weights.sum())
    miss = 1.0 - pd if np.ndim(pd) == 0 else float((1.0 - pd) @ weights) / W if W > 0 else 1.0
    with np.errstate(divide="ignore"):
        log_p = np.log(cardinality)
        log_psi = np.log(pd * weights)[pairs.j] + pairs.log_likelihood - log_c[pairs.i]  # p_D w q / c
    # log Lambda(z) / W of the contacts with pairs (W = 0: no component, Lambda = 0)
    seen = np.unique(pairs.i) if W > 0 else np.empty(0, np.int64)
    log_lam = per_contact_logsumexp(log_psi, pairs.i, m, np.full(m, -np.inf))[seen] - (np.log(W) if W > 0 else 0.0)
    degree = min(len(seen), n_max)  # e_k = 0 past the number of contacts with Lambda > 0
    pre = _log_prefix(log_lam, degree)  # one forward pass: the ESFs and the leave-one-out sums
    log_e = pre[-1]
    # the counts the prediction gives a probability: a count of p(n) = 0 has none after the update either, and adds
    # nothing to a sum over the counts, so only these rows of the (count, degree) tables are formed
    support = np.flatnonzero(cardinality)
    rows = slice(int(support[0]), int(support[-1]) + 1)
    ups0 = np.full(n_max + 1, -np.inf)
    ups0[rows] = _logsumexp(_log_coefficients(0, m, rows, degree, clutter_rate, miss, 1.0) + log_e, axis=1)
    den = _logsumexp(ups0 + log_p)
    if not np.isfinite(den):
        raise TrackingError(f"CPHD: no target count up to max_cardinality = {n_max} explains a scan of {m} "
                            f"contacts with clutter rate {clutter_rate} (with no clutter, every contact needs a "
                            f"component near it and every target a contact when p_D = 1)")
    posterior = np.exp(ups0 + log_p - den)
    posterior /= posterior.sum()
    if W == 0:
        return np.zeros(len(pairs.j)), np.zeros(J), posterior
    ups1 = np.full(n_max + 1, -np.inf)
    ups1[rows] = _logsumexp(_log_coefficients(1, m, rows, degree, clutter_rate, miss, W) + log_e, axis=1)
    missed = (1.0 - pd) * weights * np.exp(_logsumexp(ups1 + log_p) - den)
    if not len(seen):
        return np.zeros(0), missed, posterior
    loo_degree = min(len(seen) - 1, n_max - 1)
    log_b = _logsumexp(_log_coefficients(1, m - 1, rows, loo_degree, clutter_rate, miss, W) + log_p[rows, None],
                       axis=0)
    log_r = np.full(m, -np.inf)
    # log <Upsilon^1[Z \ z], p> / <Upsilon^0[Z], p>
    log_r[seen] = _leave_one_out(pre, log_lam, log_b) - den
    with np.errstate(invalid="ignore"):
        detected = np.exp(log_psi + log_r[pairs.i])
    return np.nan_to_num(detected, nan=0.0), missed, posterior
