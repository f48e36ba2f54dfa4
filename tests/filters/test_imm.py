"""IMM batching, selection, missed scans, gating outputs and input checks."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.special import logsumexp

from nnda.data.sensor import cart_to_polar, polar_to_cart
from nnda.errors import FilterError
from nnda.filters.imm import IMM, IMMPrediction, IMMState
from nnda.filters.measurement import PolarMeasurement, PositionMeasurement
from nnda.filters.motion import ConstantVelocity, CoordinatedTurn
from nnda.filters.two_point import two_point
from tolerances import RTOL, assert_cov, assert_state

K = 7


def tracks(seed: int = 0, k: int = K):
    """k random tracks: first two polar fixes (2 s apart) and 12 more scans of fixes."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-2e4, 2e4, (k, 2))
    pos[np.hypot(*pos.T) < 6e3] += 8e3
    vel = rng.normal(0, 120, (k, 2))
    t = 2.0 * np.arange(14)
    xy = pos[:, None] + vel[:, None] * t[:, None] + rng.normal(0, 40, (k, 14, 2))
    r, az = cart_to_polar(xy[..., 0], xy[..., 1])
    return np.stack([r, az], axis=-1)


def test_batch_equals_loop():
    """A batch of K tracks against K batches of one: products summed in other orders, equal to rounding."""
    imm = IMM()
    Z = tracks(1)
    rng = np.random.default_rng(2)
    batch = imm.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0)
    singles = [imm.initialise(Z[i:i + 1, 0], Z[i:i + 1, 1], 0.0, 2.0) for i in range(K)]
    for k in range(2, 14):
        dt = rng.choice([2.0, 4.0, 6.0, 8.0], K)
        mask = rng.random(K) < 0.7
        pred = imm.predict(batch, dt)
        batch = imm.update(pred, Z[:, k], mask)
        for i in range(K):
            p = imm.predict(singles[i], dt[i])
            # range m, azimuth rad (atol: an azimuth near north)
            np.testing.assert_allclose(p.measurement.z[0], pred.measurement.z[i], rtol=RTOL, atol=RTOL)
            assert_cov(p.measurement.S[0], pred.measurement.S[i])
            singles[i] = imm.update(p, Z[i:i + 1, k], mask[i:i + 1])
            assert_state(singles[i].x[0], batch.x[i], batch.P[i])
            assert_cov(singles[i].P[0], batch.P[i])
            np.testing.assert_allclose(singles[i].mu[0], batch.mu[i], rtol=RTOL)


def test_missed_scan_keeps_the_prediction_and_propagates_mode_probabilities():
    imm = IMM()
    Z = tracks(3)
    state = imm.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0)
    state = imm.update(imm.predict(state, 2.0), Z[:, 2])
    pred = imm.predict(state, 2.0)
    # eq. 4.47 (the compiled sum may round differently from numpy's product)
    np.testing.assert_allclose(pred.state.mu, state.mu @ np.array(imm.tpm), rtol=RTOL)
    mask = np.arange(K) % 2 == 0
    z = np.where(mask[:, None], Z[:, 3], np.nan)
    out = imm.update(pred, z, mask)
    missed = ~mask
    np.testing.assert_array_equal(out.x[missed], pred.state.x[missed])
    np.testing.assert_array_equal(out.P[missed], pred.state.P[missed])
    np.testing.assert_array_equal(out.mu[missed], pred.state.mu[missed])
    full = imm.update(pred, Z[:, 3])
    np.testing.assert_array_equal(out.x[mask], full.x[mask])  # exactly: one batch, missed rows replaced
    assert not np.array_equal(full.x[missed], pred.state.x[missed])


