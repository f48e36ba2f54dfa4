"""Scenarios with several sensors: generation, dataset format 2 (and reading format 1), plotting, refusals."""

from __future__ import annotations

import json
import shutil
from dataclasses import fields
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from dataset_edits import rewrite_table, set_value
from nnda.app.data_commands import generate as generate_command
from nnda.data.dataset import FORMAT_VERSION, read_dataset, write_dataset
from nnda.data.generator import generate
from nnda.data.presets import PRESETS
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Sensor, Target, load_scenario
from nnda.data.sensor import in_coverage, in_coverage_polar, polar_to_cart_at
from nnda.errors import ConfigError, DatasetError
from nnda.files import file_digests

V1_FIXTURE = Path(__file__).parent / "fixtures" / "dataset-v1"


def _files(path: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(path.iterdir())}


@pytest.fixture(scope="module")
def two() -> object:
    return generate(PRESETS["two-radars"], seed=4)


TWO_SENSORS = """
name = "harbour"
duration_s = 120

[[sensors]]
name = "west"
x_m = -10000
boresight_deg = 30
fov_deg = 120
[sensors.clutter]
law = "annulus"
count = 50

[[sensors]]
name = "east"
x_m = 10000
boresight_deg = 330
fov_deg = 120
scan_offset_s = 1.0
pd = 0.9

[[targets]]
name = "alpha"
x_m = 0
y_m = 25000
heading_deg = 180
speed_m_s = 120
segments = [{ duration_s = 120 }]
"""


def test_a_two_sensor_config_generates(tmp_path):
    """[[sensors]] tables, each with its clutter (east's none), interleaved sweeps (east 1 s after west)."""
    (tmp_path / "harbour.toml").write_text(TWO_SENSORS)
    sc = load_scenario(tmp_path / "harbour.toml")
    assert [s.name for s in sc.sensors] == ["west", "east"] and sc.n_scans == 120
    ds = generate(sc)
    assert ds.scan_time[:3].tolist() == [1.0, 2.0, 3.0] and ds.scan_sensor[:3].tolist() == [1, 0, 1]
    assert (ds.detections.sensor[ds.detections.is_clutter] == 0).sum() == 50 * 60


def test_scans_are_in_time_order_with_their_sensor(two):
    sc = two.scenario
    scans = list(two.scans())
    assert len(scans) == sc.n_scans == 180 and [s.index for s in scans] == list(range(1, 181))
    times = [s.time for s in scans]
    assert times == sorted(times) and times[:4] == [1.0, 2.0, 3.0, 4.0]  # west at 2k s, east 1 s later
    assert [s.sensor for s in scans[:4]] == [1, 0, 1, 0]
    np.testing.assert_array_equal(two.scan_sensor, [s.sensor for s in scans])
    np.testing.assert_array_equal(two.scan_time, times)
    det = two.detections
    np.testing.assert_array_equal(det.sensor, two.scan_sensor[det.scan - 1])
    np.testing.assert_array_equal(det.time, two.scan_time[det.scan - 1])
    np.testing.assert_array_equal(two.truth.time, two.scan_time[two.truth.scan - 1])
    assert sum(len(s.measurements) for s in scans) == det.scan.size
    for s in scans[:6]:  # measurements are (range, azimuth) from the scan's own radar
        rows = det.scan == s.index
        np.testing.assert_array_equal(s.measurements, np.column_stack([det.range[rows], det.azimuth[rows]]))


def test_every_detection_lies_in_its_sensors_coverage(two):
    det, sc = two.detections, two.scenario
    for j, sensor in enumerate(sc.sensors):
        mine = det.sensor == j
        assert mine.sum() > 1000
        # the measured polar values (what the coverage test saw) and the converted positions
        assert in_coverage_polar(sensor, det.range[mine], det.azimuth[mine]).all()
        np.testing.assert_allclose(np.column_stack(polar_to_cart_at(sensor.position, det.range[mine],
                                                                    det.azimuth[mine])),
                                   np.column_stack([det.x[mine], det.y[mine]]), rtol=1e-9)
        clutter = mine & det.is_clutter
        assert in_coverage(sensor, det.x[clutter], det.y[clutter]).all()
        assert clutter.sum() == 100 * 90  # 100 points in each of the sensor's 90 sweeps
        # the sector wraps through north: clutter on both sides of it
        az = np.degrees(det.azimuth[clutter])
        assert (az < 10).any() and (az > 350).any()


