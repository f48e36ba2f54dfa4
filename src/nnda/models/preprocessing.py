"""Input normalisation and the train/validation/test split.

The normaliser is a per-feature z-score, like MATLAB's ``mapstd``, fitted on
the training split only (fitting it on all pairs, as the MATLAB toolbox
does, would let validation and test statistics leak into training).
The split is a seeded random permutation cut 60/20/20, with the training
and validation sizes rounded (2766 pairs give Vargas Avila (2015)'s 1660/553/553).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nnda.errors import ModelError


@dataclass(frozen=True)
class Normaliser:
    """z = (x - mean) / scale per feature; ``mean`` and ``scale`` have shape (F,).

    ``scale`` is the sample standard deviation (ddof = 1, as ``mapstd``); a
    constant feature gets scale 1, so it maps to 0 instead of dividing by 0.
    """

    mean: np.ndarray
    scale: np.ndarray

    @classmethod
    def fit(cls, x: np.ndarray) -> Normaliser:
        """Statistics of ``x`` (N, F), N >= 2, all finite."""
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or len(x) < 2:
            raise ModelError(f"normaliser: need an (N, F) array with N >= 2 rows, got shape {x.shape}")
        if not np.isfinite(x).all():
            raise ModelError("normaliser: the features hold non-finite values")
        std = x.std(axis=0, ddof=1)
        return cls(x.mean(axis=0), np.where(std > 0, std, 1.0))

    def transform(self, x: np.ndarray) -> np.ndarray:
        """Normalised copy of ``x`` (N, F)."""
        return (np.asarray(x, dtype=float) - self.mean) / self.scale


@dataclass(frozen=True)
class Split:
    """Row indices of the three subsets; disjoint, together every row once."""

    train: np.ndarray
    validation: np.ndarray
    test: np.ndarray

    def items(self) -> list[tuple[str, np.ndarray]]:
        return [("train", self.train), ("validation", self.validation), ("test", self.test)]


def split_indices(
    n: int, rng: np.random.Generator, fractions: tuple[float, float, float] = (0.6, 0.2, 0.2),
) -> Split:
    """Random split of ``n`` rows; train and validation sizes are round(fraction * n), test the rest."""
    if len(fractions) != 3 or min(fractions) < 0 or not np.isclose(sum(fractions), 1.0):
        raise ModelError(f"split fractions must be three non-negative numbers summing to 1, got {fractions}")
    n_train, n_val = round(fractions[0] * n), round(fractions[1] * n)
    if n_train < 2 or n_val < 1 or n - n_train - n_val < 1:
        raise ModelError(f"split: {n} pairs are too few for a {fractions} train/validation/test split")
    order = rng.permutation(n)
    return Split(np.sort(order[:n_train]), np.sort(order[n_train:n_train + n_val]),
                 np.sort(order[n_train + n_val:]))