def test_take_and_concat():
    imm = IMM()
    Z = tracks(4)
    state = imm.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0)
    pred = imm.predict(state, 2.0)
    idx = np.array([5, 0, 0, 3])
    sub = pred.take(idx)
    assert isinstance(sub, IMMPrediction) and len(sub) == 4
    np.testing.assert_array_equal(sub.measurement.S, pred.measurement.S[idx])
    np.testing.assert_array_equal(sub.state.x, pred.state.x[idx])
    # branching one track over several measurements: take repeats, update with one z per copy
    # (a batch of 4 against one of K: equal to rounding)
    upd, whole = imm.update(sub, Z[idx, 2]), imm.update(pred, Z[:, 2])
    assert_state(upd.x[0], whole.x[5], whole.P[5])
    both = IMMState.concat([state.take(slice(0, 3)), state.take(np.arange(K) >= 3)])
    for name in ("x", "P", "mu"):
        np.testing.assert_array_equal(getattr(both, name), getattr(state, name))
    with pytest.raises(FilterError, match="boolean mask"):
        state.take(np.array([True, False]))
    other = IMM(models=(ConstantVelocity(), ConstantVelocity(1.0))).initialise(Z[:2, 0], Z[:2, 1], 0.0, 2.0)
    with pytest.raises(FilterError, match="field 'x'"):
        IMMState.concat([state, other])
    with pytest.raises(FilterError, match="nothing"):
        IMMState.concat([])


def test_kept_is_take_of_a_mask_and_the_batch_itself_when_all_stay():
    state = IMM().initialise(*(tracks(4)[:, i] for i in (0, 1)), 0.0, 2.0)
    some = np.arange(K) % 2 == 0
    part = state.kept(some)
    for name in ("x", "P", "mu"):
        np.testing.assert_array_equal(getattr(part, name), getattr(state.take(some), name))
    assert part is not state and state.kept(np.ones(K, bool)) is state
    for wrong in (np.array([True, False]), np.ones(K + 1, bool)):
        with pytest.raises(FilterError, match="boolean mask"):
            state.kept(wrong)


def test_replaced_is_dataclasses_replace():
    state = IMM().initialise(*(tracks(4)[:, i] for i in (0, 1)), 0.0, 2.0)
    mu = np.full_like(state.mu, 0.5)
    got, want = state.replaced(mu=mu), dataclasses.replace(state, mu=mu)
    assert type(got) is IMMState and got.x is state.x and got.P is state.P and got.mu is mu
    for name in ("x", "P", "mu"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
    with pytest.raises(FilterError, match="no field"):
        state.replaced(sigma=mu)

def test_gating_distances_and_log_likelihoods_against_every_contact():
    imm = IMM()
    Z = tracks(5)
    state = imm.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0)
    pred = imm.predict(state, 2.0)
    contacts = Z[:, 2]
    gate = imm.combined_measurement(pred)
    d2 = imm.mahalanobis(gate, contacts)
    assert d2.shape == (K, K)
    for i in range(K):
        for j in range(K):
            nu = contacts[j] - gate.z[i]
            nu[1] = (nu[1] + math.pi) % (2 * math.pi) - math.pi
            assert math.isclose(d2[i, j], nu @ np.linalg.solve(gate.S[i], nu), rel_tol=1e-9)
    # each track's own contact is the nearest
    np.testing.assert_array_equal(d2.argmin(axis=1), np.arange(K))
    per_model = imm.mahalanobis(pred.measurement, contacts)
    assert per_model.shape == (K, 2, K)
    ll = imm.log_likelihood(pred, contacts)
    log_norm = -np.log(2 * math.pi * np.sqrt(np.linalg.det(pred.measurement.S)))[..., None]
    manual = logsumexp(-0.5 * per_model + log_norm, b=pred.state.mu[..., None], axis=1)
    np.testing.assert_allclose(ll, manual, rtol=RTOL)
    # far-away contacts do not underflow to -inf
    assert np.isfinite(imm.log_likelihood(pred, np.array([[29_000.0, 3.0]]))).all()


def _mixture_by_hand(imm: IMM, pred: IMMPrediction, k: int, z: np.ndarray) -> float:
    """log sum_j mu_j N(z; z_j, S_j) of one track and measurement, each model's Gaussian by numpy's solve
    and determinant (azimuth residual wrapped for a polar measurement)."""
    mp = pred.measurement
    terms = []
    for j in range(len(imm.models)):
        nu = z - mp.z[k, j]
        if isinstance(imm.measurement, PolarMeasurement):
            nu[1] = (nu[1] + math.pi) % (2 * math.pi) - math.pi
        S = mp.S[k, j]
        terms.append(-0.5 * nu @ np.linalg.solve(S, nu) - math.log(2 * math.pi * math.sqrt(np.linalg.det(S))))
    return float(logsumexp(terms, b=pred.state.mu[k]))


