"""Geodetic input at import (lat/lon reports, truth and sensor sites; ``--origin``), ``--region``, and lat/lon
in the outputs of ``nnda track`` and `export_detections`."""

from __future__ import annotations

import json
import math
import warnings
from types import SimpleNamespace

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest
from pyproj import Geod
from typer.testing import CliRunner

from nnda.app.cli import app
from nnda.app.track_commands import write_track_outputs
from nnda.data.dataset import MANIFEST, manifest_seal, read_dataset, write_dataset
from nnda.data.detections_import import export_detections, import_detections, read_detections
from nnda.data.generator import generate
from nnda.data.geodesy import GeodeticOrigin, mean_position
from nnda.data.presets import preset
from nnda.data.region import in_polygon
from nnda.data.scenario import Sensor
from nnda.errors import BoundWarning, ConfigError, DatasetError
from nnda.reports.track_plot import track_png
from nnda.study.track import TRACK_SCHEMA

SITE = GeodeticOrigin(51.47, -0.45)
SIGMA_M = 20.0
WGS84 = Geod(ellps="WGS84")


def _scene(tmp_path, n_scans: int = 12, alt: bool = False):
    """One target (A1) crossing 14 km north of a radar at SITE, a clutter plot per scan, every 2 s; written as
    fixes.csv (time, lat, lon[, alt], target_id) and truth.csv (time, target_id, lat, lon, vx, vy). Returns the
    reports' true x, y (m) on SITE's plane, (N, 2)."""
    rng = np.random.default_rng(7)
    det, truth, xy = ["time,lat,lon" + (",alt" if alt else "") + ",target_id"], ["time,target_id,lat,lon,vx,vy"], []
    for k in range(1, n_scans + 1):
        t = 2.0 * k
        x, y = -6000.0 + 150.0 * t, 14000.0 - 20.0 * t
        lat, lon = SITE.on_surface(x, y)
        truth.append(f"{t},A1,{float(lat):.9f},{float(lon):.9f},150,-20")
        for px, py, label in ((x + rng.normal(0, SIGMA_M), y + rng.normal(0, SIGMA_M), "A1"),
                              (rng.uniform(-2e4, 2e4), rng.uniform(-2e4, 2e4), "")):
            lat, lon = SITE.on_surface(px, py)
            det.append(f"{t},{float(lat):.9f},{float(lon):.9f}" + (",300" if alt else "") + f",{label}")
            xy.append((px, py))
    (tmp_path / "fixes.csv").write_text("\n".join(det) + "\n")
    (tmp_path / "truth.csv").write_text("\n".join(truth) + "\n")
    return np.array(xy)


RADAR = {"lat": SITE.lat_deg, "lon": SITE.lon_deg, "scan_period_s": 2.0, "sigma_range_m": SIGMA_M}


