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


def test_a_sensor_of_no_given_kind_measures_positions_when_the_file_has_no_range_and_azimuth(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from nnda.app.cli import app

    cart = pa.table({"time": [2.0, 4.0], "x": [100.0, 110.0], "y": [9000.0, 9010.0]})
    geo = pa.table({"time": [2.0, 4.0], "lat": [51.5, 51.5001], "lon": [-0.4, -0.4001]})
    both = cart.append_column("range", pa.array([9000.0, 9010.0])).append_column("azimuth", pa.array([0.01, 0.01]))
    kinds = lambda table, sensors=None: [s.kind for s in read_detections(table, sensors=sensors).scenario.sensors]  # noqa: E731
    assert kinds(cart) == kinds(geo) == ["position"]
    assert kinds(cart, [{"kind": "polar"}]) == kinds(both) == ["polar"]  # asked for, or measured as range/azimuth
    assert kinds(cart.append_column("sensor", pa.array(["north", "camp"])),
                 [{"name": "north", "kind": "polar", "scan_period_s": 2.0}, {"name": "camp"}]) == ["polar", "position"]
    # the command's summary line says the kind was not given
    monkeypatch.chdir(tmp_path)
    (tmp_path / "xy.csv").write_text("time,x,y\n2,100,9000\n4,110,9010\n")
    done = CliRunner().invoke(app, ["import-detections", "xy.csv", "--out", "ds"])
    assert done.exit_code == 0, done.output
    assert "sensor radar (position: no kind given, no range/azimuth columns) at (0, 0) m" in " ".join(
        done.output.split())
    done = CliRunner().invoke(app, ["import-detections", "xy.csv", "--out", "ds2", "--sensor", "kind=polar"])
    assert "sensor radar (polar) at" in done.output
