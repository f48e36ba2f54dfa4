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
written out). Then p'(n) = Upsilon^0[Z](n) p(n) / <Upsilon^0[Z], p>, missed
copies weigh (1 - p_D) w_j <Upsilon^1[Z], p> / <Upsilon^0[Z], p> and the
copy of component j updated by z weighs
p_D w_j q_j(z) / c(z) <Upsilon^1[Z \\ {z}], p> / <Upsilon^0[Z], p>.

Numerics. The elementary symmetric functions e_k span hundreds of orders
of magnitude, so every sum runs on logarithms (the factors above) or on
rescaled values with their scale kept as a logarithm. e_k(Lambda) comes
from Vieta's recursion on Lambda / max(Lambda); the N values
<Upsilon^1[Z \\ {z}], p> come from one forward pass (prefix ESFs) and one
backward pass (the prefix's partner, a correlation of the Upsilon^1
coefficients with the suffix ESFs), both sums of non-negative terms only
(no subtraction, so no cancellation), renormalised at every step: O(N
min(N, N_max)) work in 2 N vectorised steps (the recursion is sequential in
the contacts; each step is a vector operation over the degrees).
"""

from __future__ import annotations

import numpy as np
from scipy.special import gammaln, logsumexp, xlogy
from scipy.stats import binom, poisson

from nnda.errors import TrackingError
from nnda.tracking.phd.gmphd import Pairs, per_contact_logsumexp


def predict_cardinality(p: np.ndarray, ps: float, birth_mean: float) -> np.ndarray:
    """Predicted cardinality (N_max+1,) of ``p`` (N_max+1,): each target survives with probability
    ``ps`` (binomial thinning), then a Poisson number of mean ``birth_mean`` is born (a convolution);
    the mass past N_max is cut and the rest renormalised."""
    n = np.arange(len(p))
    survive = binom.pmf(n[:, None], n[None, :], ps) @ p  # P(j survivors) = sum_l C(l, j) ps^j (1-ps)^(l-j) p(l)
    out = np.convolve(survive, poisson.pmf(n, birth_mean))[:len(p)]
    return out / out.sum()


def _vieta(lam: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Prefix ESFs of ``lam`` (m,) >= 0, truncated at ``degree``: rows (m+1, degree+1), row z the ESFs
    of lam[:z] divided by exp(its log scale) (m+1,), so every row's largest entry is 1."""
    m = len(lam)
    rows = np.zeros((m + 1, degree + 1))
    scale = np.zeros(m + 1)
    rows[0, 0] = 1.0
    for z in range(m):
        nxt = rows[z].copy()
        nxt[1:] += lam[z] * rows[z, :-1]
        top = nxt.max()
        rows[z + 1] = nxt / top
        scale[z + 1] = scale[z] + np.log(top)
    return rows, scale


def log_esf(log_lam: np.ndarray, degree: int) -> np.ndarray:
    """log e_k(Lambda), k = 0..degree, of Lambda = exp(``log_lam``) (m,) (-inf entries are zeros);
    e_k = 0 (log -inf) for k > m."""
    lam, shift = _scaled(log_lam)
    rows, scale = _vieta(lam, degree)
    with np.errstate(divide="ignore"):
        return np.log(rows[-1]) + scale[-1] + shift * np.arange(degree + 1)


def _scaled(log_lam: np.ndarray) -> tuple[np.ndarray, float]:
    """Lambda / s and log s with s = max(Lambda) (s = 1 when every Lambda is 0)."""
    shift = float(log_lam.max()) if len(log_lam) and np.isfinite(log_lam).any() else 0.0
    return np.exp(log_lam - shift), shift


def log_leave_one_out(log_lam: np.ndarray, log_b: np.ndarray) -> np.ndarray:
    """log sum_k b_k e_k(Lambda without Lambda_z) for every z: (m,) from ``log_lam`` (m,) and the
    coefficients ``log_b`` (L+1,) (degrees past L are not needed: their b is 0)."""
    m = len(log_lam)
    if m == 0:
        return np.empty(0)
    degree = len(log_b) - 1
    lam, shift = _scaled(log_lam)
    pre, pre_scale = _vieta(lam, degree)  # pre[z]: ESFs of lam[:z]
    # rescale b so that b_k s^k e_k(lam / s) = b_k e_k(lam), and normalise it
    log_bs = log_b + shift * np.arange(degree + 1)
    top = log_bs.max()
    if not np.isfinite(top):  # every coefficient zero
        return np.full(m, -np.inf)
    g = np.exp(log_bs - top)  # g_z[a] = sum_c b[a + c] suffix_z[c]: starts with an empty suffix
    g_scale = top
    out = np.empty(m)
    for z in range(m - 1, -1, -1):
        with np.errstate(divide="ignore"):
            out[z] = np.log(pre[z] @ g) + pre_scale[z] + g_scale
        g = g.copy()
        g[:-1] += lam[z] * g[1:]
        peak = g.max()
        if peak > 0:
            g /= peak
            g_scale += np.log(peak)
    return out


