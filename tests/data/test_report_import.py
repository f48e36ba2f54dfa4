"""Asynchronous report sensors (``Sensor.reports``): import into windows, own times kept, checks, round trips."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from nnda.app.cli import app
from nnda.data.dataset import check_dataset, read_dataset, write_dataset
from nnda.data.detections_import import export_detections, read_detections, sensor_specs
from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.data.scenario import Sensor
from nnda.errors import ConfigError, DatasetError

REPORTS = [{"kind": "position", "reports": True, "scan_period_s": 1.0}]


def write(path, text: str):
    path.write_text(text)
    return path


@pytest.fixture
def reports_csv(tmp_path):
    """Six reports of two ships and a clutter row: two of ship A in window 1, one on a window's end."""
    return write(tmp_path / "r.csv", "time,x,y,target_id\n0.5,1000,2000,A\n1.0,1100,2000,B\n1.0,1200,2000,A\n"
                                     "2.0,1300,2000,A\n2.7,1400,2000,\n3.1,1500,2000,B\n")


def test_each_report_keeps_its_time_in_the_window_that_holds_it(reports_csv):
    ds = read_detections(reports_csv, sensors=REPORTS)
    d = ds.detections
    assert d.scan.tolist() == [1, 1, 1, 2, 3, 4]  # (0, 1], (1, 2], (2, 3], (3, 4]: a time on an end stays in
    assert d.time.tolist() == [0.5, 1.0, 1.0, 2.0, 2.7, 3.1]
    assert [t.name for t in ds.scenario.targets] == ["A", "B"]
    assert d.target_id.tolist() == [0, 1, 0, 0, -1, 1]  # two reports of A in scan 1: separate reports
    scans = list(ds.scans())
    assert [s.time for s in scans] == [1.0, 2.0, 3.0, 4.0]
    assert scans[0].times.tolist() == [0.5, 1.0, 1.0]
    assert scans[0].measurements[:, 0].tolist() == [1000, 1100, 1200]  # equal times keep the file's order


def test_rows_of_a_report_scan_are_in_time_order_and_never_rounded(tmp_path):
    rng = np.random.default_rng(4)
    t = np.sort(rng.uniform(0.01, 30.0, 400))
    t[::7] = np.round(t[::7], 1)  # many on a window's end (0.1 s windows: k 0.1 computed as the schedule does)
    t = np.sort(t)
    lines = [f"{v!r},{1000 + i},{-500 - i % 50}" for i, v in enumerate(t.tolist())]
    path = write(tmp_path / "r.csv", "time,x,y\n" + "\n".join(lines) + "\n")
    ds = read_detections(path, sensors=[{"kind": "position", "reports": True, "scan_period_s": 0.1}])
    d = ds.detections
    np.testing.assert_array_equal(d.time, t)  # bit for bit
    end = ds.scan_time[d.scan - 1]
    start = np.concatenate([[0.0], ds.scan_time])[d.scan - 1]
    assert np.all((start < d.time) & (d.time <= end))
    for s in ds.scans():
        assert s.times is not None and np.all(np.diff(s.times) >= 0)


def test_an_offset_in_the_file_clock_and_a_sweep_sensor_beside(tmp_path):
    path = write(tmp_path / "r.csv", "time,sensor,x,y\n100.5,ais,10,2000\n101.0,radar,20,3000\n101.75,ais,30,2000\n"
                                     "103.0,radar,40,3000\n")
    ds = read_detections(path, time_origin=100.0, sensors=[
        {"name": "ais", "kind": "position", "reports": True, "scan_period_s": 2.0, "scan_offset_s": 101.0},
        {"name": "radar", "kind": "position", "scan_period_s": 2.0}])
    ais, radar = ds.scenario.sensors
    assert (ais.scan_offset_s, ais.reports, radar.reports, radar.scan_offset_s) == (1.0, True, False, 1.0)
    by_scan = {s.index: s for s in ds.scans()}
    got = [(s.sensor, s.time, None if s.times is None else s.times.tolist()) for s in by_scan.values()
           if s.measurements.size]
    # windows end at 1 and 3 s, each before the radar's sweep at its end
    assert got == [(0, 1.0, [0.5]), (1, 1.0, None), (0, 3.0, [1.75]), (1, 3.0, None)]
    # windows ending between the radar's sweeps would hold one: refused at import, naming both sensors
    with pytest.raises(ConfigError, match=r"(?s)r.csv: the sensors: invalid set of sensors.*sensor 1 \('radar'\) has "
                                          r"a sweep at t = 1 s, inside the window \(-0.5, 1.5\] s of report sensor 0"):
        read_detections(path, time_origin=100.0, sensors=[
            {"name": "ais", "kind": "position", "reports": True, "scan_period_s": 2.0, "scan_offset_s": 101.5},
            {"name": "radar", "kind": "position", "scan_period_s": 1.0}])


