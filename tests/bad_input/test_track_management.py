"""Bad track-management settings (the confirmation and deletion rules): each refused by `make_tracker`
with a ConfigError that names the field and what was wrong."""

from __future__ import annotations

import re

import pytest

from nnda.data.scenario import Sensor
from nnda.errors import ConfigError
from nnda.tracking.registry import make_tracker


@pytest.mark.parametrize("kind", ["gnn", "jpda", "mht"])
@pytest.mark.parametrize("lifecycle, fragments", [
    ({"max_speed_m_s": -100.0}, ["lifecycle.max_speed_m_s", "greater than 0"]),
    ({"max_speed_m_s": 0.0}, ["lifecycle.max_speed_m_s", "greater than 0"]),
    ({"max_position_sd_m": -1.0}, ["lifecycle.max_position_sd_m", "greater than 0"]),
    ({"max_speed_m_s": 150.0}, ["max_speed_m_s = 150.0 must exceed v_max = 200.0"]),
    ({"coverage_deletion": "sometimes"}, ["lifecycle.coverage_deletion", "boolean"]),
])
def test_bad_sanity_limits_name_the_field(kind, lifecycle, fragments):
    with pytest.raises(ConfigError) as err:
        make_tracker(kind, Sensor(), {"lifecycle": lifecycle})
    for fragment in fragments:
        assert re.search(re.escape(fragment), str(err.value)), str(err.value)


@pytest.mark.parametrize("lifecycle, fragments", [
    ({"confirmation": "sprt"}, ["lifecycle.confirmation", "'mn', 'score' or 'existence'"]),
    ({"false_confirmation": 1.5}, ["lifecycle.false_confirmation", "less than 1"]),
    ({"false_deletion": 0.0}, ["lifecycle.false_deletion", "greater than 0"]),
    ({"preliminary_false_deletion": -0.2}, ["lifecycle.preliminary_false_deletion", "greater than 0"]),
    ({"survival_probability": 1.2}, ["lifecycle.survival_probability", "less than or equal to 1"]),
    ({"existence_confirmation": 0.05, "existence_deletion": 0.1}, ["existence_deletion must be below"]),
    ({"existence_confirmation": 0.9999}, ["existence_confirmation = 0.9999 must be below survival_probability"]),
    ({"new_targets_per_scan": 0.0}, ["lifecycle.new_targets_per_scan", "greater than 0"]),
])
def test_bad_confirmation_settings_name_the_field(lifecycle, fragments):
    with pytest.raises(ConfigError) as err:
        make_tracker("gnn", Sensor(), {"lifecycle": lifecycle})
    for fragment in fragments:
        assert re.search(re.escape(fragment), str(err.value)), str(err.value)
