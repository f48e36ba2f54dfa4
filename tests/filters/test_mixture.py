"""Mixture reduction (prune, merge, cap) against slow loop-per-component references (Vo & Ma 2006, Table II)."""

from __future__ import annotations

import numpy as np
import pytest

from nnda.errors import FilterError
from nnda.filters.mixture import Mixture, cap, merge, prune


def random_mixture(seed: int, j: int = 40, n: int = 4, clusters: int = 6) -> Mixture:
    """Components around a few cluster centres (so merges happen), varied covariances, some tied weights."""
    rng = np.random.default_rng(seed)
    centres = rng.normal(0, 50, (clusters, n))
    means = centres[rng.integers(clusters, size=j)] + rng.normal(0, 2, (j, n))
    A = rng.normal(0, 1, (j, n, n))
    covs = A @ A.swapaxes(1, 2) + np.eye(n) * rng.uniform(0.5, 20, (j, 1, 1))
    w = rng.choice([1e-6, 1e-3, 0.05, 0.2, 0.5, 0.9], size=j) * rng.choice([1.0, 1.0, 1.7], size=j)
    return Mixture.make(w, means, covs, rng.permutation(j) + 100)


def merge_reference(mix: Mixture, U: float, covariance: str) -> list[tuple[float, np.ndarray, np.ndarray, int]]:
    """Vo & Ma's loop as written: heaviest first, its group under the heaviest's or each candidate's
    covariance, moment-matched."""
    w, m, P, lab = mix.weights, mix.means, mix.covariances, mix.labels
    left = list(range(len(w)))
    out = []
    while left:
        j = max(left, key=lambda k: (w[k], -k))
        group = [i for i in left
                 if (m[i] - m[j]) @ np.linalg.inv(P[j if covariance == "heaviest" else i]) @ (m[i] - m[j]) <= U]
        W = sum(w[i] for i in group)
        mean = sum(w[i] * m[i] for i in group) / W
        cov = sum(w[i] * (P[i] + np.outer(mean - m[i], mean - m[i])) for i in group) / W
        out.append((W, mean, cov, int(lab[j])))
        left = [i for i in left if i not in group]
    return out


@pytest.mark.parametrize("seed, j", [(s, 40) for s in range(6)] + [(6, 150), (7, 300)])  # few and many per window
@pytest.mark.parametrize("U", [0.0, 4.0, 25.0, 400.0])
@pytest.mark.parametrize("covariance", ["heaviest", "candidate"])
def test_merge_matches_the_reference(seed, j, U, covariance):
    mix = random_mixture(seed, j=j, clusters=6 if j <= 40 else 40)
    got = merge(mix, U, covariance)
    ref = merge_reference(mix, U, covariance)
    assert len(got) == len(ref)
    np.testing.assert_allclose(got.weights, [r[0] for r in ref], rtol=1e-9)
    np.testing.assert_allclose(got.means, [r[1] for r in ref], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(got.covariances, [r[2] for r in ref], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(got.labels, [r[3] for r in ref])
    assert np.isclose(got.weights.sum(), mix.weights.sum(), rtol=1e-9)  # merging keeps the total
    np.testing.assert_array_equal(got.covariances, got.covariances.swapaxes(1, 2))


def test_merge_keeps_singletons_exactly_and_the_input_unchanged():
    mix = random_mixture(1)
    before = [a.copy() for a in (mix.weights, mix.means, mix.covariances, mix.labels)]
    got = merge(mix, 0.0)  # nothing within distance 0 of another: every component alone, heaviest first
    order = np.lexsort((np.arange(len(mix)), -mix.weights))
    np.testing.assert_array_equal(got.means, mix.means[order])
    np.testing.assert_array_equal(got.covariances, mix.covariances[order])
    for a, b in zip(before, (mix.weights, mix.means, mix.covariances, mix.labels)):
        np.testing.assert_array_equal(a, b)


def test_merge_two_components_by_hand():
    mix = Mixture.make([0.6, 0.2, 0.3], [[0.0, 0.0], [1.0, 0.0], [10.0, 0.0]], [np.eye(2)] * 3, [7, 8, 9])
    got = merge(mix, 4.0)
    np.testing.assert_allclose(got.weights, [0.8, 0.3])
    np.testing.assert_allclose(got.means[0], [0.25, 0.0])
    # (0.6 (1 + 0.25^2) + 0.2 (1 + 0.75^2)) / 0.8 on the first axis
    np.testing.assert_allclose(got.covariances[0], [[1.1875, 0.0], [0.0, 1.0]])
    np.testing.assert_array_equal(got.labels, [7, 9])


def test_merge_covariance_choice():
    """A wide light component near a tight heavy one: far under the heavy one's covariance (d^2 = 25), near
    under its own (d^2 = 0.25)."""
    mix = Mixture.make([0.9, 0.1], [[0.0, 0.0], [5.0, 0.0]], [np.eye(2), 100 * np.eye(2)], [1, 2])
    assert len(merge(mix, 4.0)) == 2 and len(merge(mix, 25.0)) == 1
    assert len(merge(mix, 4.0, "candidate")) == 1 and len(merge(mix, 0.2, "candidate")) == 2


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("T", [0.0, 1e-5, 0.1, 0.5, 10.0])
def test_prune_matches_the_reference(seed, T):
    mix = random_mixture(seed)
    got = prune(mix, T)
    keep = [i for i in range(len(mix)) if mix.weights[i] > T]
    np.testing.assert_array_equal(got.weights, mix.weights[keep])
    np.testing.assert_array_equal(got.labels, mix.labels[keep])
    np.testing.assert_array_equal(got.means, mix.means[keep])


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("j_max", [1, 5, 17, 40, 100])
def test_cap_matches_the_reference(seed, j_max):
    mix = random_mixture(seed)
    got = cap(mix, j_max)
    if len(mix) <= j_max:
        assert got is mix
        return
    ref = sorted(range(len(mix)), key=lambda k: (-mix.weights[k], k))[:j_max]
    np.testing.assert_array_equal(got.labels, mix.labels[ref])
    np.testing.assert_array_equal(got.covariances, mix.covariances[ref])


def test_reduction_of_an_empty_mixture():
    e = Mixture.empty(4)
    assert len(prune(e, 1e-5)) == len(merge(e, 4.0)) == len(cap(e, 3)) == 0


def test_bad_input():
    with pytest.raises(FilterError, match="j_max must be >= 1"):
        cap(random_mixture(0), 0)
    with pytest.raises(FilterError, match="prune threshold"):
        prune(random_mixture(0), -1.0)
    with pytest.raises(FilterError, match="merge threshold"):
        merge(random_mixture(0), np.nan)
    with pytest.raises(FilterError, match="'heaviest' or 'candidate'"):
        merge(random_mixture(0), 4.0, "mean")
    with pytest.raises(FilterError, match="weights: must be >= 0"):
        Mixture.make([0.5, -0.1], np.zeros((2, 2)), [np.eye(2)] * 2, [0, 1])
    with pytest.raises(FilterError, match="not positive definite"):
        Mixture.make([0.5], np.zeros((1, 2)), [[[1.0, 0.0], [0.0, -1.0]]], [0])
    with pytest.raises(FilterError, match="labels"):
        Mixture.make([0.5], np.zeros((1, 2)), [np.eye(2)], [0.5])
    with pytest.raises(FilterError, match=r"covariances: expected shape \(1, 2, 2\)"):
        Mixture.make([0.5], np.zeros((1, 2)), [np.eye(3)], [0])
