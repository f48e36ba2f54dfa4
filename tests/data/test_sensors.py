"""Sensor configs, the one-sensor form, the scan schedule, sensor-relative geometry and coverage."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, Scenario, Sensor, scenario_from_dict
from nnda.data.sensor import (
    cart_to_polar,
    cart_to_polar_at,
    in_coverage,
    in_coverage_polar,
    measure,
    polar_to_cart,
    polar_to_cart_at,
)
from nnda.errors import ConfigError


def _base(**extra) -> dict:
    return {
        "name": "x", "duration_s": 20,
        "targets": [{"name": "a", "x_m": 0, "y_m": 10000, "heading_deg": 0, "speed_m_s": 100,
                     "segments": [{"duration_s": 20}]}],
        **extra,
    }


def _two(**second) -> list[dict]:
    return [{"name": "west", "x_m": -10_000}, {"name": "east", "x_m": 10_000, **second}]


@pytest.mark.parametrize("data, where", [
    (_base(sensors=[{"x_m": math.nan}]), "sensors.0.x_m"),
    (_base(sensors=[{"y_m": math.inf}]), "sensors.0.y_m"),
    (_base(sensors=_two(y_m=2e7)), "sensors.1.y_m: Value error, 2e+07 m lies outside the scenario's frame"),
    (_base(sensors=[{"x_m": -1.5e7}]), "outside the scenario's frame"),
    (_base(sensors=[{"name": "a"}, {"name": "a"}]), "sensor names must be unique, got ['a', 'a']"),
    (_base(sensors=[{}, {}]), "sensor names must be unique, got ['radar', 'radar']"),
    (_base(sensors=_two(fov_deg=0)), "sensors.1.fov_deg"),
    (_base(sensors=_two(fov_deg=-30)), "sensors.1.fov_deg"),
    (_base(sensors=_two(fov_deg=361)), "sensors.1.fov_deg: Input should be less than or equal to 360"),
    (_base(sensors=_two(scan_offset_s=2.0)), "sensors.1: Value error, scan_offset_s = 2.0 must be below "
                                             "scan_period_s = 2.0"),
    (_base(sensors=_two(scan_offset_s=-1.0)), "sensors.1.scan_offset_s"),
    (_base(sensors=_two(min_range_m=30_000)), "sensors.1: Value error, min_range_m must be below max_range_m"),
    (_base(sensors=_two(kind="sonar")), "sensors.1.kind"),
    (_base(sensors=_two(name="east side")), "sensors.1.name"),
    (_base(sensors=_two(scan_period_s=3.0)), "not a whole number of scan periods (3.0 s) of sensor 1 ('east')"),
    (_base(sensors=[]), "sensors: give at least one sensor"),
    (_base(sensors=_two(clutter={"law": "fog"})), "sensors.1.clutter.law"),
    (_base(sensors=_two(), sensor={"pd": 0.5}), "give either `sensors` or the one-sensor form"),
    (_base(sensors=_two(), clutter={"count": 5}), "give either `sensors` or the one-sensor form"),
    (_base(sensor={"clutter": {"count": 5}}, clutter={"count": 6}), "clutter is given twice"),
    (_base(sensors=_two(boresight_deg=400)), "sensors.1.boresight_deg"),
])
def test_bad_sensor_configs_name_the_field(data, where):
    with pytest.raises(ConfigError) as info:
        scenario_from_dict(data, "harbour.toml")
    assert "harbour.toml" in str(info.value) and where in str(info.value)


def test_one_sensor_form_is_one_sensor_with_that_clutter():
    legacy = scenario_from_dict(_base(sensor={"pd": 0.8, "scan_period_s": 4.0}, clutter={"law": "annulus"}))
    new = scenario_from_dict(_base(sensors=[{"pd": 0.8, "scan_period_s": 4.0, "clutter": {"law": "annulus"}}]))
    assert legacy == new
    assert legacy.sensors == (Sensor(pd=0.8, scan_period_s=4.0, clutter=Clutter(law="annulus")),)
    assert legacy.sensor is legacy.sensors[0] and legacy.clutter.law == "annulus"
    # keyword construction with instances, as the presets and the Stone Soup importer do
    built = Scenario(**_base(), sensor=Sensor(pd=0.8, scan_period_s=4.0), clutter=Clutter(law="annulus"))
    assert built == new
    assert scenario_from_dict(_base(clutter={"count": 7})).sensor == Sensor(clutter=Clutter(count=7))
    assert scenario_from_dict(_base()).sensors == (Sensor(),)


def test_several_sensors_refuse_the_one_sensor_conveniences():
    sc = PRESETS["two-radars"]
    with pytest.raises(ConfigError, match=r"scenario 'two-radars' has 2 sensors \(west, east\); this code handles "
                                          r"one sensor only"):
        sc.sensor
    with pytest.raises(ConfigError, match="has 2 sensors"):
        sc.clutter
    with pytest.raises(ConfigError, match="has 2 sensors"):
        sc.model_copy(update={"clutter": Clutter(law="none")})


def test_model_copy_takes_the_one_sensor_keys():
    sc = scenario_from_dict(_base(clutter={"count": 7}))
    no_clutter = sc.model_copy(update={"clutter": Clutter(law="none")})
    assert no_clutter.clutter.law == "none" and no_clutter.sensor.pd == 1.0 and sc.clutter.count == 7
    lower_pd = no_clutter.model_copy(update={"sensor": Sensor(pd=0.5)})
    assert lower_pd.sensor.pd == 0.5 and lower_pd.clutter.law == "none"  # the clutter stays
    own = sc.model_copy(update={"sensor": Sensor(clutter=Clutter(count=3))})
    assert own.clutter.count == 3
    both = sc.model_copy(update={"sensor": Sensor(pd=0.5), "clutter": Clutter(count=2), "duration_s": 10.0})
    assert (both.sensor.pd, both.clutter.count, both.n_scans) == (0.5, 2, 5)
    with pytest.raises(ConfigError, match="clutter is given twice"):
        sc.model_copy(update={"sensor": Sensor(clutter=Clutter(count=3)), "clutter": Clutter(count=2)})
    with pytest.raises(ConfigError, match="give either `sensors` or `sensor`"):
        sc.model_copy(update={"sensors": (Sensor(),), "clutter": Clutter(count=2)})
    assert sc.model_copy(update={"seed": 9}).sensors == sc.sensors


def test_scan_schedule_merges_sweeps_in_time_order_ties_in_sensor_order():
    sc = scenario_from_dict(_base(sensors=[
        {"name": "a", "scan_period_s": 4.0},
        {"name": "b", "scan_period_s": 2.0},
        {"name": "c", "scan_period_s": 5.0, "scan_offset_s": 2.5},
    ]))
    time, sensor = sc.scan_schedule()
    assert sc.n_scans == 5 + 10 + 4 == time.size
    expected = sorted([(t, 0) for t in (4, 8, 12, 16, 20)] + [(t, 1) for t in range(2, 21, 2)]
                      + [(t, 2) for t in (2.5, 7.5, 12.5, 17.5)])
    assert list(zip(time.tolist(), sensor.tolist())) == expected
    assert sensor.dtype == np.int32
    one = scenario_from_dict(_base())
    t1, s1 = one.scan_schedule()
    np.testing.assert_array_equal(t1, 2.0 * np.arange(1, 11))
    assert one.n_scans == 10 and not s1.any()


def test_missed_scans_count_in_the_global_numbering():
    data = _base(sensors=_two(scan_offset_s=1.0))
    data["targets"][0]["missed_scans"] = [20]
    assert scenario_from_dict(data).n_scans == 20
    data["targets"][0]["missed_scans"] = [21]
    with pytest.raises(ConfigError, match=r"missed_scans \[21\] lie after the last scan \(20\)"):
        scenario_from_dict(data)


def test_sensor_relative_transforms():
    rng = np.random.default_rng(3)
    x, y = rng.uniform(-3e4, 3e4, (2, 500))
    origin = (-10_000.0, 2_500.0)
    r, az = cart_to_polar_at(origin, x, y)
    np.testing.assert_allclose((r, az), cart_to_polar(x - origin[0], y - origin[1]), rtol=1e-9)
    assert ((az >= 0) & (az < 2 * np.pi)).all()
    np.testing.assert_allclose(polar_to_cart_at(origin, r, az), (x, y), rtol=1e-9, atol=1e-7)
    # about the origin the _at forms are the origin forms, bit for bit
    for a, b in zip(cart_to_polar_at((0.0, 0.0), x, y), cart_to_polar(x, y)):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(polar_to_cart_at((0.0, 0.0), r, az), polar_to_cart(r, az)):
        np.testing.assert_array_equal(a, b)


def test_coverage_of_a_sector_across_north():
    s = Sensor(x_m=5_000.0, y_m=-2_000.0, boresight_deg=350.0, fov_deg=40.0, min_range_m=1_000.0,
               max_range_m=20_000.0)
    az = np.radians([329.0, 331.0, 350.0, 359.9, 0.0, 9.0, 11.0, 90.0, 170.0])
    inside = [False, True, True, True, True, True, False, False, False]
    r = np.full(az.size, 10_000.0)
    assert in_coverage_polar(s, r, az).tolist() == inside
    x, y = polar_to_cart_at(s.position, r, az)
    assert in_coverage(s, x, y).tolist() == inside
    # range limits about the sensor, not the origin
    assert in_coverage(s, np.array([5_000.0, 5_000.0, 5_000.0]), np.array([-1_500.0, 17_900.0, 18_100.0])).tolist() \
        == [False, True, False]
    full = Sensor(x_m=5_000.0)
    assert in_coverage(full, np.array([5_000.0, 5_000.0]), np.array([-4_000.0, -6_000.0])).tolist() == [False, True]


def test_position_sensor_measures_cartesian_fixes():
    s = Sensor(kind="position", x_m=3_000.0, sigma_position_m=5.0, min_range_m=0.0)
    x, y = np.full(20_000, 1_000.0), np.full(20_000, -4_000.0)
    mx, my = measure(s, x, y, np.random.default_rng(4))
    for m, truth in ((mx, 1_000.0), (my, -4_000.0)):
        assert abs(m.mean() - truth) < 4 * 5.0 / np.sqrt(m.size)
        assert abs(m.std() - 5.0) < 0.1
    assert abs(np.corrcoef(mx, my)[0, 1]) < 4 / np.sqrt(mx.size)


def test_polar_measure_is_relative_to_the_sensor():
    s = Sensor(x_m=-10_000.0, y_m=4_000.0, sigma_range_m=0.0, sigma_azimuth_mrad=0.0)
    r, az = measure(s, np.array([-10_000.0, 0.0]), np.array([14_000.0, 4_000.0]), np.random.default_rng(1))
    np.testing.assert_allclose(r, [10_000.0, 10_000.0])
    np.testing.assert_allclose(az, [0.0, np.pi / 2], atol=1e-15)
