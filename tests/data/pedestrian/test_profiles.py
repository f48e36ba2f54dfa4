"""The heading-deviation profiles of Frencl (2014): variances, densities, samplers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from nnda.data.pedestrian.profiles import HeadingProfile
from nnda.errors import ConfigError

N_DRAWS = 200_000


@pytest.mark.parametrize("kind, parameter, expected", [
    ("leaf", 7.0, 0.0408), ("leaf", 2.0, 0.476), ("leaf", 3.0, 0.221), ("leaf", 5.0, 0.080),
    ("drop", 10.0, 1.789), ("drop", 2.0, 2.750), ("drop", 100.0, 1.051), ("drop", 1000.0, 0.713),
])
def test_closed_form_variances_are_the_spec_table(kind, parameter, expected):
    assert HeadingProfile(kind, parameter).variance() == pytest.approx(expected, abs=6e-4)


@pytest.mark.parametrize("kind, parameter", [("leaf", 7.0), ("leaf", 2.0), ("drop", 10.0), ("drop", 400.0),
                                             ("balloon", 0.5), ("balloon", 1.0)])
def test_sample_variance_matches_the_closed_form_within_monte_carlo_error(kind, parameter):
    prof = HeadingProfile(kind, parameter)
    d = prof.sample(np.random.default_rng(2014), N_DRAWS)
    # the standard error of a sample variance of a zero-mean law: sqrt((E d^4 - var^2) / n)
    fourth = integrate.quad(lambda x: x**4 * float(prof.density(x)), -math.inf if kind == "balloon" else -math.pi,
                            math.inf if kind == "balloon" else math.pi, limit=200)[0]
    se = math.sqrt((fourth - prof.variance() ** 2) / N_DRAWS)
    assert abs(np.mean(d * d) - prof.variance()) < 4 * se
    assert abs(d.mean()) < 4 * math.sqrt(prof.variance() / N_DRAWS)


@pytest.mark.parametrize("kind, parameter", [("leaf", 7.0), ("leaf", 0.9), ("drop", 1.5), ("drop", 1000.0),
                                             ("balloon", 0.45), ("balloon", 2.0)])
def test_densities_integrate_to_one_and_are_the_cdf_derivative(kind, parameter):
    prof = HeadingProfile(kind, parameter)
    lo, hi = (-math.inf, math.inf) if kind == "balloon" else (-math.pi, math.pi)
    total = integrate.quad(lambda x: float(prof.density(x)), lo, 0, limit=200)[0] + \
        integrate.quad(lambda x: float(prof.density(x)), 0, hi, limit=200)[0]
    assert total == pytest.approx(1.0, abs=1e-9)
    x = np.linspace(-3.0, 3.0, 13) + 0.01
    h = 1e-6
    np.testing.assert_allclose((prof.cdf(x + h) - prof.cdf(x - h)) / (2 * h), prof.density(x), rtol=1e-5, atol=1e-8)
    if kind != "balloon":
        assert prof.cdf(-math.pi) == pytest.approx(0.0, abs=1e-12) and prof.cdf(math.pi) == pytest.approx(1.0)
        assert float(prof.density(3.2)) == 0.0


@pytest.mark.parametrize("kind, parameter", [("leaf", 3.0), ("drop", 10.0), ("balloon", 1.0)])
def test_sampler_follows_its_law_kolmogorov_smirnov(kind, parameter):
    prof = HeadingProfile(kind, parameter)
    d = prof.sample(np.random.default_rng(7), 20_000)
    assert stats.kstest(d, prof.cdf).pvalue > 0.01


def test_quantile_inverts_the_cdf_and_samples_are_seeded():
    for kind, p in (("leaf", 7.0), ("drop", 10.0), ("balloon", 0.3)):
        prof = HeadingProfile(kind, p)
        u = np.linspace(0.001, 0.999, 101)
        np.testing.assert_allclose(prof.cdf(prof.quantile(u)), u, rtol=1e-9, atol=1e-12)
        a = prof.sample(np.random.default_rng(3), (4, 5))
        assert a.shape == (4, 5) and np.array_equal(a, prof.sample(np.random.default_rng(3), (4, 5)))


@pytest.mark.parametrize("kind, parameter, message", [
    ("drop", 1.0, "drop.*n must be a finite number > 1"), ("leaf", 0.0, "lambda must be"),
    ("balloon", float("nan"), "sigma must be"), ("wedge", 1.0, "kind must be one of drop, leaf, balloon"),
])
def test_bad_parameters_are_named(kind, parameter, message):
    with pytest.raises(ConfigError, match=message):
        HeadingProfile(kind, parameter)
