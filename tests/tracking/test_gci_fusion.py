"""Generalised covariance intersection of two GM-PHDs (`nnda.tracking.phd.fusion.gci`) against the closed form
of the weighted geometric mean of two Gaussians, evaluated pointwise."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from nnda.errors import FilterError
from nnda.filters.mixture import Mixture
from nnda.tracking.phd.fusion import gci


def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    A = rng.normal(size=(n, n))
    return A @ A.T + n * np.eye(n)


@pytest.mark.parametrize("omega", [0.5, 0.3, 0.85])
def test_gci_of_two_single_gaussian_phds_is_their_weighted_geometric_mean(omega):
    """w_a^omega w_b^(1 - omega) N(x; m_a, P_a)^omega N(x; m_b, P_b)^(1 - omega) at random points x, computed
    directly, equals the one fused component's weighted density there."""
    rng = np.random.default_rng(7)
    n = 5
    Pa, Pb = _spd(rng, n), _spd(rng, n)
    ma, mb = rng.normal(size=n), rng.normal(size=n)
    a, b = Mixture.make([0.7], [ma], [Pa], [3]), Mixture.make([1.3], [mb], [Pb], [5])
    fused, i, j = gci(a, b, omega)
    assert len(fused) == 1 and i.tolist() == [0] and j.tolist() == [0] and fused.labels.tolist() == [3]
    x = ma + 2.0 * rng.normal(size=(50, n))
    direct = (0.7 ** omega * 1.3 ** (1 - omega) * multivariate_normal(ma, Pa).pdf(x) ** omega
              * multivariate_normal(mb, Pb).pdf(x) ** (1 - omega))
    mine = fused.weights[0] * multivariate_normal(fused.means[0], fused.covariances[0]).pdf(x)
    np.testing.assert_allclose(mine, direct, rtol=1e-9, atol=0)
    # the closed form of the product's moments: information-weighted
    info = omega * np.linalg.inv(Pa) + (1 - omega) * np.linalg.inv(Pb)
    np.testing.assert_allclose(fused.covariances[0], np.linalg.inv(info), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(fused.means[0], np.linalg.solve(
        info, omega * np.linalg.solve(Pa, ma) + (1 - omega) * np.linalg.solve(Pb, mb)), rtol=1e-9, atol=1e-12)


def test_gci_of_an_intensity_with_itself_is_that_intensity_and_each_pair_is_fused():
    rng = np.random.default_rng(1)
    P = np.stack([_spd(rng, 4) for _ in range(2)])
    one = Mixture.make([0.9, 0.4], [[0.0, 1.0, 0.0, 1.0], [60.0, 0.0, 60.0, 0.0]], P, [0, 1])
    fused, i, j = gci(one, one, 0.5, gate=50.0)
    assert i.tolist() == j.tolist() == [0, 1]  # the far pairs are gated out
    np.testing.assert_allclose(fused.weights, one.weights, rtol=1e-9)
    np.testing.assert_allclose(fused.means, one.means, atol=1e-9)
    np.testing.assert_allclose(fused.covariances, one.covariances, rtol=1e-9)
    every, _, _ = gci(one, one, 0.5, gate=None)
    assert len(every) == 4 and 0 < every.weights[1] < 1e-6  # ungated: the far pairs too, of little weight


def test_gci_needs_both_intensities_and_a_weight_inside_zero_one():
    one = Mixture.make([1.0], [[0.0, 0.0, 0.0, 0.0]], [np.eye(4)], [0])
    fused, i, j = gci(one, Mixture.empty(4), 0.5)
    assert len(fused) == len(i) == len(j) == 0  # a target one intensity lacks is lost
    with pytest.raises(FilterError, match="omega must lie in \\(0, 1\\), got 1.0"):
        gci(one, one, 1.0)
