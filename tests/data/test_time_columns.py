"""Dates and times in an imported file (ISO 8601 text, Arrow/Parquet timestamps): seconds after an origin."""

from __future__ import annotations

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from nnda.data.dataset import read_dataset, write_dataset
from nnda.data.detections_import import read_detections
from nnda.data.time_columns import absolute_ns, default_origin_ns, utc_text
from nnda.errors import DatasetError

REPORTS = [{"kind": "position", "reports": True, "scan_period_s": 10.0}]


def write(path, text: str):
    path.write_text(text)
    return path


def where(row: int) -> str:
    return f"row {row + 1}"


def test_iso_text_in_every_spelling_is_utc_nanoseconds():
    col = pa.chunked_array([["2016-01-12 13:02:11.218", "2016-01-12T13:02:11Z", " 2016-01-12T14:02:11.5+01:00",
                             "2016-01-12T13:02:11.123456789", "2016-01-12"]])
    got = absolute_ns(col, where)
    base = np.datetime64("2016-01-12T13:02:11", "ns").astype(np.int64)
    assert (got - base).tolist() == [218_000_000, 0, 500_000_000, 123_456_789, -(13 * 3600 + 131) * 10**9]


def test_a_text_that_is_not_a_time_is_named_with_its_row_and_value(tmp_path):
    path = write(tmp_path / "r.csv", "t,x,y\n2016-01-12 13:02:11,1,2000\n2016-01-12 13:02:12,1,2000\n"
                                     "2016-13-12 13:02:13,1,2000\n2016-01-12 13:02:14,1,2000\n")
    with pytest.raises(DatasetError, match=r"r.csv: data row 3 \(line 4\), column 't': '2016-13-12 13:02:13' is "
                                           r"not a time \(ISO 8601"):
        read_detections(path, sensors=REPORTS, columns={"time": "t"})
    empty = write(tmp_path / "e.csv", "time,x,y\n2016-01-12T13:02:11Z,1,2000\n,1,2000\n")
    with pytest.raises(DatasetError, match=r"data row 2 \(line 3\), column 'time': an empty cell \(a time"):
        read_detections(empty, sensors=REPORTS)


def test_the_origin_starts_the_window_of_the_first_report_and_is_recorded(tmp_path):
    path = write(tmp_path / "r.csv", "time,x,y,id\n2016-01-12 13:02:11.218,10,2000,7\n"
                                     "2016-01-12T13:02:20Z,20,2000,7\n2016-01-12 13:02:31.5,30,2000,8\n")
    ds = read_detections(path, sensors=REPORTS, columns={"target_id": "id"})
    assert ds.time_origin_utc == "2016-01-12T13:02:10Z"
    assert ds.detections.time.tolist() == [1.218, 10.0, 21.5]  # exact: the difference is taken in ns
    assert ds.detections.scan.tolist() == [1, 1, 3]
    write_dataset(ds, tmp_path / "ds")
    meta = json.loads((tmp_path / "ds" / "scenario.json").read_text())
    assert meta["time_origin_utc"] == "2016-01-12T13:02:10Z"
    assert read_dataset(tmp_path / "ds").time_origin_utc == "2016-01-12T13:02:10Z"


def test_numbers_keep_their_origin_and_write_no_utc_origin(tmp_path):
    path = write(tmp_path / "r.csv", "time,x,y\n0.5,10,2000\n")
    ds = read_detections(path, sensors=REPORTS)
    assert ds.time_origin_utc is None and ds.detections.time.tolist() == [0.5]
    write_dataset(ds, tmp_path / "ds")
    assert "time_origin_utc" not in (tmp_path / "ds" / "scenario.json").read_text()


def test_a_sweep_sensor_starts_one_period_before_its_first_time(tmp_path):
    table = pa.table({"time": pa.array(np.array(["2020-05-01T00:00:03", "2020-05-01T00:00:05"], "datetime64[ms]")),
                      "range": [12000.0, 12100.0], "azimuth": [0.5, 0.51]})
    pq.write_table(table, tmp_path / "p.parquet")
    ds = read_detections(tmp_path / "p.parquet", sensors=[{"scan_period_s": 2.0}])
    assert ds.time_origin_utc == "2020-05-01T00:00:01Z"
    assert ds.scan_time.tolist() == [2.0, 4.0] and ds.detections.time.tolist() == [2.0, 4.0]


def test_a_zoned_parquet_timestamp_and_a_truth_file_of_the_same_clock(tmp_path):
    stamps = pa.array(np.array(["2016-01-12T13:02:11", "2016-01-12T13:02:25"], "datetime64[us]")).cast(
        pa.timestamp("us", tz="Europe/London"))
    pq.write_table(pa.table({"time": stamps, "x": [10.0, 20.0], "y": [2000.0, 2000.0], "target_id": ["a", "a"]}),
                   tmp_path / "d.parquet")
    truth = write(tmp_path / "t.csv", "time,target_id,x,y,vx,vy\n2016-01-12T13:02:20Z,a,10,2000,1,0\n")
    ds = read_detections(tmp_path / "d.parquet", sensors=REPORTS, truth=truth)
    assert ds.detections.time.tolist() == [1.0, 15.0] and ds.truth.time.tolist() == [10.0]
    numbers = write(tmp_path / "n.csv", "time,target_id,x,y,vx,vy\n10,a,10,2000,1,0\n")
    with pytest.raises(DatasetError, match=r"n.csv: data row 1 \(line 2\), column 'time': the truth file's times are "
                                           r"seconds \(numbers\) but the detections' are absolute times"):
        read_detections(tmp_path / "d.parquet", sensors=REPORTS, truth=numbers)


def test_origin_rule_and_utc_text():
    t0 = int(np.datetime64("2016-01-12T13:02:11.218", "ns").astype(np.int64))
    assert utc_text(default_origin_ns([t0], [10.0], [True])) == "2016-01-12T13:02:10Z"
    assert utc_text(default_origin_ns([t0 - 1_218_000_000], [10.0], [True])) == "2016-01-12T13:02:00Z"  # on an end
    assert utc_text(default_origin_ns([t0, None], [2.0, 1.0], [False, True])) == "2016-01-12T13:02:09.218Z"
