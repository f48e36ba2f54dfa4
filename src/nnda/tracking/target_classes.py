"""The speed window and motion noise a contact tracker takes from the class of target its sensors declare.

A sensor may declare what it watches (`nnda.data.scenario.Sensor.declared_targets`:
``nnda import-detections --sensor targets=aircraft``, or a scenario's sensor
table). Each class sets the life cycle's initiation window (``v_min``,
``v_max``, m/s), the speed above which a track is deleted
(``max_speed_m_s``) and the IMM's process noise (``motion.cv_sigma_q``,
``ct_sigma_q`` in m/s^2, ``ct_sigma_omega`` in rad/s); ships also the
longest wait between a track's reports (``report_gap_s``, s). The noise's
time law (``motion.noise``: "continuous" for asynchronous reports) and the
turn's form depend on the data, not on the class, and are left alone.

| class         | v_min-v_max (m/s) | max_speed_m_s | cv_sigma_q | ct_sigma_q | ct_sigma_omega | report_gap_s |
|---------------|-------------------|---------------|------------|------------|----------------|--------------|
| `ships`       | 0-20              | 50            | 0.2        | 0.2        | 0.001          | 400          |
| `aircraft`    | 50-300            | 750           | 3.5        | 5.0        | 0.044          | (default)    |
| `pedestrians` | 0-4.5             | 11.25         | 0.5        | 0.5        | 0.2            | (default)    |

- ships: merchant ships and small craft move at 0-20 m/s and stop, moor
  and anchor (v_min 0); a ship accelerates and turns slowly (0.2 m/s^2,
  0.001 rad/s); one at anchor reports by AIS every 3 minutes, so a track
  waits 400 s for its next report. These are `examples/ais.toml`'s values.
- aircraft: general aviation from ~50 m/s (a light aircraft's approach) to
  airliners' cruise of 230-260 m/s ground speed, with 40 m/s of tailwind to
  spare; the motion noise is the radar thesis's (Vargas Avila (2015),
  Sec. 5.6, the trackers' defaults), made for aircraft.
- pedestrians: walkers stand still and walk or run at up to 4.5 m/s (the
  pedestrian study's window, `nnda.study.pedestrian`); they start, stop and
  turn sharply (0.5 m/s^2, 0.2 rad/s; ours).
- max_speed_m_s is everywhere the default rule's 2.5 v_max, written out.

Resolution (`target_config`), once when a tracker is built, per field: a
field the user set in the tracker config (its ``model_fields_set``, nested:
``lifecycle.v_max`` set, ``lifecycle.v_min`` not) wins; else the declared
class's value; else the config's default. The effective config is validated
again, so an impossible mix (the config's ``v_max`` 30 under the aircraft's
``v_min`` 50) is a ConfigError naming the fields, the class and the sensor.
Sensors that declare different classes are refused (one tracker has one
window); sensors that declare none take the class of those that do.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Any

from pydantic import BaseModel, ValidationError

from nnda.data.scenario import TARGET_CLASSES, Sensor
from nnda.errors import ConfigError

#: per class, per config section (``lifecycle``, ``motion``), the values it sets (module docstring's table)
CLASS_DEFAULTS: MappingProxyType[str, dict[str, dict[str, float]]] = MappingProxyType({
    "ships": {"lifecycle": {"v_min": 0.0, "v_max": 20.0, "max_speed_m_s": 50.0, "report_gap_s": 400.0},
              "motion": {"cv_sigma_q": 0.2, "ct_sigma_q": 0.2, "ct_sigma_omega": 0.001}},
    "aircraft": {"lifecycle": {"v_min": 50.0, "v_max": 300.0, "max_speed_m_s": 750.0},
                 "motion": {"cv_sigma_q": 3.5, "ct_sigma_q": 5.0, "ct_sigma_omega": 0.044}},
    "pedestrians": {"lifecycle": {"v_min": 0.0, "v_max": 4.5, "max_speed_m_s": 11.25},
                    "motion": {"cv_sigma_q": 0.5, "ct_sigma_q": 0.5, "ct_sigma_omega": 0.2}},
})
assert tuple(CLASS_DEFAULTS) == TARGET_CLASSES
#: the config sections a class sets
SECTIONS = ("lifecycle", "motion")
#: the units of the class's motion values, for the line a run says
_UNITS = {"cv_sigma_q": "m/s^2", "ct_sigma_q": "m/s^2", "ct_sigma_omega": "rad/s"}


@dataclass(frozen=True)
class TargetClassUse:
    """A tracker's declared class: its name, the sensors that declare it, the values the tracker took from it
    (``"lifecycle.v_max"`` -> value), the class's fields the tracker config set itself (kept) and the effective
    window: (v_min, v_max, the speed above which a track is deleted, report gap) in m/s and s."""

    name: str
    sensors: tuple[str, ...]
    applied: dict[str, float]
    from_config: tuple[str, ...]
    window: tuple[float, float, float, float] = (math.nan,) * 4

    @property
    def source(self) -> str:
        """Where the class came from, e.g. "declared by sensor 'radar'"."""
        return f"declared by sensor{'s' if len(self.sensors) > 1 else ''} {', '.join(map(repr, self.sensors))}"

    def line(self) -> str:
        """One line, e.g. "targets: aircraft (declared by sensor 'radar'): v 50-300 m/s, deleted above 750 m/s,
        cv_sigma_q 3.5 m/s^2, ..."."""
        v_min, v_max, limit, gap = self.window
        said = [f"{k.split('.')[1]} {v:g} {_UNITS[k.split('.')[1]]}" for k, v in self.applied.items()
                if k.startswith("motion.")]
        if "lifecycle.report_gap_s" in self.applied:
            said.append(f"report gap {gap:g} s")
        kept = f"; from the tracker config: {', '.join(self.from_config)}" if self.from_config else ""
        return (f"targets: {self.name} ({self.source}): v {v_min:g}-{v_max:g} m/s, deleted above {limit:g} m/s"
                f"{''.join(', ' + x for x in said)}{kept}")

    def record(self) -> dict:
        """What a run's metadata records: the class, its sensors, the effective window (m/s), the values taken
        from the class and the class's fields the tracker config set."""
        v_min, v_max, limit, _ = self.window
        return {"class": self.name, "sensors": list(self.sensors), "v_min_m_s": v_min, "v_max_m_s": v_max,
                "max_speed_m_s": limit, "applied": dict(self.applied), "from_config": list(self.from_config)}


