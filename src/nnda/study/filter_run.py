"""A single-target filter's run, scored against the truth: the functions of the filter job's measures.

`FilterRun` holds one run's estimates (NaN before the filter's start) and
the target's true state at every scan where it exists; the registry
(`nnda.study.measures`) names these functions for the ``filter`` kind:
position error per scan, position and velocity RMSE over the scans with an
estimate, NEES per scan on [x, vx, y, vy] (4 when consistent), the share of
scans whose NEES exceeds `NEES_BOUND`, and the time to the first estimate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nnda.study.stats import root_mean_square

#: chi-square 99.9% quantile, 4 degrees of freedom: a NEES above it counts as divergence
NEES_BOUND = 18.4668


@dataclass(frozen=True)
class FilterRun:
    """One filter job's estimates and truth over the target's scans, all with the scan axis first (S,).

    ``x`` (S, 4) and ``P`` (S, 4, 4) are the estimates ([x, vx, y, vy], m and m/s; NaN before the
    start), ``truth`` (S, 4) the true state, ``time`` (S,) the scan times (s).
    """

    time: np.ndarray
    x: np.ndarray
    P: np.ndarray
    truth: np.ndarray

    @property
    def started(self) -> np.ndarray:
        return np.isfinite(self.x).all(axis=1)

    def error(self) -> np.ndarray:
        return self.x - self.truth

    def nees(self) -> np.ndarray:
        """(S,) NEES, NaN before the start."""
        out = np.full(len(self.time), np.nan)
        ok = self.started
        if ok.any():
            e = self.error()[ok]
            out[ok] = np.einsum("si,si->s", e, np.linalg.solve(self.P[ok], e[..., None])[..., 0])
        return out


def position_error(r: FilterRun) -> np.ndarray:
    e = r.error()
    return np.hypot(e[:, 0], e[:, 2])


def rmse(columns: tuple[int, int]):
    def compute(r: FilterRun) -> float:
        e = r.error()[r.started][:, list(columns)]
        return float(root_mean_square((e**2).sum(axis=1)))
    return compute


def divergence(r: FilterRun) -> float:
    nees = r.nees()[r.started]
    return float(100.0 * (nees > NEES_BOUND).mean()) if nees.size else math.nan


def start(r: FilterRun) -> float:
    ok = np.flatnonzero(r.started)
    return float(r.time[ok[0]] - r.time[0]) if ok.size else math.nan
