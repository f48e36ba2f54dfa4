"""nnda's batched filters against filterpy and a per-track loop, to 1e-9 relative, over generated trajectories.

Relative as in tolerances.py: a state entry within 1e-9 of its own size (or
of its standard deviation, for entries near zero), a covariance entry P_ij
within 1e-9 of sqrt(P_ii P_jj).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import reference_filters as ref
from filterpy.kalman import ExtendedKalmanFilter, IMMEstimator, KalmanFilter

from nnda.data.scenario import Segment, Sensor, Target
from nnda.data.sensor import measure, polar_to_cart
from nnda.data.trajectory import evaluate
from nnda.filters import kalman
from nnda.filters.imm import IMM
from nnda.filters.measurement import PolarMeasurement, PositionMeasurement
from nnda.filters.motion import ConstantVelocity, CoordinatedTurn
from nnda.filters.two_point import two_point
from tolerances import RTOL, assert_cov, assert_state

MANOEUVRING = Target(
    name="m", x_m=-8_000.0, y_m=14_000.0, heading_deg=100.0, speed_m_s=150.0,
    segments=[Segment(duration_s=40), Segment(duration_s=30, turn_rate_deg_s=3.0),
              Segment(duration_s=20, tangential_accel=2.0), Segment(duration_s=24, turn_rate_deg_s=-4.0),
              Segment(duration_s=26)],
)
#: scans without a detection (after the first two)
GAPS = {9, 16, 17, 31, 40, 41, 42}


def assert_measurement(actual, desired):
    """Predicted (range, azimuth): range relative, azimuth to RTOL rad (its own scale) after wrapping."""
    assert math.isclose(actual[0], desired[0], rel_tol=RTOL)
    assert abs(ref.polar_residual(actual, desired)[1]) < RTOL


def polar_track(seed: int = 0):
    """Scan times (s) and noisy polar measurements (n, 2) of MANOEUVRING, one per scan."""
    t = 2.0 * np.arange(1, int(MANOEUVRING.duration_s / 2) + 1)
    st = evaluate(MANOEUVRING, t)
    r, az = measure(Sensor(), st.x, st.y, np.random.default_rng(seed))
    return t, np.column_stack([r, az])


def detected_steps(t):
    """(time, index) of the detections after the first two, with the elapsed time since the previous one."""
    keep = [k for k in range(2, len(t)) if k + 1 not in GAPS]
    prev = [1, *keep[:-1]]
    return [(k, t[k] - t[p]) for k, p in zip(keep, prev)]


def test_cv_kalman_filter_with_position_fixes_matches_filterpy():
    t, z = polar_track(1)
    xy = np.column_stack(polar_to_cart(z[:, 0], z[:, 1]))
    R = np.array([[900.0, 150.0], [150.0, 2500.0]])
    cv, pos = ConstantVelocity(), PositionMeasurement(R)
    x, P = two_point(xy[:1], xy[1:2], R[None], t[1] - t[0])
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.x, kf.P, kf.R = x[0].copy(), P[0].copy(), R.copy()
    kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    for k, dt in detected_steps(t):
        x, P = kalman.predict(x, P, cv, dt)
        kf.predict(F=ref.cv_F(dt), Q=ref.cv_Q(dt))
        assert_state(x[0], kf.x, kf.P)
        assert_cov(P[0], kf.P)
        mp = kalman.predict_measurement(x, P, pos)
        x, P, nu = kalman.update(x, P, xy[k:k + 1], mp, pos)
        kf.update(xy[k])
        assert_state(nu[0], kf.y, kf.S)
        assert_cov(mp.S[0], kf.S)
        assert_state(x[0], kf.x, kf.P)
        assert_cov(P[0], kf.P)


@pytest.mark.parametrize("model", ["cv", "ct"])
def test_polar_ekf_matches_filterpy(model):
    t, z = polar_track(2)
    pm = PolarMeasurement()
    p1, _ = pm.position(z[:1])
    x, P = two_point(p1, *pm.position(z[1:2]), t[1] - t[0])
    mm = ConstantVelocity() if model == "cv" else CoordinatedTurn()
    x, P = mm.from_cv(x, P)
    ekf = ref.PolarEKF(model, x[0], P[0], sigma_q=mm.sigma_q)
    for k, dt in detected_steps(t):
        x, P = kalman.predict(x, P, mm, dt)
        ekf.dt = dt
        ekf.predict()
        assert_state(x[0], ekf.x, ekf.P)
        assert_cov(P[0], ekf.P)
        mp = kalman.predict_measurement(x, P, pm)
        x, P, _ = kalman.update(x, P, z[k:k + 1], mp, pm)
        ekf.update(z[k])
        assert_cov(mp.S[0], ekf.S)
        assert_state(x[0], ekf.x, ekf.P)
        assert_cov(P[0], ekf.P)
        assert math.isclose(
            kalman.gaussian_log_likelihood(
                kalman.mahalanobis_2x2(pm.residual(z[k], mp.z[0]), mp.S_inv[0]), mp.log_det_S[0]
            ),
            ekf.log_likelihood, rel_tol=1e-9,
        )


def test_plain_ekf_class_agrees_with_the_reference_glue():
    """The PolarEKF glue is filterpy's own EKF update with the spec's h and H (guards the reference itself)."""
    t, z = polar_track(3)
    x, P = ref.two_point(z[0], z[1], t[1] - t[0])
    glue = ref.PolarEKF("cv", x, P, sigma_q=3.5)
    plain = ExtendedKalmanFilter(dim_x=4, dim_z=2)
    plain.x, plain.P, plain.R = x.copy(), P.copy(), ref.R_POLAR.copy()
    for k in range(2, 12):
        glue.predict()
        plain.F, plain.Q = ref.cv_F(2.0), ref.cv_Q(2.0)
        plain.predict()
        glue.update(z[k])
        plain.update(z[k], ref.polar_H, ref.polar_h, residual=ref.polar_residual)
        np.testing.assert_array_equal(glue.x, plain.x)
        np.testing.assert_array_equal(glue.P, plain.P)


def run_against_imm_estimator(imm: IMM, filters: list, t, z):
    fp = IMMEstimator(filters, list(imm.mu0), np.array(imm.tpm))
    state = imm.initialise(z[:1], z[1:2], t[0], t[1])
    for k, dt in detected_steps(t):
        for f in filters:
            f.dt = dt
        fp.predict()
        pred = imm.predict(state, dt)
        state = imm.update(pred, z[k:k + 1])
        fp.update(z[k])
        for j, f in enumerate(filters):
            d = imm.models[j].dim
            assert_state(state.x[0, j, :d], f.x[:d], f.P[:d, :d])
            assert_cov(state.P[0, j, :d, :d], f.P[:d, :d])
        np.testing.assert_allclose(state.mu[0], fp.mu, rtol=RTOL)
        xc, Pc = imm.estimate(state)
        assert_state(xc[0], fp.x[:4], fp.P[:4, :4])
        assert_cov(Pc[0], fp.P[:4, :4])


def test_two_cv_imm_matches_filterpy_imm_estimator():
    t, z = polar_track(4)
    imm = IMM(models=(ConstantVelocity(3.5), ConstantVelocity(0.5)), tpm=((0.95, 0.05), (0.05, 0.95)))
    x0, P0 = ref.two_point(z[0], z[1], t[1] - t[0])
    filters = [ref.PolarEKF("cv", x0, P0, sigma_q=3.5), ref.PolarEKF("cv", x0, P0, sigma_q=0.5)]
    run_against_imm_estimator(imm, filters, t, z)


def test_spec_cv_ct_imm_matches_filterpy_with_cv_written_in_five_states():
    """With augmentation variance 0, a 5-state CV whose omega is forced to 0 is the spec's 4/5-state IMM."""
    t, z = polar_track(5)
    x0, P0 = ref.two_point(z[0], z[1], t[1] - t[0])
    x5 = np.append(x0, 0.0)
    P5 = np.pad(P0, ((0, 1), (0, 1)))
    P5_ct = P5.copy()
    P5_ct[4, 4] = ref.P_OMEGA
    filters = [ref.PolarEKF("cv5", x5, P5, sigma_q=3.5), ref.PolarEKF("ct", x5, P5_ct, sigma_q=5.0)]
    run_against_imm_estimator(IMM(), filters, t, z)


