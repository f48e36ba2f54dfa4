"""A report sensor's rows at import: each report to the scan window that holds its time.

A sensor with ``reports = True`` (`nnda.data.scenario.Sensor`: AIS,
ADS-B, a tracker's plot stream) stamps every report with its own time. Its
scan k is the window (t_{k-1}, t_k], t_k = offset + k period, and every
report goes to the window that holds it: no tolerance, no rounding of
times. The window (``scan_period_s``) must be given; the offset is the
given ``scan_offset_s`` (in the file's clock) or 0 after the time origin.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from nnda.errors import ConfigError, DatasetError


def report_grid(spec: Mapping[str, Any], name: str, index: int, time_origin: float) -> tuple[float, float]:
    """Window (s) and offset (s, after ``time_origin``, in [0, window)) of report sensor ``spec``; ConfigError
    naming the sensor when its ``scan_period_s`` is not given (a window is never guessed)."""
    if spec.get("scan_period_s") is None:
        raise ConfigError(f"sensor {index} ({name!r}): reports=true needs scan_period_s, the window (s) that "
                          f"groups its reports into scans, e.g. --sensor scan_period_s=10 or scan_period_s = 10 in "
                          f"the sensors file")
    period = float(spec["scan_period_s"])
    offset = round((float(spec.get("scan_offset_s", time_origin)) - time_origin) % period, 9)
    return period, (0.0 if offset >= period else offset)


def window_index(t: np.ndarray, period: float, offset: float) -> np.ndarray:
    """Index k (int64, shape of ``t``) of the window (t_{k-1}, t_k] holding each time ``t`` (s), with t_k
    computed as the scan schedule computes it (k period + offset), so a time on a window's end stays in it."""
    k = np.ceil((t - offset) / period).astype(np.int64)
    k -= (k - 1) * period + offset >= t  # the division rounded up past a window's end
    k += k * period + offset < t  # ... or down
    return k


def report_windows(t: np.ndarray, rows: np.ndarray, period: float, offset: float,
                   where: Callable[[int], str], shown: Callable[[float], float], name: str) -> np.ndarray:
    """The window index k of each report of one sensor (times ``t`` s after the origin, its file rows
    ``rows``); DatasetError at the first time that goes back (equal times are separate reports).
    ``where(row)`` names a file row, ``shown(t)`` gives a time in the file's clock."""
    back = np.diff(t) < 0
    if back.any():
        i = int(np.argmax(back))
        raise DatasetError(f"{where(int(rows[i + 1]))}: time {shown(t[i + 1])!r} s goes back from "
                           f"{shown(t[i])!r} s (data row {rows[i] + 1}) for report sensor {name!r}; each sensor's "
                           f"rows must be in time order (equal times are allowed)")
    return window_index(t, period, offset)


def scan_order(scan: np.ndarray, azimuth: np.ndarray, time: np.ndarray, report: np.ndarray) -> np.ndarray:
    """Row order of the detections: by scan, then by azimuth in a sweep's scan and by time in a report
    sensor's scan (``report``: bool per row), stable (equal keys keep the file's order)."""
    return np.lexsort((np.where(report, time, azimuth), scan))
