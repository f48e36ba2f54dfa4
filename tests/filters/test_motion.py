"""CV and CT motion models against the spec's matrices (eqs. 5.8-5.18) and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filterpy.common import Q_continuous_white_noise, Q_discrete_white_noise
from reference_filters import ct_F, ct_f, ct_Q, cv_F, cv_Q

from nnda.errors import FilterError
from nnda.filters.imm import IMM
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


@pytest.mark.parametrize("form", ["second-order", "exact"])
def test_ct_jacobian_is_the_derivative_of_the_transition(form):
    ct = CoordinatedTurn(omega_max=1.0, form=form)  # keep the limit out of the way of the finite differences
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


def test_the_exact_turn_keeps_the_speed_over_any_interval_and_meets_its_series():
    ct, second = CoordinatedTurn(form="exact"), CoordinatedTurn()
    x = np.array([[0.0, 10.0, 0.0, 5.0, 0.05]])
    for T in (2.0, 60.0, 300.0):
        fx = ct.transition(x, np.array([T]))[0][0]
        assert np.hypot(fx[1], fx[3]) == pytest.approx(np.hypot(10.0, 5.0), rel=1e-12)
    # the thesis's second-order form gains speed on a long coast: 6.2 times at w T = 5
    grown = second.transition(np.array([[0.0, 10.0, 0.0, 5.0, 0.05]]), np.array([100.0]))[0][0]
    assert np.hypot(grown[1], grown[3]) > 6 * np.hypot(10.0, 5.0)
    # just below w T = 1e-3 the series give the closed form
    w, T = 0.99e-4, 10.0
    fx = ct.transition(np.array([[0.0, 10.0, 0.0, 5.0, w]]), np.array([T]))[0][0]
    s, c = math.sin(w * T), math.cos(w * T)
    np.testing.assert_allclose(fx[:4], [10 * s / w - 5 * (1 - c) / w, 10 * c - 5 * s, 10 * (1 - c) / w + 5 * s / w,
                                        10 * s + 5 * c], rtol=1e-9)  # series against closed form
    # no turn: the constant-velocity transition
    fx, F = ct.transition(np.array([[1.0, 10.0, 2.0, 5.0, 0.0]]), np.array([7.0]))
    np.testing.assert_allclose(fx[0, :4], cv_F(7.0) @ [1.0, 10.0, 2.0, 5.0], rtol=RTOL)


def test_the_imm_cycle_runs_the_exact_turn_as_the_model_does():
    """The compiled IMM prediction of an exact-turn model is f(x) and J P J^T + Q of `CoordinatedTurn` (1e-9)."""
    ct = CoordinatedTurn(form="exact", omega_max=1.0)
    imm = IMM(models=(ct,), tpm=((1.0,),), mu0=(1.0,))
    P = np.diag([400.0, 25.0, 400.0, 25.0, 1e-4])[None].repeat(len(STATES), 0)
    pred = imm.predict(imm.make_state(STATES[:, None], P[:, None], np.ones((len(STATES), 1))), DTS)
    fx, J = ct.transition(STATES, DTS)
    np.testing.assert_allclose(pred.state.x[:, 0], fx, rtol=RTOL, atol=1e-9)
    np.testing.assert_allclose(pred.state.P[:, 0], J @ P @ J.swapaxes(1, 2) + ct.noise(DTS), rtol=RTOL, atol=1e-9)


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
                                    dict(noise_variant="exact"), dict(noise_kind="brownian"), dict(form="sin")])
def test_bad_parameters(kwargs):
    with pytest.raises(FilterError):
        CoordinatedTurn(**kwargs)