def _log_coefficients(u: int, m: int, n_max: int, degree: int, clutter_rate: float, pd: float, W: float
                      ) -> np.ndarray:
    """log of Upsilon^u's factor (n_max+1, degree+1) at (n, k), for ESFs of the normalised Lambda / W:
    e^-lambda lambda^(m-k) n! / (n-k-u)! (1 - p_D)^(n-k-u) W^-u for k <= m and k + u <= n, else -inf
    (((1 - p_D) W)^(n-k-u) / W^n e_k(Lambda) = (1 - p_D)^(n-k-u) W^-u e_k(Lambda / W))."""
    n = np.arange(n_max + 1)[:, None]
    k = np.arange(degree + 1)[None, :]
    r = n - k - u
    ok = (r >= 0) & (k <= m)
    rr = np.maximum(r, 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = (-clutter_rate + xlogy(m - k, clutter_rate) + gammaln(n + 1.0) - gammaln(rr + 1.0)
             + xlogy(rr, 1.0 - pd) - u * np.log(W))
    return np.where(ok, v, -np.inf)


def cphd_weights(weights: np.ndarray, pairs: Pairs, pd: float, clutter_rate: float, log_c: np.ndarray,
                 cardinality: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """GM-CPHD update weights: of the detection copies (P,), of the missed copies (J,), and the posterior
    cardinality (N_max+1,).

    ``weights`` (J,) predicted weights, ``pairs`` the gated pairs
    (`nnda.tracking.phd.gmphd.Pairs`), ``pd`` detection probability,
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
    with np.errstate(divide="ignore"):
        log_p = np.log(cardinality)
        log_psi = np.log(pd * weights)[pairs.j] + pairs.log_likelihood - log_c[pairs.i]  # p_D w q / c
    # log Lambda(z) / W of the contacts with pairs (W = 0: no component, Lambda = 0)
    seen = np.unique(pairs.i) if W > 0 else np.empty(0, np.int64)
    log_lam = per_contact_logsumexp(log_psi, pairs.i, m, np.full(m, -np.inf))[seen] - (np.log(W) if W > 0 else 0.0)
    degree = min(m, n_max)
    log_e = log_esf(log_lam, min(len(seen), degree))
    log_e = np.concatenate([log_e, np.full(degree + 1 - len(log_e), -np.inf)])
    ups0 = logsumexp(_log_coefficients(0, m, n_max, degree, clutter_rate, pd, 1.0) + log_e, axis=1)
    den = logsumexp(ups0 + log_p)
    if not np.isfinite(den):
        raise TrackingError(f"CPHD: no target count up to max_cardinality = {n_max} explains a scan of {m} "
                            f"contacts with clutter rate {clutter_rate}")
    posterior = np.exp(ups0 + log_p - den)
    posterior /= posterior.sum()
    if W == 0:
        return np.zeros(len(pairs.j)), np.zeros(J), posterior
    ups1 = logsumexp(_log_coefficients(1, m, n_max, degree, clutter_rate, pd, W) + log_e, axis=1)
    missed = (1.0 - pd) * weights * np.exp(logsumexp(ups1 + log_p) - den)
    if not len(seen):
        return np.zeros(0), missed, posterior
    loo_degree = min(len(seen) - 1, n_max - 1)
    log_b = logsumexp(_log_coefficients(1, m - 1, n_max, loo_degree, clutter_rate, pd, W) + log_p[:, None], axis=0)
    log_r = np.full(m, -np.inf)
    log_r[seen] = log_leave_one_out(log_lam, log_b) - den  # log <Upsilon^1[Z \ z], p> / <Upsilon^0[Z], p>
    with np.errstate(invalid="ignore"):
        detected = np.exp(log_psi + log_r[pairs.i])
    return np.nan_to_num(detected, nan=0.0), missed, posterior
