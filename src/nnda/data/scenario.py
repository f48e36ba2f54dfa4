"""Scenario configuration: targets, sensor, clutter, duration and seed.

A scenario is validated data (pydantic), loadable from TOML or JSON. It speaks
as a pilot would (conventions.md): headings in degrees clockwise from north,
turn rates in degrees per second with positive = right (clockwise) turn,
accelerations in m/s^2. Everything is converted to SI radians once, in
`nnda.data.trajectory`.

Numbers without a citation come from shared/spec/seed-001.md §2-§3; the spec's
ambiguity labels (A2, A3, ...) mark the defaults the spec chose.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from nnda.errors import validated
from nnda.files import read_config

_STRICT = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Probability = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]


class Segment(BaseModel):
    """One section of a trajectory (spec §3.1).

    Motion inside a section is set by a tangential acceleration (m/s^2) and
    either a normal acceleration (m/s^2; the turn rate then follows as a_n / V
    and changes with speed) or a constant turn rate (deg/s). Positive normal
    acceleration or turn rate is a right (clockwise) turn (spec A6).
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
        """Section type in the spec's words: straight CV, straight accelerating, turn, mixed."""
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


class Sensor(BaseModel):
    """The static radar at the origin (spec §2)."""

    model_config = _STRICT

    scan_period_s: PositiveFloat = 2.0
    sigma_range_m: NonNegativeFloat = 30.0
    sigma_azimuth_mrad: NonNegativeFloat = 3.0
    min_range_m: NonNegativeFloat = 5_000.0
    max_range_m: PositiveFloat = 30_000.0
    pd: Probability = Field(default=1.0, description="detection probability outside scripted gaps (A4)")

    @model_validator(mode="after")
    def _coverage(self) -> Sensor:
        if self.min_range_m >= self.max_range_m:
            raise ValueError("min_range_m must be below max_range_m")
        return self

    @property
    def sigma_azimuth_rad(self) -> float:
        return self.sigma_azimuth_mrad * 1e-3


class Clutter(BaseModel):
    """False contacts per scan (spec §2 and ambiguity A3, calibrated in §14).

    Laws: ``square`` (default) uniform in a square of side ``side_m`` centred on
    ``centre_m`` (default: centre of the targets' noise-free bounding box);
    ``gaussian`` with std ``sigma_m`` per axis centred on ``centre_m`` (default:
    the targets' mean position); ``annulus`` uniform in area over the coverage
    ring; ``none``. Points outside the coverage are redrawn (the §14 rule), so
    every scan holds exactly ``count`` points, or a Poisson number of mean
    ``count`` when ``count_law = "poisson"``.
    """

    model_config = _STRICT

    law: Literal["square", "gaussian", "annulus", "none"] = "square"
    count: Annotated[int, Field(ge=0)] = 100
    count_law: Literal["fixed", "poisson"] = "fixed"
    side_m: PositiveFloat = 16_600.0
    sigma_m: PositiveFloat = 6_300.0
    centre_m: tuple[FiniteFloat, FiniteFloat] | None = None


class ProcessNoise(BaseModel):
    """Target process noise (spec §3.2 and ambiguity A2).

    ``jitter`` (default): each scan adds an independent position perturbation
    (T^2/2) w with w ~ N(0, sigma_accel^2) per axis, not carried into velocity.
    """

    model_config = _STRICT

    model: Literal["jitter", "none"] = "jitter"
    sigma_accel: NonNegativeFloat = 2.0


class Scenario(BaseModel):
    """Everything needed to generate a dataset, apart from the run index."""

    model_config = _STRICT

    name: Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")]
    description: str = ""
    duration_s: PositiveFloat
    targets: Annotated[list[Target], Field(min_length=1)]
    sensor: Sensor = Sensor()
    clutter: Clutter = Clutter()
    process_noise: ProcessNoise = ProcessNoise()
    seed: Annotated[int, Field(ge=0)] = 0

    @property
    def n_scans(self) -> int:
        """Scans k = 1..n_scans at times t_k = k T (spec §1)."""
        return round(self.duration_s / self.sensor.scan_period_s)

    @model_validator(mode="after")
    def _consistent(self) -> Scenario:
        ratio = self.duration_s / self.sensor.scan_period_s
        if not math.isclose(ratio, round(ratio), abs_tol=1e-9):
            raise ValueError(
                f"duration_s = {self.duration_s} is not a whole number of scan periods "
                f"({self.sensor.scan_period_s} s)"
            )
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


def scenario_from_dict(data: dict, source: str = "<config>") -> Scenario:
    """Validate a plain mapping into a Scenario; errors name the source and the field."""
    return validated(Scenario, data, source, "scenario")


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario from a ``.toml`` or ``.json`` file."""
    return scenario_from_dict(read_config(path, "scenario"), str(path))
