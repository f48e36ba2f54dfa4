"""Polar and position measurement models and the two-point start of Vargas Avila (2015)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import reference_filters as ref

from nnda.data.scenario import Sensor
from nnda.data.sensor import cart_to_polar, measure, polar_to_cart, polar_to_cart_at
from nnda.errors import FilterError
from nnda.filters.measurement import PolarMeasurement, PositionMeasurement, converted_covariance, measurement_model
from nnda.filters.two_point import two_point
from tolerances import RTOL

RNG = np.random.default_rng(5)
X = np.column_stack([RNG.uniform(-2.5e4, 2.5e4, 8), RNG.normal(0, 100, 8), RNG.uniform(-2.5e4, 2.5e4, 8),
                     RNG.normal(0, 100, 8), RNG.normal(0, 0.03, 8)])
#: a radar away from the origin (m)
ORIGIN = (-12_345.0, 6_789.0)


def test_polar_prediction_and_jacobian_match_the_spec():
    pm = PolarMeasurement()
    z, H = pm.predict(X)
    r, az = cart_to_polar(X[:, 0], X[:, 2])
    np.testing.assert_array_equal(z, np.column_stack([r, az]))  # exactly: predict calls cart_to_polar too
    assert ((z[:, 1] >= 0) & (z[:, 1] < 2 * np.pi)).all()
    for k in range(len(X)):
        np.testing.assert_allclose(H[k], ref.polar_H(X[k]), rtol=RTOL)
        np.testing.assert_allclose(pm.predict(X[k, :4])[1], ref.polar_H(X[k, :4]), rtol=RTOL)  # 2 x 4 (5.23)
    np.testing.assert_array_equal(pm.R, np.diag([900.0, 9e-6]))


@pytest.mark.parametrize("origin", [(0.0, 0.0), "shifted"])
def test_polar_jacobian_is_the_derivative(origin):
    pm = PolarMeasurement(origin=ORIGIN if origin == "shifted" else origin)
    _, H = pm.predict(X)
    for i, h in ((0, 1e-2), (2, 1e-2)):
        e = np.zeros(5)
        e[i] = h
        num = pm.residual(pm.predict(X + e)[0], pm.predict(X - e)[0]) / (2 * h)
        # the finite differences' own accuracy (their rounding, eps r / h, is below 1e-8 relative here)
        np.testing.assert_allclose(H[:, :, i], num, rtol=1e-7, atol=1e-12)
    assert not H[:, :, [1, 3, 4]].any()  # range and azimuth depend on the position only


def test_azimuth_residual_is_wrapped():
    pm = PolarMeasurement()
    z = np.array([[1e4, 0.001], [1e4, 2 * np.pi - 0.001]])
    nu = pm.residual(z, np.array([[1e4 - 5, 2 * np.pi - 0.002], [1e4, 0.002]]))
    np.testing.assert_allclose(nu, [[5.0, 0.003], [0.0, -0.003]], atol=RTOL)  # m, rad


def test_converted_covariance_matches_linearised_monte_carlo():
    sensor = Sensor()
    rng = np.random.default_rng(1)
    x, y = 12_000.0, -15_000.0
    r, az = measure(sensor, np.full(200_000, x), np.full(200_000, y), rng)
    xy = np.column_stack([r * np.sin(az), r * np.cos(az)])
    rt, azt = cart_to_polar(np.array(x), np.array(y))
    cov = converted_covariance(rt, azt, 30.0, 3e-3)
    sample = np.cov(xy.T)
    np.testing.assert_allclose(cov, sample, rtol=0.02, atol=0.02 * np.abs(sample).max())


def test_two_point_matches_the_spec_formulas_and_noise_free_truth():
    pm = PolarMeasurement()
    z1 = np.array([[15_000.0, 0.3], [22_000.0, 4.0]])
    z2 = np.array([[15_300.0, 0.31], [21_800.0, 3.99]])
    T = np.array([2.0, 6.0])
    p1, _ = pm.position(z1)
    p2, cov2 = pm.position(z2)
    x, P = two_point(p1, p2, cov2, T)
    for k in range(2):
        xr, Pr = ref.two_point(z1[k], z2[k], T[k])
        np.testing.assert_allclose(x[k], xr, rtol=RTOL)
        np.testing.assert_allclose(P[k], Pr, rtol=RTOL)
    assert np.linalg.eigvalsh(P).min() > 0
    # a noise-free straight track gives back its position and velocity exactly
    truth = np.array([[9_000.0, 120.0, -12_000.0, -80.0]])
    a = truth[:, ::2] - 2.0 * truth[:, 1::2]
    z_a = np.column_stack(cart_to_polar(a[:, 0], a[:, 1]))
    z_b = np.column_stack(cart_to_polar(truth[:, 0], truth[:, 2]))
    x, _ = two_point(pm.position(z_a)[0], pm.position(z_b)[0], pm.position(z_b)[1], 2.0)
    np.testing.assert_allclose(x, truth, rtol=RTOL)


def test_position_measurement():
    R = ((100.0, 20.0), (20.0, 400.0))
    pos = PositionMeasurement(R)
    z, H = pos.predict(X)
    np.testing.assert_array_equal(z, X[:, [0, 2]])
    np.testing.assert_array_equal(H[0], [[1, 0, 0, 0, 0], [0, 0, 1, 0, 0]])
    np.testing.assert_array_equal(pos.position(z)[1][3], np.array(R))
    with pytest.raises(FilterError, match="not symmetric"):
        PositionMeasurement(((100.0, 20.0), (21.0, 400.0)))
    with pytest.raises(FilterError, match="not positive definite"):
        PositionMeasurement(((100.0, 300.0), (300.0, 400.0)))
    with pytest.raises(FilterError, match="shape"):
        PositionMeasurement(((100.0,),))


def test_polar_measurement_checks():
    with pytest.raises(FilterError, match="sigma_range"):
        PolarMeasurement(sigma_range=0.0)
    pm = PolarMeasurement.from_sensor(Sensor(sigma_range_m=10.0, sigma_azimuth_mrad=1.0))
    assert (pm.sigma_range, pm.sigma_azimuth) == (10.0, 1e-3)
    with pytest.raises(FilterError, match=r"non-finite value nan at index \(1, 1\)"):
        pm.validate("z", np.array([[1e4, 0.1], [1e4, math.nan]]))
    with pytest.raises(FilterError, match="range must be > 0"):
        pm.validate("z", np.array([[-1e4, 0.1]]))


def test_origin_model_computes_exactly_the_origin_formulas():
    """At (0, 0) no shift is computed: h and H are the pre-sensor expressions bit for bit, and the converted
    positions those expressions to RTOL (the compiled conversion takes libm's sine and cosine, numpy may take
    its SIMD ones on other CPUs)."""
    pm = PolarMeasurement(origin=(0.0, 0.0))
    assert pm == PolarMeasurement() and pm._shift is None
    z, H = pm.predict(X)
    r, az = cart_to_polar(X[:, 0], X[:, 2])
    np.testing.assert_array_equal(z, np.column_stack([r, az]))
    np.testing.assert_array_equal(H[:, 0, [0, 2]], X[:, [0, 2]] / r[:, None])
    np.testing.assert_array_equal(H[:, 1, [0, 2]], X[:, [2, 0]] * [1.0, -1.0] / (r * r)[:, None])
    xy, _ = pm.position(z)
    np.testing.assert_allclose(xy, np.column_stack(polar_to_cart(z[:, 0], z[:, 1])), rtol=RTOL)


@pytest.mark.parametrize("origin", [(0.0, 0.0), ORIGIN])
def test_compiled_position_is_the_numpy_conversion(origin):
    """`PolarMeasurement.position` (one compiled loop) against `polar_to_cart_at` and `converted_covariance`,
    for measurements of any leading shape; `PolarMeasurement.cartesian` gives position's positions."""
    pm = PolarMeasurement(sigma_range=25.0, sigma_azimuth=2e-3, origin=origin)
    rng = np.random.default_rng(7)
    z = np.stack([rng.uniform(100.0, 40_000.0, (3, 5)), rng.uniform(0.0, 2 * np.pi, (3, 5))], axis=-1)
    xy, cov = pm.position(z)
    assert xy.shape == (3, 5, 2) and cov.shape == (3, 5, 2, 2)
    np.testing.assert_allclose(xy, np.stack(polar_to_cart_at(origin, z[..., 0], z[..., 1]), axis=-1), rtol=RTOL,
                               atol=RTOL * 40_000.0)
    np.testing.assert_array_equal(pm.cartesian(z), xy)
    want = converted_covariance(z[..., 0], z[..., 1], 25.0, 2e-3)
    np.testing.assert_allclose(cov, want, rtol=RTOL, atol=RTOL * np.abs(want).max())
    one_xy, one_cov = pm.position(z[1, 2])  # a single measurement (2,)
    np.testing.assert_array_equal(one_xy, xy[1, 2])
    np.testing.assert_array_equal(one_cov, cov[1, 2])
    empty_xy, empty_cov = pm.position(np.empty((0, 2)))
    assert empty_xy.shape == (0, 2) and empty_cov.shape == (0, 2, 2) and pm.cartesian(np.empty((0, 2))).shape == (0, 2)


