"""numpy's float64 reductions as compiled functions that give the same bits, for compiled passes that replace
numpy code whose outputs must not move.

    total = add_reduce(a)        # np.sum(a) of a contiguous 1-D float64 array (or a row of a C-ordered one)
    both = logaddexp(x, y)       # np.logaddexp(x, y) of two floats

numpy sums a contiguous array pairwise, in blocks of eight partial sums (its ``pairwise_sum``), so a plain
loop differs from it in the last bits once there are eight terms or more; `add_reduce` follows the same
order. numpy's ``logaddexp`` (also in ``reduce``, ``reduceat`` and ``at``) works on each pair in turn with
libm's ``log1p`` and ``exp``, as `logaddexp` does. Both are held to numpy in the tests.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: ln 2
_LN2 = math.log(2.0)


@numba.njit(cache=True, nogil=True)
def add_reduce(a):
    """``np.sum(a)`` of the float64 array ``a`` (n,), contiguous, summed in numpy's order: its ``pairwise_sum``
    (`_block` up to 128 terms, beyond that the two halves, cut at a multiple of 8, each summed so and then
    added), walked with a stack of its own (a cached compiled function must not call itself)."""
    start, size = np.zeros(64, np.int64), np.zeros(64, np.int64)
    stage, left = np.zeros(64, np.int64), np.zeros(64)  # 0: to split, 1: left half summed, 2: both
    size[0] = a.size
    top, value = 0, 0.0
    while top >= 0:
        lo, n = start[top], size[top]
        if n <= 128:
            value = _block(a, lo, n)  # handed to the half above
            top -= 1
            continue
        half = n // 2 - (n // 2) % 8
        if stage[top] == 0:
            stage[top] = 1
            top += 1
            start[top], size[top], stage[top] = lo, half, 0
        elif stage[top] == 1:
            left[top], stage[top] = value, 2
            top += 1
            start[top], size[top], stage[top] = lo + half, n - half, 0
        else:
            value = left[top] + value
            top -= 1
    return 0.0 + value


@numba.njit(cache=True, nogil=True)
def _block(a, lo, n):
    """numpy's ``pairwise_sum`` of ``a[lo:lo + n]``, n <= 128: below 8 terms in turn from 0, else in eight
    running sums joined as a tree, then the terms past the last multiple of 8 in turn."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r = a[lo:lo + 8].copy()
    i = 8
    while i < n - n % 8:
        for j in range(8):
            r[j] += a[lo + i + j]
        i += 8
    res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@numba.njit(cache=True, nogil=True)
def logaddexp(x, y):
    """ln(e^x + e^y) as numpy's ``logaddexp`` works it out (the same operations, so the same bits)."""
    if x == y:  # equal infinities too
        return x + _LN2
    d = x - y
    if d > 0:
        return x + math.log1p(math.exp(-d))
    if d <= 0:
        return y + math.log1p(math.exp(d))
    return d  # a NaN
