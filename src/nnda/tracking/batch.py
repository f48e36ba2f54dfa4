"""Records of K tracks held as arrays with a leading track axis: select, reorder, concatenate.

Trackers add and drop tracks every scan and branch a track over several
candidate measurements; `Batch.take` (any numpy index along the track axis,
repeats allowed) and `Batch.concat` do that for every record built on it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields
from functools import cache
from typing import Self

import numpy as np

from nnda.errors import FilterError


@cache
def _names(cls: type) -> tuple[str, ...]:
    """Field names of a dataclass, computed once per class (take/concat run every scan)."""
    return tuple(f.name for f in fields(cls))


class Batch:
    """Mixin for dataclasses whose fields are arrays (K, ...) or other batches of K tracks."""

    def __len__(self) -> int:
        return len(getattr(self, _names(type(self))[0]))

    def take(self, index: np.ndarray | Sequence[int] | slice) -> Self:
        """The tracks selected by ``index`` (integer array, boolean mask of length K, or slice)."""
        if not isinstance(index, slice):
            index = np.asarray(index)
            if index.dtype == bool:
                if index.shape != (len(self),):
                    raise FilterError(f"take: boolean mask of shape {index.shape} for {len(self)} tracks")
                index = np.flatnonzero(index)  # one scan of the mask, not one per field
        return type(self)(*[_take(getattr(self, name), index) for name in _names(type(self))])

    @classmethod
    def concat(cls, batches: Sequence[Self]) -> Self:
        """One batch holding the tracks of ``batches`` in order."""
        if not batches:
            raise FilterError(f"{cls.__name__}.concat: nothing to concatenate")
        parts = []
        for name in _names(cls):
            try:
                parts.append(_concat([getattr(b, name) for b in batches]))
            except ValueError as exc:
                raise FilterError(f"{cls.__name__}.concat: field {name!r} does not match: {exc}") from None
        return cls(*parts)


def _take(value: np.ndarray | Batch, index: np.ndarray | slice) -> np.ndarray | Batch:
    return value.take(index) if isinstance(value, Batch) else value[index]


def _concat(values: list) -> np.ndarray | Batch:
    if isinstance(values[0], Batch):
        return type(values[0]).concat(values)
    return np.concatenate(values, axis=0)
