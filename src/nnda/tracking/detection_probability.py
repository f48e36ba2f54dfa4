"""The detection probability P_D a tracker assumes for each of its sensors, and where that value came from.

A sensor's ``pd`` is the generator's truth and no tracker reads it; a sensor
may instead declare the P_D trackers should assume for it
(`nnda.data.scenario.Sensor.declared_pd`: ``nnda import-detections
--sensor pd=X``, or a scenario's sensor table). Per sensor a tracker
assumes (`detection_probabilities`):

1. its config's ``pd`` when the user set it: the field is among the config's
   ``model_fields_set`` (a default left alone is no choice, and keeping the
   default 0.9 keeps every config's dump, hence study job keys, as they were);
2. else the sensor's declared P_D, held to the bounds of the config's ``pd``
   field (0 < P_D <= 1 for a config without one);
3. else the tracker's default: its config's ``pd`` default, or `DEFAULT_PD`.

Each scan comes from one sensor, so the trackers index the values by
``scan.sensor``, resolved once when the tracker is built.

A default is a guess. Where a tracker runs on one (case 3) and its life
cycle's ``estimate_pd`` is on, the value it uses is learnt as the run goes
(`DetectionRecord`): the assumed P_D, lowered to the detection record of the
tracker's confirmed tracks. A score that expects 0.9 from a radar that
detects 0.8 of the time charges each miss ln(0.1) instead of ln(0.2) and
deletes the tracks of turning, fading targets too early.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated

from pydantic import BaseModel, Field, TypeAdapter, ValidationError

from nnda.data.scenario import Sensor
from nnda.errors import ConfigError

#: P_D of a tracker whose config has no ``pd`` (the track score's of GNN and the neural tracker)
DEFAULT_PD = 0.9


class _AnyTracker(BaseModel):
    """The bounds of a P_D for a tracker whose config has no ``pd`` field."""

    pd: Annotated[float, Field(gt=0, le=1)] = DEFAULT_PD


#: the weight of the assumed P_D in a learnt one (`DetectionRecord`), in observed scans of confirmed tracks
PRIOR_SCANS = 20.0

#: where a value came from (`DetectionProbabilities.sources`); a declared one is "declared by sensor 'NAME'"
FROM_CONFIG = "tracker config"
FROM_DEFAULT = "tracker default"


@dataclass(frozen=True)
class DetectionProbabilities:
    """Per sensor of a tracker, in the scenario's order: its name, the P_D the tracker assumes and its source."""

    sensors: tuple[str, ...]
    values: tuple[float, ...]
    sources: tuple[str, ...]

    def __getitem__(self, sensor: int) -> float:
        return self.values[sensor]

    def line(self) -> str:
        """One line: each sensor's P_D and source, e.g. "P_D: radar 0.6 (declared by sensor 'radar')"."""
        return "P_D: " + ", ".join(f"{n} {v:g} ({s})" for n, v, s in zip(self.sensors, self.values, self.sources))

    def record(self) -> list[dict]:
        """What a run's metadata records: ``[{"sensor", "pd", "source"}, ...]``."""
        return [{"sensor": n, "pd": v, "source": s} for n, v, s in zip(self.sensors, self.values, self.sources)]


def declared_source(sensor: Sensor) -> str:
    """The source of a value the sensor declared."""
    return f"declared by sensor {sensor.name!r}"


