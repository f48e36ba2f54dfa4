"""A user's recorded detections (CSV or Parquet) as an nnda dataset: ``nnda import-detections``.

Usage sketch::

    ds = read_detections("plots.csv", sensors=[{"scan_period_s": 2.0, "sigma_range_m": 30}],
                         azimuth_unit="deg", columns={"time": "t_sec"})     # a Dataset, checked
    import_detections("plots.csv", "data/plots", truth="truth.csv")        # read, then write_dataset

The file's schema (names as here, or mapped with ``columns``: nnda name ->
the file's name; the mapping applies to the truth file too):

* ``time`` (s), required: numbers, or dates and times (ISO 8601 text or a
  timestamp column, UTC without a zone; `nnda.data.time_columns`); and the position: ``range`` (m) and ``azimuth``
  (rad, or degrees with ``azimuth_unit="deg"``; clockwise from north, from
  the detecting sensor, in [-pi, 2 pi) and stored wrapped to [0, 2 pi)),
  or ``x`` and ``y`` (m, x east, y north, scenario frame), or ``lat`` and
  ``lon`` (deg, WGS 84; optional ``alt``, m) placed on the local plane of
  the geodetic origin (`nnda.data.geodetic_import`). A polar sensor's
  detections are taken from ``range``/``azimuth`` when the file has them,
  a position sensor's from ``x``/``y``; the other pair is derived from the
  sensor's position. A sensor whose ``kind`` is not given is polar when the
  file has ``range`` and ``azimuth``, a position sensor otherwise.
* ``sensor`` (optional): a sensor's name, matched first (an integer 12 finds
  a sensor named "12"); when not every sensor was given a name, a whole
  number that names none is its index in the sensor list. Without the
  column every row belongs to the only sensor.
* ``target_id`` (optional truth label): any integer or text; an empty cell
  (or a negative integer) marks clutter. Without the column every detection
  is unlabelled, stored as the format stores clutter (target_id -1).
* a truth file (optional, same formats; `nnda.data.truth_import`): ``time``,
  ``target_id``, ``x``, ``y`` (or ``lat``, ``lon``), optional ``vx``, ``vy``
  (s, m or deg, m/s; velocities east and north, derived from the positions
  when absent), one row per target per time; each time
  must be the time of a scan (within the tolerance), its row is stored for
  every scan at that time, and a detection's target must appear in it.
  Without one, ``truth_from_labels`` takes the truth from the labelled
  detections (`nnda.data.truth_import.labelled_truth`).

Distances (range, x, y, alt) are in ``distance_unit`` and the truth's
velocities in ``speed_unit`` (`DISTANCE_UNITS`, `SPEED_UNITS`), stored
in metres and m/s.

Scans: a scan is one sensor's detections at one sweep time. Each sensor
sweeps at ``scan_offset_s + k scan_period_s`` (`nnda.data.scenario.Sensor`);
a row belongs to the sweep nearest its time and must lie within
``scan_tolerance`` s of it (default `SCAN_TOLERANCE_S`: equal times up to
rounding; raise it, below half a period, for a radar that stamps each plot
with its own time). The dataset records the sweep's time. A sensor's
period, when not given, is the median gap between its successive distinct
times (rounded to 1 us) and its offset the first time modulo the period;
range limits not given are widened from the default 5-30 km to hold every
detection. A ``region`` drops the rows outside it first: everything
inferred (the time origin of dates, periods, offsets, range limits, and an
origin chosen as the reports' mean when the region is in degrees) comes
from the rows kept. nnda's scans lie at t > 0: ``time_origin`` (s) is subtracted
from every time first (for clock times or a file that starts at 0). Rows of
one sensor must not go back in time (in file order). A report sensor
(``reports = True``: AIS, ADS-B) instead keeps each row's own time and puts
it in the window (t_k - scan_period_s, t_k] that holds it
(`nnda.data.report_import`); its ``scan_period_s`` must be given. Absolute
times (dates) become seconds after an origin: ``time_origin`` (seconds
since 1970 UTC) when given, else the start of the window holding the first
report (a report sensor; windows counted from 1970-01-01 00:00 UTC) or the
first time less one period (a sweep sensor), the earliest over the
sensors; the dataset records it (``time_origin_utc``).

A CSV (the detections and the truth file alike; `nnda.data.table_reading`; compressed when named .csv.gz,
.csv.bz2 or .csv.zst) is UTF-8 text with ","
between fields and "." in numbers unless ``delimiter`` (``;``, ``|``, a
tab), ``decimal`` (``,``) and ``encoding`` (a Python codec name, e.g.
``latin-1``) say otherwise; a Parquet file ignores them. A byte that is not
text in the encoding is refused with its line (as an editor counts) and
column, never read as mangled text; a header that another delimiter splits
is refused with the options to pass; a column name nnda reads must not
repeat.

Every problem names the file, the data row (1-based, the header not
counted: line = row + 1 in a CSV with one header line) and the column, as a
`DatasetError` (the file's content) or a `ConfigError` (the options); the
reader builds the whole dataset before anything is written, and the writer
(`nnda.data.dataset.write_dataset`) is atomic, so a refused import leaves
the output untouched.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from nnda.data.dataset import Dataset, Detections, write_dataset
from nnda.data.detections_export import export_detections as export_detections  # re-exported
from nnda.data.detections_export import sensor_specs as sensor_specs  # re-exported
from nnda.data.geodesy import GeodeticOrigin, check_geodetic
from nnda.data.geodetic_import import (
    SITE_FIELDS,
    choose_origin,
    keep_in_region,
    local_positions,
    place_sites,
    sensor_sites,
)
from nnda.data.import_schedule import schedule_duration, sensor_sweeps
from nnda.data.import_sensors import declared_targets, default_time_origin, imported_sensors, uses_polar
from nnda.data.region import Region, parse_region
from nnda.data.report_import import scan_order
from nnda.data.scenario import ProcessNoise, Scenario, Segment, Sensor, Target
from nnda.data.sensor import TWO_PI, cart_to_polar_at, polar_to_cart_at, wrap_azimuth
from nnda.data.table_reading import (
    Source,
    csv_dialect,
    decimal_mark,
    find_columns,
    labels_of,
    numbers_of,
    read_source,
    require_columns,
    table_stem,
    texts_of,
    where_in,
)
from nnda.data.time_columns import (
    NS,
    absolute_ns,
    is_absolute,
    origin_ns_of,
    seconds_after,
    utc_text,
)
from nnda.data.truth_import import (
    TRUTH_COLUMNS,
    check_truth_gap,
    labelled_truth,
    read_truth,
    truth_record,
    truth_scans,
)
from nnda.errors import ConfigError, DatasetError, validated

#: columns nnda reads from a detections file (a truth file's: `TRUTH_COLUMNS`)
DETECTION_COLUMNS = ("time", "range", "azimuth", "x", "y", "lat", "lon", "alt", "sensor", "target_id")
AZIMUTH_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}
#: --distance-unit (range, x, y, alt of both files) and --speed-unit (the truth's vx, vy): metres, m/s per unit
DISTANCE_UNITS = {"m": 1.0, "km": 1000.0, "nmi": 1852.0, "ft": 0.3048}
SPEED_UNITS = {"m/s": 1.0, "kn": 1852.0 / 3600.0, "km/h": 1.0 / 3.6}
#: default grouping tolerance (s): a row is in a sweep when within this of the sweep's time
SCAN_TOLERANCE_S = 1e-6


def column_mapping(pairs: Sequence[str] | Mapping[str, str] | None) -> dict[str, str]:
    """``["time=t_sec", ...]`` (or a mapping) as {nnda name: file column}; ConfigError for an unknown name."""
    if pairs is None:
        return {}
    items = pairs.items() if isinstance(pairs, Mapping) else []
    if not isinstance(pairs, Mapping):
        parsed = []
        for p in pairs:
            name, sep, column = p.partition("=")
            if not sep or not name or not column:
                raise ConfigError(f"--column {p!r}: give NAME=COLUMN, e.g. time=t_sec")
            parsed.append((name.strip(), column.strip()))
        items = parsed
    mapping: dict[str, str] = {}
    known = sorted({*DETECTION_COLUMNS, *TRUTH_COLUMNS})
    for name, column in items:
        if name not in known:
            raise ConfigError(f"--column {name}={column}: unknown column name {name!r}; nnda reads "
                              f"{', '.join(known)}")
        if name in mapping:
            raise ConfigError(f"--column: {name!r} is mapped twice")
        mapping[name] = column
    return mapping


# ----------------------------------------------------------------------------- the import

def _check_azimuth(path: Path, column: str, az: np.ndarray, unit: str) -> None:
    bad = (az < -math.pi) | (az >= TWO_PI)
    if bad.any():
        row = int(np.argmax(bad))
        shown = az[row] / AZIMUTH_UNITS[unit]
        limits = "[-180, 360) deg" if unit == "deg" else "[-pi, 2 pi) rad"
        hint = "" if unit == "deg" or abs(shown) > 360 else " (degrees? pass --azimuth-unit deg)"
        raise DatasetError(f"{where_in(path, row, column)}: azimuth {float(shown)!r} {unit} is outside {limits}{hint}")


def _sensor_index(path: Path, column: str, table: pa.Table, names: list[str], named: bool) -> np.ndarray:
    """Each row's sensor index from column ``column``: a value is a sensor's name, else (unless every sensor
    was ``named`` by the user) its index in the list; an integer column is matched as text (a sensor named
    "12", value 12)."""
    col = table.column(column)
    n = len(names)
    if pa.types.is_integer(col.type) and not col.null_count and not named and not any(s.isdigit() for s in names):
        idx = col.to_numpy().astype(np.int64)
        bad = (idx < 0) | (idx >= n)
        if bad.any():
            row = int(np.argmax(bad))
            raise DatasetError(f"{where_in(path, row, column)}: unknown sensor {int(idx[row])} (sensors: "
                               f"{', '.join(f'{i} {s!r}' for i, s in enumerate(names))})")
        return idx.astype(np.int32)
    values = np.array(["" if v is None else str(v) for v in texts_of(table, path, column)], dtype=object)
    uniq, inverse = np.unique(values, return_inverse=True)
    lookup = []
    for value in uniq:
        if value in names:
            lookup.append(names.index(value))
        elif not named and re.fullmatch(r"\d{1,9}", value) and int(value) < n:
            lookup.append(int(value))
        else:
            row = int(np.argmax(values == value))
            got = "an empty cell" if value == "" else f"unknown sensor {value!r}"
            raise DatasetError(f"{where_in(path, row, column)}: {got} (sensors: "
                               f"{', '.join(f'{i} {s!r}' for i, s in enumerate(names))})")
    return np.asarray(lookup, dtype=np.int32)[inverse]


#: a label that is an integer (sorted as one)
_INTEGER_LABEL = re.compile(r"-?\d{1,30}")


def _target_order(labels: list[str]) -> list[str]:
    """Target labels in id order: numerically when every label is an integer, as text otherwise."""
    if all(_INTEGER_LABEL.fullmatch(s) for s in labels):
        return sorted(labels, key=int)
    return sorted(labels)


def _scenario_name(name: str) -> str:
    kept = "".join(c if (c.isascii() and c.isalnum()) or c in "_.-" else "_" for c in name) or "imported"
    return "_" + kept[1:] if kept.startswith(".") else kept


def read_detections(
    path: Source, *, sensors: Sequence[Mapping[str, Any] | Sensor] | None = None,
    truth: Source | None = None, columns: Sequence[str] | Mapping[str, str] | None = None,
    azimuth_unit: str = "rad", scan_tolerance: float = SCAN_TOLERANCE_S, time_origin: float | None = None,
    name: str | None = None, delimiter: str = ",", decimal: str = ".", encoding: str = "utf-8",
    origin: str | Sequence[float] | GeodeticOrigin | None = None, region: str | Path | Region | None = None,
    distance_unit: str = "m", speed_unit: str = "m/s", truth_from_labels: float | None = None,
) -> Dataset:
    """The detections file at ``path`` (and its ``truth`` file) as a checked `Dataset` (see the module).

    ``path`` and ``truth`` may also be tables in memory, a pyarrow Table or a
    pandas DataFrame (its index ignored), with the columns a file has;
    messages then name "the table" (or "the truth table") and its row
    (1-based) and column, and the scenario is named "imported" by default.

    ``sensors``: one mapping of Sensor fields (or a Sensor) per sensor, in
    index order (default: one radar with the default fields); fields left out
    are inferred as the module docstring says. ``columns`` maps nnda's column
    names to the file's. ``name`` names the scenario (default: the file's stem).
    ``delimiter`` (``,`` ``;`` ``|`` or a tab), ``decimal`` (``.`` or ``,``)
    and ``encoding`` (a Python codec name) say how a CSV (detections and
    truth) is written; a Parquet file ignores them. ``origin`` (``"LAT,LON[,ALT]"``, deg, deg, m) fixes
    the geodetic origin of the frame (default: chosen from the data, `nnda.data.geodetic_import`);
    ``region`` (a box or a polygon file, `nnda.data.region`) drops the reports outside it.
    ``distance_unit`` (`DISTANCE_UNITS`: m, km, nmi, ft) is the unit of the
    files' range, x, y and alt, ``speed_unit`` (`SPEED_UNITS`: m/s, kn,
    km/h) of the truth's vx, vy; the dataset holds metres and m/s (the
    sensors' fields stay in metres). ``truth_from_labels`` (s), in place of
    a ``truth`` file, takes the truth at the scan times from the labelled
    reports, interpolated across gaps of at most that many seconds
    (`nnda.data.truth_import.labelled_truth`).
    """
    if azimuth_unit not in AZIMUTH_UNITS:
        raise ConfigError(f"--azimuth-unit {azimuth_unit!r}: unknown unit; choose one of {', '.join(AZIMUTH_UNITS)}")
    for option, unit, known in (("--distance-unit", distance_unit, DISTANCE_UNITS), ("--speed-unit", speed_unit,
                                                                                      SPEED_UNITS)):
        if unit not in known:
            raise ConfigError(f"{option} {unit!r}: unknown unit; choose one of {', '.join(known)}")
    metres = DISTANCE_UNITS[distance_unit]
    if not (math.isfinite(scan_tolerance) and scan_tolerance >= 0):
        raise ConfigError(f"--scan-tolerance {scan_tolerance!r}: must be a finite number of seconds >= 0")
    if time_origin is not None and not math.isfinite(time_origin):
        raise ConfigError(f"--time-origin {time_origin!r}: must be a finite number of seconds")
    gap_s = check_truth_gap(truth_from_labels, truth)
    mapping = column_mapping(columns)
    dialect = csv_dialect(delimiter, decimal, encoding)
    specs = [s.model_dump(exclude_unset=True) if isinstance(s, Sensor) else dict(s) for s in (sensors or [{}])]
    given = [dict(s) for s in specs]  # as the user gave them (names before the defaults)
    for i, s in enumerate(specs):
        s.setdefault("name", "radar" if len(specs) == 1 else f"sensor{i}")
    names = [str(s["name"]) for s in specs]
    sites = sensor_sites(specs, names)
    if isinstance(region, (str, Path)):
        region = parse_region(region, dialect)
    for j, s in enumerate(specs):  # the fields given, before anything is inferred (an offset needs its period)
        specs[j] = s = declared_targets(s, f"sensor {j} ({names[j]!r})")  # --sensor targets=aircraft
        validated(Sensor, {k: v for k, v in s.items() if k != "scan_offset_s"}, f"sensor {j} ({names[j]!r})",
                  "sensor")
    path, table = read_source(path, "detections", dialect)
    dec = decimal_mark(path, dialect)
    present = find_columns(table, path, DETECTION_COLUMNS, mapping)
    require_columns(path, present, ["time"], mapping, table, "the time of each detection, s")
    n = table.num_rows
    tcol = present["time"]
    absolute = is_absolute(table.column(tcol))
    if absolute:
        t_ns = absolute_ns(table.column(tcol), lambda row: where_in(path, row, tcol))
    else:
        time_origin = 0.0 if time_origin is None else float(time_origin)
        t = numbers_of(table, path, "time", tcol, dec) - time_origin
    polar, cart = {"range", "azimuth"} <= present.keys(), {"x", "y"} <= present.keys()
    geodetic = not cart and ({"lat", "lon"} <= present.keys() or not polar and ("lat" in present or "lon" in present))
    if not polar:  # positions only: a sensor of no given kind measures positions (a radar is asked for)
        for s in specs:
            s.setdefault("kind", "position")
    if not (polar or cart or geodetic):
        pair = ["range", "azimuth"] if "x" not in present and "y" not in present else ["x", "y"]
        require_columns(path, present, pair, mapping, table, "a position: range and azimuth, x and y, or lat and lon")
    lat = lon = alt = None
    if geodetic:
        require_columns(path, present, ["lat", "lon"], mapping, table, "a position in degrees: lat and lon")
        lat, lon, alt = (numbers_of(table, path, c, present[c], dec) if c in present else None for c in SITE_FIELDS)
        alt = alt * metres if alt is not None else None
        check_geodetic(lat, lon, alt, where=lambda c, row: where_in(path, row, present[c]), error=DatasetError)
    frame = choose_origin(origin, sites, names, lat, lon)
    place_sites(specs, sites, frame)
    rng = az = x = y = None
    if polar:
        rng = numbers_of(table, path, "range", present["range"], dec) * metres
        az = numbers_of(table, path, "azimuth", present["azimuth"], dec) * AZIMUTH_UNITS[azimuth_unit]
        _check_azimuth(path, present["azimuth"], az, azimuth_unit)
        az = wrap_azimuth(az)
        bad = ~(rng > 0)
        if bad.any():
            row = int(np.argmax(bad))
            raise DatasetError(f"{where_in(path, row, present['range'])}: range {float(rng[row])!r} m must be positive")
    if cart:
        x = numbers_of(table, path, "x", present["x"], dec) * metres
        y = numbers_of(table, path, "y", present["y"], dec) * metres
    elif geodetic:
        x, y = local_positions(path, present, frame, lat, lon, alt)
        cart = True
    if "sensor" in present:
        sensor = _sensor_index(path, present["sensor"], table, names, all("name" in s for s in given))
    elif len(specs) > 1:
        raise DatasetError(f"{path}: {len(specs)} sensors are given but the file has no column "
                           f"{mapping.get('sensor', 'sensor')!r} saying which one made each detection")
    else:
        sensor = np.zeros(n, dtype=np.int32)
    forms = _both_forms(path, mapping, specs, names, sensor, rng, az, x, y, polar)
    keep, n_dropped = keep_in_region(region, forms[2], forms[3], frame)
    rows_kept = np.arange(n) if keep is None else np.flatnonzero(keep)  # file row of each row kept
    if n_dropped and region.geodetic and origin is None and not (sites and sites[0]) and lat is not None:
        # the frame of the reports kept: their mean (which rows a region in degrees keeps hardly depends on the
        # plane: a box's none, a polygon's edges are straight on the plane of all the reports' mean)
        frame = choose_origin(None, sites, names, lat[keep], lon[keep])
        place_sites(specs, sites, frame)
        x, y, _ = frame.to_local(lat, lon, alt)
        forms = _both_forms(path, mapping, specs, names, sensor, rng, az, x, y, polar)
    if keep is not None:  # what is inferred below (time origin, periods, offsets, range limits) is the kept rows'
        n = rows_kept.size
        forms = tuple(a[keep] for a in forms)
        sensor, rng, az, x, y = (a[keep] if a is not None else None for a in (sensor, rng, az, x, y))
        if absolute:
            t_ns = t_ns[keep]
        else:
            t = t[keep]
    tol = float(scan_tolerance)
    origin_ns = None
    if absolute:
        origin_ns = (default_time_origin(specs, names, sensor, t_ns, tol) if time_origin is None
                     else origin_ns_of(time_origin))
        time_origin, t = origin_ns / NS, seconds_after(t_ns, origin_ns)
    bad = ~(t > 0)
    if bad.any():
        row = int(np.argmax(bad))
        raise DatasetError(f"{where_in(path, int(rows_kept[row]), tcol)}: time {float(t[row] + time_origin)!r} s is "
                           f"not after the time origin ({time_origin:g} s); nnda's scans lie at t > 0: pass "
                           f"--time-origin T with T below the first time (e.g. --time-origin "
                           f"{math.floor(t.min() + time_origin) - 1})")

    sweep, grids, needed = sensor_sweeps(specs, names, sensor, t, rows_kept, tol, time_origin,
                                         lambda row: where_in(path, row, tcol))
    truth_rows = (read_truth(truth, mapping, time_origin, dialect, frame, origin_ns,
                              (metres, SPEED_UNITS[speed_unit])) if truth is not None else None)
    last_truth = float(truth_rows["t"].max()) if truth_rows is not None and truth_rows["t"].size else None
    duration = schedule_duration(grids, needed, names, last_truth, time_origin, f"{path}: column {tcol!r}")
    built = imported_sensors(specs, names, grids, sensor, rng, x, y, polar, cart)

    labels = labels_of(table, path, present["target_id"])[rows_kept] if "target_id" in present else None
    scenario_name = _scenario_name(name or table_stem(path))
    return _assemble(path, truth_rows, mapping, scenario_name, built, duration, time_origin, tol,
                     t, sweep, sensor, forms, labels, rows_kept, frame, region, n_dropped,
                     None if origin_ns is None else utc_text(origin_ns), gap_s)


def _both_forms(path: Path, mapping: Mapping[str, str], specs: Sequence[Mapping[str, Any]], names: list[str],
                sensor: np.ndarray, rng: np.ndarray | None, az: np.ndarray | None, x: np.ndarray | None,
                y: np.ndarray | None, polar: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Range (m), azimuth (rad), x, y (m) of every row, shape (N,) each: a row's own form from the columns its
    sensor reads, the other derived from the sensor's site (``specs``' x_m, y_m); DatasetError for a
    detection on its sensor (range 0)."""
    n = sensor.size
    r_out, az_out, x_out, y_out = (np.empty(n) for _ in range(4))
    for j, s in enumerate(specs):
        mine = sensor == j
        if not mine.any():
            continue
        site = (float(s.get("x_m", 0.0)), float(s.get("y_m", 0.0)))
        if uses_polar(s.get("kind", "polar"), polar, x is not None):
            r_out[mine], az_out[mine] = rng[mine], az[mine]
            x_out[mine], y_out[mine] = polar_to_cart_at(site, rng[mine], az[mine])
        else:
            x_out[mine], y_out[mine] = x[mine], y[mine]
            r_out[mine], az_out[mine] = cart_to_polar_at(site, x[mine], y[mine])
    bad = ~(r_out > 0)
    if bad.any():
        row = int(np.argmax(bad))
        raise DatasetError(f"{where_in(path, row, mapping.get('x', 'x'))}: the detection lies on sensor "
                           f"{names[sensor[row]]!r} (range 0 m); nnda needs a positive range")
    return r_out, az_out, x_out, y_out