@pytest.mark.parametrize("linear", [False, True])
def test_pair_log_likelihoods_by_hand(linear):
    """Sparse pairs (repeated tracks, azimuths across +-pi, a contact far from every model) against the
    mixture by hand, and against the dense (K, N) form's entries."""
    Z = tracks(3)
    if linear:
        imm = IMM(models=(ConstantVelocity(), ConstantVelocity(0.5)),
                  measurement=PositionMeasurement(((900.0, 0.0), (0.0, 900.0))))
        Z = np.stack(polar_to_cart(Z[..., 0], Z[..., 1]), axis=-1)
    else:
        imm = IMM()
    pred = imm.predict(imm.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0), 2.0)
    rng = np.random.default_rng(8)
    rows = np.concatenate([rng.integers(0, K, 40), [0, 0, 3]])
    z = pred.measurement.z[rows, 0] + rng.normal(0.0, [60.0, 0.01] if not linear else [60.0, 60.0], (len(rows), 2))
    if linear:
        z[-1] = [2e5, -2e5]
    else:
        z[-3:, 1] = [math.pi - 1e-4, -math.pi + 1e-4, 2.0]
        z[-1, 0] = 29_000.0
    ll = imm.pair_log_likelihood(pred, rows, z)
    assert ll.shape == rows.shape and np.isfinite(ll).all()
    np.testing.assert_allclose(ll, [_mixture_by_hand(imm, pred, k, zk) for k, zk in zip(rows, z)], rtol=RTOL)
    dense = imm.log_likelihood(pred, z)
    np.testing.assert_array_equal(ll, dense[rows, np.arange(len(rows))])
    assert imm.pair_log_likelihood(pred, np.empty(0, np.int64), np.empty((0, 2))).shape == (0,)


def test_no_tracks_and_no_contacts():
    imm = IMM()
    empty = imm.initialise(np.empty((0, 2)), np.empty((0, 2)), 0.0, 2.0)
    pred = imm.predict(empty, np.empty(0))
    assert len(imm.update(pred, np.empty((0, 2)), np.zeros(0, bool))) == 0
    assert imm.mahalanobis(imm.combined_measurement(pred), tracks(1, 2)[:, 0]).shape == (0, 2)
    assert imm.estimate(empty)[1].shape == (0, 4, 4)
    Z = tracks(10, 2)
    pred = imm.predict(imm.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0), 2.0)
    assert imm.log_likelihood(pred, np.empty((0, 2))).shape == (2, 0)
    assert len(IMMState.concat([empty, pred.state])) == 2


def test_combined_estimate_covers_the_shared_dimensions():
    imm = IMM()
    Z = tracks(6)
    state = imm.update(imm.predict(imm.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0), 2.0), Z[:, 2])
    x, P = imm.estimate(state)
    assert x.shape == (K, 4) and P.shape == (K, 4, 4)
    mu = state.mu
    assert_state(x, mu[:, :1] * state.x[:, 0, :4] + mu[:, 1:] * state.x[:, 1, :4], P)
    assert np.linalg.eigvalsh(P).min() > 0
    # exactly symmetric: entries (i, j) and (j, i) are the same weighted sum of exactly symmetric terms
    np.testing.assert_array_equal(P, np.swapaxes(P, 1, 2))
    # padding of the CV model stays exactly zero
    assert (state.x[:, 0, 4] == 0).all() and (state.P[:, 0, 4] == 0).all() and (state.P[:, 0, :, 4] == 0).all()


def test_cv_only_and_linear_measurement_configurations_run():
    fixes = PositionMeasurement(((900.0, 0.0), (0.0, 900.0)))
    imm = IMM(models=(ConstantVelocity(), ConstantVelocity(0.5)), measurement=fixes)
    xy = np.array([[1e4, 2e4], [-5e3, 7e3]])
    state = imm.initialise(xy, xy + 200.0, 0.0, 2.0)
    state = imm.update(imm.predict(state, 2.0), xy + 400.0)
    assert imm.dim == imm.output_dim == 4
    np.testing.assert_allclose(imm.estimate(state)[0][:, 1], 100.0, atol=1.0)


