"""`nnda import-detections` and `nnda.data.detections_import`: round trips, the schema's options, every refusal."""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pytest
from typer.testing import CliRunner

from nnda.app.cli import app
from nnda.data.dataset import Dataset, read_dataset
from nnda.data.detections_import import export_detections, import_detections, read_detections, sensor_specs
from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.data.scenario import Clutter, Scenario, Segment, Sensor, Target
from nnda.errors import ConfigError, DatasetError


def assert_same_scans(a: Dataset, b: Dataset) -> None:
    """The same scans: index, time, sensor and contacts (measurements, their order and their labels)."""
    assert a.n_scans == b.n_scans
    bounds_a, bounds_b = a.scan_bounds(), b.scan_bounds()
    for sa, sb in zip(a.scans(), b.scans(), strict=True):
        assert (sa.index, sa.time, sa.sensor) == (sb.index, sb.time, sb.sensor)
        np.testing.assert_array_equal(sa.measurements, sb.measurements)
        k = sa.index
        assert (a.detections.target_id[bounds_a[k - 1]:bounds_a[k]] >= 0).tolist() == \
            (b.detections.target_id[bounds_b[k - 1]:bounds_b[k]] >= 0).tolist()


@pytest.fixture(scope="module")
def polar_and_position() -> Dataset:
    """A radar and a position sensor (offset 1 s) on two targets: both measurement kinds and ties in time."""
    target = dict(heading_deg=90.0, speed_m_s=120.0, segments=[Segment(duration_s=40.0)])
    return generate(Scenario(
        name="mixed", duration_s=40.0, seed=5,
        targets=[Target(name="a", x_m=-3000, y_m=12000, **target), Target(name="b", x_m=2000, y_m=-15000, **target)],
        sensors=(Sensor(name="radar", clutter=Clutter(count=8)),
                 Sensor(name="fix", kind="position", x_m=500.0, y_m=-200.0, scan_period_s=4.0, scan_offset_s=2.0,
                        sigma_position_m=20.0, clutter=Clutter(count=3)))))


@pytest.mark.parametrize("name", ["S1", "two-radars"])
def test_round_trip_of_a_preset_through_csv(tmp_path, name):
    ds = generate(preset(name), seed=3)
    export_detections(ds, tmp_path / "det.csv", truth=tmp_path / "truth.csv")
    back = read_detections(tmp_path / "det.csv", sensors=sensor_specs(ds.scenario), truth=tmp_path / "truth.csv")
    assert_same_scans(ds, back)
    np.testing.assert_array_equal(back.detections.sensor, ds.detections.sensor)
    assert [t.name for t in back.scenario.targets] == sorted(t.name for t in ds.scenario.targets)  # text order
    for a in (ds, back):  # the same truth rows, by target name
        names = np.array([t.name for t in a.scenario.targets])[a.truth.target_id]
        rows = np.lexsort((names, a.truth.scan))
        a_rows = [names[rows]] + [getattr(a.truth, f)[rows] for f in ("scan", "time", "x", "y", "vx", "vy", "detected")]
        if a is ds:
            want = a_rows
    for got, expected in zip(a_rows, want, strict=True):
        np.testing.assert_array_equal(got, expected)


def test_round_trip_with_a_position_sensor_through_parquet(tmp_path, polar_and_position):
    ds = polar_and_position
    export_detections(ds, tmp_path / "det.parquet", truth=tmp_path / "truth.parquet")
    path, back = import_detections(tmp_path / "det.parquet", tmp_path / "out", sensors=sensor_specs(ds.scenario),
                                   truth=tmp_path / "truth.parquet")
    assert_same_scans(ds, back)
    assert_same_scans(ds, read_dataset(path))  # written, sealed, read back


