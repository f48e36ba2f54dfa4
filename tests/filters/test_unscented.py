"""The batched unscented transform against filterpy's sigma points and transform, and the EKF on a linear model."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, unscented_transform

from nnda.errors import FilterError
from nnda.filters import kalman, unscented
from nnda.filters.measurement import PolarMeasurement, PositionMeasurement
from nnda.filters.unscented import UnscentedTransform

RADAR = PolarMeasurement(30.0, 3e-3)


def states(k: int = 12, seed: int = 0, n: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """k states [x, vx, y, vy(, omega)] 6-25 km from the radar with varied, correlated covariances."""
    rng = np.random.default_rng(seed)
    r, az = rng.uniform(6_000, 25_000, k), rng.uniform(0.2, 2 * np.pi - 0.2, k)
    x = np.zeros((k, n))
    x[:, 0], x[:, 2] = r * np.sin(az), r * np.cos(az)
    x[:, 1], x[:, 3] = rng.normal(0, 150, (2, k))
    A = rng.normal(0, 1, (k, n, n)) * np.array([300.0, 30.0, 300.0, 30.0, 0.01][:n])[:, None]
    return x, A @ A.swapaxes(1, 2) + np.diag([100.0, 10.0, 100.0, 10.0, 1e-4][:n])


@pytest.mark.parametrize("alpha, beta, kappa", [(1.0, 2.0, 0.0), (0.5, 2.0, 0.0), (1.0, 0.0, 8.0), (0.3, 2.0, 1.0)])
def test_sigma_points_and_weights_match_filterpy(alpha, beta, kappa):
    x, P = states()
    ut = UnscentedTransform(alpha, beta, kappa)
    X = ut.sigma_points(x, P)
    _, wm, wc = ut.weights(4)
    ref = MerweScaledSigmaPoints(4, alpha, beta, kappa)
    np.testing.assert_allclose(wm, ref.Wm, rtol=1e-9)
    np.testing.assert_allclose(wc, ref.Wc, rtol=1e-9)
    for k in range(len(x)):
        np.testing.assert_allclose(X[k], ref.sigma_points(x[k], P[k]), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("n", [4, 5])
def test_polar_prediction_matches_filterpys_transform(n):
    x, P = states(n=n)
    ut = UnscentedTransform()
    mp = unscented.predict_measurement(x, P, RADAR, ut)
    ref = MerweScaledSigmaPoints(n, ut.alpha, ut.beta, ut.kappa)
    for k in range(len(x)):
        sig = ref.sigma_points(x[k], P[k])
        Z = RADAR.predict(sig)[0]
        z, S = unscented_transform(Z, ref.Wm, ref.Wc, RADAR.R)  # azimuths away from the 0 / 2 pi seam
        C = np.einsum("s,si,sj->ij", ref.Wc, sig - x[k], Z - z)
        np.testing.assert_allclose(mp.z[k], z, rtol=1e-9)
        np.testing.assert_allclose(mp.S[k], S, rtol=1e-9)
        np.testing.assert_allclose(mp.PHt[k], C, rtol=1e-9, atol=1e-9 * np.abs(C).max())
        np.testing.assert_allclose(mp.S_inv[k], np.linalg.inv(S), rtol=1e-9)
        np.testing.assert_allclose(mp.log_det_S[k], np.log(np.linalg.det(S)), rtol=1e-9)
        np.testing.assert_allclose(P[k] @ mp.H[k].T, C, rtol=1e-9, atol=1e-9 * np.abs(C).max())


def test_equals_the_ekf_on_a_linear_measurement():
    x, P = states()
    lin = PositionMeasurement(((900.0, 50.0), (50.0, 400.0)))
    ekf = kalman.predict_measurement(x, P, lin)
    ukf = unscented.predict_measurement(x, P, lin, UnscentedTransform(0.5, 2.0, 1.0))
    for a, b in zip((ukf.z, ukf.S, ukf.S_inv, ukf.log_det_S, ukf.H, ukf.PHt),
                    (ekf.z, ekf.S, ekf.S_inv, ekf.log_det_S, ekf.H, ekf.PHt)):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9 * np.abs(b).max())


def test_azimuths_across_north_wrap():
    """A target just east of north: sigma points straddle azimuth 0 / 2 pi, the prediction does not."""
    x = np.array([[5.0, 0.0, 15_000.0, 100.0]])
    P = np.diag([400.0, 100.0, 400.0, 100.0])[None]
    ukf = unscented.predict_measurement(x, P, RADAR)
    ekf = kalman.predict_measurement(x, P, RADAR)
    assert abs(RADAR.residual(ukf.z, ekf.z)[0, 1]) < 1e-6
    sd = np.sqrt(np.diag(ekf.S[0]))
    np.testing.assert_allclose(ukf.S[0], ekf.S[0], rtol=1e-3, atol=1e-3 * sd.prod())


def test_bad_parameters_and_covariances():
    with pytest.raises(FilterError, match="alpha"):
        UnscentedTransform(alpha=0.0)
    with pytest.raises(FilterError, match="n \\+ kappa must be > 0"):
        UnscentedTransform(kappa=-4.0).weights(4)
    x, P = states(k=1)
    with pytest.raises(FilterError, match="not positive definite"):
        UnscentedTransform().sigma_points(x, -P)