def test_detection_counts_follow_each_sensors_pd():
    sc = PRESETS["two-radars"]
    sensors = tuple(s.model_copy(update={"clutter": Clutter(law="none"), "min_range_m": 0.0, "max_range_m": 1e5,
                                         "fov_deg": 360.0}) for s in sc.sensors)
    wide = sc.model_copy(update={"sensors": sensors})
    n_hits, n_rows = np.zeros(2), np.zeros(2)
    for run in range(8):
        ds = generate(wide, seed=5, run=run)
        rows_sensor = ds.scan_sensor[ds.truth.scan - 1]
        for j in range(2):
            n_rows[j] += (rows_sensor == j).sum()
            n_hits[j] += ds.truth.detected[rows_sensor == j].sum()
            assert (ds.detections.sensor == j).sum() == ds.truth.detected[rows_sensor == j].sum()
    for j, pd in enumerate((0.9, 0.85)):
        assert abs(n_hits[j] / n_rows[j] - pd) < 4 * np.sqrt(pd * (1 - pd) / n_rows[j])


def test_targets_outside_a_sector_are_seen_by_the_other_radar_only(two):
    det, truth, sc = two.detections, two.truth, two.scenario
    eastbound = [t.name for t in sc.targets].index("eastbound")
    rows = truth.target_id == eastbound
    sensor = two.scan_sensor[truth.scan[rows] - 1]
    west, east = sc.sensors
    west_sees = in_coverage(west, truth.x[rows], truth.y[rows])
    assert (~west_sees & (sensor == 0)).sum() > 5  # it starts west of the west radar's sector
    blind = ~west_sees & (sensor == 0)
    assert not truth.detected[rows][blind].any()
    assert truth.detected[rows][in_coverage(east, truth.x[rows], truth.y[rows]) & (sensor == 1)].mean() > 0.7
    assert set(det.sensor[det.target_id == eastbound].tolist()) == {0, 1}


def _crossing(name: str, sensors: tuple[Sensor, ...], missed: list[int] = ()) -> Scenario:
    target = Target(name="a", x_m=-8_000.0, y_m=15_000.0, heading_deg=90.0, speed_m_s=100.0,
                    segments=[Segment(duration_s=60.0)], missed_scans=list(missed))
    return Scenario(name=name, duration_s=60.0, targets=[target], sensors=sensors,
                    process_noise=ProcessNoise())


def test_a_sensors_draws_do_not_depend_on_the_others():
    west = Sensor(name="west", x_m=-10_000.0, clutter=Clutter(count=20))
    east = Sensor(name="east", x_m=10_000.0, scan_offset_s=0.5, clutter=Clutter(law="annulus", count=30))
    alone, both = generate(_crossing("pair", (west,)), seed=2), generate(_crossing("pair", (west, east)), seed=2)
    mine = both.detections.sensor == 0
    for name in ("time", "range", "azimuth", "x", "y", "target_id"):
        np.testing.assert_array_equal(getattr(alone.detections, name), getattr(both.detections, name)[mine])
    west_rows = both.scan_sensor[both.truth.scan - 1] == 0
    for name in ("time", "x", "y", "detected"):
        np.testing.assert_array_equal(getattr(alone.truth, name), getattr(both.truth, name)[west_rows])
    # the second sensor draws from streams of its own
    other = both.detections.sensor == 1
    assert other.sum() > 0 and not np.isin(both.detections.range[other], alone.detections.range).any()


def test_missed_scans_hit_the_global_scan_numbers():
    sensors = (Sensor(name="west", x_m=-10_000.0, clutter=Clutter(law="none")),
               Sensor(name="east", x_m=10_000.0, scan_offset_s=1.0, clutter=Clutter(law="none")))
    ds = generate(_crossing("gaps", sensors, missed=[1, 2, 7]), seed=1)
    assert ds.n_scans == 60
    assert sorted(ds.truth.scan[~ds.truth.detected].tolist()) == [1, 2, 7]
    assert set(ds.detections.scan.tolist()) == set(range(1, 61)) - {1, 2, 7}


