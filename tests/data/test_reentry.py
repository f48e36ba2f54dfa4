"""The re-entry model of seed 004: spec B.6's deterministic checks, the data modes, impact and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.data.reentry import (
    ReentryConfig,
    air_density,
    converted_covariance,
    drag_acceleration,
    initial_distribution,
    noise_free_trajectory,
    simulate,
    to_polar,
    transition_jacobian,
    transition_mean,
)
from nnda.errors import ConfigError, validated

#: spec B.1's noise-free trajectory from m0: step -> [x, vx, y, vy]
SPEC_TRAJECTORY = {
    1: [227489.585, -2255.205, 87185.092, -417.254],
    10: [186896.502, -2255.118, 78087.059, -593.634],
    30: [96747.740, -2247.821, 46522.297, -982.719],
    45: [33207.475, -1664.832, 14633.850, -962.893],
    50: [20656.448, -853.816, 6955.552, -568.075],
    55: [14645.747, -411.403, 2538.763, -349.165],
    59: [12066.053, -249.089, 66.167, -277.275],
}


def test_air_density_at_the_spec_altitudes():
    assert air_density(0.0) == pytest.approx(1.227, rel=1e-12)
    assert air_density(9144.0) == pytest.approx(0.44908, abs=5e-6)
    assert air_density(np.nextafter(9144.0, 0.0)) == pytest.approx(0.45164, abs=5e-6)
    assert air_density(88000.0) == pytest.approx(3.5445e-6, rel=1e-4)


def test_initial_mean():
    m0, P0 = initial_distribution(ReentryConfig())
    np.testing.assert_allclose(m0, [232000.0, -2255.2098, 88000.0, -397.6543], rtol=0, atol=5e-5)
    np.testing.assert_array_equal(np.diag(P0), [100.0**2, 20.0**2, 100.0**2, 20.0**2])


def test_noise_free_trajectory_impact_and_peak_deceleration():
    cfg = ReentryConfig()
    states, impact = noise_free_trajectory(cfg)
    assert impact == 60
    for k, want in SPEC_TRAJECTORY.items():  # the table's three decimals: 1e-6 relative or half a millimetre
        np.testing.assert_allclose(states[k], want, rtol=1e-6, atol=5e-4)
    decel = np.linalg.norm(drag_acceleration(states, cfg), axis=-1)
    assert int(decel.argmax()) == 47
    assert decel.max() == pytest.approx(101.29, abs=5e-3)


def test_jacobian_matches_finite_differences():
    cfg = ReentryConfig()
    s = np.array([[30000.0, -1600.0, 9500.0, -900.0], [30000.0, -1600.0, 8000.0, -900.0]])
    J = transition_jacobian(s, cfg)
    h = np.array([1e-2, 1e-4, 1e-2, 1e-4])
    for i in range(4):
        e = np.zeros(4)
        e[i] = h[i]
        fd = (transition_mean(s + e, cfg) - transition_mean(s - e, cfg)) / (2 * h[i])
        np.testing.assert_allclose(J[..., :, i], fd, rtol=1e-6, atol=1e-9)


def test_converted_covariance_has_range_and_cross_range_eigenvalues():
    r, e = np.array([248100.0, 14900.0]), np.array([0.363, 0.1])
    R = converted_covariance(r, e, 200.0, 0.017)
    np.testing.assert_allclose(np.linalg.eigvalsh(R), np.sort(np.stack([np.full(2, 200.0**2), (r * 0.017) ** 2]), 0).T,
                               rtol=1e-9)


@pytest.mark.parametrize("mode", ["polar", "gaussian"])
def test_simulate_shapes_seed_and_measurements(mode):
    cfg = ReentryConfig(mode=mode)
    a, b = simulate(cfg, 20, 3), simulate(cfg, 20, 3)
    np.testing.assert_array_equal(a.z, b.z)
    assert a.truth.shape == (20, 56, 4) and a.z.shape == (20, 55, 2) and a.cov.shape == (20, 55, 2, 2)
    r, e = to_polar(a.z)
    np.testing.assert_allclose(a.polar, np.stack([r, e], -1), rtol=1e-12)
    np.testing.assert_allclose(a.cov, converted_covariance(r, e, cfg.sigma_r, cfg.sigma_eps), rtol=1e-12)
    # standardised converted errors: about unit variance in both modes (the covariance is the measured one)
    err = a.z - a.truth[:, 1:, ::2]
    d2 = np.einsum("rki,rkij,rkj->rk", err, np.linalg.inv(a.cov), err)
    assert 1.7 < d2.mean() < 2.3


def test_simulate_stops_at_ground_impact():
    data = simulate(ReentryConfig(steps=80), 30, 0)
    assert (data.impact > 0).all() and data.steps == data.impact.min() - 1
    assert (data.truth[..., 2] >= 0).all()
    assert 57 <= np.median(data.impact) <= 62  # spec B.1: impact at steps 58-61 (median 60)


@pytest.mark.parametrize("field, value", [("beta", 0.0), ("beta", -1.0), ("steps", 0), ("sigma_r", 0.0),
                                          ("mode", "cartesian")])
def test_bad_config_is_a_config_error_naming_the_field(field, value):
    with pytest.raises(ConfigError, match=field):
        validated(ReentryConfig, {field: value}, "reentry", "re-entry config")


def test_simulate_needs_a_run():
    with pytest.raises(ConfigError, match="runs"):
        simulate(ReentryConfig(), 0, 0)
