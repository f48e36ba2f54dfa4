"""Intervals and tests over Monte Carlo runs: pure functions of arrays, used by every study and report section.

    mean_ci([1.0, 2.5, None, 3.0])                  # {"mean", "ci_low", "ci_high", "n"}, Student-t, 95%
    clip_interval(record, 0.0)                      # a saved mean_ci record cut to a measure's range
    idx = bootstrap_indices([seed, 3], runs=R, resamples=1000)   # (1000, R) run indices, resampled
    percentile_interval(statistic_of_each_resample, 0.95)        # (low, high)
    clopper_pearson(3, 100, 0.95)                   # exact binomial interval of 3 in 100
    fisher_p((3, 100), (14, 100))                   # two-sided Fisher exact test of two counts
    sign_test_p(differences)                        # two-sided sign test of paired differences (ties left out)
    root_mean_square(squares, counts, axis=0)       # sqrt(sum squares / sum counts), NaN where no count
    ragged_mean([[1.0, 2.0], [3.0]])                # element-wise mean of series of unequal length: [2.0, 2.0]

Every function takes plain numbers or numpy arrays and returns floats or
arrays; nothing here knows a tracker, a scene or a file.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import stats


def mean_ci(values, confidence: float = 0.95, low: float = -math.inf, high: float = math.inf) -> dict:
    """Mean and two-sided Student-t interval of the mean over runs, clipped to [low, high].

    ``values`` may hold None/NaN (undefined in a run, e.g. a hit rate with
    no contacts); they are left out and ``n`` counts the rest. With one
    value the interval is undefined (None); with none, everything is None.
    ``low``/``high`` are the measure's possible range (a count is never
    negative): with few runs the t-interval can reach past it, and is cut.
    """
    x = np.array([np.nan if v is None else v for v in values], dtype=float)
    x = x[np.isfinite(x)]
    n = int(x.size)
    if n == 0:
        return {"mean": None, "ci_low": None, "ci_high": None, "n": 0}
    mean = float(x.mean())
    if n == 1:
        return {"mean": mean, "ci_low": None, "ci_high": None, "n": 1}
    half = float(stats.t.ppf(0.5 + confidence / 2, n - 1) * x.std(ddof=1) / math.sqrt(n))
    return {"mean": mean, "ci_low": max(mean - half, low), "ci_high": min(mean + half, high), "n": n}


def clip_interval(stat: dict | None, low: float = -math.inf, high: float = math.inf) -> dict | None:
    """A ``mean_ci`` record with its interval cut to the measure's possible range [low, high] (a copy; None, an
    undefined end and the mean are kept).

    Why clipping and not a log-scale or bootstrap interval: the quantity's true mean lies in [low, high], so
    cutting the t-interval there never drops it from an interval that held it (the coverage is unchanged),
    and the printed mean stays the centre's estimate. A log-scale interval covers the geometric mean, not the
    mean printed beside it, and a percentile bootstrap over 2-3 runs is the runs' range, narrower than the
    t-interval and too short. `mean_ci` does the same when it is given the bounds; this is for a record
    computed without them.
    """
    if stat is None:
        return None
    out = dict(stat)
    if out.get("ci_low") is not None:
        out["ci_low"] = min(max(out["ci_low"], low), high)
    if out.get("ci_high") is not None:
        out["ci_high"] = max(min(out["ci_high"], high), low)
    return out


def bootstrap_indices(seed: int | Sequence[int], runs: int, resamples: int) -> np.ndarray:
    """(resamples, runs) run indices drawn with replacement by ``numpy.random.default_rng(seed)``: index every
    estimator's per-run array with the same rows for a paired bootstrap."""
    return np.random.default_rng(seed).integers(0, runs, size=(resamples, runs))


def percentile_interval(samples: np.ndarray, confidence: float) -> tuple[float, float]:
    """The two-sided percentile interval of a statistic's bootstrap ``samples`` (1-D)."""
    tail = (1 - confidence) / 2
    return float(np.quantile(samples, tail)), float(np.quantile(samples, 1 - tail))


def clopper_pearson(count: int, n: int, confidence: float) -> tuple[float, float]:
    """The exact (Clopper-Pearson) binomial interval of a proportion ``count`` / ``n``."""
    ci = stats.binomtest(count, n).proportion_ci(confidence, method="exact")
    return float(ci.low), float(ci.high)


def fisher_p(a: tuple[int, int], b: tuple[int, int]) -> float:
    """Two-sided p of Fisher's exact test of two proportions, each given as (count, n)."""
    table = [[a[0], a[1] - a[0]], [b[0], b[1] - b[0]]]
    return float(stats.fisher_exact(table).pvalue)


def sign_test_p(differences: np.ndarray) -> float:
    """Two-sided p of the sign test of paired ``differences``: positives against the non-zero ones (ties are
    left out; 1.0 when every pair ties)."""
    d = np.asarray(differences)
    positive, ties = int((d > 0).sum()), int((d == 0).sum())
    return float(stats.binomtest(positive, d.size - ties).pvalue) if d.size > ties else 1.0


def root_mean_square(squares: np.ndarray, counts: np.ndarray | None = None, axis: int | None = None) -> np.ndarray:
    """sqrt(sum of ``squares`` / sum of ``counts``) along ``axis``: ``squares`` holds squared errors or per-group
    sums of them, ``counts`` how many terms each entry holds (None: one each, the plain RMS). NaN where the
    counts sum to 0."""
    squares = np.asarray(squares)
    if counts is None:
        n = squares.size if axis is None else squares.shape[axis]
    else:
        n = np.asarray(counts).sum(axis=axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, np.sqrt(squares.sum(axis=axis) / n), np.nan)


def ragged_mean(rows: Sequence[Sequence[float | None]]) -> list[float | None]:
    """Element-wise mean of series of possibly different lengths (the missing tail of a shorter one, None and
    NaN left out); None where no series has a value."""
    width = max(len(r) for r in rows)
    a = np.full((len(rows), width), np.nan)
    for i, r in enumerate(rows):
        a[i, :len(r)] = [np.nan if v is None else v for v in r]
    counts = np.isfinite(a).sum(axis=0)
    sums = np.nansum(a, axis=0)
    return [float(s / c) if c and math.isfinite(s / c) else None for s, c in zip(sums, counts)]