def test_lat_lon_reports_and_truth_with_a_radar_site_in_lat_lon(tmp_path):
    xy = _scene(tmp_path)
    _, ds = import_detections(tmp_path / "fixes.csv", tmp_path / "ds", sensors=[RADAR], truth=tmp_path / "truth.csv")
    assert ds.geodetic_origin == GeodeticOrigin(51.47, -0.45, 0.0, "the site of sensor 'radar'")
    assert ds.scenario.sensors[0].position == (0.0, 0.0)
    order = np.lexsort((np.arange(len(xy)), np.repeat(np.arange(len(xy) // 2), 2)))
    got = np.sort(np.column_stack([ds.detections.x, ds.detections.y]), axis=0)
    np.testing.assert_allclose(got, np.sort(xy[order], axis=0), atol=1e-3)  # 9 decimals of a degree: < 1 mm
    np.testing.assert_allclose(ds.truth.x, -6000.0 + 150.0 * ds.truth.time, atol=1e-3)
    back = read_dataset(tmp_path / "ds")
    assert back.geodetic_origin == ds.geodetic_origin and back.dropped_rows == {}
    meta = json.loads((tmp_path / "ds" / MANIFEST).read_text())
    assert meta["geodetic_origin"] == {"lat_deg": 51.47, "lon_deg": -0.45, "alt_m": 0.0,
                                       "source": "the site of sensor 'radar'"}


def test_track_outputs_carry_lat_lon_and_the_plot_names_the_origin(tmp_path):
    _scene(tmp_path, n_scans=3)
    ds = read_detections(tmp_path / "fixes.csv", sensors=[RADAR])
    x, y = ds.detections.x[:3], ds.detections.y[:3]
    table = pa.Table.from_arrays(
        [pa.array(np.asarray(v, dtype=f.type.to_pandas_dtype())) if f.type != pa.string() else
         pa.array(v, pa.string()) for f, v in zip(TRACK_SCHEMA, _track_columns(x, y))], schema=TRACK_SCHEMA)
    run = SimpleNamespace(table=table, tracker="gnn", scores=None, management=None, detection=None, targets=None)
    write_track_outputs(tmp_path / "tr", ds, run, {}, 100.0, "parquet", lagged=run, lag=2)
    for name in ("tracks.parquet", "tracks_lag2.parquet"):
        got = pq.read_table(tmp_path / "tr" / name)
        assert got.column_names == [*TRACK_SCHEMA.names[:8], "lat", "lon", *TRACK_SCHEMA.names[8:]]
        back_x, back_y, _ = SITE.to_local(got.column("lat").to_numpy(), got.column("lon").to_numpy())
        np.testing.assert_allclose(np.column_stack([back_x, back_y]), np.column_stack([x, y]), atol=1e-6)
    plain = pq.read_table(tmp_path / "tr" / "tracks.parquet")
    assert plain.drop_columns(["lat", "lon"]).equals(table)  # the tracker's columns unchanged
    assert "origin lat 51.470000 deg, lon -0.450000 deg, alt 0 m" in _png_title(ds, table)


def _track_columns(x, y):
    n = x.size
    return [np.arange(1, n + 1), np.arange(2.0, 2.0 * n + 1, 2.0), np.zeros(n), ["confirmed"] * n,
            x, np.zeros(n), y, np.zeros(n), *([np.ones(n)] * 10), np.zeros(n), np.arange(n)]


def _png_title(ds, table) -> str:
    """The title `track_png` sets, caught on its way to matplotlib."""
    from matplotlib.axes import Axes

    titles = []
    original = Axes.set_title
    Axes.set_title = lambda self, label, *a, **k: titles.append(label) or original(self, label, *a, **k)
    try:
        track_png(ds, table, "gnn")
    finally:
        Axes.set_title = original
    return titles[0]


def test_track_writes_lat_lon_that_return_to_the_reports(tmp_path, monkeypatch):
    _scene(tmp_path)
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    done = runner.invoke(app, ["import-detections", "fixes.csv", "--out", "ds", "--truth", "truth.csv",
                               "--sensor", "lat=51.47", "--sensor", "lon=-0.45", "--sensor", "scan_period_s=2",
                               "--sensor", f"sigma_range_m={SIGMA_M}"])
    assert done.exit_code == 0, done.output
    assert "geodetic origin: lat 51.470000 deg, lon -0.450000 deg" in done.output
    done = runner.invoke(app, ["track", "ds", "--tracker", "gnn", "--out", "tr", "--quiet", "--format", "csv",
                               "--lag", "1"])
    assert done.exit_code == 0, done.output
    for name in ("tracks.csv", "tracks_lag1.csv"):
        table = pacsv.read_csv(tmp_path / "tr" / name)
        assert table.column_names[table.column_names.index("vy") + 1:][:2] == ["lat", "lon"]
        confirmed = table.filter(table.column("status").to_numpy(zero_copy_only=False) == "confirmed")
        assert confirmed.num_rows >= 5
        lat, lon = (confirmed.column(c).to_numpy() for c in ("lat", "lon"))
        x, y = SITE.to_local(lat, lon)[:2]  # the table's lat/lon place the track where its x, y say
        np.testing.assert_allclose(x, confirmed.column("x").to_numpy(), atol=1e-3)
        np.testing.assert_allclose(y, confirmed.column("y").to_numpy(), atol=1e-3)
        # and within the noise of the imported reports of the target at those times
        reports = pacsv.read_csv(tmp_path / "fixes.csv").to_pandas().query("target_id == 'A1'").set_index("time")
        at = confirmed.column("time").to_numpy()
        _, _, miss = WGS84.inv(lon, lat, reports.loc[at, "lon"].to_numpy(), reports.loc[at, "lat"].to_numpy())
        assert np.all(miss < 5 * SIGMA_M), miss


def test_the_origin_defaults_to_the_mean_of_the_reports_and_an_alt_column_is_dropped_with_a_warning(tmp_path):
    _scene(tmp_path, alt=True)
    with pytest.warns(BoundWarning, match=r"column 'alt': the altitudes of 24 row\(s\) .* dropped") as caught:
        ds = read_detections(tmp_path / "fixes.csv", sensors=[{"kind": "position", "scan_period_s": 2.0}])
    assert len([w for w in caught if w.category is BoundWarning]) == 1
    table = pacsv.read_csv(tmp_path / "fixes.csv")
    lat, lon = (table.column(c).to_numpy() for c in ("lat", "lon"))
    o = ds.geodetic_origin
    assert (o.lat_deg, o.lon_deg, o.alt_m) == (round(lat.mean(), 4), round(lon.mean(), 4), 0.0)
    assert o.source == "the mean of the reports' lat/lon"
    with pytest.warns(BoundWarning, match="column 'alt'"):
        given = read_detections(tmp_path / "fixes.csv", sensors=[{"kind": "position", "scan_period_s": 2.0}],
                                origin="51.47,-0.45,0")
    assert given.geodetic_origin.source == "the --origin option"


def test_export_writes_lat_lon_and_reads_back(tmp_path):
    _scene(tmp_path)
    ds = read_detections(tmp_path / "fixes.csv", sensors=[RADAR], truth=tmp_path / "truth.csv")
    export_detections(ds, tmp_path / "out.parquet", truth=tmp_path / "out_truth.parquet")
    table = pq.read_table(tmp_path / "out.parquet")
    assert {"lat", "lon", "x", "y"} <= set(table.column_names)
    source = pacsv.read_csv(tmp_path / "fixes.csv")
    np.testing.assert_allclose(np.sort(table.column("lat").to_numpy()), np.sort(source.column("lat").to_numpy()),
                               atol=1e-9)
    assert {"lat", "lon"} <= set(pq.read_table(tmp_path / "out_truth.parquet").column_names)
    plain = generate(preset("T1"), seed=1)
    export_detections(plain, tmp_path / "plain.csv")
    assert "lat" not in pacsv.read_csv(tmp_path / "plain.csv").column_names


# ----------------------------------------------------------------------------- --region

def test_a_box_in_metres_drops_the_reports_outside_with_one_warning_and_records_the_count(tmp_path):
    xy = _scene(tmp_path)
    outside = int(np.sum(~((xy[:, 0] >= -8000) & (xy[:, 0] <= 0) & (xy[:, 1] >= 10000) & (xy[:, 1] <= 16000))))
    assert 0 < outside < len(xy)
    with pytest.warns(BoundWarning, match=rf"--region -8000,10000,0,16000: {outside} of {len(xy)} report\(s\)"):
        _, ds = import_detections(tmp_path / "fixes.csv", tmp_path / "ds", sensors=[RADAR],
                                  region="-8000,10000,0,16000")
    assert ds.detections.scan.size == len(xy) - outside
    assert read_dataset(tmp_path / "ds").dropped_rows == {"--region": outside}


def test_a_geodetic_box_and_a_polygon_file_keep_the_same_reports(tmp_path):
    _scene(tmp_path)
    lat, lon = SITE.on_surface(np.array([-8000.0, 0.0]), np.array([10000.0, 16000.0]))
    (tmp_path / "area.csv").write_text(
        "lat,lon\n" + "\n".join(f"{a:.9f},{b:.9f}" for a, b in ((lat[0], lon[0]), (lat[0], lon[1]),
                                                                 (lat[1], lon[1]), (lat[1], lon[0]))) + "\n")
    (tmp_path / "area_xy.csv").write_text("x,y\n-8000,10000\n0,10000\n0,16000\n-8000,16000\n-8000,10000\n")
    kept = []
    for region in (f"lat:{lat[0]:.9f},{lat[1]:.9f},lon:{lon[0]:.9f},{lon[1]:.9f}", str(tmp_path / "area.csv"),
                   tmp_path / "area_xy.csv"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BoundWarning)
            ds = read_detections(tmp_path / "fixes.csv", sensors=[RADAR], region=region)
        kept.append(ds.detections.scan.size)
        assert ds.dropped_rows["--region"] > 0
    assert len(set(kept)) == 1  # the box's edges are (almost) meridians and parallels: the same reports


def test_what_is_inferred_comes_from_the_reports_a_region_keeps(tmp_path):
    """A report far away (another continent) outside the region moves neither the range limits nor the
    origin chosen from the reports' mean: both are the kept reports'. Without --region the origin stays the
    mean of every report."""
    _scene(tmp_path)
    lines = (tmp_path / "fixes.csv").read_text().splitlines()
    (tmp_path / "fixes.csv").write_text("\n".join([*lines, "24.0,50.3,54.8,"]) + "\n")  # data row 25
    position = [{"kind": "position", "scan_period_s": 2.0, "sigma_position_m": SIGMA_M}]
    with pytest.warns(BoundWarning, match=r"1 of 25 report\(s\) outside the region dropped"):
        ds = read_detections(tmp_path / "fixes.csv", sensors=position, region="lat:51,52,lon:-1,0")
    table = pacsv.read_csv(tmp_path / "fixes.csv")
    lat, lon = (table.column(c).to_numpy() for c in ("lat", "lon"))
    o = ds.geodetic_origin
    assert (o.lat_deg, o.lon_deg) == mean_position(lat[:-1], lon[:-1]) != mean_position(lat, lon)
    far = float(np.hypot(ds.detections.x, ds.detections.y).max())
    radar = ds.scenario.sensors[0]
    assert radar.max_range_m == max(Sensor().max_range_m, math.ceil(far)) < 100e3
    every = read_detections(tmp_path / "fixes.csv", sensors=position)
    assert (every.geodetic_origin.lat_deg, every.geodetic_origin.lon_deg) == mean_position(lat, lon)
    assert every.scenario.sensors[0].max_range_m > 1e6


def test_a_sweep_sensors_period_and_offset_come_from_the_rows_a_region_keeps(tmp_path):
    """A stray row at 0.7 s outside the region would set the inferred offset (and then every sweep at 2 k s
    would be 1.3 s from the grid); the kept rows alone give period 2 s, offset 0."""
    rows = ["time,x,y", "0.7,90000,0"] + [f"{2 * k},{100 * k},12000" for k in range(1, 8)]
    (tmp_path / "xy.csv").write_text("\n".join(rows) + "\n")
    with pytest.warns(BoundWarning, match=r"1 of 8 report\(s\)"):
        ds = read_detections(tmp_path / "xy.csv", region="-1000,0,1000,20000")
    radar = ds.scenario.sensors[0]
    assert (radar.scan_period_s, radar.scan_offset_s, ds.detections.scan.size) == (2.0, 0.0, 7)
    assert radar.max_range_m == Sensor().max_range_m


def test_the_time_origin_of_dates_comes_from_the_reports_a_region_keeps(tmp_path):
    rows = ["time,x,y", "2016-01-12 12:00:03,90000,0", "2016-01-12 13:02:11.2,100,12000",
            "2016-01-12 13:02:25.5,140,12010"]
    (tmp_path / "dates.csv").write_text("\n".join(rows) + "\n")
    ais = [{"kind": "position", "reports": True, "scan_period_s": 10.0}]
    with pytest.warns(BoundWarning, match=r"1 of 3 report\(s\)"):
        ds = read_detections(tmp_path / "dates.csv", sensors=ais, region="-1000,0,1000,20000")
    assert ds.time_origin_utc == "2016-01-12T13:02:10Z" and ds.n_scans == 2


def test_a_region_that_excludes_everything_names_the_option_and_the_extent(tmp_path):
    _scene(tmp_path)
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / "keep.txt").write_text("old")
    with pytest.raises(ConfigError, match=r"--region 50000,50000,60000,60000: excludes all 24 reports, which span "
                                          r"x -?\d+\.\d+\.\.-?\d+\.\d+ km, y .* \(lat .* lon .* deg\)"):
        import_detections(tmp_path / "fixes.csv", tmp_path / "ds", overwrite=True, sensors=[RADAR],
                          region="50000,50000,60000,60000")
    assert [p.name for p in (tmp_path / "ds").iterdir()] == ["keep.txt"]  # a refused import writes nothing


@pytest.mark.parametrize(("region", "error", "fragment"), [
    ("1,2,3", ConfigError, "3 numbers; a box has 4"),
    ("lat:51,52", ConfigError, "unreadable"),
    ("0,0,-1,5", ConfigError, "an empty box"),
    ("a,b,c,d", ConfigError, "not numbers"),
    ("lat:52,51,lon:0,1", ConfigError, "LAT0 52 must be below LAT1 51"),
    ("lat:51,95,lon:0,1", ConfigError, "lat 95.0 is outside [-90, 90]"),
    ("missing.csv", DatasetError, "--region missing.csv: no such file"),
])
def test_a_malformed_region_is_refused(tmp_path, region, error, fragment):
    _scene(tmp_path, n_scans=2)
    with pytest.raises(error) as err:
        read_detections(tmp_path / "fixes.csv", sensors=[RADAR], region=str(tmp_path / region)
                        if region.endswith(".csv") else region)
    assert fragment in str(err.value).replace(str(tmp_path) + "/", "")


def test_a_concave_polygon_keeps_its_inside_and_its_edges():
    vx, vy = np.array([0.0, 4.0, 4.0, 2.0, 0.0]), np.array([0.0, 0.0, 4.0, 1.0, 4.0])  # a notch from the top
    x = np.array([1.0, 2.0, 2.0, 3.8, 4.0, 2.0, 5.0, 0.0])
    y = np.array([1.0, 0.5, 3.0, 3.0, 2.0, 0.0, 1.0, 4.0])
    assert in_polygon(x, y, vx, vy).tolist() == [True, True, False, True, True, True, False, True]


def test_a_polygon_of_two_vertices_is_refused(tmp_path):
    _scene(tmp_path, n_scans=2)
    (tmp_path / "line.csv").write_text("x,y\n0,0\n100,100\n0,0\n")
    with pytest.raises(DatasetError, match=r"line.csv: a polygon needs at least 3 distinct vertices, the file "
                                           r"has 2"):
        read_detections(tmp_path / "fixes.csv", sensors=[RADAR], region=tmp_path / "line.csv")


def test_a_geodetic_region_on_data_without_a_geodetic_origin_is_refused(tmp_path):
    (tmp_path / "xy.csv").write_text("time,x,y\n2,100,12000\n4,120,12010\n")
    with pytest.raises(ConfigError, match=r"--region lat:51,52,lon:0,1: a region in latitude and longitude needs "
                                          r"geodetic data"):
        read_detections(tmp_path / "xy.csv", region="lat:51,52,lon:0,1")


# ----------------------------------------------------------------------------- bad input

def test_a_latitude_out_of_range_is_named_by_file_row_and_column(tmp_path):
    _scene(tmp_path, n_scans=5)
    lines = (tmp_path / "fixes.csv").read_text().splitlines()
    cells = lines[7].split(",")
    lines[7] = ",".join([cells[0], "95", *cells[2:]])  # data row 7
    (tmp_path / "fixes.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(DatasetError, match=r"fixes.csv: data row 7 \(line 8\), column 'lat': lat 95.0 is outside "
                                           r"\[-90, 90\]"):
        read_detections(tmp_path / "fixes.csv", sensors=[RADAR])


def test_a_longitude_that_is_no_number_is_named(tmp_path):
    (tmp_path / "p.csv").write_text("time,lat,lon\n2,51.5,-0.4\n4,51.5,west\n")
    with pytest.raises(DatasetError, match=r"p.csv: data row 2 \(line 3\), column 'lon': 'west', not a number"):
        read_detections(tmp_path / "p.csv")


def test_lat_without_lon_and_half_a_sensor_site_are_refused(tmp_path):
    (tmp_path / "p.csv").write_text("time,lat\n2,51.5\n")
    with pytest.raises(DatasetError, match=r"required column\(s\) 'lon' missing"):
        read_detections(tmp_path / "p.csv")
    _scene(tmp_path, n_scans=2)
    with pytest.raises(ConfigError, match=r"sensor 0 \('radar'\): field\(s\) lat given without lon"):
        read_detections(tmp_path / "fixes.csv", sensors=[{"lat": 51.0}])
    with pytest.raises(ConfigError, match=r"given both as lat/lon and as x_m/y_m"):
        read_detections(tmp_path / "fixes.csv", sensors=[{"lat": 51.0, "lon": 0.0, "x_m": 5.0}])


def test_a_malformed_origin_is_one_error_line_and_writes_nothing(tmp_path, monkeypatch):
    _scene(tmp_path, n_scans=2)
    monkeypatch.chdir(tmp_path)
    for value, fragment in (("51.5", "give --origin LAT,LON"), ("51.5,400,0", "lon 400.0 is outside"),
                            ("95,0", "lat 95.0 is outside")):
        done = CliRunner().invoke(app, ["import-detections", "fixes.csv", "--out", "ds", "--origin", value])
        assert isinstance(done.exception, ConfigError), done.output  # the CLI prints it as one error: line
        assert str(done.exception).startswith(f"--origin '{value}': ") and fragment in str(done.exception)
        assert not (tmp_path / "ds").exists()


def test_a_dataset_without_an_origin_reads_and_a_bad_recorded_origin_is_refused(tmp_path):
    plain = generate(preset("T1"), seed=1)
    write_dataset(plain, tmp_path / "plain")
    meta = json.loads((tmp_path / "plain" / MANIFEST).read_text())
    assert "geodetic_origin" not in meta and "dropped_rows" not in meta
    assert read_dataset(tmp_path / "plain").geodetic_origin is None
    meta["geodetic_origin"] = {"lat_deg": 99.0, "lon_deg": 0.0, "alt_m": 0.0, "source": "edited"}
    meta["manifest_sha256"] = manifest_seal(meta)
    (tmp_path / "plain" / MANIFEST).write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match=r"field 'geodetic_origin': geodetic origin lat: lat 99.0 is outside"):
        read_dataset(tmp_path / "plain")
    meta["format_version"] = 3
    del meta["manifest_sha256"]
    (tmp_path / "plain" / MANIFEST).write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match=r"field 'geodetic_origin' is written since format version 4"):
        read_dataset(tmp_path / "plain")