def _assemble(path, truth_rows, mapping, scenario_name, sensors, duration, time_origin, tol, t, sweep, sensor,
              forms, labels, rows_kept, frame=None, region=None, n_dropped=0, origin_utc=None,
              gap_s=None) -> Dataset:
    """The dataset from the checked columns of the rows kept (``rows_kept``: their file rows): scans,
    positions in both forms (``forms``: range, azimuth, x, y), targets, truth (the truth file's, or with
    ``gap_s`` the labels')."""
    n = t.size
    draft = validated(Scenario, {"name": scenario_name, "duration_s": duration, "sensors": tuple(sensors),
                                 "targets": [_placeholder(duration)], "process_noise": ProcessNoise(model="none")},
                      f"{path}: the sensors", "set of sensors")
    sched_time, sched_sensor = draft.scan_schedule()
    scan = np.empty(n, dtype=np.int32)
    for j in range(len(sensors)):
        mine = sensor == j
        scans_j = np.flatnonzero(sched_sensor == j).astype(np.int32) + 1
        scan[mine] = scans_j[sweep[mine]]
    r_out, az_out, x_out, y_out = forms
    # targets: the truth file's, else the labels'
    truth_path = truth_rows["path"] if truth_rows is not None else None
    if gap_s is not None:
        truth_rows = labelled_truth(t, x_out, y_out, labels, np.unique(sched_time), gap_s, path,
                                    mapping.get("target_id", "target_id"))
    truth_table = truth_scans(truth_rows, time_origin, tol, sched_time) if truth_rows is not None else None
    known = set(truth_table["label"]) if truth_table is not None else set()
    found = {v for v in labels if v is not None} if labels is not None else set()
    if truth_path is not None and found - known:
        unknown = found - known
        row = int(np.flatnonzero(np.isin(labels, list(unknown)))[0])
        raise DatasetError(f"{where_in(path, int(rows_kept[row]), mapping.get('target_id', 'target_id'))}: target "
                           f"{labels[row]!r} is not in the truth file {truth_path}")
    order = _target_order(sorted(known | found))
    index = {lab: i for i, lab in enumerate(order)}
    tid = (np.array([-1 if v is None else index[v] for v in labels.tolist()], dtype=np.int32)
           if labels is not None else np.full(n, -1, dtype=np.int32))
    report = np.array([s.reports for s in sensors])[sensor]
    rows = scan_order(scan, az_out, t, report) if report.any() else _scan_then_azimuth(scan, az_out)
    time = np.where(report[rows], t[rows], sched_time[scan[rows] - 1])
    det = Detections(scan=scan[rows], time=time, range=r_out[rows], azimuth=az_out[rows],
                     x=x_out[rows], y=y_out[rows], is_clutter=tid[rows] < 0, target_id=tid[rows],
                     sensor=sensor[rows].astype(np.int32))
    targets = _targets(order, truth_table, det, sched_time, duration)
    truth_rec = truth_record(truth_table, index, det)
    what = f"{n} detections from {path.name}" + (f", truth from {truth_path.name}" if truth_path else "")
    what += f", truth from the labels across gaps up to {gap_s:g} s" if gap_s is not None else ""
    what += f"; geodetic origin {frame}" if frame is not None else ""
    what += f"; {n_dropped} outside --region {region.text} dropped" if region is not None else ""
    scenario = Scenario(
        name=scenario_name, duration_s=duration, sensors=tuple(sensors), targets=targets,
        process_noise=ProcessNoise(model="none"),
        description=(f"imported by nnda import-detections: {what}; times less the origin "
                     f"{origin_utc or f'{time_origin:g} s'}, "
                     f"grouped into sweeps within {tol:g} s"
                     + (", a report sensor's into windows of its scan period" if report.any() else "")
                     + "; targets give each one's first true state "
                     f"(a placeholder when unlabelled), the {'labels' if gap_s is not None else 'truth file'} its "
                     "motion"))
    return Dataset(scenario, 0, 0, det, truth_rec, frame, {"--region": n_dropped} if region is not None else {},
                   origin_utc)


