"""Scenario configuration: targets, sensors (each with its clutter), duration and seed.

A scenario is validated data (pydantic), loadable from TOML or JSON. It speaks
as a pilot would: headings in degrees clockwise from north,
turn rates in degrees per second with positive = right (clockwise) turn,
accelerations in m/s^2. Everything is converted to SI radians once, in
`nnda.data.trajectory`.

Numbers without a citation come from the radar and scenario generator of
Vargas Avila (2015), Ch. 5; where the thesis leaves a choice open, the
docstrings say what we chose.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal, get_args

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializerFunctionWrapHandler,
    field_validator,
    model_serializer,
    model_validator,
)

from nnda.errors import ConfigError, validated
from nnda.files import path_component, read_config

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Probability = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]
#: the classes of target a sensor may declare it watches (`Sensor.declared_targets`; their trackers' defaults:
#: `nnda.tracking.target_classes`)
TargetClass = Literal["ships", "aircraft", "pedestrians"]
TARGET_CLASSES: tuple[str, ...] = get_args(TargetClass)

#: a sensor position must lie within this distance of the origin on each axis (m): the scenario's frame
FRAME_HALF_WIDTH_M = 1e7


class Segment(BaseModel):
    """One section of a trajectory (the curvilinear model of Vargas Avila (2015), eqs. A.1-A.7).

    Motion inside a section is set by a tangential acceleration (m/s^2) and
    either a normal acceleration (m/s^2; the turn rate then follows as a_n / V
    and changes with speed) or a constant turn rate (deg/s). Positive normal
    acceleration or turn rate is a right (clockwise) turn (our convention; the
    thesis does not fix one).
    """

    model_config = _STRICT

    duration_s: PositiveFloat
    tangential_accel: FiniteFloat = 0.0
    normal_accel: FiniteFloat | None = None
    turn_rate_deg_s: FiniteFloat | None = None

    @model_validator(mode="after")
    def _one_turn_law(self) -> Segment:
        if self.normal_accel is not None and self.turn_rate_deg_s is not None:
            raise ValueError("give either normal_accel or turn_rate_deg_s, not both")
        return self

    @property
    def kind(self) -> Literal["cv", "accel", "turn", "mixed"]:
        """Section type in the thesis's words: straight CV, straight accelerating, turn, mixed."""
        turning = bool(self.normal_accel) or bool(self.turn_rate_deg_s)
        if turning:
            return "mixed" if self.tangential_accel else "turn"
        return "accel" if self.tangential_accel else "cv"


class Target(BaseModel):
    """A target: its start (position, heading, speed), its sections and its gaps."""

    model_config = _STRICT

    name: Annotated[str, Field(min_length=1)]
    x_m: FiniteFloat
    y_m: FiniteFloat
    heading_deg: FiniteFloat = Field(description="initial heading, degrees clockwise from north")
    speed_m_s: PositiveFloat
    segments: Annotated[list[Segment], Field(min_length=1)]
    start_time_s: NonNegativeFloat = 0.0
    missed_scans: list[Annotated[int, Field(ge=1)]] = Field(
        default_factory=list, description="scripted gap table: scans with no detection"
    )
    pd: Probability | None = Field(default=None, description="overrides the sensor's PD")
    length_m: PositiveFloat | None = Field(
        default=None, description="hull length: hides shorter targets behind it from a sensor "
        "(nnda.data.occlusion); None: a point that hides nothing")

    @property
    def duration_s(self) -> float:
        return sum(s.duration_s for s in self.segments)

    @model_validator(mode="after")
    def _speed_stays_positive(self) -> Target:
        speed = self.speed_m_s
        for i, seg in enumerate(self.segments):
            speed += seg.tangential_accel * seg.duration_s
            if speed <= 0:
                raise ValueError(
                    f"segment {i}: speed falls to {speed:.3g} m/s; a target must keep moving forward"
                )
        if len(set(self.missed_scans)) != len(self.missed_scans):
            raise ValueError("missed_scans lists a scan twice")
        return self


