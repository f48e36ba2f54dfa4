"""The CPHD update (`nnda.tracking.phd.cphd`): elementary symmetric functions and their leave-one-out sums
against brute force and high precision, the cardinality prediction, and the update weights against the
formulas of Vo, Vo & Cantoni 2007 evaluated term by term."""

from __future__ import annotations

import itertools
import math
from decimal import Decimal, getcontext

import numpy as np
import pytest
from scipy.special import gammaln
from scipy.stats import binom, poisson
from test_phd_recursion import scene

from nnda.errors import TrackingError
from nnda.filters.measurement import PolarMeasurement
from nnda.tracking.phd import cphd, gmphd


def esf_brute(lam):
    """e_k as sums of products over k-subsets."""
    return [sum(math.prod(c) for c in itertools.combinations(lam, k)) for k in range(len(lam) + 1)]


@pytest.mark.parametrize("seed", range(4))
def test_esf_against_brute_force(seed):
    rng = np.random.default_rng(seed)
    lam = np.exp(rng.uniform(-8, 8, 9))
    lam[rng.integers(9)] = 0.0
    with np.errstate(divide="ignore"):
        got = cphd.log_esf(np.log(lam), 9)
    np.testing.assert_allclose(np.exp(got), esf_brute(lam), rtol=1e-9)
    np.testing.assert_allclose(cphd.log_esf(np.log(lam[lam > 0]), 4), np.log(esf_brute(lam[lam > 0])[:5]),
                               rtol=1e-9)


def test_esf_over_a_huge_range_against_high_precision():
    """500 values from 1e-60 to 1e60: every log e_k finite and equal to Vieta in 80-digit decimals."""
    rng = np.random.default_rng(7)
    log_lam = rng.uniform(-60, 60, 500) * np.log(10)
    got = cphd.log_esf(log_lam, 40)
    getcontext().prec = 80
    e = [Decimal(1)] + [Decimal(0)] * 40
    for v in log_lam:
        x = Decimal(float(v)).exp()
        for k in range(40, 0, -1):
            e[k] += x * e[k - 1]
    np.testing.assert_allclose(got, [float(x.ln()) for x in e], rtol=1e-9)


def test_esf_of_a_thousand_contacts_spans_more_than_a_float():
    """1,500 equal Lambda = 1: e_k = C(1500, k) runs from 1 to ~1e450, past a float's range within one set; every
    degree still exact (the log of the binomial coefficient), none lost to underflow."""
    m = 1_500
    k = np.arange(m + 1)
    np.testing.assert_allclose(cphd.log_esf(np.zeros(m), m), gammaln(m + 1) - gammaln(k + 1) - gammaln(m - k + 1),
                               rtol=1e-9, atol=1e-9)


