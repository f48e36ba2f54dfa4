"""The truth file of an import (``nnda import-detections --truth``): its columns, each row's scans, and the
dataset's truth record.

A truth file has ``time``, ``target_id``, ``x``, ``y`` (or ``lat``,
``lon``) and optionally ``vx``, ``vy`` (m/s, east and north). Without the
velocity columns `derived_velocities` takes them from each target's
positions: central differences in time (second order on uneven steps, as
`numpy.gradient`), one-sided at a target's first and last row, 0 for a
target with one row (one BoundWarning counts those targets).

Without a truth file, `labelled_truth` (``--truth-from-labels GAP_S``)
takes the truth from the labelled reports themselves (AIS, ADS-B: each
report names its transmitter): at a scan time T a label's position is
linearly interpolated between its last report at or before T and its
next after T, when they are at most GAP_S apart, and its velocity is their
difference quotient; elsewhere the label has no truth row.
"""

from __future__ import annotations

import numbers
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from nnda.data.dataset import Detections, Truth
from nnda.data.geodesy import GeodeticOrigin, check_geodetic
from nnda.data.geodetic_import import SITE_FIELDS, local_positions
from nnda.data.table_reading import (
    CsvDialect,
    InMemory,
    Source,
    decimal_mark,
    find_columns,
    labels_of,
    numbers_of,
    read_source,
    require_columns,
    where_in,
)
from nnda.data.time_columns import absolute_ns, is_absolute, seconds_after
from nnda.errors import BoundWarning, ConfigError, DatasetError

#: columns nnda reads from a truth file
TRUTH_COLUMNS = ("time", "target_id", "x", "y", "vx", "vy", "lat", "lon", "alt")


def read_truth(path: Source, mapping: Mapping[str, str], time_origin: float, dialect: CsvDialect = CsvDialect(),
               frame: GeodeticOrigin | None = None, origin_ns: int | None = None,
               units: tuple[float, float] = (1.0, 1.0)) -> dict:
    """The truth file's checked columns: time (after the origin; absolute times, after ``origin_ns``, when the
    detections' are absolute), labels, state (positions in lat/lon placed on ``frame``'s plane); its path and
    time column. ``units``: metres per distance unit (x, y, alt), m/s per speed unit (vx, vy). Without vx and
    vy columns the velocities are `derived_velocities`."""
    path, table = read_source(path, "truth", dialect)
    dec = decimal_mark(path, dialect)
    present = find_columns(table, path, TRUTH_COLUMNS, mapping)
    position = ["lat", "lon"] if not {"x", "y"} & present.keys() and {"lat", "lon"} & present.keys() else ["x", "y"]
    velocity = ["vx", "vy"] if {"vx", "vy"} & present.keys() else []
    require_columns(path, present, ["time", "target_id", *position, *velocity], mapping, table,
                    "a truth file has time, target_id, x, y (or lat, lon), and vx, vy or neither")
    tcol = present["time"]
    if is_absolute(table.column(tcol)) != (origin_ns is not None):
        kinds = ("absolute times (date and time)", "seconds (numbers)")
        truth_kind, det_kind = kinds if origin_ns is None else kinds[::-1]
        raise DatasetError(f"{where_in(path, 0, tcol)}: the truth file's times are {truth_kind} but the detections' "
                           f"are {det_kind}; write both files' times alike")
    if origin_ns is not None:
        t = seconds_after(absolute_ns(table.column(tcol), lambda row: where_in(path, row, tcol)), origin_ns)
    else:
        t = numbers_of(table, path, "time", tcol, dec) - time_origin
    values = {c: numbers_of(table, path, c, present[c], dec) * units[1] for c in velocity}
    if position[0] == "x":
        values |= {c: numbers_of(table, path, c, present[c], dec) * units[0] for c in ("x", "y")}
    else:
        lat, lon, alt = (numbers_of(table, path, c, present[c], dec) if c in present else None for c in SITE_FIELDS)
        alt = alt * units[0] if alt is not None else None
        check_geodetic(lat, lon, alt, where=lambda c, row: where_in(path, row, present[c]), error=DatasetError)
        values["x"], values["y"] = local_positions(path, present, frame, lat, lon, alt)
    labels = labels_of(table, path, present["target_id"])
    if any(v is None for v in labels):
        row = int(np.flatnonzero(np.array([v is None for v in labels]))[0])
        raise DatasetError(f"{where_in(path, row, present['target_id'])}: no target id (a truth row needs one)")
    if not velocity:
        values["vx"], values["vy"] = derived_velocities(path, tcol, t, labels, values["x"], values["y"])
    return {"t": t, "labels": labels, "values": values, "path": path, "time_column": present["time"]}