def test_period_offset_and_coverage_are_inferred_from_the_times(tmp_path, polar_and_position):
    ds = polar_and_position
    export_detections(ds, tmp_path / "det.csv")
    given = [{"name": s.name, "kind": s.kind, "x_m": s.x_m, "y_m": s.y_m} for s in ds.scenario.sensors]
    back = read_detections(tmp_path / "det.csv", sensors=given)
    assert [(s.scan_period_s, s.scan_offset_s) for s in back.scenario.sensors] == [(2.0, 0.0), (4.0, 2.0)]
    assert_same_scans(ds, back)
    assert back.truth.scan.size == 0 and back.detections.target_id.max() >= 0  # labels without a truth file


def test_degrees_mapped_names_clock_times_and_a_tolerance(tmp_path):
    ds = generate(preset("S1"), seed=1)
    d = ds.detections
    jitter = np.random.default_rng(0).uniform(-0.3, 0.3, d.time.size)
    pacsv.write_csv(pa.table({"t_sec": d.time + 1.7e9 + jitter, "rng": d.range, "az_deg": np.degrees(d.azimuth)}),
                    tmp_path / "plots.csv")
    back = read_detections(tmp_path / "plots.csv", columns=["time=t_sec", "range=rng", "azimuth=az_deg"],
                           azimuth_unit="deg", time_origin=1.7e9, scan_tolerance=0.5,
                           sensors=[{"scan_period_s": 2.0, "scan_offset_s": 0.0}])
    assert back.n_scans == ds.n_scans
    np.testing.assert_array_equal(back.detections.scan, d.scan)
    np.testing.assert_allclose(back.detections.azimuth, d.azimuth, rtol=1e-12, atol=1e-12)
    assert back.detections.is_clutter.all()  # no target_id column: unlabelled


def test_the_shipped_example_imports(tmp_path):
    from pathlib import Path

    examples = Path(__file__).resolve().parents[2] / "examples"
    _, ds = import_detections(examples / "plots.csv", tmp_path / "plots", sensors=[{"scan_period_s": 2.0}],
                              truth=examples / "plots_truth.csv")
    assert ds.n_scans > 0 and ds.truth.scan.size > 0 and not ds.detections.is_clutter.all()


# ----------------------------------------------------------------------------- refusals

HEADER = "time,range,azimuth,sensor,target_id\n"
GOOD = ["2,12000,0.5,radar,7", "2,15000,1.0,radar,", "4,12100,0.51,radar,7"]


def _csv(tmp_path, rows, header=HEADER, name="det.csv"):
    path = tmp_path / name
    path.write_text(header + "\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("rows, fragments", [
    (GOOD[:1] + ["abc,15000,1.0,radar,"], ("data row 2 (line 3)", "column 'time'", "'abc', not a number")),
    (GOOD[:2] + ["4,nan,0.51,radar,7"], ("data row 3 (line 4)", "column 'range'", "finite")),
    (GOOD[:1] + ["2,,1.0,radar,"], ("data row 2", "column 'range'", "empty cell")),
    (GOOD + ["2,13000,0.2,radar,"], ("data row 4 (line 5)", "column 'time'", "goes back")),
    (GOOD + ["6,13000,7.0,radar,"], ("data row 4", "column 'azimuth'", "outside [-pi, 2 pi) rad")),
    (GOOD + ["6,13000,45,radar,"], ("data row 4", "column 'azimuth'", "--azimuth-unit deg")),
    (GOOD + ["6,-5,0.3,radar,"], ("data row 4", "column 'range'", "positive")),
    (GOOD + ["6,13000,0.3,lidar,"], ("data row 4", "column 'sensor'", "unknown sensor 'lidar'")),
    (GOOD + ["6.5,13000,0.3,radar,"], ("data row 4", "column 'time'", "from the nearest sweep")),
    (["0,12000,0.5,radar,7"] + GOOD, ("data row 1", "column 'time'", "--time-origin")),
])
def test_a_bad_cell_is_named_by_file_row_and_column(tmp_path, rows, fragments):
    path = _csv(tmp_path, rows)
    with pytest.raises(DatasetError) as exc:
        read_detections(path, sensors=[{"scan_period_s": 2.0}])
    assert str(path) in str(exc.value)
    for fragment in fragments:
        assert fragment in str(exc.value)


