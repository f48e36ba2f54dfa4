"""Filter consistency over Monte Carlo runs: NEES and NIS against their chi-square 95% bands.

Runs are the K tracks of one batch. A filter is checked on a truth that
follows its own model (the matched case):

* CV with the spec's sigma_q = 3.5 m/s^2 on trajectories drawn from the CV
  white-noise-acceleration model;
* CT with the spec's sigma_q = 5 m/s^2 on trajectories drawn from the spec's
  second-order CT model; the turn-rate noise is lowered to 0.001 rad/s in
  truth and filter alike, because the spec's 0.044 rad/s random walk would
  take the turn rate far past omega_max within a few scans;
* CV with sigma_q = 0 on a noise-free straight trajectory of nnda.data.

Criteria: at most the binomial 99.9% quantile of steps may have their
run-averaged NEES / NIS outside the 95% band (about 5% of steps are
expected to); the NIS averaged over all runs and steps lies in its 99%
band (matched innovations are white); and the mean NEES is within 2.576
standard errors (99%) of the state size. The pooled averages use 99% so
that each check raises a false alarm once in a hundred seeds, not once in
twenty. Both averages leave out the first BURN_IN steps:
the two-point start is not drawn from the truth's distribution (for CT,
P_omega spans +-5 deg/s while the truth turns at a fixed 2 deg/s), so the
first few scans are conservative by design. The spec's IMM on the generator's noise-free
CV, turn and acceleration trajectories is not a matched case (its process
noise is sized for manoeuvres); there it must be conservative on average.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import reference_filters as ref
from scipy.stats import binom, chi2

from nnda.data.generator import generate_runs
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Sensor, Target
from nnda.data.sensor import measure
from nnda.data.trajectory import evaluate
from nnda.filters import kalman
from nnda.filters.imm import IMM
from nnda.filters.measurement import PolarMeasurement
from nnda.filters.motion import ConstantVelocity, CoordinatedTurn
from nnda.filters.two_point import two_point

T = 2.0
#: steps after the two-point start left out of the run-and-step averages (see the module docstring)
BURN_IN = 5
START = Target(name="start", x_m=-6_000.0, y_m=14_000.0, heading_deg=60.0, speed_m_s=150.0,
               segments=[Segment(duration_s=2.0)])


def nees(err: np.ndarray, P: np.ndarray) -> np.ndarray:
    return (err * np.linalg.solve(P, err[..., None])[..., 0]).sum(axis=-1)


def start_state() -> np.ndarray:
    st = evaluate(START, np.array([0.0]))
    return np.array([st.x[0], st.vx[0], st.y[0], st.vy[0]])


def simulate(f, x0: np.ndarray, sigmas: np.ndarray, runs: int, scans: int, rng) -> np.ndarray:
    """Truth (runs, scans, n) from x_{k+1} = f(x_k) + Gamma w, w ~ N(0, diag(sigmas^2)) (eqs. 5.9 / 5.14)."""
    n = len(x0)
    G = np.zeros((n, len(sigmas)))
    G[[0, 2], [0, 1]] = T**2 / 2
    G[[1, 3], [0, 1]] = T
    if n == 5:
        G[4, 2] = T
    X = np.empty((runs, scans, n))
    X[:, 0] = x0
    for k in range(1, scans):
        X[:, k] = np.array([f(x, T) for x in X[:, k - 1]]) + (rng.standard_normal((runs, len(sigmas))) * sigmas) @ G.T
    return X


def filter_runs(model, Z: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Run one EKF per run (batched) from a two-point start; NEES and NIS per (run, step)."""
    pm = PolarMeasurement()
    p1, _ = pm.position(Z[:, 0])
    x, P = model.from_cv(*two_point(p1, *pm.position(Z[:, 1]), T))
    ne, ni = [], []
    for k in range(2, Z.shape[1]):
        x, P = kalman.predict(x, P, model, T)
        mp = kalman.predict_measurement(x, P, pm)
        x, P, nu = kalman.update(x, P, Z[:, k], mp, pm)
        ni.append(kalman.mahalanobis_2x2(nu, mp.S_inv))
        ne.append(nees(X[:, k] - x, P))
    return np.array(ne).T, np.array(ni).T


def polar(X: np.ndarray, rng) -> np.ndarray:
    r, az = measure(Sensor(), X[..., 0], X[..., 2], rng)
    return np.stack([r, az], axis=-1)


def assert_consistent(ne: np.ndarray, ni: np.ndarray, n: int) -> None:
    runs, steps = ne.shape
    allowed = binom.ppf(0.999, steps, 0.05)
    for values, dof in ((ne.mean(axis=0), n), (ni.mean(axis=0), 2)):
        lo, hi = chi2.ppf([0.025, 0.975], runs * dof) / runs
        outside = int(((values < lo) | (values > hi)).sum())
        assert outside <= allowed, f"{outside} of {steps} steps outside [{lo:.3f}, {hi:.3f}]: {values.round(2)}"
    settled = ni[:, BURN_IN:]
    lo, hi = chi2.ppf([0.005, 0.995], settled.size * 2) / settled.size
    assert lo <= settled.mean() <= hi, f"mean NIS {settled.mean():.4f} outside [{lo:.4f}, {hi:.4f}]"
    per_run = ne[:, BURN_IN:].mean(axis=1)
    assert abs(per_run.mean() - n) < 2.576 * per_run.std(ddof=1) / math.sqrt(runs), f"mean NEES {per_run.mean():.3f}"


