"""CV and CT motion models against the spec's matrices (eqs. 5.8-5.18) and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filterpy.common import Q_continuous_white_noise, Q_discrete_white_noise
from reference_filters import ct_F, ct_f, ct_Q, cv_F, cv_Q

from nnda.errors import FilterError
from nnda.filters.motion import ConstantVelocity, CoordinatedTurn
from tolerances import RTOL

RNG = np.random.default_rng(11)
STATES = np.column_stack([
    RNG.uniform(-2e4, 2e4, 6), RNG.uniform(-200, 200, 6), RNG.uniform(-2e4, 2e4, 6),
    RNG.uniform(-200, 200, 6), RNG.uniform(-0.08, 0.08, 6),
])
DTS = np.array([2.0, 4.0, 6.0, 8.0, 2.0, 3.3])


def test_cv_matches_spec_and_filterpy():
    cv = ConstantVelocity()
    fx, F = cv.transition(STATES[:, :4], DTS)
    Q = cv.noise(DTS)
    for k, T in enumerate(DTS):
        np.testing.assert_array_equal(F[k], cv_F(T))  # exactly: entries 0, 1 and T
        np.testing.assert_allclose(fx[k], cv_F(T) @ STATES[k, :4], rtol=RTOL)
        np.testing.assert_allclose(Q[k], cv_Q(T, 3.5), rtol=RTOL)
        fp = Q_discrete_white_noise(dim=2, dt=T, var=3.5**2, block_size=2, order_by_dim=True)
        np.testing.assert_allclose(Q[k], fp, rtol=RTOL)


def test_ct_transition_is_the_printed_second_order_form():
    ct = CoordinatedTurn()
    fx, J = ct.transition(STATES, DTS)
    for k, T in enumerate(DTS):
        # atol for entries near zero, where terms of up to ~1e3 (m, m/s) cancel: 1e4 roundings of those
        np.testing.assert_allclose(fx[k], ct_f(STATES[k], T), rtol=RTOL, atol=1e-9)
        np.testing.assert_allclose(J[k], ct_F(STATES[k], T), rtol=RTOL, atol=1e-9)


def test_ct_jacobian_is_the_derivative_of_the_transition():
    ct = CoordinatedTurn(omega_max=1.0)  # keep the limit out of the way of the finite differences
    x = STATES.copy()
    _, J = ct.transition(x, DTS)
    steps = np.array([1e-3, 1e-4, 1e-3, 1e-4, 1e-7])
    num = np.empty_like(J)
    for i, h in enumerate(steps):
        e = np.zeros(5)
        e[i] = h
        num[:, :, i] = (ct.transition(x + e, DTS)[0] - ct.transition(x - e, DTS)[0]) / (2 * h)
    np.testing.assert_allclose(J, num, rtol=1e-6, atol=1e-6)


def test_ct_noise_variants():
    T = DTS
    np.testing.assert_allclose(CoordinatedTurn().noise(T), [ct_Q(t) for t in T], rtol=RTOL)
    printed = CoordinatedTurn(noise_variant="printed").noise(T)
    np.testing.assert_allclose(printed, [ct_Q(t, printed=True) for t in T], rtol=RTOL)
    # the printed per-axis block is indefinite, the derived one is a covariance
    assert np.linalg.eigvalsh(printed[:, :2, :2]).min() < 0
    assert np.linalg.eigvalsh(CoordinatedTurn().noise(T)[:, :2, :2]).min() > -1e-9


def test_ct_with_zero_turn_rate_is_cv():
    x = STATES.copy()
    x[:, 4] = 0.0
    fx_ct, F_ct = CoordinatedTurn().transition(x, DTS)
    fx_cv, F_cv = ConstantVelocity().transition(x[:, :4], DTS)
    np.testing.assert_array_equal(fx_ct[:, :4], fx_cv)
    np.testing.assert_array_equal(F_ct[:, :4, :4], F_cv)


def test_turn_rate_is_limited_to_omega_max():
    ct = CoordinatedTurn()
    x = np.array([[1e4, 100.0, 1e4, 0.0, 0.5], [1e4, 100.0, 1e4, 0.0, -0.5]])
    fx, _ = ct.transition(x, np.array([2.0, 2.0]))
    np.testing.assert_allclose(fx[:, 4], [math.radians(5), -math.radians(5)])
    limited = x.copy()
    limited[:, 4] = fx[:, 4]
    np.testing.assert_allclose(fx, ct.transition(limited, np.array([2.0, 2.0]))[0])


def test_positive_omega_turns_counter_clockwise():
    # heading north (vy > 0) with omega > 0: the velocity rotates towards west (vx < 0)
    fx, _ = CoordinatedTurn().transition(np.array([[0.0, 0.0, 1e4, 100.0, 0.05]]), np.array([2.0]))
    assert fx[0, 1] < 0


def test_from_cv_extends_with_zero_turn_rate():
    x, P = STATES[:2, :4], np.stack([np.eye(4)] * 2)
    x5, P5 = CoordinatedTurn().from_cv(x, P)
    np.testing.assert_array_equal(x5[:, :4], x)
    assert (x5[:, 4] == 0).all() and (P5[:, 4, 4] == 0.0076).all() and (P5[:, 4, :4] == 0).all()


def test_continuous_noise_is_filterpys_and_grows_linearly_in_velocity():
    """White-noise acceleration in continuous time: filterpy's Q for spectral density sigma_q^2, on both axes
    of CV and of CT's [x, vx, y, vy], and sigma_omega^2 T on CT's turn rate."""
    cv = ConstantVelocity(sigma_q=0.3, noise_kind="continuous")
    ct = CoordinatedTurn(sigma_q=0.3, sigma_omega=0.01, noise_kind="continuous")
    for k, T in enumerate(DTS):
        fp = Q_continuous_white_noise(dim=2, dt=T, spectral_density=0.09, block_size=2, order_by_dim=True)
        np.testing.assert_allclose(cv.noise(DTS)[k], fp, rtol=RTOL)
        np.testing.assert_allclose(ct.noise(DTS)[k][:4, :4], fp, rtol=RTOL)
        assert ct.noise(DTS)[k][4, 4] == pytest.approx(1e-4 * T, rel=RTOL)
    assert ConstantVelocity(sigma_q=0.3).noise(np.array([100.0]))[0, 1, 1] == pytest.approx(0.09 * 100.0**2)


@pytest.mark.parametrize("kwargs", [dict(sigma_q=-1.0), dict(sigma_q=float("nan")), dict(omega_max=0.0),
                                    dict(noise_variant="exact"), dict(noise_kind="brownian")])
def test_bad_parameters(kwargs):
    with pytest.raises(FilterError):
        CoordinatedTurn(**kwargs)