def derived_velocities(path: Path | InMemory, column: str, t: np.ndarray, labels: np.ndarray, x: np.ndarray,
                       y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """vx, vy (m/s, shape (N,)) of truth rows at times ``t`` (s), positions ``x``, ``y`` (m) and target
    ``labels`` (object (N,)), in row order: per target, in time order, the second-order central difference
    inside (`numpy.gradient` on uneven steps) and the one-sided difference at its ends; 0 for a target with
    one row (one BoundWarning counting them). DatasetError when a target has two rows at one time (``column``
    names the file's time column in the message)."""
    n = t.size
    vx, vy = np.zeros(n), np.zeros(n)
    if not n:
        return vx, vy
    target = np.unique(labels, return_inverse=True)[1].ravel()
    order = np.lexsort((np.arange(n), t, target))  # by target, then time, then file row
    g, ts = target[order], t[order]
    same = g[1:] == g[:-1]  # row i and i + 1 (sorted) are one target's
    twice = np.flatnonzero(same & (ts[1:] == ts[:-1]))
    if twice.size:
        a, b = order[twice[0]], order[twice[0] + 1]
        raise DatasetError(f"{where_in(path, int(b), column)}: target {labels[b]!r} has a second row at the time of "
                           f"data row {a + 1}; one row per target per scan")
    has_prev = np.concatenate([[False], same])
    has_next = np.concatenate([same, [False]])
    prev, nxt = np.maximum(np.arange(n) - 1, 0), np.minimum(np.arange(n) + 1, n - 1)
    prev = np.where(has_prev, prev, np.arange(n))  # at a target's first row the step back is none
    nxt = np.where(has_next, nxt, np.arange(n))
    h0, h1 = ts - ts[prev], ts[nxt] - ts  # s, 0 where there is no neighbour
    inner = has_prev & has_next
    for out, p in ((vx, x[order]), (vy, y[order])):
        with np.errstate(divide="ignore", invalid="ignore"):
            central = (h0 ** 2 * p[nxt] - h1 ** 2 * p[prev] + (h1 ** 2 - h0 ** 2) * p) / (h0 * h1 * (h0 + h1))
            one_sided = (p[nxt] - p[prev]) / (h0 + h1)
        out[order] = np.where(inner, central, np.where(has_prev | has_next, one_sided, 0.0))
    alone = int(np.sum(~has_prev & ~has_next))
    if alone:
        warnings.warn(f"{path}: no vx, vy columns: the velocities are derived from each target's positions; "
                      f"{alone} target(s) with one row get velocity 0", BoundWarning, stacklevel=4)
    return vx, vy



def truth_scans(truth: dict, time_origin: float, tol: float, sched_time: np.ndarray) -> dict:
    """The truth rows, each repeated for every scan at its time: scan, label, state, source row."""
    t, labels, values, path = truth["t"], truth["labels"], truth["values"], truth["path"]
    present = {"time": truth["time_column"]}
    times = np.unique(sched_time)
    pos = np.clip(np.searchsorted(times, t), 1, max(times.size - 1, 1))
    near = np.where(np.abs(times[pos - 1] - t) <= np.abs(times[np.minimum(pos, times.size - 1)] - t),
                    pos - 1, np.minimum(pos, times.size - 1))
    miss = np.abs(times[near] - t) > tol + 1e-9 * np.maximum(1.0, np.abs(t))
    if miss.any():
        row = int(np.argmax(miss))
        raise DatasetError(f"{where_in(path, row, present['time'])}: time {float(t[row] + time_origin)!r} s is no "
                           f"scan's time (nearest {times[near[row]] + time_origin:.6g} s, tolerance {tol:g} s); truth "
                           f"rows must be at the sweeps' times")
    first_scan = np.searchsorted(sched_time, times[near], side="left")
    last_scan = np.searchsorted(sched_time, times[near], side="right")
    src, scan = _spread(first_scan, last_scan)
    scan += 1
    return {"scan": scan.astype(np.int32), "label": labels[src].tolist(), "row": src, "path": path,
            "time_column": present["time"], "sched_time": sched_time, **{c: v[src] for c, v in values.items()}}


def _spread(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (i, j) with lo[i] <= j < hi[i], as two int64 arrays (shape (sum(hi - lo),)), i ascending, then j."""
    counts = hi - lo
    i = np.repeat(np.arange(lo.size), counts)
    starts = np.cumsum(counts) - counts
    return i, (np.arange(i.size) - starts[i] + lo[i]).astype(np.int64)


def check_truth_gap(gap_s: object, truth: object) -> float | None:
    """``--truth-from-labels`` checked: None, or the longest gap (s) across which a label's position is
    interpolated; ConfigError for a gap that is not a positive finite number, or one given with ``truth``."""
    if gap_s is None:
        return None
    number = isinstance(gap_s, numbers.Real) and not isinstance(gap_s, bool)
    what = f"--truth-from-labels {float(gap_s):g}" if number else f"--truth-from-labels {gap_s!r}"
    if not number or not (0 < float(gap_s) < float("inf")):
        raise ConfigError(f"{what}: must be a positive number of seconds, the longest gap between a label's two "
                          f"reports across which its position is interpolated, e.g. --truth-from-labels 60")
    if truth is not None:
        raise ConfigError(f"{what} with --truth {truth}: give one source of truth: the truth file, or the "
                          f"labels (without --truth)")
    return float(gap_s)


def labelled_truth(t: np.ndarray, x: np.ndarray, y: np.ndarray, labels: np.ndarray | None, times: np.ndarray,
                   gap_s: float, path: Path | InMemory, column: str) -> dict:
    """The truth (as `read_truth` gives it) taken from labelled reports: at each scan time in ``times`` (s,
    sorted, unique) and for each label, the position linearly interpolated between the label's last report at
    or before the time and its next after it (or, at the time of a report with no next close enough, that report
    and the one before), when the two are at most ``gap_s`` (s) apart, and the velocity their difference quotient
    (m/s); no row otherwise.

    ``t`` (s), ``x``, ``y`` (m): the reports, shape (N,); ``labels`` (object (N,), None for clutter) their
    labels (``column``, the file's target_id column, names them in messages). Of a label's reports at one time
    the first counts. ConfigError when no report is labelled.
    """
    known = np.zeros(t.size, bool) if labels is None else np.not_equal(labels, None)
    if not known.any():
        raise ConfigError(f"--truth-from-labels {gap_s:g}: {path} has no labelled reports (column {column!r}"
                          f"{' is missing' if labels is None else ' is empty or negative in every row'}); the truth "
                          f"is taken from the labels (e.g. --column target_id=MMSI): give a file with labels, or "
                          f"a truth file with --truth")
    rows = np.flatnonzero(known)
    names, label = np.unique(labels[rows].astype(str), return_inverse=True)
    order = np.lexsort((t[rows], label))  # by label, then time (stable: the file's first of equal times)
    rows, label = rows[order], label.ravel()[order]
    ts = t[rows]
    keep = np.concatenate([[True], (label[1:] != label[:-1]) | (ts[1:] != ts[:-1])])
    rows, label, ts = rows[keep], label[keep], ts[keep]
    # pair i: reports i and i + 1 of one label, at most gap_s apart; it covers the times in [t_i, t_i+1), and
    # t_i+1 too when no pair starts there (the label's last report, or one before a longer gap)
    pair = (label[1:] == label[:-1]) & (ts[1:] - ts[:-1] <= gap_s)
    closes = pair & ~np.concatenate([pair[1:], [False]])
    a = np.flatnonzero(pair)
    lo = np.searchsorted(times, ts[a], side="left")
    hi = np.searchsorted(times, ts[a + 1], side="left") + (closes[a] & np.isin(ts[a + 1], times))
    which, at = _spread(lo, hi)
    if not which.size:
        same = label[1:] == label[:-1]
        gaps = (ts[1:] - ts[:-1])[same]
        typical = f"the median gap between a label's reports is {np.median(gaps):g} s" if gaps.size else (
            "no label has two reports at distinct times")
        raise ConfigError(f"--truth-from-labels {gap_s:g}: no label has two reports at most {gap_s:g} s apart around "
                          f"a scan time in {path} ({typical}); give a larger GAP_S, or a truth file with --truth")
    i, tq = a[which], times[at]
    dt = ts[i + 1] - ts[i]
    w = (tq - ts[i]) / dt
    values = {}
    for c, p in (("x", x[rows]), ("y", y[rows])):
        step = p[i + 1] - p[i]
        values[c], values[f"v{c}"] = p[i] + w * step, step / dt
    return {"t": tq, "labels": names[label[i]].astype(object), "values": values, "path": path,
            "time_column": column}


def truth_record(truth: dict | None, index: Mapping[str, int], det: Detections) -> Truth:
    if truth is None:
        e = np.empty(0)
        return Truth(scan=np.empty(0, np.int32), time=e, target_id=np.empty(0, np.int32), x=e, y=e, vx=e, vy=e,
                     detected=np.empty(0, bool))
    tid = np.array([index[v] for v in truth["label"]], dtype=np.int32)
    scan = truth["scan"]
    n_targets = max(len(index), 1)
    key = scan.astype(np.int64) * n_targets + tid
    order = np.argsort(key, kind="stable")
    twice = np.flatnonzero(np.diff(key[order]) == 0)
    if twice.size:
        a, b = sorted(truth["row"][order[twice[0]:twice[0] + 2]])
        raise DatasetError(f"{where_in(truth['path'], int(b), truth['time_column'])}: target {truth['label'][b]!r} "
                           f"has a second row at the time of data row {a + 1}; one row per target per scan")
    seen = np.zeros(0, np.int64) if not det.scan.size else np.unique(
        det.scan[~det.is_clutter].astype(np.int64) * n_targets + det.target_id[~det.is_clutter])
    k = key[order]
    return Truth(scan=scan[order], time=truth["sched_time"][scan[order] - 1], target_id=tid[order],
                 x=truth["x"][order], y=truth["y"][order], vx=truth["vx"][order], vy=truth["vy"][order],
                 detected=np.isin(k, seen))
