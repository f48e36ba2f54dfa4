"""The compiled IMM cycle (`nnda.filters.imm_kernels`, through `IMM`) against per-track references.

The references are the spec's single-track IMM written out in numpy
(`reference_filters.LoopIMM`) and brute-force loops over pairs; random states
come from hypothesis. Agreement is to RTOL (other summation orders), and the
kernels give the same bits when run twice.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
import reference_filters as ref
from hypothesis import given, settings
from hypothesis import strategies as st

from nnda.data.sensor import cart_to_polar
from nnda.errors import FilterError
from nnda.filters.ground_motion import ModifiedNCSHT
from nnda.filters.imm import IMM
from nnda.filters.measurement import PositionMeasurement
from nnda.filters.motion import ConstantVelocity
from tolerances import RTOL, assert_cov, assert_state

IMM_SPEC = IMM()


def random_tracks(seed: int, K: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K CV + CT IMM posteriors in the padded layout: x (K, 2, 5), P (K, 2, 5, 5), mu (K, 2); positions 5-25 km
    from the radar, speeds up to ~200 m/s, turn rates up to 8 deg/s (beyond CT's 5 deg/s limit)."""
    rng = np.random.default_rng(seed)
    r, b = rng.uniform(5e3, 2.5e4, K), rng.uniform(0, 2 * np.pi, K)
    x = np.zeros((K, 2, 5))
    x[:, :, 0], x[:, :, 2] = (r * np.sin(b))[:, None], (r * np.cos(b))[:, None]
    x[:, :, [1, 3]] = rng.normal(0, 120, (K, 1, 2))
    x[:, :, :4] += rng.normal(0, [30, 5, 30, 5], (K, 2, 4))  # the models disagree a little
    x[:, 1, 4] = rng.uniform(-0.14, 0.14, K)
    P = np.zeros((K, 2, 5, 5))
    for j, d in enumerate((4, 5)):
        A = rng.normal(0, 1, (K, d, d)) * np.array([40, 8, 40, 8, 0.02][:d])[:, None]
        P[:, j, :d, :d] = A @ A.swapaxes(-1, -2) + np.diag([400, 25, 400, 25, 1e-4][:d])
    mu = rng.dirichlet([1.0, 1.0], K)
    return x, P, mu


def loop_imm(x: np.ndarray, P: np.ndarray, mu: np.ndarray) -> ref.LoopIMM:
    """The reference single-track IMM holding one track's padded state."""
    loop = ref.LoopIMM(x[0, :4], P[0, :4, :4])
    loop.x, loop.P, loop.mu = [x[0, :4].copy(), x[1].copy()], [P[0, :4, :4].copy(), P[1].copy()], mu.copy()
    return loop


def assert_models(actual_x, actual_P, loop: ref.LoopIMM) -> None:
    for j, d in enumerate((4, 5)):
        assert_state(actual_x[j, :d], loop.x[j], loop.P[j])
        assert_cov(actual_P[j, :d, :d], loop.P[j])
    assert not actual_x[0, 4:].any() and not actual_P[0, 4:].any() and not actual_P[0, :, 4:].any()


cycles = settings(max_examples=25, deadline=None)


@cycles
@given(seed=st.integers(0, 2**32 - 1), K=st.integers(1, 12), dt=st.sampled_from([0.5, 2.0, 4.0, 6.0, 8.0]))
def test_predict_measure_update_estimate_equal_the_spec_loop(seed, K, dt):
    x, P, mu = random_tracks(seed, K)
    pred = IMM_SPEC.predict(IMM_SPEC.make_state(x, P, mu), dt)
    rng = np.random.default_rng(seed + 1)
    z = pred.measurement.z[:, 0] + rng.normal(0, [30.0, 3e-3], (K, 2))
    z[:, 1] %= 2 * np.pi
    post = IMM_SPEC.update(pred, z)
    xc, Pc = IMM_SPEC.estimate(post)
    for k in range(K):
        loop = loop_imm(x[k], P[k], mu[k])
        loop.predict(dt)
        assert_models(pred.state.x[k], pred.state.P[k], loop)
        np.testing.assert_allclose(pred.state.mu[k], loop.mu, rtol=RTOL)
        for j in range(2):
            zj, Sj = loop.measurement(j)
            np.testing.assert_allclose(pred.measurement.z[k, j], [zj[0], zj[1] % (2 * np.pi)], rtol=RTOL)
            assert_cov(pred.measurement.S[k, j], Sj)
            np.testing.assert_allclose(pred.measurement.S_inv[k, j] @ Sj, np.eye(2), atol=RTOL)
            np.testing.assert_allclose(pred.measurement.log_det_S[k, j], np.log(np.linalg.det(Sj)), rtol=RTOL)
        loop.update(z[k])
        assert_models(post.x[k], post.P[k], loop)
        np.testing.assert_allclose(post.mu[k], loop.mu, rtol=RTOL, atol=RTOL)
        x_ref, P_ref = loop.combined()
        assert_state(xc[k], x_ref, P_ref)
        assert_cov(Pc[k], P_ref)