@pytest.mark.parametrize("aug_var", [0.0, ref.P_OMEGA])
def test_cv_ct_imm_matches_a_per_track_loop_with_missed_scans(aug_var):
    """Predict every scan (2 s); missed scans keep the prediction (mask False)."""
    t, z = polar_track(6)
    imm = IMM(augment_variance=aug_var)
    state = imm.initialise(z[:1], z[1:2], t[0], t[1])
    loop = ref.LoopIMM(*ref.two_point(z[0], z[1], 2.0), aug_var=aug_var)
    for k in range(2, len(t)):
        detected = k + 1 not in GAPS
        pred = imm.predict(state, 2.0)
        loop.predict(2.0)
        gate = imm.combined_measurement(pred)
        xc, Pc = loop.combined()
        H = ref.polar_H(xc)
        assert_measurement(gate.z[0], ref.polar_h(xc))
        assert_cov(gate.S[0], H @ Pc @ H.T + ref.R_POLAR)
        mixture = sum(loop.mu[j] * math.exp(ref.gauss_loglik(ref.polar_residual(z[k], zj), Sj))
                      for j, (zj, Sj) in enumerate(loop.measurement(j) for j in range(2)))
        assert math.isclose(imm.log_likelihood(pred, z[k:k + 1])[0, 0], math.log(mixture), rel_tol=1e-9)
        state = imm.update(pred, np.where(detected, z[k], np.nan)[None], np.array([detected]))
        loop.update(z[k] if detected else None)
        assert_state(state.x[0, 0, :4], loop.x[0], loop.P[0])
        assert_state(state.x[0, 1], loop.x[1], loop.P[1])
        assert_cov(state.P[0, 0, :4, :4], loop.P[0])
        assert_cov(state.P[0, 1], loop.P[1])
        np.testing.assert_allclose(state.mu[0], loop.mu, rtol=RTOL)
        xc, Pc = imm.estimate(state)
        lxc, lPc = loop.combined()
        assert_state(xc[0], lxc, lPc)
        assert_cov(Pc[0], lPc)