def test_a_mode_with_probability_zero_stays_finite():
    """Identity TPM and mu0 = (1, 0): the CT model is never entered and keeps its own estimate."""
    imm = IMM(tpm=((1.0, 0.0), (0.0, 1.0)), mu0=(1.0, 0.0))
    Z = tracks(9, 3)
    state = imm.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0)
    for k in range(2, 8):
        pred = imm.predict(state, 2.0)
        state = imm.update(pred, Z[:, k])
    assert np.isfinite(state.x).all() and np.isfinite(state.P).all()
    assert (state.mu[:, 0] == 1.0).all() and (state.mu[:, 1] < 1e-250).all()
    # the CT model ran as a filter of its own: same result as a CT-only IMM
    ct = IMM(models=(CoordinatedTurn(),), tpm=((1.0,),), mu0=(1.0,))
    alone = ct.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0)
    for k in range(2, 8):
        alone = ct.update(ct.predict(alone, 2.0), Z[:, k])
    assert_state(state.x[:, 1], alone.x[:, 0], alone.P[:, 0])  # another model stack: equal to rounding


@pytest.mark.parametrize("dt", [2.0, "per track"])
def test_start_is_the_two_point_state_in_every_model(dt):
    """`IMM.start` (one compiled call) against `two_point` then `from_cv`, with one interval or one per track."""
    imm = IMM()
    rng = np.random.default_rng(3)
    K = 6
    p1, p2 = rng.uniform(-2e4, 2e4, (K, 2)), rng.uniform(-2e4, 2e4, (K, 2))
    a = rng.normal(size=(K, 2, 2))
    cov2 = a @ a.swapaxes(1, 2) * 400.0 + np.eye(2) * 100.0
    T = rng.uniform(1.0, 8.0, K) if dt == "per track" else dt
    got, want = imm.start(p1, p2, cov2, T), imm.from_cv(*two_point(p1, p2, cov2, T))
    assert_state(got.x, want.x, want.P)
    assert_cov(got.P, want.P)
    np.testing.assert_array_equal(got.mu, want.mu)
    assert len(imm.start(p1[:0], p2[:0], cov2[:0], T if np.ndim(T) == 0 else T[:0])) == 0


def test_make_state_and_from_cv():
    imm = IMM()
    Z = tracks(7, 2)
    state = imm.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0)
    again = imm.make_state(state.x, state.P, state.mu)
    np.testing.assert_array_equal(again.x, state.x)
    x, P = imm.estimate(state)
    from_cv = imm.from_cv(x, P, mu=[[0.9, 0.1], [0.2, 0.8]])
    np.testing.assert_array_equal(from_cv.x[:, 1, :4], x)
    assert from_cv.P[0, 1, 4, 4] == 0.0076
    np.testing.assert_array_equal(from_cv.mu, [[0.9, 0.1], [0.2, 0.8]])


# ------------------------------------------------------------------ bad input
@pytest.fixture
def setup():
    imm = IMM()
    Z = tracks(8, 3)
    state = imm.initialise(Z[:, 0], Z[:, 1], 0.0, 2.0)
    return imm, state, imm.predict(state, 2.0), Z


def test_nan_measurement_is_refused(setup):
    imm, _, pred, Z = setup
    z = Z[:, 2].copy()
    z[1, 1] = np.nan
    with pytest.raises(FilterError, match=r"z: non-finite value nan at index \(1, 1\)"):
        imm.update(pred, z)
    with pytest.raises(FilterError, match="non-finite"):
        imm.update(pred, z, np.array([True, True, False]))
    imm.update(pred, z, np.array([True, False, True]))  # a missed track's row is ignored
    with pytest.raises(FilterError, match="Z: non-finite"):
        imm.mahalanobis(imm.combined_measurement(pred), np.array([[1e4, np.inf]]))
    with pytest.raises(FilterError, match="z2: non-finite"):
        imm.initialise(Z[:, 0], np.full((3, 2), np.nan), 0.0, 2.0)


@pytest.mark.parametrize("bad", ["asymmetric", "indefinite", "nan"])
def test_bad_covariance_is_refused(setup, bad):
    imm, state, _, _ = setup
    P = state.P.copy()
    if bad == "asymmetric":
        P[1, 0, 0, 1] += 50.0
        match = r"P\[:, 0\] \(model ConstantVelocity\): matrix \(1,\) is not symmetric"
    elif bad == "indefinite":
        P[2, 1, 4, 4] = -1e-3
        match = r"P\[:, 1\] \(model CoordinatedTurn\): matrix \(2,\) is not positive definite"
    else:
        P[0, 1, 2, 2] = np.nan
        match = "non-finite"
    with pytest.raises(FilterError, match=match):
        imm.make_state(state.x, P, state.mu)


