"""Import options: distance and speed units; sensor column values as names (a sensor named "12")."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest

from nnda.data.detections_import import read_detections
from nnda.errors import ConfigError, DatasetError


def test_distances_and_speeds_in_other_units_are_stored_in_metres_and_m_per_s():
    det = pa.table({"time": [2.0, 2.0], "range": [10.0, 12.0], "azimuth": [0.0, 1.0], "target_id": ["a", None]})
    truth = pa.table({"time": [2.0], "target_id": ["a"], "x": [0.0], "y": [10.0], "vx": [36.0], "vy": [0.0]})
    ds = read_detections(det, distance_unit="nmi", speed_unit="km/h", truth=truth)
    np.testing.assert_allclose(ds.detections.range, [18520.0, 22224.0])
    assert ds.truth.y.tolist() == [18520.0] and ds.truth.vx.tolist() == [10.0]
    cart = pa.table({"time": [2.0], "x": [1.0], "y": [10.0]})
    ds = read_detections(cart, sensors=[{"kind": "position"}], distance_unit="km")
    assert (ds.detections.x.tolist(), ds.detections.y.tolist()) == ([1000.0], [10000.0])
    with pytest.raises(ConfigError, match=r"--distance-unit 'mi': unknown unit; choose one of m, km, nmi, ft"):
        read_detections(cart, distance_unit="mi")
    with pytest.raises(ConfigError, match=r"--speed-unit 'knots': unknown unit; choose one of m/s, kn, km/h"):
        read_detections(cart, speed_unit="knots")


def test_a_sensor_named_by_a_number_is_found_by_that_number():
    det = pa.table({"time": [2.0, 2.0], "sensor": [12, 7], "x": [100.0, 200.0], "y": [9000.0, 9000.0]})
    sensors = [{"name": "7", "kind": "position", "scan_period_s": 2.0},
               {"name": "12", "kind": "position", "scan_period_s": 2.0}]
    ds = read_detections(det, sensors=sensors)
    assert sorted(zip(ds.detections.sensor.tolist(), ds.detections.x.tolist())) == [(0, 200.0), (1, 100.0)]


def test_values_are_names_when_every_sensor_is_named_and_indices_otherwise():
    det = pa.table({"time": [2.0, 2.0], "sensor": [0, 1], "x": [100.0, 200.0], "y": [9000.0, 9000.0]})
    unnamed = [{"kind": "position", "scan_period_s": 2.0}] * 2
    assert sorted(read_detections(det, sensors=unnamed).detections.sensor.tolist()) == [0, 1]
    named = [{"name": "a", "kind": "position", "scan_period_s": 2.0}, {"name": "b", "kind": "position",
                                                                       "scan_period_s": 2.0}]
    with pytest.raises(DatasetError, match=r"the table: row 1 \(1-based\), column 'sensor': unknown sensor '0' "
                                           r"\(sensors: 0 'a', 1 'b'\)"):
        read_detections(det, sensors=named)