def _scan_then_azimuth(scan: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """``np.lexsort((azimuth, scan))`` (stable), by one sort of the key scan x 8 + azimuth (azimuth < 8), several
    times faster; exact ties the key's rounding makes are checked, and then the slow sort decides."""
    rows = np.argsort(scan * 8.0 + azimuth, kind="stable")
    s, a = scan[rows], azimuth[rows]
    if np.all((np.diff(s) > 0) | ((np.diff(s) == 0) & (np.diff(a) >= 0))):
        return rows
    return np.lexsort((azimuth, scan))


def _placeholder(duration: float) -> Target:
    """The one target of a scenario without labels (a scenario has at least one): at the origin, still."""
    return Target(name="unlabelled", x_m=0, y_m=0, heading_deg=0, speed_m_s=1e-6,
                  segments=[Segment(duration_s=duration)])


def _targets(order: list[str], truth: dict | None, det: Detections, sched_time: np.ndarray, duration: float
             ) -> list[Target]:
    if not order:
        return [_placeholder(duration)]
    targets = []
    labels = np.array(truth["label"], dtype=object) if truth is not None else None
    for i, name in enumerate(order):
        rows = np.flatnonzero(labels == name) if labels is not None else np.empty(0, np.int64)
        if rows.size:  # a label of the truth; without a row in it (truth from labels), its first detection
            r0 = rows[np.argmin(truth["scan"][rows])]
            x0, y0, vx, vy = (float(truth[c][r0]) for c in ("x", "y", "vx", "vy"))
            times = sched_time[truth["scan"][rows] - 1]
        else:
            rows = np.flatnonzero(det.target_id == i)
            x0, y0, vx, vy = float(det.x[rows[0]]), float(det.y[rows[0]]), 0.0, 0.0
            times = det.time[rows]
        start, end = float(times.min()), float(times.max())
        targets.append(Target(
            name=name, x_m=x0, y_m=y0, heading_deg=math.degrees(math.atan2(vx, vy)) % 360.0,
            speed_m_s=max(math.hypot(vx, vy), 1e-6), start_time_s=start,
            segments=[Segment(duration_s=max(end - start, 1e-3))]))
    return targets



def import_detections(path: Source, out: str | Path, overwrite: bool = False, **options) -> tuple[Path, Dataset]:
    """`read_detections` (``options`` as there), then write the dataset atomically at ``out``."""
    dataset = read_detections(path, **options)
    return write_dataset(dataset, out, overwrite), dataset