def test_shifted_polar_model_is_the_origin_model_on_shifted_states():
    shifted, at_origin = PolarMeasurement(origin=ORIGIN), PolarMeasurement()
    moved = X.copy()
    moved[:, 0] -= ORIGIN[0]
    moved[:, 2] -= ORIGIN[1]
    z, H = shifted.predict(X)
    z0, H0 = at_origin.predict(moved)
    np.testing.assert_allclose(z, z0, rtol=1e-9)
    np.testing.assert_allclose(H, H0, rtol=1e-9, atol=1e-9 * np.abs(H0).max())
    xy, cov = shifted.position(z)
    xy0, cov0 = at_origin.position(z)
    np.testing.assert_allclose(xy, xy0 + ORIGIN, rtol=1e-9)
    np.testing.assert_allclose(xy, X[:, [0, 2]], rtol=1e-9)  # back to the states' own positions
    np.testing.assert_array_equal(cov, cov0)  # the error ellipse only rotates with the azimuth
    np.testing.assert_array_equal(shifted.residual(z, z0), at_origin.residual(z, z0))
    one, _ = shifted.predict(X[0, :4])  # a single state (n,) works as a batch of one
    np.testing.assert_allclose(one, z[0], rtol=1e-9)




def test_models_from_sensors():
    radar = Sensor(name="west", x_m=-10_000.0, y_m=2_000.0, sigma_range_m=20.0, sigma_azimuth_mrad=2.0)
    pm = measurement_model(radar)
    assert isinstance(pm, PolarMeasurement) and pm == PolarMeasurement(20.0, 2e-3, (-10_000.0, 2_000.0))
    assert PolarMeasurement.from_sensor(Sensor()).origin == (0.0, 0.0)
    fix = Sensor(name="gps", kind="position", sigma_position_m=4.0)
    pos = measurement_model(fix)
    assert isinstance(pos, PositionMeasurement)
    np.testing.assert_array_equal(pos.R, [[16.0, 0.0], [0.0, 16.0]])
    with pytest.raises(FilterError, match="sensor 'gps' is a position sensor"):
        PolarMeasurement.from_sensor(fix)
    with pytest.raises(FilterError, match="sensor 'west' is a polar sensor"):
        PositionMeasurement.from_sensor(radar)
    with pytest.raises(FilterError, match="not positive definite"):
        measurement_model(Sensor(kind="position", sigma_position_m=0.0))


def test_polar_origin_checks():
    with pytest.raises(FilterError, match=r"PolarMeasurement.origin: non-finite value inf"):
        PolarMeasurement(origin=(math.inf, 0.0))
    with pytest.raises(FilterError, match=r"PolarMeasurement.origin: expected shape \(2\)"):
        PolarMeasurement(origin=(1.0, 2.0, 3.0))
    assert PolarMeasurement(origin=(1, 2)).origin == (1.0, 2.0)