@pytest.mark.parametrize("bad, match", [
    ("asymmetric", r"P: matrix \(2,\) is not symmetric"),
    ("indefinite", r"P: matrix \(2,\) is not positive definite"),
    ("nan", r"P: non-finite value nan at index \(2, 3, 3\)"),
])
def test_bad_cv_covariance_is_refused(bad, match):
    P = np.tile(np.diag([1e4, 1e2, 1e4, 1e2]), (3, 1, 1))
    if bad == "asymmetric":
        P[2, 0, 1] = 10.0
    elif bad == "indefinite":
        P[2, 0, 1] = P[2, 1, 0] = 2e3
    else:
        P[2, 3, 3] = np.nan
    with pytest.raises(FilterError, match=match):
        IMM().from_cv(np.full((3, 4), 1e4), P)


def test_wrong_shapes_are_refused(setup):
    imm, state, pred, Z = setup
    with pytest.raises(FilterError, match=r"z: expected shape \(3, 2\), got \(2, 2\)"):
        imm.update(pred, Z[:2, 2])
    with pytest.raises(FilterError, match="mask"):
        imm.update(pred, Z[:, 2], np.array([1, 0, 1]))
    with pytest.raises(FilterError, match=r"dt: expected a scalar or shape \(3,\)"):
        imm.predict(state, np.array([2.0, 2.0]))
    with pytest.raises(FilterError, match="dt: intervals"):
        imm.predict(state, -2.0)
    with pytest.raises(FilterError, match="dt: intervals"):
        imm.predict(state, np.array([2.0, np.nan, 2.0]))
    with pytest.raises(FilterError, match="for this IMM"):
        IMM(models=(ConstantVelocity(), ConstantVelocity())).predict(state, 2.0)
    with pytest.raises(FilterError, match=r"x: expected shape \(\*, 2, 5\)"):
        imm.make_state(state.x[:, :, :4], state.P)
    with pytest.raises(FilterError, match="beyond a model's own state"):
        imm.make_state(state.x + 1.0, state.P)
    with pytest.raises(FilterError, match="mu: mode probabilities"):
        imm.make_state(state.x, state.P, np.full((3, 2), 0.6))
    with pytest.raises(FilterError, match="t1, t2"):
        imm.initialise(Z[:, 0], Z[:, 1], 2.0, 2.0)
    with pytest.raises(FilterError, match=r"z2: expected shape \(3, 2\)"):
        imm.initialise(Z[:, 0], Z[:2, 1], 0.0, 2.0)


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
def test_state_at_the_radar_is_refused():
    imm = IMM()
    state = imm.from_cv(np.zeros((1, 4)), np.eye(4)[None] * 100.0)
    with pytest.raises(FilterError, match="innovation covariance"):
        imm.predict(state, 2.0)


@pytest.mark.parametrize("kwargs, match", [
    (dict(tpm=((0.9, 0.2), (0.1, 0.9))), "row must sum to 1"),
    (dict(tpm=((1.0, 0.0), (1.0, 0.0))), "reachable"),
    (dict(tpm=((0.9, 0.1),)), r"IMM.tpm: expected shape \(2, 2\)"),
    (dict(mu0=(0.7, 0.7)), "IMM.mu0"),
    (dict(augment_variance=-1.0), "augment_variance"),
    (dict(models=()), "at least one"),
])
def test_bad_configuration(kwargs, match):
    with pytest.raises(FilterError, match=match):
        IMM(**kwargs)


def test_configuration_defaults_are_the_spec():
    imm = IMM()
    assert imm.tpm == ((0.99, 0.01), (0.10, 0.90)) and imm.mu0 == (0.5, 0.5)
    assert imm.models == (ConstantVelocity(3.5), CoordinatedTurn(5.0, 0.044, math.radians(5.0), 0.0076))
    assert imm.augment_variance == 0.0
    assert (imm.measurement.sigma_range, imm.measurement.sigma_azimuth) == (30.0, 3e-3)