def test_position_sensor_scans_hold_cartesian_fixes():
    fix = Sensor(name="fix", kind="position", x_m=2_000.0, min_range_m=0.0, max_range_m=50_000.0,
                 sigma_position_m=3.0, clutter=Clutter(law="annulus", count=4))
    radar = Sensor(name="radar", clutter=Clutter(law="none"))
    ds = generate(_crossing("mixed", (radar, fix)), seed=3)
    det = ds.detections
    for scan in ds.scans():
        rows = det.scan == scan.index
        if scan.sensor == 1:
            np.testing.assert_array_equal(scan.measurements, np.column_stack([det.x[rows], det.y[rows]]))
        else:
            np.testing.assert_array_equal(scan.measurements, np.column_stack([det.range[rows], det.azimuth[rows]]))
    hits = (det.sensor == 1) & ~det.is_clutter
    truth_rows = np.searchsorted(ds.truth.scan, det.scan[hits])  # one target: one truth row per scan
    err = np.concatenate([det.x[hits] - ds.truth.x[truth_rows], det.y[hits] - ds.truth.y[truth_rows]])
    assert abs(err.std() - 3.0) < 0.6
    np.testing.assert_allclose(np.column_stack(polar_to_cart_at(fix.position, det.range[hits], det.azimuth[hits])),
                               np.column_stack([det.x[hits], det.y[hits]]), rtol=1e-9)


def test_round_trip_and_same_seed_same_bytes(tmp_path, two):
    write_dataset(two, tmp_path / "a")
    write_dataset(generate(PRESETS["two-radars"], seed=4), tmp_path / "b")
    write_dataset(generate(PRESETS["two-radars"], seed=5), tmp_path / "c")
    a, b, c = (_files(tmp_path / n) for n in "abc")
    assert a == b and a["detections.parquet"] != c["detections.parquet"]
    meta = json.loads(a["scenario.json"])
    assert meta["format_version"] == FORMAT_VERSION == 4 and meta["sensor_names"] == ["west", "east"]
    assert meta["sha256"] == file_digests(tmp_path / "a", ["detections.parquet", "truth.parquet"])
    assert [s["name"] for s in meta["scenario"]["sensors"]] == ["west", "east"]
    assert pq.read_schema(tmp_path / "a" / "detections.parquet").field("sensor").type == pa.int32()
    back = read_dataset(tmp_path / "a")
    assert back.scenario == two.scenario
    for record in ("detections", "truth"):
        for f in fields(getattr(two, record)):
            got, want = getattr(getattr(back, record), f.name), getattr(getattr(two, record), f.name)
            np.testing.assert_array_equal(got, want)
            assert got.dtype == want.dtype
    assert [(s.index, s.time, s.sensor) for s in back.scans()] == [(s.index, s.time, s.sensor) for s in two.scans()]


