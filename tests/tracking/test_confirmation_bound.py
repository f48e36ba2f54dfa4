"""The clairvoyant SPRT's confirmation delay (`nnda.tracking.confirmation_bound`) against a Monte Carlo
brute force: the target's score walk simulated contact by contact."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nnda.tracking.confirmation_bound import (
    clairvoyant_delay_s,
    contact_log_ratio_mean,
    delay_bound_s,
    expected_tests,
    gated_mean_square,
    scan_drift,
)
from nnda.tracking.lifecycle import LifecycleConfig, sprt_thresholds
from nnda.tracking.marginals import log_miss_weight

PD, GATE = 0.9, 9.21
LOG_DET_S = 2 * math.log(30.0 * 45.0)  # S = R: 30 m range noise, 3 mrad at 15 km


def _walk(rng, n_runs, start, lower, upper, pd_true, density, max_tests=400):
    """Brute force: each run's score from ``start`` until it leaves (lower, upper); returns the tests taken
    and the final scores."""
    tail = math.exp(-GATE / 2)
    peak = math.log(PD / density) - math.log(2 * math.pi) - 0.5 * LOG_DET_S
    score = np.full(n_runs, start)
    tests = np.zeros(n_runs, np.int64)
    live = np.ones(n_runs, bool)
    for _ in range(max_tests):
        hit = rng.random(n_runs) < pd_true * (1 - tail)
        d2 = -2 * np.log1p(-rng.random(n_runs) * (1 - tail))  # chi-square 2 dof, truncated to the gate
        step = np.where(hit, peak - 0.5 * d2, log_miss_weight(PD, GATE))
        score = np.where(live, score + step, score)
        tests += live
        live &= (score > lower) & (score < upper)
        if not live.any():
            return tests, score
    raise AssertionError("a walk never ended")


def test_gated_mean_square_is_the_truncated_chi_square_mean():
    rng = np.random.default_rng(1)
    d2 = rng.chisquare(2, 400_000)
    inside = d2[d2 < GATE]
    assert gated_mean_square(GATE) == pytest.approx(inside.mean(), abs=4 * inside.std() / math.sqrt(inside.size))
    assert gated_mean_square(1e6) == pytest.approx(2.0, rel=1e-9)


@pytest.mark.parametrize("density", [8.7e-8, 8.7e-7])  # 100 and 1,000 clutter in the presets' 34 km square
@pytest.mark.parametrize("pd_true", [1.0, 0.8])
def test_expected_tests_bound_the_monte_carlo_walk(density, pd_true):
    """Wald's identity: the walk's mean increment is the closed-form drift, and its mean number of tests lies
    between Wald's E[N] (overshoot neglected) and E[N] plus one largest step over the drift."""
    lower, upper = sprt_thresholds(1e-6, 1e-3)
    start = math.log(PD / (7.46e5 * density))  # the two-point start over the presets' initiation annulus
    mu = scan_drift(pd_true, PD, GATE, LOG_DET_S, density)
    tests, score = _walk(np.random.default_rng(7), 20_000, start, lower, upper, pd_true, density)
    n = expected_tests(start, lower, upper, mu, 1e-3)
    peak = math.log(PD / density) - math.log(2 * math.pi) - 0.5 * LOG_DET_S
    sem = tests.std() / math.sqrt(tests.size)
    assert n - 4 * sem <= tests.mean() <= n + peak / mu + 4 * sem
    increments = (score - start).sum() / tests.sum()
    assert increments == pytest.approx(mu, rel=0.02)
    assert (score >= upper).mean() > 0.99  # a target's track is confirmed, as beta says


def test_denser_clutter_costs_drift_and_delay():
    lower, upper = sprt_thresholds(1e-6, 1e-3)
    delays = []
    for density in (8.7e-8, 8.7e-7):
        mu = scan_drift(1.0, PD, GATE, LOG_DET_S, density)
        assert mu == pytest.approx((1 - math.exp(-GATE / 2)) * contact_log_ratio_mean(PD, GATE, LOG_DET_S, density)
                                   + math.exp(-GATE / 2) * log_miss_weight(PD, GATE), rel=1e-9)
        start = math.log(PD / (7.46e5 * density))
        delays.append(delay_bound_s(expected_tests(start, lower, upper, mu, 1e-3), 2.0))
    # ten times the clutter: every contact's ratio and the start's fall by ln 10 each
    assert delays[1] > delays[0] > 2.0 * 2.0
    with pytest.raises(ValueError, match="drift"):
        expected_tests(0.0, lower, upper, -0.1, 1e-3)


def test_clairvoyant_delay_composes_the_steps_with_the_rules_thresholds():
    cfg = LifecycleConfig()
    density, r = 8.7e-7, 17_500.0
    lds = 2 * math.log(30.0 * 3e-3 * r)
    start = math.log(PD / (cfg.window_area(2.0, 30.0) * density))
    mu = scan_drift(1.0, PD, GATE, lds, density)
    lower, upper = sprt_thresholds(cfg.false_confirmation, cfg.false_deletion)
    want = delay_bound_s(expected_tests(start, lower, upper, mu, cfg.false_deletion), 2.0)
    assert clairvoyant_delay_s("score", cfg, density, r, 30.0, 3e-3, 2.0) == pytest.approx(want, rel=1e-9)
    # the existence rule: a lower start (the birth prior) and threshold, and the survival's loss per scan
    area = math.pi * (30e3**2 - 5e3**2)
    birth = math.log(PD * cfg.new_targets_per_scan / area / density)
    n = ((1 - 1e-3) * (math.log(99.0) - start - birth) + 1e-3 * math.log(0.1 / (1 - 1e-6))) / (mu + math.log(0.995))
    assert clairvoyant_delay_s("existence", cfg, density, r, 30.0, 3e-3, 2.0, coverage_m2=area) == pytest.approx(
        (1 + n) * 2.0, rel=1e-9)
    with pytest.raises(ValueError, match="rule"):
        clairvoyant_delay_s("mn", cfg, density, r, 30.0, 3e-3, 2.0)
