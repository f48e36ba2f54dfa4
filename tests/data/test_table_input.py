"""`read_detections` given a table in memory (a pyarrow Table or a pandas DataFrame) instead of a file."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest

from nnda.data.detections_import import read_detections
from nnda.errors import ConfigError, DatasetError

POSITION = [{"kind": "position", "scan_period_s": 1.0}]


def test_a_pyarrow_table_reads_as_its_file_would(tmp_path):
    table = pa.table({"time": [1.0, 2.0], "x": [100.0, 110.0], "y": [2000.0, 2000.0], "target_id": ["a", "a"]})
    truth = pa.table({"time": [1.0], "target_id": ["a"], "x": [100.0], "y": [2000.0], "vx": [10.0], "vy": [0.0]})
    ds = read_detections(table, sensors=POSITION, truth=truth)
    assert ds.scenario.name == "imported" and "from the table" in ds.scenario.description
    assert ds.detections.x.tolist() == [100.0, 110.0] and ds.truth.time.tolist() == [1.0]


def test_a_pandas_dataframe_with_timestamps():
    pd = pytest.importorskip("pandas")
    frame = pd.DataFrame({"Time": pd.to_datetime(["2016-01-12 13:02:11.218", "2016-01-12 13:02:15.000"]),
                          "x": [1.0, 2.0], "y": [2000.0, 2100.0], "MMSI": [235070762, 235070762]},
                         index=[10, 11])
    ds = read_detections(frame, sensors=[{"kind": "position", "reports": True, "scan_period_s": 10}],
                         columns={"time": "Time", "target_id": "MMSI"})
    assert ds.time_origin_utc == "2016-01-12T13:02:10Z"
    np.testing.assert_array_equal(ds.detections.time, [1.218, 5.0])
    assert [t.name for t in ds.scenario.targets] == ["235070762"]


def test_errors_name_the_table_row_and_column():
    bad = pa.table({"time": [1.0, 2.0], "x": [1.0, float("nan")], "y": [2000.0, 2000.0]})
    with pytest.raises(DatasetError, match=r"^the table: row 2 \(1-based\), column 'x': nan"):
        read_detections(bad, sensors=POSITION)
    truth = pa.table({"time": [1.0], "target_id": [None], "x": [1.0], "y": [1.0], "vx": [0.0], "vy": [0.0]},
                     schema=pa.schema([("time", pa.float64()), ("target_id", pa.string()), ("x", pa.float64()),
                                       ("y", pa.float64()), ("vx", pa.float64()), ("vy", pa.float64())]))
    with pytest.raises(DatasetError, match=r"^the truth table: row 1 \(1-based\), column 'target_id': no target id"):
        read_detections(bad.slice(0, 1), sensors=POSITION, truth=truth)
    with pytest.raises(ConfigError, match="int is not a file path, a pyarrow Table or a pandas DataFrame"):
        read_detections(42)