def test_a_report_sensor_needs_its_window(reports_csv):
    with pytest.raises(ConfigError, match=r"sensor 0 \('radar'\): reports=true needs scan_period_s"):
        read_detections(reports_csv, sensors=[{"kind": "position", "reports": True}])


def test_a_report_time_may_repeat_but_not_go_back(tmp_path):
    path = write(tmp_path / "r.csv", "time,x,y\n1.0,10,2000\n1.0,20,2000\n0.9,30,2000\n")
    with pytest.raises(DatasetError, match=r"data row 3 \(line 4\), column 'time': time 0.9 s goes back from 1.0 s "
                                           r"\(data row 2\) for report sensor 'radar'"):
        read_detections(path, sensors=REPORTS)


def test_truth_lies_at_the_windows_ends(tmp_path, reports_csv):
    truth = write(tmp_path / "t.csv", "time,target_id,x,y,vx,vy\n1,A,1000,2000,100,0\n2,A,1100,2000,100,0\n"
                                      "1,B,1100,2000,0,0\n4,B,1500,2000,0,0\n")
    ds = read_detections(reports_csv, sensors=REPORTS, truth=truth)
    assert ds.truth.time.tolist() == [1.0, 1.0, 2.0, 4.0]
    assert ds.truth.detected.tolist() == [True, True, True, True]
    bad = write(tmp_path / "bad.csv", "time,target_id,x,y,vx,vy\n1.5,A,1000,2000,100,0\n")
    with pytest.raises(DatasetError, match="is no scan's time"):
        read_detections(reports_csv, sensors=REPORTS, truth=bad)


def test_written_read_and_exported_with_the_reports_own_times(tmp_path, reports_csv):
    ds = read_detections(reports_csv, sensors=REPORTS)
    back = read_dataset(write_dataset(ds, tmp_path / "ds"))
    np.testing.assert_array_equal(back.detections.time, ds.detections.time)
    assert back.scenario.sensors[0].reports
    meta = json.loads((tmp_path / "ds" / "scenario.json").read_text())
    assert meta["scenario"]["sensors"][0]["reports"] is True
    export_detections(back, tmp_path / "out.csv")
    again = read_detections(tmp_path / "out.csv", sensors=sensor_specs(back.scenario))
    np.testing.assert_array_equal(again.detections.time, ds.detections.time)
    np.testing.assert_array_equal(again.detections.scan, ds.detections.scan)


def test_a_sweep_sensor_dumps_as_before_and_its_scans_have_no_times(tmp_path):
    assert "reports" not in Sensor().model_dump() and "reports" not in Sensor().model_dump(mode="json")
    ds = generate(preset("S1"), seed=1)
    write_dataset(ds, tmp_path / "ds")
    assert '"reports"' not in (tmp_path / "ds" / "scenario.json").read_text()
    assert next(iter(ds.scans())).times is None


def test_the_check_keeps_a_report_in_its_window_and_in_time_order(reports_csv):
    ds = read_detections(reports_csv, sensors=REPORTS)
    d = ds.detections
    early = replace(ds, detections=replace(d, time=np.where(np.arange(d.time.size) == 3, 0.9, d.time)))
    with pytest.raises(DatasetError, match=r"row 3, but scan 2 is in \(1.0, 2.0\] s, its report window"):
        check_dataset(early, "det", "truth")
    swapped = replace(ds, detections=replace(d, time=d.time[[1, 0, 2, 3, 4, 5]]))
    with pytest.raises(DatasetError, match="goes back from 1.0 s to 0.5 s at row 1 within report scan 1"):
        check_dataset(swapped, "det", "truth")


def test_the_command_takes_reports_true(tmp_path, reports_csv, monkeypatch):
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    done = runner.invoke(app, ["import-detections", str(reports_csv), "--out", "ds", "--sensor", "kind=position",
                               "--sensor", "reports=true", "--sensor", "scan_period_s=1"])
    assert done.exit_code == 0, done.output
    assert read_dataset(tmp_path / "ds").detections.time.tolist() == [0.5, 1.0, 1.0, 2.0, 2.7, 3.1]
    bad = runner.invoke(app, ["import-detections", str(reports_csv), "--out", "ds2", "--sensor", "reports=maybe"])
    assert isinstance(bad.exception, ConfigError) and "reports must be true or false" in str(bad.exception)