class Clutter(BaseModel):
    """False contacts per sweep of one sensor (the thesis's 100 per scan; where they fall is ours, calibrated
    so the training set has the thesis's share of clutter pairs).

    Laws: ``square`` (default) uniform in a square of side ``side_m`` centred on
    ``centre_m`` (scenario frame, m; default: centre of the targets' noise-free
    bounding box at the sensor's sweeps); ``gaussian`` with std ``sigma_m`` per
    axis centred on ``centre_m`` (default: the targets' mean position at those
    sweeps); ``annulus`` uniform in
    area over the sensor's coverage (its ring, or its sector of the ring);
    ``none``. Points outside the sensor's coverage are redrawn (as calibrated),
    so every sweep holds exactly ``count`` points, or a Poisson number of mean
    ``count`` when ``count_law = "poisson"``.
    """

    model_config = _STRICT

    law: Literal["square", "gaussian", "annulus", "none"] = "square"
    count: Annotated[int, Field(ge=0)] = 100
    count_law: Literal["fixed", "poisson"] = "fixed"
    side_m: PositiveFloat = 16_600.0
    sigma_m: PositiveFloat = 6_300.0
    centre_m: tuple[FiniteFloat, FiniteFloat] | None = None


class Sensor(BaseModel):
    """One sensor of a scenario: where it is, what it covers, when it sweeps, how well it measures.

    The default is the thesis's static radar at the origin. ``kind``:
    ``"polar"`` measures (range m, azimuth rad clockwise from north) from its
    position (x_m, y_m), with noise ``sigma_range_m`` and
    ``sigma_azimuth_mrad``; ``"position"`` measures a Cartesian fix (x, y) in
    the scenario frame with noise ``sigma_position_m`` per axis (the other
    kind's sigmas are unused). Coverage: ranges in [min_range_m, max_range_m]
    from the sensor's position and azimuths within fov_deg / 2 of
    boresight_deg (degrees clockwise from north; fov_deg = 360 is the whole
    ring). The sensor sweeps at the times scan_offset_s + k scan_period_s
    (k integer) in (0, duration], sees each target with probability ``pd``
    (unless the target overrides it) and adds its own ``clutter``. ``pd`` is
    the generator's truth, which no tracker reads; ``declared_pd`` is the
    detection probability the sensor's owner declares, which trackers assume
    unless their config sets its own (`nnda.tracking.detection_probability`;
    ``nnda import-detections --sensor pd=X`` declares X). It is left out of a
    dump while None. ``declared_targets`` likewise declares what the sensor
    watches ("ships", "aircraft", "pedestrians"): its trackers take that
    class's speed window and motion noise for every field their config leaves
    out (`nnda.tracking.target_classes`; ``--sensor targets=aircraft``).

    A sensor with ``reports = True`` (AIS, ADS-B, a tracker's plot stream)
    reports each contact at its own time: its scan k holds the reports with
    time in (t_k - scan_period_s, t_k], t_k = scan_offset_s + k scan_period_s,
    so ``scan_period_s`` is a grouping window, not a sweep period. The field
    is left out of a dump while False, so the manifests of sweep sensors keep
    their bytes.
    """

    model_config = _STRICT

    name: Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")] = "radar"
    kind: Literal["polar", "position"] = "polar"
    x_m: FiniteFloat = 0.0
    y_m: FiniteFloat = 0.0
    boresight_deg: Annotated[float, Field(ge=-360, le=360, allow_inf_nan=False)] = 0.0
    fov_deg: Annotated[float, Field(gt=0, le=360, allow_inf_nan=False)] = 360.0
    scan_period_s: PositiveFloat = 2.0
    scan_offset_s: NonNegativeFloat = 0.0
    sigma_range_m: NonNegativeFloat = 30.0
    sigma_azimuth_mrad: NonNegativeFloat = 3.0
    sigma_position_m: NonNegativeFloat = 10.0
    min_range_m: NonNegativeFloat = 5_000.0
    max_range_m: PositiveFloat = 30_000.0
    pd: Probability = Field(default=1.0, description="detection probability outside scripted gaps")
    declared_pd: Probability | None = Field(
        default=None, description="the detection probability trackers assume for this sensor unless their config "
        "sets pd; None: the tracker's own")
    declared_targets: TargetClass | None = Field(
        default=None, description="the class of target the sensor watches, whose speed window and motion noise "
        "trackers take for the fields their config leaves out; None: the trackers' own defaults")
    clutter: Clutter = Clutter()
    reports: bool = Field(
        default=False, description="asynchronous reports: each detection keeps its own time; scan k holds this "
        "sensor's reports with time in (t_k - scan_period_s, t_k], where t_k = scan_offset_s + k scan_period_s is "
        "its k-th window's end")

    @model_serializer(mode="wrap")
    def _reports_only_when_set(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """The fields as pydantic dumps them, without ``reports`` while it is False and ``declared_pd`` and
        ``declared_targets`` while they are None (older manifests' bytes)."""
        data = handler(self)
        if not self.reports:
            data.pop("reports", None)
        for field in ("declared_pd", "declared_targets"):
            if getattr(self, field) is None:
                data.pop(field, None)
        return data

    @field_validator("x_m", "y_m")
    @classmethod
    def _inside_frame(cls, value: float) -> float:
        if abs(value) > FRAME_HALF_WIDTH_M:
            raise ValueError(f"{value:g} m lies outside the scenario's frame (|x|, |y| <= {FRAME_HALF_WIDTH_M:g} m)")
        return value

    @model_validator(mode="after")
    def _coverage_and_timing(self) -> Sensor:
        if self.min_range_m >= self.max_range_m:
            raise ValueError("min_range_m must be below max_range_m")
        if self.scan_offset_s >= self.scan_period_s:
            raise ValueError(f"scan_offset_s = {self.scan_offset_s} must be below scan_period_s = {self.scan_period_s}")
        return self

    @property
    def sigma_azimuth_rad(self) -> float:
        return self.sigma_azimuth_mrad * 1e-3

    @property
    def position(self) -> tuple[float, float]:
        """(x east, y north) of the sensor in the scenario frame, m."""
        return (self.x_m, self.y_m)

    @property
    def full_circle(self) -> bool:
        """Does the sensor see every azimuth (fov_deg = 360)?"""
        return self.fov_deg == 360.0

    @property
    def boresight_rad(self) -> float:
        return math.radians(self.boresight_deg)

    @property
    def half_fov_rad(self) -> float:
        return math.radians(self.fov_deg) / 2

    def n_sweeps(self, duration_s: float) -> int:
        """Sweeps inside (0, duration_s]: one per period (the scenario checks it is a whole number)."""
        return round(duration_s / self.scan_period_s)

    def sweep_times(self, duration_s: float) -> np.ndarray:
        """Times (s) of the sweeps inside (0, duration_s], increasing, shape (n_sweeps,).

        offset + k T for k = 1.. with no offset (t = T, 2T, ..., duration),
        k = 0.. with one (t = offset, offset + T, ...).
        """
        first = 0 if self.scan_offset_s > 0 else 1
        return np.arange(first, first + self.n_sweeps(duration_s)) * self.scan_period_s + self.scan_offset_s


class ProcessNoise(BaseModel):
    """Target process noise (the thesis's 2 m/s^2; how it is applied is ours).

    ``jitter`` (default): each scan adds an independent position perturbation
    (T^2/2) w with w ~ N(0, sigma_accel^2) per axis, not carried into velocity;
    T is the scan period of the sensor that sweeps that scan.
    """

    model_config = _STRICT

    model: Literal["jitter", "none"] = "jitter"
    sigma_accel: NonNegativeFloat = 2.0


class Scenario(BaseModel):
    """Everything needed to generate a dataset, apart from the run index.

    ``sensors`` lists one or more sensors. The one-sensor form of every
    format-1 dataset and older config, top-level ``sensor`` and ``clutter``,
    still validates (as that one sensor with that clutter); giving it beside
    ``sensors`` is an error. A scan is one sweep of one sensor: the sweeps of
    all sensors, merged in time order (ties in sensor order), are the scans
    k = 1..n_scans, and a target's ``missed_scans`` count in that numbering.
    """

    model_config = _STRICT

    name: Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")]
    description: str = ""
    duration_s: PositiveFloat
    targets: Annotated[list[Target], Field(min_length=1)]
    # at least one, checked in _consistent (Field(min_length=1) would report a second, misleading
    # "at least 1 item" problem whenever a sensor is invalid)
    sensors: tuple[Sensor, ...] = (Sensor(),)
    process_noise: ProcessNoise = ProcessNoise()
    seed: Annotated[int, Field(ge=0)] = 0

    @field_validator("name")
    @classmethod
    def _a_file_name(cls, value: str) -> str:
        return path_component(value, "a scenario name")  # it names collection members, plots, study jobs

    @model_validator(mode="before")
    @classmethod
    def _one_sensor_form(cls, data: Any) -> Any:
        """Top-level ``sensor`` and ``clutter`` -> ``sensors = [sensor with that clutter]``."""
        if not isinstance(data, dict) or not {"sensor", "clutter"} & data.keys():
            return data
        if "sensors" in data:
            raise ValueError("give either `sensors` or the one-sensor form `sensor` / `clutter`, not both")
        data = dict(data)
        sensor = data.pop("sensor", {})
        if isinstance(sensor, Sensor):
            sensor = sensor.model_dump(exclude_unset=True)
        if isinstance(sensor, dict) and "clutter" in data:
            if "clutter" in sensor:
                raise ValueError("clutter is given twice: as `clutter` and as `sensor.clutter`")
            sensor = {**sensor, "clutter": data.pop("clutter")}
        data["sensors"] = [sensor]
        return data

    @model_validator(mode="after")
    def _consistent(self) -> Scenario:
        if not self.sensors:
            raise ValueError("sensors: give at least one sensor")
        for i, sensor in enumerate(self.sensors):
            ratio = self.duration_s / sensor.scan_period_s
            if not math.isclose(ratio, round(ratio), abs_tol=1e-9):
                raise ValueError(
                    f"duration_s = {self.duration_s} is not a whole number of scan periods "
                    f"({sensor.scan_period_s} s) of sensor {i} ({sensor.name!r})"
                )
        sensor_names = [s.name for s in self.sensors]
        if len(set(sensor_names)) != len(sensor_names):
            raise ValueError(f"sensor names must be unique, got {sensor_names}")
        _windows_hold_no_scan(self.sensors, self.duration_s)
        names = [t.name for t in self.targets]
        if len(set(names)) != len(names):
            raise ValueError(f"target names must be unique, got {names}")
        for t in self.targets:
            late = [k for k in t.missed_scans if k > self.n_scans]
            if late:
                raise ValueError(
                    f"target {t.name!r}: missed_scans {late} lie after the last scan ({self.n_scans})"
                )
        return self

    @property
    def n_scans(self) -> int:
        """Scans k = 1..n_scans: every sweep of every sensor (one sensor: t_k = k T)."""
        return sum(s.n_sweeps(self.duration_s) for s in self.sensors)

    def scan_schedule(self) -> tuple[np.ndarray, np.ndarray]:
        """Time (s, float64) and sensor index (int32) of each scan k = 1..n_scans; shapes (n_scans,). Scans at
        one time come in the sensors' order, a window of asynchronous reports (``reports``) before the sweeps:
        its reports lie at or before that time, so a sweep there must not be taken first."""
        times = np.concatenate([s.sweep_times(self.duration_s) for s in self.sensors])
        sensor = np.repeat(np.arange(len(self.sensors), dtype=np.int32),
                           [s.n_sweeps(self.duration_s) for s in self.sensors])
        sweeps = np.array([not s.reports for s in self.sensors])[sensor]
        order = np.lexsort((sensor, sweeps, times))
        return times[order], sensor[order]

    @property
    def sensor(self) -> Sensor:
        """The only sensor, for one-sensor code; ConfigError when the scenario has several."""
        if len(self.sensors) != 1:
            names = ", ".join(s.name for s in self.sensors)
            raise ConfigError(f"scenario {self.name!r} has {len(self.sensors)} sensors ({names}); "
                              f"this code handles one sensor only: use `sensors`")
        return self.sensors[0]

    @property
    def clutter(self) -> Clutter:
        """The clutter of the only sensor (see `sensor`)."""
        return self.sensor.clutter

    def model_copy(self, *, update: Mapping[str, Any] | None = None, deep: bool = False) -> Scenario:
        """pydantic's copy (no validation), also given the one-sensor keys.

        ``sensor`` replaces the only sensor and keeps its clutter (unless the
        new sensor sets one); ``clutter`` replaces that sensor's clutter.
        """
        if update and {"sensor", "clutter"} & update.keys():
            update = dict(update)
            if "sensors" in update:
                raise ConfigError("model_copy: give either `sensors` or `sensor` / `clutter`, not both")
            new = update.pop("sensor", None)
            own = new is not None and "clutter" in new.model_fields_set
            if own and "clutter" in update:
                raise ConfigError("model_copy: clutter is given twice: as `clutter` and as `sensor.clutter`")
            sensor = self.sensor if new is None else new
            clutter = update.pop("clutter", sensor.clutter if own else self.clutter)
            update["sensors"] = (sensor.model_copy(update={"clutter": clutter}),)
        return super().model_copy(update=update, deep=deep)


def _on_grid(t: float, period: float, offset: float) -> bool:
    """Whether time ``t`` is offset + k period for a whole k (to 1e-9 of a period)."""
    k = (t - offset) / period
    return math.isclose(k, round(k), abs_tol=1e-9)


def _windows_hold_no_scan(sensors: Sequence[Sensor], duration_s: float) -> None:
    """ValueError when another sensor's scan falls inside a report sensor's window (t_k - T, t_k): a tracker
    takes a window of reports whole, after the scans before its end, so a sweep inside it would put the
    window's earlier reports behind the tracker. Every other sensor's scan times must lie on the report
    sensor's grid: its period a whole multiple of the window, its first scan on a window's end."""
    for i, r in enumerate(sensors):
        if not r.reports:
            continue
        for j, s in enumerate(sensors):
            if j == i or not s.n_sweeps(duration_s):
                continue
            first = s.scan_offset_s if s.scan_offset_s > 0 else s.scan_period_s  # `Sensor.sweep_times`' first
            several = s.n_sweeps(duration_s) > 1
            if _on_grid(first, r.scan_period_s, r.scan_offset_s) and (
                    not several or _on_grid(s.scan_period_s, r.scan_period_s, 0.0)):
                continue
            times = s.sweep_times(duration_s)
            inside = next(float(t) for t in times if not _on_grid(float(t), r.scan_period_s, r.scan_offset_s))
            end = r.scan_offset_s + math.ceil((inside - r.scan_offset_s) / r.scan_period_s) * r.scan_period_s
            kind = "a window ending" if s.reports else "a sweep"
            raise ValueError(
                f"sensor {j} ({s.name!r}) has {kind} at t = {inside:g} s, inside the window "
                f"({end - r.scan_period_s:g}, {end:g}] s of report sensor {i} ({r.name!r}): a tracker takes a "
                f"window of reports whole, so no other sensor's scan may fall inside one; give {r.name!r} a "
                f"scan_period_s that divides {s.scan_period_s:g} s (e.g. scan_period_s = {s.scan_period_s:g}) "
                f"and a scan_offset_s on {s.name!r}'s scan times")


def sensor_tuple(sensors: Sensor | Sequence[Sensor]) -> tuple[Sensor, ...]:
    """Sensors as a tuple: one `Sensor` or a scenario's ``sensors`` (what trackers and filters are built for);
    ConfigError when there is none or an entry is not a `Sensor`."""
    found = (sensors,) if isinstance(sensors, Sensor) else tuple(sensors)
    if not found or not all(isinstance(s, Sensor) for s in found):
        raise ConfigError(f"expected one or more nnda.data.scenario.Sensor, got {sensors!r}")
    return found


def scenario_from_dict(data: dict, source: str = "<config>") -> Scenario:
    """Validate a plain mapping into a Scenario; errors name the source and the field."""
    return validated(Scenario, data, source, "scenario")


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario from a ``.toml`` or ``.json`` file."""
    return scenario_from_dict(read_config(path, "scenario"), str(path))
