"""Bad track-management settings (issue 21): each refused by `make_tracker` with a ConfigError that names the
field and what was wrong."""

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
