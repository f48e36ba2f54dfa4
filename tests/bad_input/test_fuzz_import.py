"""Fuzzing the detections importer (`nnda.data.detections_import.read_detections`): random bytes, and CSV files in
random dialects (delimiters, quoting, decimal marks, byte-order marks, line endings, encodings) with random column
sets, orders and repeats and random cells (empty, NaN, inf, huge, text, stray bytes), read with matching or other
options. Either the import succeeds, keeps every row and its result passes nnda's dataset checks, or it raises an
nnda error; any other exception fails. Derandomized and bounded (a few seconds each)."""

from __future__ import annotations

import codecs
import csv
import io
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from nnda.data.dataset import Dataset, check_dataset
from nnda.data.detections_import import read_detections
from nnda.errors import NndaError

#: numpy's overflow and invalid-value warnings are failures too: they mean a number went wrong unseen
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")
FUZZ = settings(max_examples=300, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

DELIMITERS = [",", ";", "\t", "|"]
LINE_ENDINGS = ["\n", "\r\n", "\r"]
ENCODINGS = ["utf-8", "latin-1", "cp1252", "utf-16", "utf-8-sig"]
#: header names: nnda's (each may repeat), other names, near misses
NAMES = ["time", "range", "azimuth", "x", "y", "sensor", "target_id", "note", "", "Time", " time", "range "]
#: a cell replacing a good one: empty, non-finite, huge, tiny, negative, text, a decimal comma, quotes, a newline
ODD_CELLS = ["", "nan", "NaN", "inf", "-inf", "1e308", "1e309", "-1e308", "1e-320", "0", "-0", "-1", "1e15",
             "99999999999999999999999", "abc", "true", "2020-01-01", "12:00:00", "1,5", "1.5.2", "1_000", " 2 ",
             '"', '""', "a\nb", "\u00e9", "\u20ac", "\U0001f600", "\x00", "-", "+", ".", ",", "\u00b2", "--5",
             "\u0663", "0x1f", "1e5", "-0.0"]
#: column sets an import reads, in some order
GOOD_NAMES = [["time", "range", "azimuth"], ["time", "x", "y", "target_id"], ["sensor", "time", "range", "azimuth",
              "target_id"], ["time", "x", "y", "range", "azimuth", "sensor", "target_id", "note"]]
#: sensor setups (and the sensor cells they know): one radar, a given period, a position sensor, two, a bad period
SENSORS = [(None, ["radar", "0"]), ([{"scan_period_s": 2.0}], ["radar"]),
           ([{"scan_period_s": 2.0, "kind": "position"}], ["0"]),
           ([{"name": "a", "scan_period_s": 2.0}, {"name": "b", "kind": "position"}], ["a", "b", "1"]),
           ([{"scan_period_s": 1e-7}], ["radar"])]


def _good_cell(name: str, row: int, sensors: list[str], labels: list[str]) -> str:
    """A plausible value of column ``name`` in data row ``row`` (two detections a scan, 2-s scans)."""
    return {"time": f"{2 * (row // 2 + 1)}", "range": f"{12000 + 137.5 * row}", "azimuth": f"{0.25 + 0.5 * row}",
            "x": f"{1000.5 + 10 * row}", "y": f"{12000.25 - 7 * row}", "sensor": sensors[row % len(sensors)],
            "target_id": labels[row % len(labels)]}.get(name, f"n{row}")


def _quoted(cell: str, delimiter: str, quoting: str) -> str:
    if quoting == "all" or (quoting == "minimal" and any(c in cell for c in f'{delimiter}"\r\n')):
        return '"' + cell.replace('"', '""') + '"'
    return cell


def _mostly(value, *others):
    """A strategy: ``value`` four times in five, else one of ``others``."""
    return st.sampled_from([value] * 4 * max(len(others), 1) + list(others))


def _truth_cell(name: str, row: int) -> str:
    """A plausible truth value of column ``name`` in row ``row``: target "7" at 2, 4, ... s."""
    return {"time": f"{2 * (row + 1)}", "target_id": "7", "x": f"{1000.5 + 10 * row}", "y": "12000",
            "vx": "1.5", "vy": "-0.25"}.get(name, "")


def _mutated(draw, rows: list[list[str]], width: int) -> None:
    """Replace a few cells of ``rows`` by odd ones, and maybe make a row ragged."""
    if not (rows and width):
        return
    for _ in range(draw(_mostly(0, 1, 2, 3))):
        r, c = draw(st.integers(0, len(rows) - 1)), draw(st.integers(0, width - 1))
        rows[r][c] = draw(st.one_of(st.sampled_from(ODD_CELLS), st.text(max_size=6),
                                    st.floats().map(repr), st.integers(-(2 ** 70), 2 ** 70).map(str)))
    if draw(_mostly(False, True)):  # a cell too many or too few
        r = draw(st.integers(0, len(rows) - 1))
        rows[r] = rows[r][:-1] if draw(st.booleans()) else rows[r] + ["1"]


@st.composite
def csv_files(draw) -> tuple[bytes, bytes | None, dict, int]:
    """(detections file, truth file or None, read_detections options, number of detection rows written)."""
    delimiter = draw(st.sampled_from(DELIMITERS))
    decimal = draw(st.sampled_from([".", ","] if delimiter != "," else ["."]))
    quoting = draw(_mostly("minimal", "all", "none"))
    ending = draw(st.sampled_from(LINE_ENDINGS))
    encoding = draw(_mostly("utf-8", *ENCODINGS[1:]))

    def written(names: list[str], rows: list[list[str]]) -> bytes:
        if decimal == ",":
            rows = [[c.replace(".", ",") if c[:1].isdigit() or c[:1] == "-" else c for c in row] for row in rows]
        lines = [delimiter.join(_quoted(c, delimiter, quoting) for c in line) for line in [list(names), *rows]]
        text = ending.join(lines) + draw(st.sampled_from(["", ending, ending * 2]))
        data = draw(_mostly(b"", codecs.BOM_UTF8, codecs.BOM_UTF16_LE)) + text.encode(encoding, errors="replace")
        if data and draw(_mostly(False, True)):  # stray bytes somewhere
            at = draw(st.integers(0, len(data)))
            data = data[:at] + draw(st.binary(min_size=1, max_size=3)) + data[at:]
        return data

    sensors, sensor_cells = draw(st.sampled_from(SENSORS))
    names = draw(st.one_of(st.sampled_from(GOOD_NAMES).flatmap(st.permutations),
                           st.lists(st.sampled_from(NAMES), max_size=8)))
    n_rows = draw(st.integers(0, 10))
    labels = draw(st.sampled_from([["7", "", "-1", "12"], ["7", "", "A1"], ["7"]]))
    rows = [[_good_cell(name, r, sensor_cells, labels) for name in names] for r in range(n_rows)]
    _mutated(draw, rows, len(names))
    truth = None
    if draw(st.booleans()):
        truth_names = draw(st.one_of(st.permutations(["time", "target_id", "x", "y", "vx", "vy"]),
                                     st.lists(st.sampled_from(["time", "target_id", "x", "y", "vx", "vy", "x"]),
                                              max_size=7)))
        truth_rows = [[_truth_cell(name, r) for name in truth_names] for r in range(draw(st.integers(0, 6)))]
        _mutated(draw, truth_rows, len(truth_names))
        truth = written(truth_names, truth_rows)
    options = {
        "delimiter": draw(_mostly(delimiter, ",", ";", "\\t", "tab", ":")),
        "decimal": draw(_mostly(decimal, ".", ",")),
        "encoding": draw(_mostly(encoding, "utf-8", "latin-1", "utf-16", "no-such-codec")),
        "sensors": sensors,
        "azimuth_unit": draw(st.sampled_from(["rad", "deg"])),
        "scan_tolerance": draw(_mostly(1e-6, 0.5, 0.99)),
        "time_origin": draw(_mostly(0.0, 1.0, -3.0, 1e300)),
    }
    return written(names, rows), truth, options, n_rows


def _import(data: bytes, suffix: str = ".csv", truth: bytes | None = None, **options) -> Dataset | None:
    """``read_detections`` of ``data`` saved as a file: the dataset, or None after an nnda error. Any other
    exception propagates (and fails the test)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"plots{suffix}"
        path.write_bytes(data)
        if truth is not None:
            (Path(tmp) / "truth.csv").write_bytes(truth)
            options["truth"] = Path(tmp) / "truth.csv"
        try:
            ds = read_detections(path, **options)
        except NndaError as exc:
            event(f"refused: {type(exc).__name__}: {str(exc).split(':')[1][:40]}")
            return None
        event("imported")
        return ds


def _sound(ds: Dataset, n_rows: int | None = None) -> None:
    """An imported dataset passes nnda's checks, keeps every row and names its targets as text."""
    check_dataset(ds, "imported detections", "imported truth")
    if n_rows is not None:
        assert ds.detections.scan.size == n_rows
    for target in ds.scenario.targets:
        assert isinstance(target.name, str) and not target.name.startswith(("b'", 'b"')), target.name
        assert not any("\udc80" <= ch <= "\udcff" or ch == "\ufffd" for ch in target.name), target.name
    assert np.isfinite(ds.detections.time).all() and (ds.detections.time > 0).all()


@FUZZ
@given(data=st.binary(max_size=300), delimiter=st.sampled_from([",", ";"]))
def test_random_bytes_are_imported_or_refused_with_an_nnda_error(data, delimiter):
    ds = _import(data, delimiter=delimiter, sensors=[{"scan_period_s": 2.0}])
    if ds is not None:
        _sound(ds)


@settings(FUZZ, max_examples=600)
@given(case=csv_files())
def test_csv_dialects_columns_and_cells_are_imported_or_refused_with_an_nnda_error(case):
    data, truth, options, n_rows = case
    ds = _import(data, truth=truth, **options)
    if ds is not None:
        _sound(ds, n_rows)


#: any cell: odd ones, random text, floats and integers as Python writes them
CELLS = st.one_of(st.sampled_from(ODD_CELLS), st.text(max_size=6), st.floats().map(repr),
                  st.integers(-(2 ** 70), 2 ** 70).map(str))


@FUZZ
@given(column=st.sampled_from(["time", "range", "azimuth", "sensor", "target_id"]),
       cells=st.lists(CELLS, min_size=1, max_size=6), unit=st.sampled_from(["rad", "deg"]))
def test_random_cells_in_one_column_of_a_good_file_are_imported_or_refused_with_an_nnda_error(column, cells, unit):
    names = ["time", "range", "azimuth", "sensor", "target_id"]
    rows = [[cells[r] if name == column else _good_cell(name, r, ["radar"], ["7", "", "12"]) for name in names]
            for r in range(len(cells))]
    text = io.StringIO(newline="")
    csv.writer(text, lineterminator="\n").writerows([names, *rows])
    ds = _import(text.getvalue().encode("utf-8", errors="surrogatepass"), azimuth_unit=unit)
    if ds is not None:
        _sound(ds, len(cells))


@settings(FUZZ, max_examples=150)
@given(case=csv_files())
def test_parquet_of_the_same_text_is_imported_or_refused_with_an_nnda_error(case):
    """The CSV cells, all kept as text, in a Parquet file: the text cells go through the same parsing."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    data, _, options, _ = case
    try:
        table = pacsv.read_csv(io.BytesIO(data), convert_options=pacsv.ConvertOptions(
            column_types={}, strings_can_be_null=True, auto_dict_encode=False))
    except (pa.ArrowException, UnicodeError):
        return
    buffer = io.BytesIO()
    pq.write_table(table, buffer)
    ds = _import(buffer.getvalue(), ".parquet", sensors=options["sensors"], azimuth_unit=options["azimuth_unit"])
    if ds is not None:
        _sound(ds, table.num_rows)


# ----------------------------------------------------------------------------- what the fuzzing found, kept

@pytest.mark.parametrize("text, fragment", [
    ("time,range,azimuth\n2,1_000,0.5\n", "column 'range': '1_000', not a number"),
    ("time,range,azimuth\ntrue,12000,0.5\n", "column 'time': True, not a number"),
    ("time,range,azimuth\n1e308,12000,0.5\n", "column 'time': time 1e+308 s is more than 10,000,000 scan periods"),
    ("time,range,azimuth\n2,1e308,0.5\n", "column 'range': range 1e+308 m is beyond +-1e+12 m"),
    ("time,range,azimuth,target_id\n2,12000,0.5,inf\n", "column 'target_id': inf (a target id is a whole number"),
    ("time,range,azimuth,target_id\n2,12000,0.5,1e23\n", "column 'target_id': 1e+23 (a target id beyond +-2**53"),
    ("time,range,azimuth,sensor\n2,12000,0.5,\u00b2\n", "column 'sensor': unknown sensor '\u00b2'"),
])
def test_cells_the_fuzzing_found_are_refused_by_name(tmp_path, text, fragment):
    (tmp_path / "plots.csv").write_text(text)
    with pytest.raises(NndaError) as refused:
        read_detections(tmp_path / "plots.csv", sensors=[{"scan_period_s": 2.0}])
    assert fragment in str(refused.value) and "plots.csv: data row 1 (line 2)" in str(refused.value)


def test_cases_the_fuzzing_found_are_imported_right(tmp_path):
    """A tiny negative azimuth (or x) is stored as 0, not as 2 pi; labels with digits int() refuses are text."""
    (tmp_path / "a.csv").write_text("time,range,azimuth,target_id\n2,12000,-1e-20,\u00b2\n4,12000,0.5,7\n")
    (tmp_path / "b.csv").write_text("time,x,y,target_id\n2,-3.3e-228,12000.25,--5\n")
    for name in ("a.csv", "b.csv"):
        ds = read_detections(tmp_path / name)
        _sound(ds)
        assert ds.detections.azimuth[0] == 0.0
    assert [t.name for t in read_detections(tmp_path / "a.csv").scenario.targets] == ["7", "\u00b2"]
    # a Parquet column whose name is not UTF-8
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    pq.write_table(pacsv.read_csv(io.BytesIO(b"\xfftime,range,azimuth\n2,12000,0.5\n")), tmp_path / "c.parquet")
    with pytest.raises(NndaError, match=r"c\.parquet: the name of column 1 is not UTF-8 text"):
        read_detections(tmp_path / "c.parquet")
