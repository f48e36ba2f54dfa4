"""Integer keys (track ids, labels, contact indices) looked up in a sorted array.

    at, found = sorted_find(known, keys)   # known ascending: known[at] == keys where found
    inside = members(keys, pool)           # np.isin(keys, pool) for integer arrays
    inside = among(keys, pool)             # the same, compiled, for compiled callers
    first = run_starts(keys[order])        # the first entry of each run of equal keys

The trackers ask these a few times a scan of arrays of tens to hundreds of
ids, where a sort and a binary search cost an eighth to a half of what
``np.isin``'s general set machinery does.
"""

from __future__ import annotations

import numba
import numpy as np


def sorted_find(known: np.ndarray, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each of ``keys`` (M,) lies in ``known`` (K,), ascending: its index ``at`` (M,) (the first of equal
    entries) and whether it is there, ``found`` (M,) bool; ``at`` means nothing where not found (0 for an empty
    ``known``)."""
    keys = np.asarray(keys)
    if not known.size:
        return np.zeros(keys.shape, np.int64), np.zeros(keys.shape, bool)
    at = np.minimum(np.searchsorted(known, keys), known.size - 1)
    return at, known[at] == keys


def members(keys: np.ndarray, pool: np.ndarray) -> np.ndarray:
    """Which of the integer ``keys`` (M,) are among ``pool`` (P,, any order): ``np.isin(keys, pool)``."""
    keys = np.asarray(keys)
    return among(keys.ravel(), np.asarray(pool).ravel()).reshape(keys.shape)


@numba.njit(cache=True, nogil=True)
def among(keys, pool):
    """`members` of ``keys`` (M,) and ``pool`` (P,), 1-D, compiled: (M,) bool."""
    known = np.sort(pool)
    out = np.zeros(keys.size, np.bool_)
    if known.size:
        at = np.searchsorted(known, keys)
        for i in range(keys.size):
            out[i] = at[i] < known.size and known[at[i]] == keys[i]
    return out


def run_starts(keys: np.ndarray) -> np.ndarray:
    """Which entries of ``keys`` (M,), grouped (equal keys adjacent), start a run of equal keys: (M,) bool, the
    first entry True (``np.r_[True, np.diff(keys) != 0]`` without its index-trick machinery; empty for none)."""
    starts = np.empty(keys.size, bool)
    if keys.size:
        starts[0] = True
        np.not_equal(keys[1:], keys[:-1], out=starts[1:])
    return starts