def test_a_missing_column_names_what_the_file_has(tmp_path):
    path = _csv(tmp_path, ["2,12000"], header="t,range\n")
    with pytest.raises(DatasetError, match=r"required column\(s\) 'time' missing .* the file has t, range"):
        read_detections(path)
    with pytest.raises(DatasetError, match="'azimuth' missing"):
        read_detections(path, columns={"time": "t"})


def test_bad_options_are_config_errors(tmp_path):
    path = _csv(tmp_path, GOOD)
    for kwargs, match in (({"azimuth_unit": "grad"}, "unknown unit"), ({"columns": ["speed=v"]}, "unknown column"),
                          ({"scan_tolerance": 1.5}, "half the scan period"),
                          ({"sensors": [{"sigma_range_m": -1, "scan_period_s": 2.0}]}, "sigma_range_m")):
        with pytest.raises(ConfigError, match=match):
            read_detections(path, **kwargs)


def test_truth_problems_name_the_truth_file(tmp_path):
    path = _csv(tmp_path, GOOD)
    head = "time,target_id,x,y,vx,vy\n"
    truth = _csv(tmp_path, ["2,7,5000,11000,100,0", "3,7,5200,11000,100,0"], header=head, name="truth.csv")
    with pytest.raises(DatasetError, match=r"truth.csv: data row 2 .* column 'time': time 3.0 s is no scan's time"):
        read_detections(path, truth=truth, sensors=[{"scan_period_s": 2.0}])
    truth = _csv(tmp_path, ["2,8,5000,11000,100,0"], header=head, name="truth.csv")
    with pytest.raises(DatasetError, match=r"det.csv: data row 1 .* column 'target_id': target '7' is not in"):
        read_detections(path, truth=truth, sensors=[{"scan_period_s": 2.0}])


# ----------------------------------------------------------------------------- the command

def test_the_command_writes_a_dataset_and_refuses_to_overwrite(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _csv(tmp_path, GOOD)
    (tmp_path / "sensors.toml").write_text('[[sensors]]\nname = "radar"\nscan_period_s = 2.0\nsigma_range_m = 25\n')
    runner = CliRunner()
    done = runner.invoke(app, ["import-detections", "det.csv", "--out", "ds", "--sensors", "sensors.toml"])
    assert done.exit_code == 0, done.output
    assert "wrote ds (3 detections, 2 of targets; 2 scans" in done.output
    ds = read_dataset(tmp_path / "ds")
    assert ds.scenario.sensors[0].sigma_range_m == 25 and [t.name for t in ds.scenario.targets] == ["7"]
    assert math.isclose(ds.scenario.duration_s, 4.0)
    again = runner.invoke(app, ["import-detections", "det.csv", "--out", "ds", "--sensor", "scan_period_s=2"])
    assert isinstance(again.exception, FileExistsError)
    done = runner.invoke(app, ["import-detections", "det.csv", "--out", "ds", "--sensor", "scan_period_s=2",
                               "--sensor", "sigma_range_m=40", "--overwrite"])
    assert done.exit_code == 0, done.output
    assert read_dataset(tmp_path / "ds").scenario.sensors[0].sigma_range_m == 40


def test_truth_beyond_the_last_detection_and_an_offset_in_the_file_clock(tmp_path):
    path = _csv(tmp_path, ["101,12000,0.5,radar,7", "103,12100,0.51,radar,7"])
    truth = _csv(tmp_path, [f"{t},7,{5000 + 100 * t},11000,100,0" for t in (101, 103, 105)],
                 header="time,target_id,x,y,vx,vy\n", name="truth.csv")
    ds = read_detections(path, truth=truth, time_origin=100.0,
                         sensors=[{"scan_period_s": 2.0, "scan_offset_s": 101.0}])
    assert ds.scenario.sensors[0].scan_offset_s == 1.0 and ds.scan_time.tolist() == [1.0, 3.0, 5.0]
    assert ds.truth.scan.tolist() == [1, 2, 3] and ds.truth.detected.tolist() == [True, True, False]