@cycles
@given(seed=st.integers(0, 2**32 - 1), K=st.integers(1, 8), N=st.integers(0, 30), polar=st.booleans())
def test_gate_distances_equal_brute_force(seed, K, N, polar):
    imm = IMM_SPEC if polar else IMM(measurement=PositionMeasurement(((900.0, 50.0), (50.0, 400.0))))
    x, P, mu = random_tracks(seed, K)
    pred = imm.predict(imm.make_state(x, P, mu), 2.0)
    rng = np.random.default_rng(seed + 2)
    xy = pred.state.x[:, 0, 0:3:2][rng.integers(0, K, N)] + rng.normal(0, 300, (N, 2))
    Z = np.stack(cart_to_polar(xy[:, 0], xy[:, 1]), axis=-1) if polar else xy
    for mp in (imm.combined_measurement(pred), pred.measurement):
        d2 = imm.mahalanobis(mp, Z)
        assert d2.shape == (*mp.z.shape[:-1], N)
        zs, Ss = mp.z.reshape(-1, 2), mp.S.reshape(-1, 2, 2)
        for b, (zb, Sb) in enumerate(zip(zs, Ss)):
            for n in range(N):
                nu = ref.polar_residual(Z[n], zb) if polar else Z[n] - zb
                want = nu @ np.linalg.solve(Sb, nu)
                np.testing.assert_allclose(d2.reshape(-1, N)[b, n], want, rtol=RTOL, atol=RTOL)


def test_a_missed_track_keeps_its_prediction_and_the_cycle_repeats_bit_for_bit():
    x, P, mu = random_tracks(3, 9)
    state = IMM_SPEC.make_state(x, P, mu)

    def cycle() -> bytes:
        pred = IMM_SPEC.predict(state, np.linspace(2.0, 8.0, 9))
        mask = np.arange(9) % 3 != 0
        post = IMM_SPEC.update(pred, np.where(mask[:, None], pred.measurement.z[:, 1] + [20.0, 1e-3], np.nan), mask)
        for field in ("x", "P", "mu"):
            np.testing.assert_array_equal(getattr(post, field)[~mask], getattr(pred.state, field)[~mask])
        out = (*IMM_SPEC.estimate(post), *(getattr(pred.measurement, f) for f in ("z", "S", "S_inv", "log_det_S")))
        return hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in out)).digest()

    assert cycle() == cycle()


def test_a_model_the_compiled_cycle_does_not_know_is_refused_by_name():
    with pytest.raises(FilterError, match="IMM.models: .*ModifiedNCSHT"):
        IMM(models=(ConstantVelocity(), ModifiedNCSHT()), tpm=((0.9, 0.1), (0.1, 0.9)))
    with pytest.raises(FilterError, match="IMM.measurement"):
        IMM(measurement=object())


@cycles
@given(seed=st.integers(0, 2**32 - 1), K=st.integers(1, 12), polar=st.booleans())
def test_the_fused_prediction_measures_as_the_separate_step(seed, K, polar):
    """`IMM.predict`'s one-call kernel (`imm_kernels.predict`) gives the bits of `measurement_prediction`
    run on its predicted states, and of `estimate` and `measurement_prediction` of the combined prediction
    (``pred.gating``)."""
    imm = IMM_SPEC if polar else IMM(measurement=PositionMeasurement(((900.0, 50.0), (50.0, 400.0))))
    x, P, mu = random_tracks(seed, K)
    pred = imm.predict(imm.make_state(x, P, mu), np.linspace(0.5, 8.0, K))
    x_c, P_c = imm.estimate(pred.state)
    np.testing.assert_array_equal(pred.gating.x, x_c)
    np.testing.assert_array_equal(pred.gating.P, P_c)
    for mp, alone in ((pred.measurement, imm.measurement_prediction(pred.state.x, pred.state.P)),
                      (pred.gating.measurement, imm.measurement_prediction(x_c, P_c))):
        for field in ("z", "S", "S_inv", "log_det_S", "H", "PHt"):
            np.testing.assert_array_equal(getattr(mp, field), getattr(alone, field), err_msg=field)
