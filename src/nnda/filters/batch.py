"""Records of K tracks held as arrays with a leading track axis: select, reorder, concatenate.

Trackers add and drop tracks every scan and branch a track over several
candidate measurements; `Batch.take` (any numpy index along the track axis,
repeats allowed) and `Batch.concat` do that for every record built on it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import fields
from functools import cache
from operator import attrgetter
from typing import Self

import numpy as np

from nnda.errors import FilterError


@cache
def _names(cls: type) -> tuple[str, ...]:
    """Field names of a dataclass, computed once per class (take/concat run every scan)."""
    return tuple(f.name for f in fields(cls))


@cache
def _values(cls: type) -> Callable[[object], tuple]:
    """A function returning the field values of a ``cls`` instance as a tuple, in field order."""
    names = _names(cls)
    getter = attrgetter(*names)
    return getter if len(names) > 1 else lambda record: (getter(record),)


class Batch:
    """Mixin for dataclasses whose fields are arrays (K, ...) or other batches of K tracks."""

    def __len__(self) -> int:
        return len(getattr(self, _names(type(self))[0]))

    def _fields(self) -> tuple:
        """The fields' values, in field order."""
        return _values(type(self))(self)

    def take(self, index: np.ndarray | Sequence[int] | slice) -> Self:
        """The tracks selected by ``index`` (integer array, boolean mask of length K, or slice)."""
        if not isinstance(index, slice):
            index = np.asarray(index)
            if index.dtype == bool:
                if index.shape != (len(self),):
                    raise FilterError(f"take: boolean mask of shape {index.shape} for {len(self)} tracks")
                index = np.flatnonzero(index)  # one scan of the mask, not one per field
        return self._rows(index)

    def kept(self, mask: np.ndarray) -> Self:
        """The tracks where the boolean ``mask`` (K,) holds, as `take` gives them; this batch itself, not a copy,
        when it holds everywhere (for callers that never write into the arrays)."""
        return self if mask.size == len(self) and mask.all() else self.take(mask)  # `take` checks the mask

    def _rows(self, index: np.ndarray | slice) -> Self:
        """`take` with a checked integer array or slice."""
        cls = type(self)
        return cls(*[v._rows(index) if isinstance(v, Batch) else v[index] for v in _values(cls)(self)])

    def replaced(self, **changes: object) -> Self:
        """This batch with the fields named in ``changes`` replaced (``dataclasses.replace`` without its
        per-call field inspection: the trackers replace a field or two every scan)."""
        cls = type(self)
        unknown = changes.keys() - set(_names(cls))
        if unknown:
            raise FilterError(f"{cls.__name__}.replaced: no field(s) {', '.join(sorted(unknown))}")
        return cls(*[changes.get(name, value) for name, value in zip(_names(cls), _values(cls)(self))])

    @classmethod
    def concat(cls, batches: Sequence[Self]) -> Self:
        """One batch holding the tracks of ``batches`` in order."""
        if not batches:
            raise FilterError(f"{cls.__name__}.concat: nothing to concatenate")
        try:
            return cls(*[type(parts[0]).concat(parts) if isinstance(parts[0], Batch) else np.concatenate(parts)
                         for parts in zip(*map(_values(cls), batches))])
        except ValueError:
            for name in _names(cls):  # which field: the arrays one by one, for the message
                parts = [getattr(b, name) for b in batches]
                if not isinstance(parts[0], Batch):
                    try:
                        np.concatenate(parts)
                    except ValueError as exc:
                        raise FilterError(f"{cls.__name__}.concat: field {name!r} does not match: {exc}") from None
            raise
