from __future__ import annotations

import numpy as np
import pytest

from nnda.errors import ModelError
from nnda.models.preprocessing import Normaliser, split_indices


def test_split_has_the_spec_sizes_and_partitions_the_rows():
    split = split_indices(2766, np.random.default_rng(0))
    assert (split.train.size, split.validation.size, split.test.size) == (1660, 553, 553)
    everything = np.concatenate([split.train, split.validation, split.test])
    assert np.array_equal(np.sort(everything), np.arange(2766))


def test_split_is_seeded():
    a, b, c = (split_indices(100, np.random.default_rng(s)) for s in (5, 5, 6))
    assert np.array_equal(a.test, b.test)
    assert not np.array_equal(a.test, c.test)


def test_split_refuses_too_few_rows():
    with pytest.raises(ModelError, match="too few"):
        split_indices(3, np.random.default_rng(0))


def test_normaliser_is_a_zscore_with_sample_std():
    x = np.array([[1.0, 10.0, 2.0], [3.0, 30.0, 2.0], [5.0, 20.0, 2.0]])
    norm = Normaliser.fit(x)
    assert norm.mean.tolist() == [3.0, 20.0, 2.0]
    assert norm.scale.tolist() == [2.0, 10.0, 1.0]  # constant column: scale 1, maps to 0
    z = norm.transform(x)
    assert z[:, 2].tolist() == [0.0, 0.0, 0.0]
    np.testing.assert_allclose(z[:, :2].std(axis=0, ddof=1), 1.0)


def test_normaliser_refuses_nan_and_single_rows():
    with pytest.raises(ModelError, match="non-finite"):
        Normaliser.fit(np.array([[1.0, np.nan], [2.0, 3.0]]))
    with pytest.raises(ModelError, match="N >= 2"):
        Normaliser.fit(np.ones((1, 3)))
