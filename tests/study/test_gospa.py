"""GOSPA and OSPA against brute force over every assignment on small sets."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from nnda.study.gospa import gospa, ospa


def brute_gospa(x: np.ndarray, y: np.ndarray, c: float, p: float) -> float:
    """Definition: min over partial assignments of sum d^p + c^p/2 (|X| + |Y| - 2|gamma|)."""
    best = np.inf
    m, n = len(x), len(y)
    for k in range(min(m, n) + 1):
        for rows in itertools.combinations(range(m), k):
            for cols in itertools.permutations(range(n), k):
                cost = sum(min(np.linalg.norm(x[i] - y[j]), c) ** p for i, j in zip(rows, cols))
                best = min(best, cost + c**p / 2 * (m + n - 2 * k))
    return best ** (1 / p)


def brute_ospa(x, y, c, p):
    if len(x) > len(y):
        x, y = y, x
    m, n = len(x), len(y)
    if n == 0:
        return 0.0
    best = min(sum(min(np.linalg.norm(x[i] - y[j]), c) ** p for i, j in enumerate(perm))
               for perm in itertools.permutations(range(n), m))
    return ((best + c**p * (n - m)) / n) ** (1 / p)


points = arrays(np.float64, st.tuples(st.integers(0, 4), st.just(2)), elements=st.floats(0, 3000))


@settings(max_examples=120, deadline=None)
@given(x=points, y=points, c=st.sampled_from([200.0, 500.0, 1000.0]), p=st.sampled_from([1.0, 2.0]))
def test_gospa_and_ospa_equal_brute_force(x, y, c, p):
    g = gospa(x, y, c, p)
    assert g.distance == pytest.approx(brute_gospa(x, y, c, p), rel=1e-9, abs=1e-9)
    assert g.distance**p == pytest.approx(g.localisation + g.missed + g.false, rel=1e-9, abs=1e-9)
    assert ospa(x, y, c, p) == pytest.approx(brute_ospa(x, y, c, p), rel=1e-9, abs=1e-9)


def test_gospa_parts_on_a_hand_made_case():
    truth = np.array([[0.0, 0.0], [10_000.0, 0.0], [0.0, 10_000.0]])
    est = np.array([[30.0, 40.0], [10_000.0, 2_000.0], [-5_000.0, 0.0], [-6_000.0, 0.0]])
    g = gospa(truth, est, c=1000.0)
    # one pair at 50 m; truth 2 is 2 km from its nearest estimate (beyond c): missed; truth 3 missed
    assert (g.n_missed, g.n_false) == (2, 3)
    assert g.localisation == pytest.approx(2500.0)
    assert g.missed == pytest.approx(2 * 1000.0**2 / 2) and g.false == pytest.approx(3 * 1000.0**2 / 2)
    assert gospa(np.empty((0, 2)), np.empty((0, 2)), 1000.0).distance == 0.0
    assert ospa(truth, np.empty((0, 2)), 1000.0) == 1000.0


def test_bad_input():
    with pytest.raises(ValueError, match=r"truth: expected an \(n, 2\) array"):
        gospa(np.zeros((3, 3)), np.zeros((1, 2)), 100.0)
    with pytest.raises(ValueError, match="estimates: positions must be finite"):
        gospa(np.zeros((1, 2)), np.array([[np.nan, 0.0]]), 100.0)
