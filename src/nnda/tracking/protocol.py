"""The tracker protocol: what a study, the lagged output and the common battery may assume of a tracker.

A tracker is anything with a ``name``, a ``config_type`` (its strict pydantic
config, a `TrackerConfig`), ``reset()`` and ``step(scan) -> TrackerOutput``
(`nnda.tracking.output`); it is built as ``cls(sensors, config)`` (a
scenario's sensors, or one `Sensor`), by `nnda.tracking.registry.make_tracker`.
Nothing more is assumed: a peer (Stone Soup), a PHD filter or a
track-before-detect tracker meets it without an IMM or an initiator.
`checked_scan` is the scan check every one of them can share;
`nnda.data.scenario.sensor_tuple` reads the sensors. A tracker class that
takes asynchronous reports declares ``takes_reports`` (`reporting_trackers`).
"""

from __future__ import annotations

import math
import numbers
from typing import ClassVar, Protocol, runtime_checkable

import numba
import numpy as np
from pydantic import BaseModel, ConfigDict

from nnda.data.dataset import Scan
from nnda.data.scenario import Sensor
from nnda.errors import TrackingError
from nnda.tracking.output import TrackerOutput


class TrackerConfig(BaseModel):
    """Base of every tracker's config: strict (unknown fields, NaN and infinity refused), frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


@runtime_checkable
class Tracker(Protocol):
    """What a study runs: one scan in, every track out. Built as ``cls(sensors, config)``.

    Optional capabilities, read where present (never by tracker name) by the fixed-lag output
    (`nnda.tracking.lag.FixedLag`): a ``filter`` attribute that is an `IMM` (every `ContactTracker`: its
    motion models smooth the lagged states, `nnda.tracking.lag.LagMotion`), and a ``best_branch(reported)``
    method (`nnda.tracking.lag.RevisesBranches`: MHT) giving each reported track's contacts of its last
    scans on the current best hypothesis's branch. A tracker without them gets the back-fill of
    confirmations only.
    """

    name: ClassVar[str]
    config_type: ClassVar[type[TrackerConfig]]

    def reset(self) -> None:
        """Forget everything (the start of a new run)."""

    def step(self, scan: Scan) -> TrackerOutput:
        """Process one sweep and report every track."""


def checked_config(tracker: Tracker, config: TrackerConfig | None) -> TrackerConfig:
    """``config``, or the tracker's default config when None; raises unless it is of the tracker's type."""
    config = config if config is not None else tracker.config_type()
    if not isinstance(config, tracker.config_type):
        raise TrackingError(f"{tracker.name}: config must be a {tracker.config_type.__name__}")
    return config


#: a contact's row for each kind of measurement: polar [range m, azimuth rad], position fixes [x m, y m]
CONTACT_ROW = {True: "[range m, azimuth rad]", False: "[x m, y m]"}


def checked_contacts(name: str, scan: Scan, polar: bool, sensor: str) -> np.ndarray:
    """The contacts of ``scan`` as a float (N, 2) array, one row `CONTACT_ROW` per contact (``polar``: range
    and azimuth from the sweeping sensor, named ``sensor``; else Cartesian fixes), checked for tracker
    ``name``: TrackingError naming the tracker, the scan and the sensor unless the measurements are real
    numbers (integer or float dtype) of shape (N, 2), or an empty 1-D array for a scan without contacts,
    each finite and, for a polar sensor, with a positive range. A vectorised check and one compiled pass per
    scan, never a Python loop over contacts."""
    what = CONTACT_ROW[polar]
    kind = "polar sensor" if polar else "sensor of position fixes"
    try:
        z = np.asarray(scan.measurements)
    except (ValueError, TypeError) as exc:  # a ragged nested list
        raise TrackingError(f"{name}: scan {scan.index} of {kind} {sensor!r}: measurements must be an (N, 2) "
                            f"array of real numbers, one row {what} per contact "
                            f"({' '.join(str(exc).split())})") from None
    if z.dtype.kind not in "iuf":
        raise TrackingError(f"{name}: scan {scan.index} of {kind} {sensor!r}: measurements must be real numbers "
                            f"(an integer or float array), one row {what} per contact; got dtype {z.dtype}")
    if z.ndim == 1 and z.size == 0:
        return np.empty((0, 2))
    if z.ndim != 2 or z.shape[1] != 2:
        raise TrackingError(f"{name}: scan {scan.index} of {kind} {sensor!r}: measurements must have shape "
                            f"(N, 2) {what}, one row per contact, got {z.shape}")
    z = z.astype(float, copy=False)
    if not _valid(z, polar):
        row = int(np.flatnonzero(~np.isfinite(z).all(axis=1) | (polar & ~(z[:, 0] > 0)))[0])
        raise TrackingError(f"{name}: scan {scan.index}: contact {row} is invalid {z[row].tolist()} "
                            f"({'non-finite or non-positive range' if polar else 'non-finite'}); give finite "
                            f"values{', with a range > 0 m' if polar else ''}")
    return z


def checked_scan(name: str, scan: Scan, last_time: float, sensors: tuple[Sensor, ...], last_sensor: int | None = None,
                 reports: bool = False) -> tuple[np.ndarray, float]:
    """The contacts z (N, 2) and time (s) of ``scan``, checked for tracker ``name`` built for ``sensors``.

    Raises TrackingError unless ``scan`` is a scan (`nnda.data.dataset.Scan`: index, time, measurements,
    sensor), its time is a finite number after ``last_time`` (or equal to it when the tracker gives the
    previous scan's sensor, ``last_sensor``, and this scan comes from another: two sensors' sweeps at one
    instant), its sensor is one of ``sensors`` (and sweeps, unless the tracker takes asynchronous ``reports``:
    `nnda.tracking.reports`) and its
    measurements pass `checked_contacts` for that sensor's kind ([range m, azimuth rad], positive ranges, for
    a polar sensor; [x m, y m] for a position sensor).
    """
    if not (hasattr(scan, "index") and hasattr(scan, "time") and hasattr(scan, "measurements")
            and hasattr(scan, "sensor")):  # one test a field, not a generator: every scan of every tracker
        raise TrackingError(f"{name}: step takes a scan (nnda.data.dataset.Scan: index, time, measurements, "
                            f"sensor), got {type(scan).__name__}")
    sensor = scan.sensor
    if not (isinstance(sensor, (int, np.integer)) and 0 <= sensor < len(sensors)):
        raise TrackingError(f"{name}: scan {scan.index} comes from sensor {sensor!r}, but this tracker was built "
                            f"for {len(sensors)} sensor(s) ({', '.join(s.name for s in sensors)})")
    if sensors[sensor].reports and not reports:
        raise TrackingError(f"{name}: scan {scan.index} comes from sensor {sensors[sensor].name!r} of asynchronous "
                            f"reports, which this tracker does not take; trackers that do: "
                            f"{', '.join(reporting_trackers())}")
    if type(scan.time) is not float and (isinstance(scan.time, (bool, np.bool_))  # a float passes at once
                                         or not isinstance(scan.time, numbers.Real)):
        raise TrackingError(f"{name}: scan {scan.index} has time {scan.time!r} of type {type(scan.time).__name__}; "
                            f"a scan's time is a number of seconds")
    time = float(scan.time)
    if not math.isfinite(time):
        raise TrackingError(f"{name}: scan {scan.index} has a non-finite time {scan.time}")
    if time < last_time or (time == last_time and (last_sensor is None or sensor == last_sensor)):
        raise TrackingError(f"{name}: scan {scan.index} at t = {time} s does not come after the previous scan "
                            f"(t = {last_time} s{'' if last_sensor is None else f', sensor {last_sensor}'}); scans "
                            f"must arrive in time order, those of two sensors at one instant in either order")
    return checked_contacts(name, scan, sensors[sensor].kind == "polar", sensors[sensor].name), time

#: the names of the tracker classes defined so far that take asynchronous reports (`declare_reports`)
_REPORTING: set[str] = set()


def declare_reports(cls: type) -> None:
    """Note tracker class ``cls`` among those that take asynchronous reports if it declares ``takes_reports`` and
    has a ``name`` (`nnda.tracking.tracker.ContactTracker` calls this for each of its subclasses)."""
    if getattr(cls, "takes_reports", False) and hasattr(cls, "name"):
        _REPORTING.add(cls.name)


def reporting_trackers() -> list[str]:
    """The names of the trackers defined so far that take asynchronous reports (``takes_reports``)."""
    return sorted(_REPORTING)


@numba.njit(cache=True, nogil=True)
def _valid(z, polar):
    """Whether every contact of z (N, 2) is finite, with a positive range if ``polar`` (`checked_scan`'s test
    in one compiled pass: it runs on every scan of every tracker)."""
    for i in range(z.shape[0]):
        if not (math.isfinite(z[i, 0]) and math.isfinite(z[i, 1])) or (polar and not z[i, 0] > 0):
            return False
    return True