def test_plot_draws_every_sensors_sector(tmp_path, two):
    pytest.importorskip("matplotlib")
    from matplotlib.patches import Circle, Wedge

    from nnda.reports.scenario_plot import coverage_patches, plot_scenario

    png = plot_scenario(two, tmp_path / "two.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    west, east = two.scenario.sensors
    (w,), (e,) = coverage_patches(west), coverage_patches(east)
    assert isinstance(w, Wedge) and isinstance(e, Wedge)
    # matplotlib angles: counter-clockwise from east; west looks at 30 deg +- 60 from north, east at 330 +- 60
    assert (w.center, w.r, w.width, w.theta1, w.theta2) == ((-10.0, 0.0), 30.0, 25.0, 0.0, 120.0)
    assert (e.center, e.theta1, e.theta2) == ((10.0, 0.0), 60.0, 180.0)
    ring = coverage_patches(PRESETS["S1"].sensor)
    assert [type(p) for p in ring] == [Circle, Circle] and [p.radius for p in ring] == [5.0, 30.0]


# ----------------------------------------------------------------------------- format 1 and refusals

def test_format_1_dataset_reads_as_one_radar_at_the_origin():
    """The fixture was written by the one-radar code (commit 63ca4c6): no sensor column, one-sensor manifest."""
    meta = json.loads((V1_FIXTURE / "scenario.json").read_text())
    assert meta["format_version"] == 1 and "sensor" in meta["scenario"] and "sensors" not in meta["scenario"]
    assert "sensor" not in pq.read_schema(V1_FIXTURE / "detections.parquet").names
    ds = read_dataset(V1_FIXTURE)
    assert ds.scenario.sensors == (Sensor(clutter=Clutter(count=3)),)
    assert ds.detections.sensor.dtype == np.int32 and not ds.detections.sensor.any()
    assert ds.detections.sensor.size == meta["n_detections"] == 24
    assert [(s.index, s.time, s.sensor) for s in ds.scans()] == [(k, 2.0 * k, 0) for k in range(1, 6)]
    # and it holds what the current generator draws for its scenario and seed (floats to 1e-9 across machines)
    now = generate(ds.scenario, seed=meta["seed"], run=meta["run"])
    for record in ("detections", "truth"):
        for f in fields(getattr(ds, record)):
            got, want = getattr(getattr(ds, record), f.name), getattr(getattr(now, record), f.name)
            if got.dtype.kind == "f":
                np.testing.assert_allclose(got, want, rtol=1e-9)
            else:
                np.testing.assert_array_equal(got, want)


def test_format_1_dataset_with_other_sensors_is_refused(tmp_path):
    shutil.copytree(V1_FIXTURE, tmp_path / "d")
    meta = json.loads((tmp_path / "d" / "scenario.json").read_text())
    meta["scenario"]["sensor"]["x_m"] = 1000.0
    (tmp_path / "d" / "scenario.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="scenario.json: a format-1 dataset holds one radar at the origin"):
        read_dataset(tmp_path / "d")


@pytest.fixture
def written(tmp_path):
    return write_dataset(generate(PRESETS["two-radars"].model_copy(update={"duration_s": 20.0}), seed=1),
                         tmp_path / "d")


@pytest.mark.parametrize("version", [5, 0, "3"])
def test_unknown_format_version_is_refused(written, version):
    meta = json.loads((written / "scenario.json").read_text())
    meta["format_version"] = version
    (written / "scenario.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match=rf"{written / 'scenario.json'}: field 'format_version' is "
                                           rf"{version!r}; this nnda \(.*\) reads version 1 or 2 or 3 or 4 only"):
        read_dataset(written)


@pytest.mark.parametrize("value, message", [
    (2, r"column 'sensor' names sensor 2 at row 3, but scenario.json lists 2 sensor\(s\) \(indices 0..1\)"),
    (-1, r"column 'sensor' names sensor -1 at row 3"),
])
def test_detections_of_a_sensor_not_in_the_manifest_are_refused(written, value, message):
    rewrite_table(written, "detections.parquet", set_value("sensor", 3, value))
    with pytest.raises(DatasetError, match=rf"detections.parquet: {message}"):
        read_dataset(written)


def test_detections_of_the_wrong_sensor_for_their_scan_are_refused(written):
    first = int(pq.read_table(written / "detections.parquet").column("sensor")[0].as_py())
    rewrite_table(written, "detections.parquet", set_value("sensor", 0, 1 - first))
    with pytest.raises(DatasetError, match=r"detections.parquet: column 'sensor' is \d at row 0, but scan 1 is a "
                                           r"sweep of sensor \d"):
        read_dataset(written)


def test_a_format_2_dataset_without_the_sensor_column_is_refused(written):
    rewrite_table(written, "detections.parquet", lambda t: t.drop_columns(["sensor"]))
    with pytest.raises(DatasetError, match="detections.parquet: column 'sensor' is missing"):
        read_dataset(written)


@pytest.mark.parametrize("sensors, message", [
    ('[[sensors]]\nname = "a"\n[[sensors]]\nname = "a"\n', r"sensor names must be unique, got \['a', 'a'\]"),
    ('[[sensors]]\nx_m = 3e7\n', r"sensors.0.x_m: Value error, 3e\+07 m lies outside the scenario's frame"),
    ('[[sensors]]\nfov_deg = 400\n', "sensors.0.fov_deg"),
    ('[[sensors]]\nscan_offset_s = 2\n', "scan_offset_s = 2.0 must be below scan_period_s = 2.0"),
    ('[[sensors]]\nmin_range_m = 9e3\nmax_range_m = 8e3\n', "min_range_m must be below max_range_m"),
    ('[sensor]\npd = 0.5\n[[sensors]]\nname = "b"\n', "give either `sensors` or the one-sensor form"),
    # valid config, but the clutter square misses the east radar's sector: refused before anything is written
    ('[[sensors]]\nname = "w"\n[[sensors]]\nname = "e"\nboresight_deg = 180\nfov_deg = 10\n'
     '[sensors.clutter]\ncentre_m = [0.0, 20000.0]\nside_m = 2000.0\n',
     r"scenario 'harbour': clutter of sensor 'e': the square region \(side 2000 m, centred at \(0, 20000\) m\) "
     r"has 0.00% of its points inside the coverage"),
])
def test_bad_sensor_configs_write_nothing(tmp_path, sensors, message):
    config = tmp_path / "harbour.toml"
    config.write_text('name = "harbour"\nduration_s = 20\n' + sensors + '[[targets]]\nname = "a"\nx_m = 0\n'
                      'y_m = 10000\nheading_deg = 0\nspeed_m_s = 100\nsegments = [{duration_s = 20}]\n')
    for runs in (1, 3):
        with pytest.raises(ConfigError, match=message):
            generate_command(out=tmp_path / "out", config=config, runs=runs)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["harbour.toml"]