def declared_class(tracker: str, sensors: Sequence[Sensor]) -> tuple[str, tuple[str, ...]] | None:
    """The class ``sensors`` declare and the names of those declaring it, or None; ConfigError when they
    declare different classes."""
    declaring = {s.name: s.declared_targets for s in sensors if s.declared_targets is not None}
    classes = sorted(set(declaring.values()))
    if len(classes) > 1:
        said = ", ".join(f"sensor {n!r} {c}" for n, c in declaring.items())
        raise ConfigError(f"{tracker}: the sensors declare different target classes ({said}), but one tracker has "
                          f"one speed window and motion noise; declare one class (declared_targets, "
                          f"--sensor targets=...) or none, or set the tracker config's lifecycle and motion "
                          f"fields and leave the sensors' classes out")
    return (classes[0], tuple(declaring)) if classes else None


def class_params(tracker: str, params: Mapping[str, Any], sensors: Sequence[Sensor]
                 ) -> tuple[dict[str, Any], TargetClassUse | None]:
    """Tracker config fields ``params`` (nested mappings, the fields the user set) with the declared class's
    values added for the class's fields they leave out, and what was taken; ``params`` as they are, and None,
    when no sensor declares a class."""
    found = declared_class(tracker, sensors)
    if found is None:
        return dict(params), None
    name, declaring = found
    merged, applied, kept = dict(params), {}, []
    for section, values in CLASS_DEFAULTS[name].items():
        mine = _fields_set(params.get(section) or {})
        if not isinstance(mine, Mapping):  # not a section: the config's validation says so
            continue
        taken = {k: v for k, v in values.items() if k not in mine}
        applied |= {f"{section}.{k}": v for k, v in taken.items()}
        kept += [f"{section}.{k}" for k in values if k in mine]
        merged[section] = {**taken, **mine}
    return merged, TargetClassUse(name, declaring, applied, tuple(kept))


def refused(tracker: str, use: TargetClassUse, params: Mapping[str, Any], problem: str) -> ConfigError:
    """The error for a tracker config ``params`` (the user's fields) that does not go with the class's values."""
    own = {f"{section}.{k}": v for section in SECTIONS
           for k, v in _fields_set(params.get(section) or {}).items() if k in CLASS_DEFAULTS[use.name][section]}
    touched = {k.split(".")[0] for k in own} or set(SECTIONS)
    theirs = {k: v for k, v in use.applied.items() if k.split(".")[0] in touched}
    return ConfigError(f"{tracker}: the tracker config ({_said(own) or 'its defaults'}) does not go with target class "
                       f"{use.name!r} ({use.source}: {_said(theirs)}): {problem}; set those fields too in the "
                       f"tracker config, or leave the sensor's class out")


def as_given(config: BaseModel, params: Mapping[str, Any]) -> BaseModel:
    """``config`` (validated) marked as set by the user only in the fields ``params`` gives, in it and in its
    class-set sections (``lifecycle``, ``motion``): the class's values stand as its defaults, so a tracker built
    from it finds what the user set (`target_config`)."""
    fields = dict(config)
    for section in SECTIONS:
        own = params.get(section) or {}
        own = own if isinstance(own, Mapping) else _fields_set(own)
        fields[section] = type(fields[section]).model_construct(_fields_set=set(own), **dict(fields[section]))
    return type(config).model_construct(_fields_set={k for k in params if k in fields}, **fields)


def target_config(tracker: str, config: BaseModel, sensors: Sequence[Sensor]
                  ) -> tuple[BaseModel, TargetClassUse | None]:
    """The config ``tracker`` runs with given the class its ``sensors`` declare (module docstring), and what it
    took from the class; ``config`` (a `nnda.tracking.tracker.ContactTrackerConfig`) itself, and None, when no
    sensor declares one."""
    given = {k: _fields_set(getattr(config, k)) for k in config.model_fields_set}
    merged, use = class_params(tracker, given, sensors)
    if use is None:
        return config, None
    try:
        found = as_given(type(config).model_validate(merged), given)
    except ValidationError as exc:
        raise refused(tracker, use, given, _errors(exc)) from None
    life = found.lifecycle
    return found, replace(use, window=(life.v_min, life.v_max, life.speed_limit, life.report_gap_s))


def _fields_set(value: Any) -> Any:
    """A config section (a model) as the mapping of the fields the user set in it; any other value as it is."""
    return {k: getattr(value, k) for k in value.model_fields_set} if isinstance(value, BaseModel) else value


def _said(values: dict) -> str:
    """``{"lifecycle.v_max": 30.0}`` as "lifecycle.v_max = 30"."""
    return ", ".join(f"{k} = {v:g}" if isinstance(v, float | int) else f"{k} = {v!r}" for k, v in values.items())


def _errors(exc: ValidationError) -> str:
    return "; ".join(f"{'.'.join(map(str, e['loc']))}: {e['msg'].removeprefix('Value error, ')}" for e in exc.errors())
