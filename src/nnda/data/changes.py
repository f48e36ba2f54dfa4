"""A scenario with some of its fields changed by dotted path: the same scene at another clutter count, P_D or
duration, without a copy of its whole config.

    scenario = changed_scenario(PRESETS["S1"], {"clutter.count": 1000, "sensor.pd": 0.8})

A path names a field of `nnda.data.scenario.Scenario` and, through it, of its sensors and targets:
``duration_s``, ``sensors.1.clutter.count`` (a list's item by its index from 0), ``targets.0.speed_m_s``. A
scenario of one sensor also takes ``sensor.X`` for ``sensors.0.X`` and ``clutter.X`` for
``sensors.0.clutter.X``, the spelling of its config file. A value may be a whole part (``clutter`` = a table of
its fields). The result is validated as a config file is: an unknown field, a list index out of range or a value
out of range is a ConfigError naming the path. `changed_name` is the name a study gives the changed scenario.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel

from nnda.data.scenario import Scenario, scenario_from_dict
from nnda.errors import ConfigError


def changed_scenario(scenario: Scenario, changes: Mapping[str, Any], source: str = "changes") -> Scenario:
    """``scenario`` with each field of ``changes`` (dotted path -> value, module docstring) set, validated;
    ``source`` names the changes in errors. No changes: the scenario itself."""
    if not changes:
        return scenario
    data = scenario.model_dump(mode="json")
    for path, value in changes.items():
        where = f"{source}: {path!r}"
        _put(scenario, data, _spelled_out(scenario, path, where), value, where)
    return scenario_from_dict(data, source)


def changed_name(name: str, changes: Mapping[str, Any], suffix: str | None = None) -> str:
    """The name of scenario ``name`` with ``changes``: ``name`` + ``suffix``, by default the changes written out in
    the characters a scenario's name allows (``S1-clutter.count_1000``); ``name`` itself without changes."""
    if not changes:
        return name
    if suffix is None:
        suffix = re.sub(r"[^A-Za-z0-9_.\-]", "_", "".join(f"-{path}_{value}" for path, value in changes.items()))
    return name + suffix


def changes_from_text(items: list[str], where: str) -> dict[str, Any]:
    """Changes from ``PATH=VALUE`` texts (a command line's), each VALUE read as JSON (1000, 0.8, true, a table)
    or else kept as text; ``where`` names them in errors."""
    changes: dict[str, Any] = {}
    for item in items:
        path, equals, text = item.partition("=")
        if not equals or not path.strip():
            raise ConfigError(f"{where} {item!r}: expected PATH=VALUE, e.g. clutter.count=1000")
        try:
            changes[path.strip()] = json.loads(text)
        except json.JSONDecodeError:
            changes[path.strip()] = text
    return changes


def _spelled_out(scenario: Scenario, path: str, where: str) -> list[str]:
    """The parts of ``path`` with the one-sensor shorthands (``sensor.``, ``clutter.``) written out."""
    parts = path.split(".")
    if not all(parts):
        raise ConfigError(f"{where}: a path is field names joined by dots (e.g. clutter.count), not {path!r}")
    if parts[0] in ("sensor", "clutter"):
        if len(scenario.sensors) != 1:
            names = ", ".join(s.name for s in scenario.sensors)
            raise ConfigError(f"{where}: {parts[0]}.* names the only sensor, and scenario {scenario.name!r} has "
                              f"{len(scenario.sensors)} ({names}): write sensors.<index from 0>.* instead")
        parts = ["sensors", "0", *(["clutter"] if parts[0] == "clutter" else []), *parts[1:]]
    return parts


def _put(model: BaseModel, data: dict, parts: list[str], value: Any, where: str) -> None:
    """Set ``value`` at ``parts`` in ``data``, the JSON dump of ``model``, after checking the path against the
    model itself: each part a declared field of the model there, or an index into its list."""
    obj: Any = model
    node: Any = data
    for depth, part in enumerate(parts):
        here = ".".join(parts[:depth]) or "the scenario"
        last = depth == len(parts) - 1
        if isinstance(obj, BaseModel):
            fields = type(obj).model_fields
            if part not in fields:
                raise ConfigError(f"{where}: {here} has no field {part!r} (its fields: {', '.join(fields)})")
            if last:
                node[part] = value
                return
            obj, node = getattr(obj, part), node.get(part)
        elif isinstance(obj, (list, tuple)):
            if not part.isdigit() or int(part) >= len(obj):
                raise ConfigError(f"{where}: {here} is a list of {len(obj)}, indexed 0 to {len(obj) - 1}, "
                                  f"not {part!r}")
            if last:
                node[int(part)] = value
                return
            obj, node = obj[int(part)], node[int(part)]
        else:
            raise ConfigError(f"{where}: {here} is a value ({obj!r}), without fields to set")
        if node is None:  # a part left out of the dump (None or its default): set it whole
            raise ConfigError(f"{where}: {'.'.join(parts[:depth + 1])} is not set in this scenario; set it "
                              f"whole (a table of its fields)")
