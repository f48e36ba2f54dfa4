"""Records of K tracks held as arrays with a leading track axis: select, reorder, concatenate.

Trackers add and drop tracks every scan and branch a track over several
candidate measurements; `Batch.take` (any numpy index along the track axis,
repeats allowed) and `Batch.concat` do that for every record built on it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields
from typing import Self

import numpy as np

from nnda.errors import FilterError


class Batch:
    """Mixin for dataclasses whose fields are arrays (K, ...) or other batches of K tracks."""

    def __len__(self) -> int:
        first = getattr(self, fields(self)[0].name)
        return len(first)

    def take(self, index: np.ndarray | Sequence[int] | slice) -> Self:
        """The tracks selected by ``index`` (integer array, boolean mask of length K, or slice)."""
        if not isinstance(index, slice):
            index = np.asarray(index)
            if index.dtype == bool and index.shape != (len(self),):
                raise FilterError(f"take: boolean mask of shape {index.shape} for {len(self)} tracks")
        return type(self)(**{f.name: _take(getattr(self, f.name), index) for f in fields(self)})

    @classmethod
    def concat(cls, batches: Sequence[Self]) -> Self:
        """One batch holding the tracks of ``batches`` in order."""
        if not batches:
            raise FilterError(f"{cls.__name__}.concat: nothing to concatenate")
        parts = {}
        for f in fields(cls):
            try:
                parts[f.name] = _concat([getattr(b, f.name) for b in batches])
            except ValueError as exc:
                raise FilterError(f"{cls.__name__}.concat: field {f.name!r} does not match: {exc}") from None
        return cls(**parts)


def _take(value: np.ndarray | Batch, index: np.ndarray | slice) -> np.ndarray | Batch:
    return value.take(index) if isinstance(value, Batch) else value[index]


def _concat(values: list) -> np.ndarray | Batch:
    if isinstance(values[0], Batch):
        return type(values[0]).concat(values)
    return np.concatenate(values, axis=0)