def detection_probabilities(tracker: str, config: BaseModel, sensors: Sequence[Sensor], field: str = "pd",
                            default: float = DEFAULT_PD) -> DetectionProbabilities:
    """The P_D ``tracker`` assumes for each of ``sensors`` with ``config`` (module docstring); ``field`` names the
    config's P_D field (a config without it: ``default`` unless a sensor declares one). ConfigError, naming the
    sensor, its field and the tracker's bounds, for a declared value the tracker cannot take."""
    own = field in type(config).model_fields
    if own and field in config.model_fields_set:
        value = float(getattr(config, field))
        return DetectionProbabilities(tuple(s.name for s in sensors), (value,) * len(sensors),
                                      (FROM_CONFIG,) * len(sensors))
    fallback = float(getattr(config, field)) if own else default
    bounds = (type(config) if own else _AnyTracker).model_fields[field if own else "pd"].metadata
    values, sources = [], []
    for s in sensors:
        if s.declared_pd is None:
            values.append(fallback)
            sources.append(FROM_DEFAULT)
        else:
            values.append(_within(tracker, s, bounds, field))
            sources.append(declared_source(s))
    return DetectionProbabilities(tuple(s.name for s in sensors), tuple(values), tuple(sources))


def _within(tracker: str, sensor: Sensor, bounds: list, field: str) -> float:
    """The sensor's declared P_D, checked against the ``bounds`` (annotated-types metadata) of the tracker's
    P_D field."""
    value = float(sensor.declared_pd)
    try:
        return float(TypeAdapter(Annotated[float, *bounds]).validate_python(value))
    except ValidationError:
        words = {"gt": ">", "ge": ">=", "lt": "<", "le": "<="}
        needs = " and ".join(f"{words[k]} {getattr(b, k):g}" for b in bounds for k in words if hasattr(b, k))
        raise ConfigError(f"{tracker}: sensor {sensor.name!r} declares declared_pd = {value:g}, but {tracker} needs "
                          f"a detection probability {needs}; set the sensor's declared_pd (nnda import-detections "
                          f"--sensor pd=X, or the scenario's sensor table) within that, or the tracker config's "
                          f"{field} to override it") from None


class DetectionRecord:
    """The P_D a tracker uses per sensor as a run goes: the assumed values, and for the sensors it learns
    (``learn`` (S,) true) the assumed value lowered, never raised, to its confirmed tracks' record so far.

    The record of a sensor is pooled over the tracker's confirmed tracks: the scans of that sensor that
    observed one (``observed``) and those in which it took a contact (``hits``). The learnt value is
    min(P_D0, (hits + n0 P_D0) / (observed + n0)), P_D0 the assumed value and n0 = `PRIOR_SCANS`, so a few
    scans move it little. Every observed scan of a confirmed track counts, the misses of one coasting to its
    deletion included, so where targets are nearly always detected the record runs below the truth; the
    value is never raised above the assumed one, which keeps such a radar's tracks as they were. Tracks still
    preliminary are left out: their record is mostly clutter's. Only a sweep counts (a report says nothing
    of the targets it does not name).
    """

    def __init__(self, assumed: DetectionProbabilities, learn: Sequence[bool]) -> None:
        self.assumed = tuple(float(v) for v in assumed.values)
        self.learn = tuple(bool(v) for v in learn)
        self.reset()

    def reset(self) -> None:
        """Forget the record (a new run): every value back to the assumed one."""
        self.hits = [0] * len(self.assumed)
        self.observed = [0] * len(self.assumed)
        self.values = list(self.assumed)

    def __getitem__(self, sensor: int) -> float:
        return self.values[sensor]

    def add(self, sensor: int, hits: int, observed: int) -> None:
        """Count a scan of ``sensor`` (an index): of its confirmed tracks, ``observed`` were observed and
        ``hits`` of those took a contact; the sensor's value follows when it learns."""
        if not (self.learn[sensor] and observed):
            return
        self.hits[sensor] += hits
        self.observed[sensor] += observed
        p0 = self.assumed[sensor]
        self.values[sensor] = min(p0, (self.hits[sensor] + PRIOR_SCANS * p0) / (self.observed[sensor] + PRIOR_SCANS))

    def record(self) -> list[float | None]:
        """What a run records: per sensor the value learnt so far, None for one the tracker does not learn."""
        return [v if learn else None for v, learn in zip(self.values, self.learn)]
