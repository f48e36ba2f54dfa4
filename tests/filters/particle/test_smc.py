"""Particle filters: on the linear-Gaussian model (drag off) every algorithm converges to the Kalman filter;
seeding, the float32 option, ESS-triggered resampling and the errors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from nnda.data.reentry import ReentryConfig, simulate
from nnda.errors import FilterError
from nnda.filters.particle.smc import SMCConfig, run_smc
from nnda.filters.reentry import converted_kf, reentry_ssm

#: the filters checked against the Kalman filter (every algorithm and option path), with systematic resampling
#: when the ESS falls below N / 2 unless said otherwise, and the bound on the time-averaged |PF - KF| / sd
ESS = {"resampling": "systematic", "ess_threshold": 0.5}
CONFIGS = {
    "bootstrap": (SMCConfig("bootstrap", **ESS), 0.05),
    "bootstrap-stratified-resampled-mean": (SMCConfig("bootstrap", resampling="stratified", ess_threshold=0.5,
                                                                  estimate="resampled"), 0.05),
    "optimal": (SMCConfig("optimal", **ESS), 0.05),
    "optimal-residual-resample-first": (SMCConfig("optimal", resample_first=True, resampling="residual"), 0.05),
    "auxiliary-paper": (SMCConfig("auxiliary", **ESS), 0.05),
    "auxiliary-standard-mean": (SMCConfig("auxiliary", auxiliary_form="standard", look_ahead="mean", **ESS), 0.05),
    "auxiliary-predictive": (SMCConfig("auxiliary", auxiliary_form="standard", look_ahead="predictive", **ESS), 0.05),
    "resample-move": (SMCConfig("resample-move", **ESS), 0.05),
    "bootstrap-float32": (SMCConfig("bootstrap", dtype="float32", **ESS), 0.05),
    # the paper's scheme: multinomial resampling at every step adds Monte Carlo noise (measured 0.05 here)
    "bootstrap-multinomial-every-step": (SMCConfig("bootstrap"), 0.1),
}
N = 20000


@pytest.fixture(scope="module")
def linear():
    """Drag off (spec B.6, 3): the linear-Gaussian model with the paper's sensor, 2 runs of 15 steps, and its
    exact Kalman filter."""
    data = simulate(ReentryConfig(drag=False, steps=15), 2, 4)
    return reentry_ssm(data), converted_kf(data)


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_particle_filter_matches_the_kalman_filter(linear, name):
    model, kf = linear
    base, bound = CONFIGS[name]
    cfg = SMCConfig(**{**base.__dict__, "n_particles": N})
    out = run_smc(model, cfg, np.random.default_rng(11))
    sd = np.sqrt(np.diagonal(kf.cov, axis1=-2, axis2=-1))
    err = np.abs(out.mean - kf.mean) / sd  # (R, K, 4) in posterior standard deviations
    assert err.mean(axis=(0, 1)).max() < bound, f"{name}: mean |PF - KF| / sd per component {err.mean((0, 1))}"
    # the evidence estimate: log p-hat(y_1:K) near the Kalman filter's exact log-likelihood
    np.testing.assert_allclose(out.log_evidence, kf.log_likelihood, atol=0.2)
    assert out.ess.shape == out.resampled.shape == (2, 15)
    assert ((out.ess > 0) & (out.ess <= N * (1 + 1e-9))).all()


def test_ess_threshold_resamples_only_when_needed(linear):
    model, _ = linear
    every = run_smc(model, SMCConfig(n_particles=500), 0)
    some = run_smc(model, SMCConfig(n_particles=500, ess_threshold=0.3), 0)
    assert every.resampled.all() and not some.resampled.all()
    assert (some.ess[some.resampled] < 0.3 * 500).all() and (some.ess[~some.resampled] >= 0.3 * 500).all()


def test_sis_is_the_bootstrap_step_without_resampling(linear):
    """SIS never resamples; its first step (before any resampling) is the bootstrap filter's weighted mean with
    the same draws, and over many steps its weights degenerate (lower ESS than the bootstrap filter's)."""
    model, _ = linear
    sis = run_smc(model, SMCConfig("sis", n_particles=500), 0)
    boot = run_smc(model, SMCConfig("bootstrap", n_particles=500), 0)
    assert not sis.resampled.any() and boot.resampled.all()
    np.testing.assert_array_equal(sis.mean[:, 0], boot.mean[:, 0])
    assert sis.ess[:, -1].mean() < boot.ess[:, -1].mean()


def test_resample_move_records_its_acceptance(linear):
    model, _ = linear
    out = run_smc(model, SMCConfig("resample-move", n_particles=300, moves=2), 0)
    assert out.acceptance.shape == (2, 15) and ((out.acceptance > 0) & (out.acceptance < 1)).all()


def test_same_seed_same_result_and_float32(linear):
    model, _ = linear
    a, b = (run_smc(model, SMCConfig("optimal", n_particles=200), 3) for _ in range(2))
    np.testing.assert_array_equal(a.mean, b.mean)
    f = run_smc(model, SMCConfig("optimal", n_particles=200, dtype="float32"), 3)
    assert f.mean.dtype == np.float64 and np.isfinite(f.mean).all()


@dataclass(frozen=True)
class Unreachable:
    """The linear model, except that step 3's measurement has zero likelihood everywhere."""

    base: object

    def __getattr__(self, name):
        return getattr(self.base, name)

    def log_likelihood(self, k, x):
        ll = self.base.log_likelihood(k, x)
        return np.full_like(ll, -np.inf) if k == 3 else ll


def test_weights_that_all_underflow_name_the_step(linear):
    model, _ = linear
    for algorithm in ("bootstrap", "auxiliary", "resample-move"):
        with pytest.raises(FilterError, match=r"step 3: every particle weight of run\(s\) \[0, 1\] underflowed"):
            run_smc(Unreachable(model), SMCConfig(algorithm, n_particles=50), 0)


@pytest.mark.parametrize("kwargs, match", [
    ({"n_particles": 0}, "n_particles: must be an integer >= 1"),
    ({"algorithm": "sir"}, "algorithm: unknown 'sir'"),
    ({"resampling": "sorted"}, "unknown resampling scheme 'sorted'"),
    ({"ess_threshold": 0.0}, "ess_threshold"),
    ({"dtype": "float16"}, "dtype"),
    ({"moves": 0}, "moves"),
])
def test_bad_config(kwargs, match):
    with pytest.raises(FilterError, match=match):
        SMCConfig(**kwargs)


def test_optimal_needs_a_model_with_a_proposal(linear):
    model, _ = linear

    @dataclass(frozen=True)
    class NoProposal(Unreachable):
        def __getattr__(self, name):
            if name == "optimal_proposal":
                raise AttributeError(name)
            return getattr(self.base, name)

        def log_likelihood(self, k, x):
            return self.base.log_likelihood(k, x)

    with pytest.raises(FilterError, match="has no optimal proposal"):
        run_smc(NoProposal(model), SMCConfig("optimal", n_particles=10), 0)
