"""The sensors of an import (``nnda import-detections --sensors/--sensor``): their specs, and the scan grid
(period, offset) and time origin inferred from their rows' times where the user gave none.

A sweep sensor's period, when not given, is the median gap between its
successive distinct times (to `TIME_RESOLUTION_S`), its offset the first
time modulo the period; the scan schedule needs the periods' common
multiple (`common_multiple`), so each period must be a whole number of
microseconds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from nnda.data.geodetic_import import SITE_FIELDS
from nnda.data.report_import import report_grid
from nnda.data.scenario import Sensor
from nnda.data.time_columns import default_origin_ns, seconds_after
from nnda.errors import ConfigError
from nnda.files import read_config

#: periods and offsets are compared and inferred to this resolution (s)
TIME_RESOLUTION_S = 1e-6


def load_sensors(path: str | Path) -> list[dict]:
    """The ``[[sensors]]`` tables of a TOML (or JSON) file, fields as in a scenario's sensors."""
    data = read_config(path, "sensors")
    sensors = data.get("sensors")
    extra = sorted(set(data) - {"sensors"})
    if extra:
        raise ConfigError(f"{path}: unknown key(s) {', '.join(extra)}; give the sensors as [[sensors]] tables")
    if not isinstance(sensors, list) or not sensors or not all(isinstance(s, dict) for s in sensors):
        raise ConfigError(f"{path}: give one or more [[sensors]] tables (Sensor fields: name, kind, x_m, y_m, "
                          f"scan_period_s, sigma_range_m, ...)")
    return sensors


#: --sensor reports=VALUE spellings
_BOOLEANS = {"true": True, "false": False, "1": True, "0": False, "yes": True, "no": False}


def sensor_fields(pairs: Sequence[str]) -> dict[str, Any]:
    """``["scan_period_s=2", "kind=position"]`` as a Sensor field mapping (numbers parsed; validated later)."""
    fields: dict[str, Any] = {}
    for p in pairs:
        name, sep, value = p.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name:
            raise ConfigError(f"--sensor {p!r}: give FIELD=VALUE, e.g. scan_period_s=2")
        if (name not in Sensor.model_fields or name == "clutter") and name not in SITE_FIELDS:
            fields_known = ", ".join([*(f for f in Sensor.model_fields if f != "clutter"), *SITE_FIELDS])
            raise ConfigError(f"--sensor {p!r}: unknown sensor field {name!r}; choose one of {fields_known}")
        if name == "reports":
            if value.lower() not in _BOOLEANS:
                raise ConfigError(f"--sensor {p!r}: reports must be true or false")
            fields[name] = _BOOLEANS[value.lower()]
            continue
        try:
            fields[name] = float(value) if name not in ("name", "kind") else value
        except ValueError:
            raise ConfigError(f"--sensor {p!r}: {name} must be a number") from None
    return fields


def period_fraction(seconds: float, what: str) -> Fraction:
    """``seconds`` (a period) as an exact fraction to 1 us; ConfigError naming ``what`` when it is not one."""
    f = Fraction(seconds).limit_denominator(round(1 / TIME_RESOLUTION_S))
    if abs(float(f) - seconds) > 1e-9 * max(1.0, seconds):
        raise ConfigError(f"{what} = {seconds!r} s is not a whole number of microseconds; nnda's scan schedule "
                          f"needs periods of a common multiple")
    return f


def common_multiple(periods: Sequence[Fraction]) -> Fraction:
    """The least common multiple (s) of exact ``periods``."""
    num, den = periods[0].numerator, periods[0].denominator
    for p in periods[1:]:
        num, den = math.lcm(num, p.numerator), math.gcd(den, p.denominator)
    return Fraction(num, den)


def sweep_grid(sensor: Mapping[str, Any], t: np.ndarray, tol: float, time_origin: float) -> tuple[float, float]:
    """Period and offset (s, after the origin) of a sensor: as given (an offset in the file's clock), or
    inferred from its times ``t`` (after the origin, in order)."""
    starts = t[np.concatenate([[True], np.diff(t) > tol])] if t.size else t
    period = sensor.get("scan_period_s")
    if period is None:
        gaps = np.diff(starts)
        period = round(float(np.median(gaps)), 6) if gaps.size else Sensor().scan_period_s
        period = period if period > 0 else Sensor().scan_period_s
    period = float(period)
    if "scan_offset_s" in sensor:
        offset = round((float(sensor["scan_offset_s"]) - time_origin) % period, 9)
    else:
        offset = round(float(starts[0] % period), 6) if starts.size else 0.0
    if offset <= max(tol, 1e-9) or period - offset <= max(tol, 1e-9):
        offset = 0.0
    return period, offset


def default_time_origin(specs: Sequence[Mapping[str, Any]], names: list[str], sensor: np.ndarray, t_ns: np.ndarray,
                    tol: float) -> int:
    """The time origin (ns since 1970 UTC) of absolute times ``t_ns`` (`nnda.data.time_columns.default_origin_ns`):
    a report sensor's window, a sweep sensor's period given or inferred from its times."""
    firsts, periods, reports = [], [], []
    for j, spec in enumerate(specs):
        tj = t_ns[sensor == j]
        report = bool(spec.get("reports", False))
        if report:
            period = report_grid(spec, names[j], j, 0.0)[0]
        elif spec.get("scan_period_s") is not None:
            period = float(spec["scan_period_s"])
        else:  # the gaps between its times: the offset (and so the origin) does not change them
            period = sweep_grid({}, seconds_after(tj, int(tj[0])) if tj.size else np.empty(0), tol, 0.0)[0]
        firsts.append(int(tj.min()) if tj.size else None)
        periods.append(period)
        reports.append(report)
    return default_origin_ns(firsts, periods, reports)
