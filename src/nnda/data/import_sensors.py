"""The sensors of an import (``nnda import-detections --sensors/--sensor``): their specs, and the scan grid
(period, offset) and time origin inferred from their rows' times where the user gave none.

A sweep sensor's period, when not given, is the median gap between its
successive distinct times (to `TIME_RESOLUTION_S`), its offset the first
time modulo the period; the scan schedule needs the periods' common
multiple (`common_multiple`), so each period must be a whole number of
microseconds. `imported_sensors` builds the validated sensors from the
specs, the grids and the rows' ranges.
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
from nnda.data.scenario import TARGET_CLASSES, Clutter, Sensor
from nnda.data.time_columns import default_origin_ns, seconds_after
from nnda.errors import ConfigError, validated
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
#: the import's name for `Sensor.declared_targets` (``--sensor targets=aircraft``, ``targets = "ships"`` in a
#: sensors file): the class of target the sensor watches, as ``pd`` declares its P_D
TARGETS = "targets"
#: the sensor fields whose values are words, not numbers
_WORDS = ("name", "kind", TARGETS, "declared_targets")


def sensor_fields(pairs: Sequence[str]) -> dict[str, Any]:
    """``["scan_period_s=2", "kind=position"]`` as a Sensor field mapping (numbers parsed; validated later)."""
    fields: dict[str, Any] = {}
    for p in pairs:
        name, sep, value = p.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name:
            raise ConfigError(f"--sensor {p!r}: give FIELD=VALUE, e.g. scan_period_s=2")
        if (name not in Sensor.model_fields or name == "clutter") and name not in (*SITE_FIELDS, TARGETS):
            fields_known = ", ".join([*(f for f in Sensor.model_fields if f != "clutter"), TARGETS, *SITE_FIELDS])
            raise ConfigError(f"--sensor {p!r}: unknown sensor field {name!r}; choose one of {fields_known}")
        if name == "reports":
            if value.lower() not in _BOOLEANS:
                raise ConfigError(f"--sensor {p!r}: reports must be true or false")
            fields[name] = _BOOLEANS[value.lower()]
            continue
        try:
            fields[name] = float(value) if name not in _WORDS else value
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


def declared_targets(spec: Mapping[str, Any], where: str) -> dict[str, Any]:
    """``spec`` with its ``targets`` (the import's name) as ``declared_targets``; ConfigError naming ``where``
    (the sensor) for a class nnda does not know or for the two names given different classes."""
    if TARGETS not in spec:
        return dict(spec)
    full = {k: v for k, v in spec.items() if k != TARGETS}
    given = spec[TARGETS]
    if given not in TARGET_CLASSES:
        raise ConfigError(f"{where}: targets = {given!r} is no target class nnda knows; choose one of "
                          f"{', '.join(TARGET_CLASSES)} (or leave it out: the trackers' own defaults)")
    if full.setdefault("declared_targets", given) != given:
        raise ConfigError(f"{where}: targets = {given!r} and declared_targets = {full['declared_targets']!r} "
                          f"disagree; give one of them")
    return full


def uses_polar(kind: str, polar: bool, cart: bool) -> bool:
    """Does a sensor of ``kind`` take its detections from the range/azimuth columns (else from x/y)? ``polar``,
    ``cart``: whether the file has those columns."""
    return polar and (kind == "polar" or not cart)


def imported_sensors(specs: Sequence[Mapping[str, Any]], names: list[str], grids: Sequence[tuple[float, float]],
                     sensor: np.ndarray, rng: np.ndarray | None, x: np.ndarray | None, y: np.ndarray | None,
                     polar: bool, cart: bool) -> list[Sensor]:
    """The sensors of an import, validated: each spec as the user gave it, its (period, offset) s from
    ``grids``, no clutter model unless given, a ``pd`` given also declared (``declared_pd``, the P_D trackers
    assume, unless the spec declares its own), and range limits not given widened from the defaults to hold
    its detections (``sensor`` (N,) each row's sensor; ``rng`` (N,) m or None; ``x``, ``y`` (N,) m or None)."""
    built = []
    for j, spec in enumerate(specs):
        mine = sensor == j
        full = {**spec, "scan_period_s": grids[j][0], "scan_offset_s": grids[j][1]}
        full.setdefault("clutter", Clutter(law="none").model_dump())
        if "pd" in full:
            full.setdefault("declared_pd", full["pd"])
        site = (float(full.get("x_m", 0.0)), float(full.get("y_m", 0.0)))
        if uses_polar(full.get("kind", "polar"), polar, cart):
            rj = rng[mine]
        else:
            rj = np.hypot(x[mine] - site[0], y[mine] - site[1])
        if rj.size:
            full.setdefault("min_range_m", float(min(Sensor().min_range_m, math.floor(rj.min()))))
            full.setdefault("max_range_m", float(max(Sensor().max_range_m, math.ceil(rj.max()))))
        built.append(validated(Sensor, full, f"sensor {j} ({names[j]!r})", "sensor"))
    return built