@pytest.mark.parametrize("runs", [200, pytest.param(2000, marks=pytest.mark.slow)])
def test_cv_filter_is_consistent_on_its_own_model(runs):
    rng = np.random.default_rng(100 + runs)
    X = simulate(lambda x, dt: ref.cv_F(dt) @ x, start_state(), np.array([3.5, 3.5]), runs, 40, rng)
    assert_consistent(*filter_runs(ConstantVelocity(), polar(X, rng), X), 4)


@pytest.mark.parametrize("runs", [200, pytest.param(2000, marks=pytest.mark.slow)])
def test_ct_filter_is_consistent_on_its_own_model(runs):
    rng = np.random.default_rng(200 + runs)
    x0 = np.append(start_state(), math.radians(-2.0))
    X = simulate(ref.ct_f, x0, np.array([5.0, 5.0, 0.001]), runs, 40, rng)
    assert_consistent(*filter_runs(CoordinatedTurn(sigma_omega=0.001), polar(X, rng), X), 5)


def scenario(name: str, segments: list[Segment]) -> Scenario:
    return Scenario(
        name=name, duration_s=sum(s.duration_s for s in segments),
        targets=[START.model_copy(update=dict(name="a", segments=segments))],
        clutter=Clutter(law="none"), process_noise=ProcessNoise(model="none"),
    )


def generated(sc: Scenario, runs: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Truth [x, vx, y, vy] per scan (S, 4) and the runs' polar detections (runs, S, 2), one per scan."""
    sets = list(generate_runs(sc, range(runs), seed=seed))
    tr = sets[0].truth
    Z = np.stack([np.column_stack([d.detections.range, d.detections.azimuth]) for d in sets])
    assert Z.shape == (runs, len(tr.scan), 2), "every scan must hold exactly the target's detection"
    return np.column_stack([tr.x, tr.vx, tr.y, tr.vy]), Z


def test_noise_free_cv_trajectory_with_a_noise_free_cv_filter():
    X, Z = generated(scenario("cv", [Segment(duration_s=100.0)]), 200, seed=7)
    assert_consistent(*filter_runs(ConstantVelocity(sigma_q=0.0), Z, np.broadcast_to(X, Z.shape[:2] + (4,))), 4)


def imm_runs(imm: IMM, X: np.ndarray, Z: np.ndarray):
    """NEES of the combined estimate, NIS of the combined prediction, CT probability and CT turn rate."""
    runs = len(Z)
    state = imm.initialise(Z[:, 0], Z[:, 1], T, 2 * T)
    ne, ni, mu_ct, omega = [], [], [], []
    for k in range(2, Z.shape[1]):
        pred = imm.predict(state, T)
        ni.append(imm.mahalanobis(imm.combined_measurement(pred), Z[:, k])[np.arange(runs), np.arange(runs)])
        state = imm.update(pred, Z[:, k])
        x, P = imm.estimate(state)
        ne.append(nees(X[k] - x, P))
        mu_ct.append(state.mu[:, 1])
        omega.append(state.x[:, 1, 4])
    return (np.array(a).T for a in (ne, ni, mu_ct, omega))


@pytest.mark.parametrize("segments", [
    [Segment(duration_s=120.0)],
    [Segment(duration_s=30.0), Segment(duration_s=60.0, turn_rate_deg_s=3.0), Segment(duration_s=30.0)],
    [Segment(duration_s=30.0), Segment(duration_s=20.0, tangential_accel=2.5), Segment(duration_s=30.0)],
], ids=["cv", "turn", "acceleration"])
def test_spec_imm_is_conservative_on_generated_trajectories(segments):
    X, Z = generated(scenario("imm", segments), 100, seed=3)
    ne, ni, _, _ = imm_runs(IMM(), X, Z)
    runs = len(Z)
    assert ne.mean() < chi2.ppf(0.975, runs * ne.shape[1] * 4) / (runs * ne.shape[1])
    assert ni.mean() < chi2.ppf(0.975, ni.size * 2) / ni.size


def test_ct_probability_rises_during_a_turn_and_omega_has_the_turn_sign():
    """A right turn (positive in configs) has omega < 0 in the filter (counter-clockwise positive)."""
    turn = Segment(duration_s=50.0, turn_rate_deg_s=4.0)
    X, Z = generated(scenario("turn", [Segment(duration_s=70.0), turn, Segment(duration_s=80.0)]), 50, seed=1)
    _, _, mu_ct, omega = imm_runs(IMM(), X, Z)
    time = T * np.arange(3, Z.shape[1] + 1)
    straight = ((time >= 30) & (time <= 70)) | (time >= 150)
    turning = (time >= 80) & (time <= 120)
    assert mu_ct[:, straight].mean() < 0.1
    assert mu_ct[:, turning].mean() > 0.5
    assert (mu_ct[:, turning].mean(axis=1) > mu_ct[:, straight].mean(axis=1)).all()
    rate = np.degrees(omega[:, turning].mean())
    assert -4.5 < rate < -2.5
