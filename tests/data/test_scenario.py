"""Scenario configs: loading from TOML/JSON and clear errors on bad input."""

from __future__ import annotations

import json
import math

import pytest

from nnda.data.presets import PRESETS
from nnda.data.scenario import load_scenario, scenario_from_dict
from nnda.errors import ConfigError

GOOD_TOML = """
name = "mine"
duration_s = 60
seed = 4

[clutter]
law = "annulus"
count = 50

[[targets]]
name = "alpha"
x_m = -10000
y_m = 12000
heading_deg = 90
speed_m_s = 120
missed_scans = [5, 6]
segments = [{duration_s = 20}, {duration_s = 40, turn_rate_deg_s = 2.5}]
"""


def _base() -> dict:
    return {
        "name": "x", "duration_s": 20,
        "targets": [{"name": "a", "x_m": 0, "y_m": 10000, "heading_deg": 0, "speed_m_s": 100,
                     "segments": [{"duration_s": 20}]}],
    }


def test_toml_and_json_load_the_same(tmp_path):
    toml = tmp_path / "mine.toml"
    toml.write_text(GOOD_TOML)
    sc = load_scenario(toml)
    assert sc.n_scans == 30 and sc.targets[0].missed_scans == [5, 6]
    assert sc.targets[0].segments[1].kind == "turn"
    js = tmp_path / "mine.json"
    js.write_text(json.dumps(sc.model_dump(mode="json")))
    assert load_scenario(js) == sc


def test_presets_round_trip_through_json():
    for sc in PRESETS.values():
        assert scenario_from_dict(json.loads(json.dumps(sc.model_dump(mode="json")))) == sc


@pytest.mark.parametrize("mutate, where", [
    (lambda d: d["targets"][0].update(speed_m_s=-5), "targets.0.speed_m_s"),
    (lambda d: d.update(targets=[]), "targets"),
    (lambda d: d["targets"][0].update(x_m=math.nan), "targets.0.x_m"),
    (lambda d: d["targets"][0]["segments"][0].update(duration_s=0), "targets.0.segments.0.duration_s"),
    (lambda d: d["targets"][0]["segments"][0].update(normal_accel=1, turn_rate_deg_s=1), "targets.0.segments.0"),
    (lambda d: d["targets"][0]["segments"][0].update(tangential_accel=-10), "speed falls"),
    (lambda d: d.update(duration_s=21), "whole number of scan periods"),
    (lambda d: d["targets"][0].update(missed_scans=[11]), "lie after the last scan"),
    (lambda d: d["targets"][0].update(pd=1.5), "targets.0.pd"),
    (lambda d: d.update(colour="red"), "colour"),
    (lambda d: d.update(clutter={"law": "fog"}), "clutter.law"),
    (lambda d: d.update(sensor={"min_range_m": 40000}), "min_range_m must be below"),
    (lambda d: d["targets"].append(dict(d["targets"][0])), "unique"),
])
def test_bad_configs_name_the_field(mutate, where):
    data = _base()
    mutate(data)
    with pytest.raises(ConfigError) as info:
        scenario_from_dict(data, "my.toml")
    assert "my.toml" in str(info.value) and where in str(info.value)


def test_bad_files(tmp_path):
    with pytest.raises(ConfigError, match="no such scenario file"):
        load_scenario(tmp_path / "missing.toml")
    broken = tmp_path / "broken.toml"
    broken.write_text("name = [unclosed")
    with pytest.raises(ConfigError, match="broken.toml: not valid TOML"):
        load_scenario(broken)
    other = tmp_path / "scenario.yaml"
    other.write_text("name: x")
    with pytest.raises(ConfigError, match="scenario.yaml: unknown scenario file type"):
        load_scenario(other)
