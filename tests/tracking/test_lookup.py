"""The sorted-id lookups against numpy's set functions."""

import numpy as np
import pytest

from nnda.tracking.lookup import members, run_starts, sorted_find


@pytest.mark.parametrize("seed", range(5))
def test_members_is_isin(seed):
    rng = np.random.default_rng(seed)
    keys, pool = rng.integers(-5, 40, rng.integers(0, 60)), rng.integers(-5, 40, rng.integers(0, 60))
    np.testing.assert_array_equal(members(keys, pool), np.isin(keys, pool))


def test_sorted_find_gives_the_first_equal_entry():
    known = np.array([1, 3, 3, 7])
    at, found = sorted_find(known, np.array([3, 0, 7, 8, 1]))
    np.testing.assert_array_equal(found, [True, False, True, False, True])
    np.testing.assert_array_equal(at[found], [1, 3, 0])


def test_empty_known_finds_nothing():
    at, found = sorted_find(np.empty(0, np.int64), np.array([[1, 2]]))
    assert at.shape == found.shape == (1, 2) and not found.any()
    assert not members(np.array([4]), np.empty(0, np.int64)).any()


@pytest.mark.parametrize("seed", range(5))
def test_run_starts_marks_the_first_of_each_run(seed):
    keys = np.sort(np.random.default_rng(seed).integers(0, 8, 1 + seed * 7))
    np.testing.assert_array_equal(run_starts(keys), np.r_[True, np.diff(keys) != 0])
    assert run_starts(np.empty(0, np.int64)).shape == (0,)
