"""The scans of an import: each row's sweep (or report window) per sensor, and the schedule's length.

`sensor_sweeps` gives every row the index of its sensor's sweep, the one
nearest its time within the scan tolerance (a report sensor's window
(t_k - T, t_k] instead, `nnda.data.report_import`), refusing a sensor's
rows that go back in time or fall between sweeps; `schedule_duration` is the
length of the schedule that holds every sweep found and the truth's last
time, a whole number of the sensors' common period. Both name the file's row
and column of a problem through ``where(row)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from fractions import Fraction
from typing import Any

import numpy as np

from nnda.data.import_sensors import common_multiple, period_fraction, sweep_grid
from nnda.data.report_import import report_grid, report_windows
from nnda.errors import ConfigError, DatasetError

#: an import refuses a schedule of more scans than this (a clock time without --time-origin)
MAX_SCANS = 10_000_000


def sensor_sweeps(specs: Sequence[Mapping[str, Any]], names: list[str], sensor: np.ndarray, t: np.ndarray,
                  rows: np.ndarray, tol: float, time_origin: float, where: Callable[[int], str]
                  ) -> tuple[np.ndarray, list[tuple[float, float]], list[int]]:
    """(sweep (N,) int64: each row's sweep of its sensor, from 0; per sensor its (period, offset) s and the
    number of its sweeps the rows need). ``sensor`` (N,) each row's sensor index, ``t`` (N,) s its time after
    ``time_origin``, ``rows`` (N,) its file row (for ``where``); ``tol`` s the scan tolerance."""
    sweep = np.empty(t.size, dtype=np.int64)
    grids: list[tuple[float, float]] = []
    needed: list[int] = []
    for j, spec in enumerate(specs):
        mine = np.flatnonzero(sensor == j)
        rj, tj = rows[mine], t[mine]
        reports = bool(spec.get("reports", False))
        period, offset = (report_grid(spec, names[j], j, time_origin) if reports
                          else sweep_grid(spec, tj, tol, time_origin))
        if tol >= period / 2 and not reports:
            raise ConfigError(f"--scan-tolerance {tol:g} s: must be below half the scan period of sensor "
                              f"{names[j]!r} ({period:g} s)")
        far = np.abs(tj - offset) > MAX_SCANS * period  # before the sweep index overflows
        if far.any():
            i = int(np.argmax(far))
            raise DatasetError(f"{where(int(rj[i]))}: time {float(tj[i] + time_origin)!r} s is more than "
                               f"{MAX_SCANS:,} scan periods ({period:g} s) of sensor {names[j]!r} after t = "
                               f"{time_origin:g} s; clock times? pass --time-origin with a time just before the first")
        first = 1 if offset == 0 else 0  # t > 0 lies in sweep (window) k >= first
        if reports:
            k = report_windows(tj, rj, period, offset, where, lambda time: float(time + time_origin), names[j])
        else:
            k = _nearest_sweeps(tj, rj, period, offset, first, tol, time_origin, names[j], where)
        sweep[mine] = k - first
        grids.append((period, offset))
        needed.append(int(k.max()) + 1 - first if rj.size else 1)
    return sweep, grids, needed


def _nearest_sweeps(t: np.ndarray, rows: np.ndarray, period: float, offset: float, first: int, tol: float,
                    time_origin: float, name: str, where: Callable[[int], str]) -> np.ndarray:
    """The index k (N,) of the sweep offset + k period nearest each time ``t`` (N,) of one sensor; DatasetError
    for a time going back to an earlier sweep, or beyond ``tol`` s of every sweep k >= ``first``."""
    k = np.round((t - offset) / period).astype(np.int64)
    back = np.diff(k) < 0
    if back.any():
        i = int(np.argmax(back))
        raise DatasetError(f"{where(int(rows[i + 1]))}: time {float(t[i + 1] + time_origin)!r} s goes back from "
                           f"{float(t[i] + time_origin)!r} s (data row {rows[i] + 1}, an earlier sweep) for sensor "
                           f"{name!r}; each sensor's rows must be in time order")
    miss = np.abs(t - (offset + k * period))
    bad = (miss > tol + 1e-9 * np.maximum(1.0, np.abs(t))) | (k < first)
    if bad.any():
        i = int(np.argmax(bad))
        nearest = offset + max(k[i], first) * period
        raise DatasetError(
            f"{where(int(rows[i]))}: time {float(t[i] + time_origin)!r} s is {abs(t[i] - nearest):.6g} s from the "
            f"nearest sweep of sensor {name!r} ({nearest + time_origin:.6g} s; period {period:g} s, offset "
            f"{offset + time_origin:g} s), beyond the scan tolerance ({tol:g} s): give the sensor's scan_period_s "
            f"and scan_offset_s, or a larger --scan-tolerance")
    return k


def schedule_duration(grids: Sequence[tuple[float, float]], needed: Sequence[int], names: list[str],
                      last_truth_s: float | None, time_origin: float, what: str) -> float:
    """The schedule's duration (s): a whole number of the sensors' common period that holds each sensor's
    ``needed`` sweeps (`sensor_sweeps`) and the truth's last time ``last_truth_s`` (None: no truth);
    DatasetError naming ``what`` (the file and time column) past `MAX_SCANS` scans."""
    periods = [period_fraction(p, f"sensor {names[j]!r}: scan_period_s") for j, (p, _) in enumerate(grids)]
    common = common_multiple(periods)
    longest = max(Fraction(m) * p for m, p in zip(needed, periods))
    if last_truth_s is not None:
        longest = max(longest, Fraction(last_truth_s))
    duration = common * math.ceil(longest / common)
    n_scans = sum(int(duration / p) for p in periods)
    if n_scans > MAX_SCANS:
        raise DatasetError(f"{what}: the times reach {float(longest) + time_origin:.6g} s, a schedule of "
                           f"{n_scans:,} scans from t = {time_origin:g} s (more than {MAX_SCANS:,}); clock times? "
                           f"pass --time-origin with a time just before the first")
    return float(duration)
