"""The GM-PHD recursion (`nnda.tracking.phd.gmphd`): seed 002's 1-D worked example, the component count
J_k|k-1 (1 + |Z_k|), the three linearisations on a linear measurement, the gate, and the weights against a
loop over pairs."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.filters.measurement import PolarMeasurement, PositionMeasurement
from nnda.filters.mixture import Mixture, prune
from nnda.filters.motion import ConstantVelocity
from nnda.filters.unscented import UnscentedTransform
from nnda.tracking.phd import gmphd

RADAR = PolarMeasurement(30.0, 3e-3)


class RandomWalk:
    """x' = x + w on [x, vx, y, vy] with noise on x only (seed 002's F = 1, Q = 0.09 on the first axis)."""

    dim = 4

    def transition(self, x, dt, out=None):
        return x.copy(), np.broadcast_to(np.eye(4), (*x.shape[:-1], 4, 4))

    def noise(self, dt):
        return np.diag([0.09, 0.0, 0.0, 0.0])


def one_d(weights, means, variances, labels):
    """1-D components on the x axis of [x, vx, y, vy]: y = 0 with variance 0.01 for all (an axis every
    component shares, so it scales every likelihood alike), velocities irrelevant."""
    k = len(weights)
    m = np.zeros((k, 4))
    m[:, 0] = means
    P = np.tile(np.diag([1.0, 1.0, 0.01, 1.0]), (k, 1, 1))
    P[:, 0, 0] = variances
    return Mixture.make(weights, m, P, labels)


def test_seed_002_worked_example_has_16_components():
    """Ex. 2.4.1-2.4.2 of the harbour thesis: two survivors, two births (the birth line's 0.05 / 0.2 typo
    resolved to the stated 0.01 / 0.01), three contacts: 4 x (1 + 3) = 16 components, weights as the 1-D
    formulas give them."""
    prior = one_d([0.04, 0.04], [-2.0, 2.0], [0.01, 0.01], [0, 1])
    pred = Mixture.concat([gmphd.predict(prior, RandomWalk(), 1.0, 0.9),
                           one_d([0.01, 0.01], [-1.0, 1.0], [0.01, 0.01], [2, 3])])
    np.testing.assert_allclose(pred.weights, [0.036, 0.036, 0.01, 0.01])
    np.testing.assert_allclose(pred.covariances[:, 0, 0], [0.10, 0.10, 0.01, 0.01])
    Z = np.array([[-2.0, 0.0], [-1.0, 0.0], [1.0, 0.0]])
    meas = PositionMeasurement(((0.04, 0.0), (0.0, 0.04)))
    lin = gmphd.Linear(meas)
    zc, R = lin.contacts(Z)
    pairs = lin.pairs(pred, zc, R, gate=None)
    # c(z) = 0.3 on the x axis; the shared y axis multiplies every q by N(0; 0, 0.01 + 0.04)
    log_kappa = np.full(3, np.log(0.3) - 0.5 * np.log(2 * np.pi * 0.05))
    det, missed = gmphd.phd_weights(pred.weights, pairs, 0.7, log_kappa)
    post = gmphd.posterior(pred, pairs, missed, det)
    assert len(post) == 16
    w, m, P = pred.weights, pred.means[:, 0], pred.covariances[:, 0, 0]
    S = P + 0.04
    expect_w, expect_m, expect_P = list(0.3 * w), list(m), list(P)
    for z in Z[:, 0]:
        q = np.exp(-0.5 * (z - m) ** 2 / S) / np.sqrt(2 * np.pi * S)
        expect_w += list(0.7 * w * q / (0.3 + 0.7 * np.sum(w * q)))
        expect_m += list(m + P / S * (z - m))
        expect_P += list(P - P * P / S)
    np.testing.assert_allclose(post.weights, expect_w, rtol=1e-9)
    np.testing.assert_allclose(post.means[:, 0], expect_m, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(post.covariances[:, 0, 0], expect_P, rtol=1e-9)
    np.testing.assert_array_equal(post.labels, np.tile([0, 1, 2, 3], 4))
    assert len(prune(post, 1e-5)) < 16


def scene(seed=0, J=7, N=9):
    """A predicted mixture of J CV components 8-20 km from the radar and N polar contacts near some."""
    rng = np.random.default_rng(seed)
    r, az = rng.uniform(8_000, 20_000, J), rng.uniform(0.3, 2.5, J)
    m = np.zeros((J, 4))
    m[:, 0], m[:, 2] = r * np.sin(az), r * np.cos(az)
    m[:, [1, 3]] = rng.normal(0, 100, (J, 2))
    A = rng.normal(0, 1, (J, 4, 4)) * np.array([60.0, 10.0, 60.0, 10.0])[:, None]
    P = A @ A.swapaxes(1, 2) + np.diag([400.0, 25.0, 400.0, 25.0])
    pred = Mixture.make(rng.uniform(0.01, 1.0, J), m, P, np.arange(J))
    near = rng.integers(J, size=N)
    zr = np.hypot(m[near, 0], m[near, 2]) + rng.normal(0, 60, N)
    za = np.arctan2(m[near, 0], m[near, 2]) % (2 * np.pi) + rng.normal(0, 0.006, N)
    far = rng.random(N) < 0.3  # some contacts nowhere near a component
    zr[far] += 3_000.0
    return pred, np.column_stack([zr, za])


@pytest.mark.parametrize("lin", [gmphd.EKF(RADAR), gmphd.UKF(RADAR, UnscentedTransform()), gmphd.Linear(RADAR)],
                         ids=["ekf", "ukf", "linear"])
def test_component_count_before_reduction(lin):
    pred, z = scene()
    zc, R = lin.contacts(z)
    pairs = lin.pairs(pred, zc, R, gate=None)
    det, missed = gmphd.phd_weights(pred.weights, pairs, 0.9, np.full(len(z), np.log(1e-4)))
    post = gmphd.posterior(pred, pairs, missed, det)
    assert len(post) == len(pred) * (1 + len(z))  # J_k = J_k|k-1 (1 + |Z_k|)
    gated = lin.pairs(pred, zc, R, gate=50.0)
    assert 0 < len(gated.j) < len(pred) * len(z)


@pytest.mark.parametrize("lin", [gmphd.EKF(RADAR), gmphd.UKF(RADAR, UnscentedTransform()), gmphd.Linear(RADAR)],
                         ids=["ekf", "ukf", "linear"])
def test_weights_against_a_loop_over_pairs(lin):
    pred, z = scene(1)
    zc, R = lin.contacts(z)
    pairs = lin.pairs(pred, zc, R, gate=None)
    log_kappa = np.log(np.linspace(1e-5, 1e-3, len(z)))
    det, missed = gmphd.phd_weights(pred.weights, pairs, 0.8, log_kappa)
    q = np.zeros((len(pred), len(z)))
    for k, (j, i) in enumerate(zip(pairs.j, pairs.i)):
        q[j, i] = np.exp(pairs.log_likelihood[k])
    for k, (j, i) in enumerate(zip(pairs.j, pairs.i)):
        expect = 0.8 * pred.weights[j] * q[j, i] / (np.exp(log_kappa[i]) + 0.8 * pred.weights @ q[:, i])
        assert det[k] == pytest.approx(expect, rel=1e-9, abs=1e-300)
    np.testing.assert_allclose(missed, 0.2 * pred.weights)


@pytest.mark.parametrize("lin", [gmphd.EKF(RADAR), gmphd.Linear(RADAR)], ids=["ekf", "linear"])
def test_the_gate_keeps_what_matters(lin):
    """The gated update equals the full one after pruning: pairs outside a 50 gate weigh nothing."""
    pred, z = scene(2, J=30, N=40)
    zc, R = lin.contacts(z)
    out = []
    for gate in (None, 50.0):
        pairs = lin.pairs(pred, zc, R, gate=gate)
        assert (pairs.i[1:] >= pairs.i[:-1]).all()  # contact-major
        det, missed = gmphd.phd_weights(pred.weights, pairs, 0.9, np.full(len(z), np.log(1e-4)))
        out.append(prune(gmphd.posterior(pred, pairs, missed, det), 1e-5))
    full, gated = out
    assert len(full) == len(gated)
    np.testing.assert_allclose(gated.weights, full.weights, rtol=1e-9)
    np.testing.assert_allclose(gated.means, full.means, rtol=1e-9)


def test_three_linearisations_agree_on_a_linear_measurement():
    """UK-PHD = EK-PHD = linear GM-PHD when the measurement is a Cartesian fix."""
    pred, z = scene(3)
    fixes = np.column_stack([z[:, 0] * np.sin(z[:, 1]), z[:, 0] * np.cos(z[:, 1])])
    meas = PositionMeasurement(((900.0, 100.0), (100.0, 2500.0)))
    posts = []
    for lin in (gmphd.Linear(meas), gmphd.EKF(meas), gmphd.UKF(meas, UnscentedTransform(0.5, 2.0, 1.0))):
        zc, R = lin.contacts(fixes)
        pairs = lin.pairs(pred, zc, R, gate=50.0)
        det, missed = gmphd.phd_weights(pred.weights, pairs, 0.9, np.full(len(z), np.log(1e-7)))
        posts.append(gmphd.posterior(pred, pairs, missed, det, prune_above=0.0))
    for other in posts[1:]:
        np.testing.assert_array_equal(other.labels, posts[0].labels)
        np.testing.assert_allclose(other.weights, posts[0].weights, rtol=1e-9)
        np.testing.assert_allclose(other.means, posts[0].means, rtol=1e-9)
        np.testing.assert_allclose(other.covariances, posts[0].covariances, rtol=1e-9, atol=1e-9)


def test_a_contact_nothing_explains():
    """No clutter and no component near a contact: its pairs get no weight (not 0 / 0)."""
    pred, z = scene(4, J=3, N=4)
    lin = gmphd.EKF(RADAR)
    pairs = lin.pairs(pred, z, gate=50.0)
    det, _ = gmphd.phd_weights(pred.weights, pairs, 0.9, np.full(len(z), -np.inf))
    assert np.isfinite(det).all()
    explained = np.bincount(pairs.i, det, minlength=len(z))
    assert ((explained == 0) | np.isclose(explained, 1.0)).all()


def test_predict_and_spawn():
    pred, _ = scene(5, J=4)
    cv = ConstantVelocity(10.0)
    surv = gmphd.predict(pred, cv, 2.0, 0.95)
    np.testing.assert_allclose(surv.weights, 0.95 * pred.weights)
    np.testing.assert_allclose(surv.means[:, 0], pred.means[:, 0] + 2.0 * pred.means[:, 1])
    Qs = np.diag([100.0, 4.0, 100.0, 4.0])
    sp = gmphd.spawn(pred, cv, 2.0, 0.05, Qs, np.arange(10, 14))
    np.testing.assert_allclose(sp.means, surv.means)
    F = cv.transition(pred.means, np.asarray(2.0))[1]
    np.testing.assert_allclose(sp.covariances, F @ pred.covariances @ F.swapaxes(1, 2) + Qs, rtol=1e-9)
    np.testing.assert_array_equal(sp.labels, np.arange(10, 14))
