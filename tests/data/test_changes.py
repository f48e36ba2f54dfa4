"""A scenario's fields changed by dotted path (`nnda.data.changes`), for studies and ``nnda generate --set``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from nnda.data.changes import changed_name, changed_scenario, changes_from_text
from nnda.data.dataset import read_dataset
from nnda.data.presets import PRESETS
from nnda.data.scenario import load_scenario
from nnda.data.sources import resolve_scenes
from nnda.errors import ConfigError

SWEEP = Path(__file__).resolve().parents[2] / "studies" / "clutter-sweep"


def test_a_change_sets_that_field_and_only_it():
    s1 = PRESETS["S1"]
    changed = changed_scenario(s1, {"clutter.count": 1000, "sensor.pd": 0.8, "duration_s": 100.0})
    assert (changed.clutter.count, changed.sensor.pd, changed.duration_s) == (1000, 0.8, 100.0)
    back = s1.sensor.model_copy(update={"clutter": s1.clutter, "pd": s1.sensor.pd})
    assert changed.model_copy(update={"sensor": back, "duration_s": s1.duration_s}) == s1
    assert changed_scenario(s1, {}) is s1


def test_the_one_sensor_shorthands_are_the_first_sensors_fields():
    s1 = PRESETS["S1"]
    assert (changed_scenario(s1, {"clutter.count": 7, "sensor.sigma_range_m": 40.0})
            == changed_scenario(s1, {"sensors.0.clutter.count": 7, "sensors.0.sigma_range_m": 40.0}))
    assert changed_scenario(s1, {"targets.1.speed_m_s": 150.0}).targets[1].speed_m_s == 150.0


def test_a_whole_part_is_set_from_a_table():
    s1 = PRESETS["S1"]
    clutter = s1.clutter.model_dump(mode="json") | {"count": 300}
    assert changed_scenario(s1, {"clutter": clutter}).clutter == s1.clutter.model_copy(update={"count": 300})


def test_the_clutter_sweep_files_are_the_presets_with_one_count_changed():
    """What the shipped sweep spells out as 24 files is one change of each preset: equal but for the description."""
    for name in ("S1", "S4"):
        for count in (10, 5_000):
            stored = load_scenario(SWEEP / f"{name}-c{count}.json")
            (source,) = resolve_scenes(preset=name, changes={"clutter.count": count}, suffix=f"-c{count}")
            assert source.name == stored.name
            assert source.scenario.model_copy(update={"description": stored.description}) == stored


def test_a_group_changes_every_member_and_names_each():
    sources = resolve_scenes(preset="validation", changes={"clutter.count": 1000})
    assert [s.name for s in sources] == [f"S{i}-clutter.count_1000" for i in range(1, 7)]
    assert all(s.scenario.clutter.count == 1000 and s.scenario.name == s.name for s in sources)
    assert all("clutter.count = 1000" in s.description and "clutter.count = 1000" in s.scenario.description
               for s in sources)
    assert changed_name("S1", {}) == "S1"
    assert changed_name("S1", {"sensor.pd": 0.8}, "-pd80") == "S1-pd80"
    assert changed_name("S1", {"name": "a b/c"}) == "S1-name_a_b_c"
    with pytest.raises(ConfigError, match="name: String should match pattern"):
        resolve_scenes(preset="S1", changes={"sensor.pd": 0.8}, suffix=" 80%")


@pytest.mark.parametrize("changes, message", [
    ({"clutter.cont": 1}, "sensors.0.clutter has no field 'cont' (its fields: law, count"),
    ({"colour": 1}, "the scenario has no field 'colour'"),
    ({"targets.9.speed_m_s": 1.0}, "targets is a list of 4, indexed 0 to 3, not '9'"),
    ({"targets.x.speed_m_s": 1.0}, "not 'x'"),
    ({"duration_s.value": 1.0}, "duration_s is a value (200.0), without fields to set"),
    ({"clutter..count": 1}, "field names joined by dots"),
    ({"clutter.count": -5}, "sensors.0.clutter.count: Input should be greater than or equal to 0"),
    ({"sensor.pd": 1.5}, "sensors.0.pd"),
    ({"clutter.centre_m.x": 1.0}, "is not set in this scenario"),
])
def test_a_bad_change_names_its_path(changes, message):
    with pytest.raises(ConfigError, match="changes") as err:
        changed_scenario(PRESETS["S1"], changes)
    assert message in str(err.value)


def test_the_shorthands_refuse_a_scenario_of_several_sensors():
    with pytest.raises(ConfigError, match=r"has 2 \(west, east\): write sensors.<index from 0>"):
        changed_scenario(PRESETS["two-radars"], {"sensor.pd": 0.5})
    assert changed_scenario(PRESETS["two-radars"], {"sensors.1.pd": 0.5}).sensors[1].pd == 0.5


def test_stored_datasets_and_walker_scenes_take_no_changes(tmp_path):
    with pytest.raises(ConfigError, match="apply to generated radar scenarios, not to walker scene"):
        resolve_scenes(preset="walk-test2", changes={"duration_s": 10.0})
    with pytest.raises(ConfigError, match="not to the datasets at"):
        resolve_scenes(path=tmp_path, changes={"duration_s": 10.0})


def test_command_line_values_are_json_or_text():
    assert changes_from_text(["clutter.count=1000", "sensor.pd=0.8", "name=my scene", "x={\"a\": [1]}"],
                             "--set") == {"clutter.count": 1000, "sensor.pd": 0.8, "name": "my scene",
                                          "x": {"a": [1]}}
    for bad in ("clutter.count", "=3"):
        with pytest.raises(ConfigError, match="expected PATH=VALUE"):
            changes_from_text([bad], "--set")


def test_generate_writes_the_changed_scenario(tmp_path):
    def nnda(*args):
        return subprocess.run([sys.executable, "-m", "nnda", *args], cwd=tmp_path, capture_output=True, text=True,
                              timeout=300)

    out = nnda("generate", "--preset", "S1", "--out", "ds", "--seed", "3", "--set", "clutter.count=20", "--set",
               "sensor.pd=1")
    assert out.returncode == 0, out.stderr
    ds = read_dataset(tmp_path / "ds")
    assert ds.scenario.name == "S1-clutter.count_20-sensor.pd_1"
    assert (ds.scenario.clutter.count, ds.scenario.sensor.pd) == (20, 1.0)
    bad = nnda("generate", "--preset", "S1", "--out", "b", "--set", "sensor.pdd=1")
    assert bad.returncode != 0 and "sensors.0 has no field 'pdd'" in bad.stderr
    assert not (tmp_path / "b").exists()
