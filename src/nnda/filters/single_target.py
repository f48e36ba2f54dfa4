"""Single-target filters: one object followed through its own contacts, no association, no track management.

A study's filter jobs (`nnda.study.kinds.filter`) run these on single-target scenes:
every scan hands the filter its time, its sensor and the target's own
contact of that scan (or None when the target was missed):

    f = make_filter("imm", scenario.sensors, {"motion": "cv"})   # validated config
    f.reset()
    est = f.step(time, sensor, z)   # z (2,) in the sensor's measurement space, or None
    est.x, est.P                    # [x, vx, y, vy] (4,) m, m/s and its covariance (4, 4); None before the start

`IMMFilter` starts with the two-point estimate from the first two contacts
(eqs. 5.26-5.31, as the trackers do) and then predicts to every scan and
updates with the scan's contact when there is one; on a miss the estimate
is the prediction. Each sensor has its own measurement model
(`IMM.for_measurement`), so a two-radar scene updates from both. The
re-entry and track-before-detect filters are particle filters batched over
runs, not per-contact filters: they live in `nnda.filters.reentry` and
`nnda.filters.tbd` and run as the study's ``reentry`` and ``tbd`` jobs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Literal, Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict

from nnda.data.scenario import Sensor, sensor_tuple
from nnda.errors import ConfigError, FilterError, validated
from nnda.filters.imm import IMM, IMMState
from nnda.filters.measurement import measurement_model
from nnda.filters.motion import ConstantVelocity


class FilterConfig(BaseModel):
    """Base of every single-target filter's config: strict and frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


@dataclass(frozen=True)
class Estimate:
    """A filter's estimate after a scan: ``x`` [x, vx, y, vy] (4,) in m and m/s, ``P`` its covariance (4, 4)."""

    x: np.ndarray
    P: np.ndarray


class SingleTargetFilter(Protocol):
    """What a filter job runs: built as ``cls(sensors, config)``; ``step`` once per scan, in time order."""

    name: ClassVar[str]
    config_type: ClassVar[type[FilterConfig]]

    def reset(self) -> None:
        """Forget the target (the start of a new run)."""

    def step(self, time: float, sensor: int, z: np.ndarray | None) -> Estimate | None:
        """The estimate after the scan at ``time`` (s) of ``sensor`` with the target's contact z (2,) or None."""


class IMMFilterConfig(FilterConfig):
    """The trackers' IMM (CV + CT) or its CV model alone, on one target's contacts."""

    motion: Literal["cv+ct", "cv"] = "cv+ct"


class IMMFilter:
    """The trackers' IMM (or its CV EKF alone) on one target; see the module docstring."""

    name: ClassVar[str] = "imm"
    config_type: ClassVar[type[FilterConfig]] = IMMFilterConfig

    def __init__(self, sensors: Sensor | Sequence[Sensor], config: IMMFilterConfig | None = None) -> None:
        sensors = sensor_tuple(sensors)
        self.config = config if config is not None else IMMFilterConfig()
        base = IMM.for_sensor(sensors[0])
        if self.config.motion == "cv":
            base = IMM(models=(ConstantVelocity(),), measurement=base.measurement, tpm=((1.0,),), mu0=(1.0,))
        self.filters = (base, *(base.for_measurement(measurement_model(s)) for s in sensors[1:]))
        self.reset()

    def reset(self) -> None:
        self.state: IMMState | None = None
        self.first: tuple[float, int, np.ndarray] | None = None  # (time, sensor, contact) before the start
        self.time = -np.inf

    def step(self, time: float, sensor: int, z: np.ndarray | None) -> Estimate | None:
        if not time > self.time:
            raise FilterError(f"{self.name}: scan at t = {time} s does not come after t = {self.time} s")
        if not 0 <= sensor < len(self.filters):
            raise FilterError(f"{self.name}: sensor {sensor} is not one of the {len(self.filters)} sensor(s)")
        imm = self.filters[sensor]
        if z is not None:
            z = np.asarray(z, dtype=float).reshape(1, 2)
            imm.measurement.validate(f"{self.name}: contact at t = {time} s", z)
        if self.state is None:
            if z is not None:
                if self.first is None:
                    self.first = (time, sensor, z)
                else:
                    t1, s1, z1 = self.first
                    p1 = self.filters[s1].measurement.cartesian(z1)
                    p2, cov2 = imm.measurement.position(z)
                    self.state = imm.start(p1, p2, cov2, time - t1)
                    self.time = time
            return None if self.state is None else self._estimate()
        pred = imm.predict(self.state, time - self.time)
        self.state = imm.update(pred, z, check=False) if z is not None else pred.state
        self.time = time
        return self._estimate()

    def _estimate(self) -> Estimate:
        x, P = self.filters[0].estimate(self.state)
        return Estimate(x[0], P[0])


#: single-target filters by name
FILTERS: dict[str, type[SingleTargetFilter]] = {cls.name: cls for cls in (IMMFilter,)}


def make_filter(name: str, sensors: Sensor | Sequence[Sensor], params: Mapping[str, Any] | None = None,
                where: str = "filter config") -> SingleTargetFilter:
    """A single-target filter of kind ``name`` with its config validated from ``params``."""
    if name not in FILTERS:
        raise ConfigError(f"{where}: unknown filter {name!r}; choose one of {', '.join(FILTERS)}")
    cls = FILTERS[name]
    return cls(sensors, validated(cls.config_type, dict(params or {}), where, f"{name} config"))
