"""Frencl (2014)'s pedestrian motion models: Jacobians against finite differences, the xi = 0 switch, conversions."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.errors import FilterError
from nnda.filters import ground_motion
from nnda.filters.ground_motion import (
    DiagonalCV,
    GroundVehicle,
    HMMap,
    ModifiedNCSHT,
    corridor_hm_map,
    cv_to_ncsht,
    ncsht_to_cv,
    plus_hm_map,
)
from tolerances import RTOL, assert_cov

FD_RTOL = 1e-6


def _numeric_jacobian(model, x: np.ndarray, dt: float, h: float = 1e-6) -> np.ndarray:
    """Central differences of f, (K, 4) -> (K, 4, 4)."""
    J = np.empty((*x.shape, x.shape[-1]))
    for j in range(x.shape[-1]):
        e = np.zeros(x.shape[-1])
        e[j] = h
        J[..., j] = (model.transition(x + e, dt)[0] - model.transition(x - e, dt)[0]) / (2 * h)
    return J


def _states(rng, n=50, x=(31.0, 47.0), y=(19.0, 29.0)):
    """Positions off the 1 m vertex lines (the bilinear xi has kinks there), speeds 0.5-2.5 m/s, any heading."""
    px = np.floor(rng.uniform(*x, n)) + rng.uniform(0.1, 0.9, n)
    py = np.floor(rng.uniform(*y, n)) + rng.uniform(0.1, 0.9, n)
    return np.stack([px, py, rng.uniform(0.5, 2.5, n), rng.uniform(-3.0, 3.0, n)], axis=1)


def _assert_close(actual, desired, rtol):
    scale = np.maximum(np.abs(desired), 1.0)
    np.testing.assert_array_less(np.abs(actual - desired), rtol * scale)


@pytest.mark.parametrize("model", [ModifiedNCSHT(), GroundVehicle(hm_map=corridor_hm_map(), rho=0.3),
                                   GroundVehicle(hm_map=plus_hm_map(), v0=1.2, rho=0.1)])
def test_complete_jacobian_matches_finite_differences(model):
    x = _states(np.random.default_rng(1))
    _, F = model.transition(x, 1.0)
    _assert_close(F, _numeric_jacobian(model, x, 1.0), FD_RTOL)


def test_printed_jacobian_drops_the_alpha0_term_and_equals_the_complete_one_where_alpha0_is_zero():
    rng = np.random.default_rng(2)
    corridor = corridor_hm_map()
    x = _states(rng, x=(5.0, 95.0), y=(21.0, 29.0))
    x[:, 3] = rng.uniform(-1.0, 1.0, x.shape[0])  # |alpha0 - alpha| < pi: the wrap is the identity
    printed = GroundVehicle(hm_map=corridor, jacobian="printed").transition(x, 1.0)[1]
    complete = GroundVehicle(hm_map=corridor).transition(x, 1.0)[1]
    _assert_close(printed, complete, RTOL)  # alpha0 = 0: -alpha dxi = (alpha0 - alpha) dxi
    _assert_close(printed, _numeric_jacobian(GroundVehicle(hm_map=corridor), x, 1.0), FD_RTOL)
    # on the "+" map's north arm alpha0 = pi/2, so the printed row misses alpha0 dxi/dx
    plus = plus_hm_map()
    x = _states(rng, x=(18.5, 29.5), y=(31.0, 47.0))
    x[:, 3] = rng.uniform(0.0, 3.0, x.shape[0])
    Fp = GroundVehicle(hm_map=plus, jacobian="printed").transition(x, 1.0)[1]
    Fc = GroundVehicle(hm_map=plus).transition(x, 1.0)[1]
    xi, dxi_x, _, a0 = plus.read(x[:, 0], x[:, 1])
    _assert_close(Fp[:, 3, 0], -x[:, 3] * dxi_x, RTOL)
    _assert_close(Fc[:, 3, 0] - Fp[:, 3, 0], a0 * dxi_x, RTOL)
    _assert_close(Fc, _numeric_jacobian(GroundVehicle(hm_map=plus), x, 1.0), FD_RTOL)


def test_the_map_model_is_modified_ncsht_where_xi_is_zero():
    rng = np.random.default_rng(3)
    plus = plus_hm_map()
    x = _states(rng, x=(18.5, 29.5), y=(18.5, 29.5))  # the centre square: xi = 0
    assert not plus.read(x[:, 0], x[:, 1])[0].any()
    fg, Fg = GroundVehicle(hm_map=plus, v0=3.0, rho=0.5).transition(x, 1.0)
    fn, Fn = ModifiedNCSHT().transition(x, 1.0)
    np.testing.assert_array_equal(fg, fn)
    np.testing.assert_array_equal(Fg, Fn)
    # and where xi > 0 speed and heading relax: xi = 1 at the corridor's edge jumps to alpha0
    edge = np.array([[40.3, 20.0, 2.0, 1.0]])
    f = GroundVehicle(hm_map=corridor_hm_map(), v0=1.0, rho=0.25).transition(edge, 1.0)[0]
    assert f[0, 2] == pytest.approx(1.75) and f[0, 3] == pytest.approx(0.0, abs=1e-12)


def test_xi_is_clipped_to_one_and_read_bilinearly():
    m = corridor_hm_map()
    assert m.clipped > 0 and m.xi.max() == 1.0 and m.xi.min() == 0.0
    xi, dx, dy, a0 = m.read(np.array([10.0, 10.5]), np.array([27.0, 27.5]))
    np.testing.assert_allclose(xi, [4 / 25, (4 / 25 + 9 / 25) / 2])
    np.testing.assert_allclose(dy, [5 / 25, 5 / 25])
    assert not dx.any() and not a0.any()


def test_process_noise_is_the_thesis_diagonal_at_one_second():
    np.testing.assert_allclose(DiagonalCV().noise(1.0), np.diag([1 / 9, 0.18**2, 1 / 9, 0.18**2]))
    np.testing.assert_allclose(ModifiedNCSHT().noise(np.ones(3)), np.broadcast_to(
        np.diag([1 / 9, 1 / 9, 1 / 12, 0.18**2]), (3, 4, 4)))
    x = np.array([[1.0, 2.0, 3.0, -1.0]])
    f, F = DiagonalCV().transition(x, 2.0)
    np.testing.assert_allclose(f, [[5.0, 2.0, 1.0, -1.0]])


def test_state_conversions_invert_each_other():
    rng = np.random.default_rng(4)
    m = np.stack([rng.normal(size=20), rng.normal(size=20), rng.uniform(0.5, 2, 20), rng.uniform(-3, 3, 20)], 1)
    A = rng.normal(size=(20, 4, 4)) * 0.1
    P = A @ np.swapaxes(A, -1, -2) + 0.01 * np.eye(4)
    cv, Pcv = ncsht_to_cv(m, P)
    back, Pb = cv_to_ncsht(cv, Pcv)
    np.testing.assert_allclose(back, m, rtol=RTOL, atol=RTOL)
    assert_cov(Pb, P)


def test_bad_maps_and_parameters():
    with pytest.raises(FilterError, match=r"HMMap.alpha0: expected shape \(3, 4\)"):
        HMMap(np.zeros((3, 4)), np.zeros((4, 3)))
    with pytest.raises(FilterError, match="at least 2 x 2 vertices"):
        HMMap(np.zeros((1, 4)), np.zeros((1, 4)))
    with pytest.raises(FilterError, match="HMMap.xi: non-finite"):
        HMMap(np.full((2, 2), np.nan), np.zeros((2, 2)))
    with pytest.raises(FilterError, match="rho: must lie in"):
        GroundVehicle(hm_map=corridor_hm_map(), rho=1.5)
    with pytest.raises(FilterError, match="an HMMap is needed"):
        GroundVehicle()


def test_thesis_cv_is_a_deprecated_alias_of_diagonal_cv():
    with pytest.warns(FutureWarning, match="ThesisCV.*DiagonalCV"):
        old = ground_motion.ThesisCV
    assert old is DiagonalCV
    with pytest.raises(AttributeError):
        _ = ground_motion.NoSuchModel