def test_leave_one_out_of_a_thousand_contacts_keeps_the_low_degrees():
    """1,500 equal Lambda = 1 with b at degree 3 (and a negligible b at 750): every leave-one-out sum is
    C(1499, 3), though the prefix ESFs at degree 3 sit ~1e300 below their largest degree."""
    m = 1_500
    log_b = np.full(751, -np.inf)
    log_b[3], log_b[750] = 0.0, -2_000.0
    expected = gammaln(m) - gammaln(4) - gammaln(m - 3)  # log C(1499, 3); C(1499, 750) e^-2000 adds < 1e-300
    np.testing.assert_allclose(cphd.log_leave_one_out(np.zeros(m), log_b), expected, rtol=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_leave_one_out_against_brute_force(seed):
    rng = np.random.default_rng(seed)
    lam = np.exp(rng.uniform(-5, 5, 8))
    b = rng.uniform(0.1, 2.0, 6)  # degrees 0..5
    got = np.exp(cphd.log_leave_one_out(np.log(lam), np.log(b)))
    for z in range(len(lam)):
        e = esf_brute(np.delete(lam, z))
        assert got[z] == pytest.approx(sum(bk * ek for bk, ek in zip(b, e)), rel=1e-12)


def test_predict_cardinality_against_the_sums():
    p = np.array([0.1, 0.3, 0.4, 0.15, 0.05, 0.0, 0.0, 0.0])
    got = cphd.predict_cardinality(p, 0.9, 0.3)
    expect = np.zeros(8)
    for n in range(8):
        for j in range(n + 1):
            expect[n] += poisson.pmf(n - j, 0.3) * sum(binom.pmf(j, ell, 0.9) * p[ell] for ell in range(j, 8))
    np.testing.assert_allclose(got, expect / expect.sum(), rtol=1e-9)


def cphd_reference(w, q, pd, lam, c, p):
    """VVC 2007's GM-CPHD update term by term (dense q (J, N), plain floats, no logs); ``pd`` a number or
    one per component (J,): the missed mass <1 - p_D, v> in place of (1 - p_D) W."""
    J, m = q.shape
    n_max = len(p) - 1
    W = w.sum()
    pd = np.broadcast_to(pd, w.shape)
    missed_mass = (1 - pd) @ w
    Lam = np.array([(pd * w) @ q[:, i] / c[i] for i in range(m)])

    def ups(u, L, n):
        mm = len(L)
        e = esf_brute(L)
        return sum(math.exp(-lam) * lam ** (mm - k) * math.factorial(n) / math.factorial(n - k - u)
                   * missed_mass ** (n - k - u) / W ** n * e[k] for k in range(min(mm, n - u) + 1))

    den = sum(ups(0, Lam, n) * p[n] for n in range(n_max + 1))
    post = np.array([ups(0, Lam, n) * p[n] / den for n in range(n_max + 1)])
    missed = (1 - pd) * w * sum(ups(1, Lam, n) * p[n] for n in range(1, n_max + 1)) / den
    det = np.zeros((J, m))
    for i in range(m):
        r = sum(ups(1, np.delete(Lam, i), n) * p[n] for n in range(1, n_max + 1)) / den
        det[:, i] = pd * w * q[:, i] / c[i] * r
    return det, missed, post


@pytest.mark.parametrize("pd, lam", [(0.9, 2.5), (0.6, 0.3), (0.99, 6.0),
                                     (np.array([0.9, 0.0, 0.8, 0.9, 0.5]), 2.5)])  # p_D per component
def test_weights_against_the_formulas(pd, lam):
    pred, z = scene(0, J=5, N=6)
    lin = gmphd.EKF(PolarMeasurement(30.0, 3e-3))
    pairs = lin.pairs(pred, z, gate=None)
    c = np.linspace(2e-6, 8e-6, len(z))  # clutter spatial density per m rad
    p = cphd.predict_cardinality(np.array([0.05, 0.2, 0.3, 0.25, 0.1, 0.05, 0.05, 0, 0, 0]), 0.95, 0.4)
    det, missed, post = cphd.cphd_weights(pred.weights, pairs, pd, lam, np.log(c), p)
    q = np.zeros((len(pred), len(z)))
    q[pairs.j, pairs.i] = np.exp(pairs.log_likelihood)
    ref_det, ref_missed, ref_post = cphd_reference(pred.weights, q, pd, lam, c, p)
    np.testing.assert_allclose(post, ref_post, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(missed, ref_missed, rtol=1e-9)
    np.testing.assert_allclose(det, ref_det[pairs.j, pairs.i], rtol=1e-9, atol=1e-300)
    # the updated intensity's mass is the posterior mean count (VVC 2007)
    assert missed.sum() + det.sum() == pytest.approx(np.arange(len(post)) @ post, rel=1e-9)


def test_gated_contacts_enter_through_the_count_only():
    """Contacts without a pair change p(n) only through |Z| (the clutter term): the gated update equals the
    full one where the far pairs' likelihoods underflow."""
    pred, z = scene(2, J=6, N=12)
    lin = gmphd.EKF(PolarMeasurement(30.0, 3e-3))
    p = cphd.predict_cardinality(np.eye(11)[3], 0.99, 0.2)
    out = [cphd.cphd_weights(pred.weights, lin.pairs(pred, z, gate=g), 0.9, 4.0, np.full(12, np.log(5e-6)), p)
           for g in (None, 50.0)]
    np.testing.assert_allclose(out[1][2], out[0][2], rtol=1e-9)
    np.testing.assert_allclose(out[1][1], out[0][1], rtol=1e-9)


def test_single_target_without_clutter_gets_weight_one():
    pred, z = scene(3, J=1, N=1)
    pairs = gmphd.EKF(PolarMeasurement(30.0, 3e-3)).pairs(pred, z, gate=None)
    p = np.zeros(5)
    p[1] = 1.0
    det, missed, post = cphd.cphd_weights(np.array([1.0]), pairs, 1.0, 0.0, np.array([np.log(1e-5)]), p)
    assert det[0] == pytest.approx(1.0, rel=1e-12) and missed[0] == 0.0
    np.testing.assert_allclose(post, p)


def test_a_scan_no_count_explains():
    pred, z = scene(4, J=2, N=5)
    pairs = gmphd.EKF(PolarMeasurement(30.0, 3e-3)).pairs(pred, z, gate=None)
    with pytest.raises(TrackingError, match="max_cardinality = 3 explains a scan of 5 contacts"):
        cphd.cphd_weights(pred.weights, pairs, 0.9, 0.0, np.zeros(5), np.full(4, 0.25))


@pytest.mark.parametrize("size, ps", [(1, 0.99), (60, 0.99), (700, 0.99), (300, 0.5)])
def test_thinning_is_the_binomial_pmf(size, ps):
    """The survivors' matrix P(j | l) (Pascal's rule, compiled) equals scipy's binomial pmf to 1e-12 relative
    wherever that is representable, and each column sums to one."""
    n = np.arange(size)
    want = binom.pmf(n[:, None], n[None, :], ps)
    got = cphd._thinning(size, ps)
    big = want > 1e-250
    np.testing.assert_allclose(got[big], want[big], rtol=1e-12)
    assert np.abs(got - want).max() < 1e-15
    np.testing.assert_allclose(got.sum(axis=0), 1.0, rtol=1e-12)
