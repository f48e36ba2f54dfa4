"""The measures of a filter job: a single-target filter's estimates against the truth, scan by scan.

`FilterRun` holds one run's estimates (NaN before the filter's start) and
the target's true state at every scan; `FILTER_MEASURES` are registry
entries (`nnda.study.measures.Measure`, read by the summary and the report
as the tracker measures are) whose ``compute`` takes a `FilterRun`:

* position error (m), per scan: |estimated - true position|;
* position and velocity RMSE (m, m/s) over the scans with an estimate;
* NEES, per scan: (x - x_true)^T P^-1 (x - x_true) on [x, vx, y, vy]; a
  consistent filter averages 4 (its chi-square degrees of freedom);
* divergence (%): the scans whose NEES exceeds the chi-square 99.9%
  quantile for 4 degrees of freedom (`NEES_BOUND`), of the scans with an
  estimate;
* start (s): time from the target's first scan to the filter's first estimate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nnda.study.measures import Measure
from nnda.study.stats import root_mean_square

#: chi-square 99.9% quantile, 4 degrees of freedom: a NEES above it counts as divergence
NEES_BOUND = 18.4668
_COUNT = (0.0, math.inf)


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


def _position_error(r: FilterRun) -> np.ndarray:
    e = r.error()
    return np.hypot(e[:, 0], e[:, 2])


def _rmse(columns: tuple[int, int]):
    def compute(r: FilterRun) -> float:
        e = r.error()[r.started][:, list(columns)]
        return float(root_mean_square((e**2).sum(axis=1)))
    return compute


def _divergence(r: FilterRun) -> float:
    nees = r.nees()[r.started]
    return float(100.0 * (nees > NEES_BOUND).mean()) if nees.size else math.nan


def _start(r: FilterRun) -> float:
    ok = np.flatnonzero(r.started)
    return float(r.time[ok[0]] - r.time[0]) if ok.size else math.nan


#: the measures of a filter job, in the order of the report's filter tables
FILTER_MEASURES: tuple[Measure, ...] = (
    Measure("position_error_m", "Position error", "m", "lower", _COUNT, True, _position_error, "{:.1f}"),
    Measure("position_rmse_m", "Position RMSE", "m", "lower", _COUNT, False, _rmse((0, 2)), "{:.1f}"),
    Measure("velocity_rmse_m_s", "Velocity RMSE", "m/s", "lower", _COUNT, False, _rmse((1, 3)), "{:.1f}"),
    Measure("nees", "NEES (4 when consistent)", "", "none", _COUNT, True, FilterRun.nees, "{:.2f}"),
    Measure("divergence_pct", "Divergent scans (NEES > 18.47)", "%", "lower", (0.0, 100.0), False, _divergence),
    Measure("start_s", "Time to the first estimate", "s", "lower", _COUNT, False, _start, "{:.1f}"),
)
#: the filter measures kept as per-scan series too
FILTER_SERIES: tuple[Measure, ...] = tuple(m for m in FILTER_MEASURES if m.per_scan)
