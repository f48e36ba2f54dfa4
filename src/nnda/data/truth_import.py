"""The truth file of an import (``nnda import-detections --truth``): its columns, each row's scans, and the
dataset's truth record.

A truth file has ``time``, ``target_id``, ``x``, ``y`` (or ``lat``,
``lon``) and optionally ``vx``, ``vy`` (m/s, east and north). Without the
velocity columns `derived_velocities` takes them from each target's
positions: central differences in time (second order on uneven steps, as
`numpy.gradient`), one-sided at a target's first and last row, 0 for a
target with one row (one BoundWarning counts those targets).
"""

from __future__ import annotations

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
from nnda.errors import BoundWarning, DatasetError

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
    reps = last_scan - first_scan
    src = np.repeat(np.arange(t.size), reps)
    scan = (np.concatenate([np.arange(a, b) for a, b in zip(first_scan, last_scan)]) + 1 if t.size
            else np.empty(0, np.int64))
    return {"scan": scan.astype(np.int32), "label": labels[src].tolist(), "row": src, "path": path,
            "time_column": present["time"], "sched_time": sched_time, **{c: v[src] for c, v in values.items()}}


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
