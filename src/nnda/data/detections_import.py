"""A user's recorded detections (CSV or Parquet) as an nnda dataset: ``nnda import-detections``.

Usage sketch::

    ds = read_detections("plots.csv", sensors=[{"scan_period_s": 2.0, "sigma_range_m": 30}],
                         azimuth_unit="deg", columns={"time": "t_sec"})     # a Dataset, checked
    import_detections("plots.csv", "data/plots", truth="truth.csv")        # read, then write_dataset

The file's schema (names as here, or mapped with ``columns``: nnda name ->
the file's name; the mapping applies to the truth file too):

* ``time`` (s), required: numbers, or dates and times (ISO 8601 text or a
  timestamp column, UTC without a zone; `nnda.data.time_columns`); and the position: ``range`` (m) and ``azimuth``
  (rad, or degrees with ``azimuth_unit="deg"``; clockwise from north, from
  the detecting sensor, in [-pi, 2 pi) and stored wrapped to [0, 2 pi)),
  or ``x`` and ``y`` (m, x east, y north, scenario frame), or ``lat`` and
  ``lon`` (deg, WGS 84; optional ``alt``, m) placed on the local plane of
  the geodetic origin (`nnda.data.geodetic_import`). A polar sensor's
  detections are taken from ``range``/``azimuth`` when the file has them,
  a position sensor's from ``x``/``y``; the other pair is derived from the
  sensor's position.
* ``sensor`` (optional): a sensor's name, matched first (an integer 12 finds
  a sensor named "12"); when not every sensor was given a name, a whole
  number that names none is its index in the sensor list. Without the
  column every row belongs to the only sensor.
* ``target_id`` (optional truth label): any integer or text; an empty cell
  (or a negative integer) marks clutter. Without the column every detection
  is unlabelled, stored as the format stores clutter (target_id -1).
* a truth file (optional, same formats): ``time``, ``target_id``, ``x``,
  ``y`` (or ``lat``, ``lon``), ``vx``, ``vy`` (s, m or deg, m/s; velocities
  east and north), one row per target per time; each time
  must be the time of a scan (within the tolerance), its row is stored for
  every scan at that time, and a detection's target must appear in it.

Distances (range, x, y, alt) are in ``distance_unit`` and the truth's
velocities in ``speed_unit`` (`DISTANCE_UNITS`, `SPEED_UNITS`), stored
in metres and m/s.

Scans: a scan is one sensor's detections at one sweep time. Each sensor
sweeps at ``scan_offset_s + k scan_period_s`` (`nnda.data.scenario.Sensor`);
a row belongs to the sweep nearest its time and must lie within
``scan_tolerance`` s of it (default `SCAN_TOLERANCE_S`: equal times up to
rounding; raise it, below half a period, for a radar that stamps each plot
with its own time). The dataset records the sweep's time. A sensor's
period, when not given, is the median gap between its successive distinct
times (rounded to 1 us) and its offset the first time modulo the period;
range limits not given are widened from the default 5-30 km to hold every
detection. nnda's scans lie at t > 0: ``time_origin`` (s) is subtracted
from every time first (for clock times or a file that starts at 0). Rows of
one sensor must not go back in time (in file order). A report sensor
(``reports = True``: AIS, ADS-B) instead keeps each row's own time and puts
it in the window (t_k - scan_period_s, t_k] that holds it
(`nnda.data.report_import`); its ``scan_period_s`` must be given. Absolute
times (dates) become seconds after an origin: ``time_origin`` (seconds
since 1970 UTC) when given, else the start of the window holding the first
report (a report sensor; windows counted from 1970-01-01 00:00 UTC) or the
first time less one period (a sweep sensor), the earliest over the
sensors; the dataset records it (``time_origin_utc``).

A CSV (the detections and the truth file alike) is UTF-8 text with ","
between fields and "." in numbers unless ``delimiter`` (``;``, ``|``, a
tab), ``decimal`` (``,``) and ``encoding`` (a Python codec name, e.g.
``latin-1``) say otherwise; a Parquet file ignores them. A byte that is not
text in the encoding is refused with its line (as an editor counts) and
column, never read as mangled text; a header that another delimiter splits
is refused with the options to pass; a column name nnda reads must not
repeat.

Every problem names the file, the data row (1-based, the header not
counted: line = row + 1 in a CSV with one header line) and the column, as a
`DatasetError` (the file's content) or a `ConfigError` (the options); the
reader builds the whole dataset before anything is written, and the writer
(`nnda.data.dataset.write_dataset`) is atomic, so a refused import leaves
the output untouched.
"""

from __future__ import annotations

import codecs
import csv
import io
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from nnda.data.dataset import Dataset, Detections, Truth, write_dataset
from nnda.data.geodesy import GeodeticOrigin, check_geodetic
from nnda.data.geodetic_import import (
    SITE_FIELDS,
    choose_origin,
    keep_in_region,
    local_positions,
    place_sites,
    sensor_sites,
)
from nnda.data.region import Region, parse_box, polygon
from nnda.data.report_import import report_grid, report_windows, scan_order
from nnda.data.scenario import Clutter, ProcessNoise, Scenario, Segment, Sensor, Target
from nnda.data.sensor import TWO_PI, cart_to_polar_at, polar_to_cart_at, wrap_azimuth
from nnda.data.time_columns import (
    NS,
    absolute_ns,
    default_origin_ns,
    is_absolute,
    origin_ns_of,
    seconds_after,
    utc_text,
)
from nnda.errors import ConfigError, DatasetError, validated
from nnda.files import atomic_output, read_config

#: columns nnda reads from a detections file, and from a truth file
DETECTION_COLUMNS = ("time", "range", "azimuth", "x", "y", "lat", "lon", "alt", "sensor", "target_id")
TRUTH_COLUMNS = ("time", "target_id", "x", "y", "vx", "vy", "lat", "lon", "alt")
AZIMUTH_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}
#: --distance-unit (range, x, y, alt of both files) and --speed-unit (the truth's vx, vy): metres, m/s per unit
DISTANCE_UNITS = {"m": 1.0, "km": 1000.0, "nmi": 1852.0, "ft": 0.3048}
SPEED_UNITS = {"m/s": 1.0, "kn": 1852.0 / 3600.0, "km/h": 1.0 / 3.6}
#: default grouping tolerance (s): a row is in a sweep when within this of the sweep's time
SCAN_TOLERANCE_S = 1e-6
#: an import refuses a schedule of more scans than this (a clock time without --time-origin)
MAX_SCANS = 10_000_000
#: an import refuses a range, x, y (m) or velocity (m/s) of a larger magnitude (a unit error; filters square them)
MAX_MAGNITUDE = 1e12
#: periods and offsets are compared and inferred to this resolution (s)
TIME_RESOLUTION_S = 1e-6


# ----------------------------------------------------------------------------- reading the files

#: --delimiter values a CSV may use (the spellings of a tab included), and the separators they stand for
DELIMITERS = {",": ",", ";": ";", "|": "|", "\t": "\t", "\\t": "\t", "tab": "\t"}
#: --decimal values: the decimal mark of the CSV's numbers
DECIMAL_MARKS = (".", ",")
#: bytes of a CSV read to guess its dialect when it does not parse
_SNIFF_BYTES = 1 << 16


@dataclass(frozen=True)
class CsvDialect:
    """How a CSV file is written: field separator, decimal mark, text encoding (a Python codec name)."""

    delimiter: str = ","
    decimal: str = "."
    encoding: str = "utf-8"


def csv_dialect(delimiter: str = ",", decimal: str = ".", encoding: str = "utf-8") -> CsvDialect:
    """The checked dialect of the options ``--delimiter``, ``--decimal`` and ``--encoding``; ConfigError
    otherwise."""
    if delimiter not in DELIMITERS:
        raise ConfigError(f"--delimiter {delimiter!r}: unknown delimiter; choose ',' ';' '|' or a tab ('\\t')")
    if decimal not in DECIMAL_MARKS:
        raise ConfigError(f"--decimal {decimal!r}: unknown decimal mark; choose '.' or ','")
    sep = DELIMITERS[delimiter]
    if sep == decimal:
        raise ConfigError(f"--decimal {decimal!r} with --delimiter {_shown(sep)}: a decimal comma needs another "
                          f"delimiter, e.g. --delimiter ';'")
    try:
        name = codecs.lookup(encoding).name
        "time,x\n".encode(name).decode(name)  # a text encoding (not base64, rot13, ...)
    except (LookupError, TypeError, ValueError):
        raise ConfigError(f"--encoding {encoding!r}: unknown text encoding; give a Python codec name such as "
                          f"utf-8, latin-1, cp1252 or utf-16") from None
    return CsvDialect(sep, decimal, name)


def _shown(delimiter: str) -> str:
    """A delimiter as the user types it for --delimiter."""
    return "'\\t'" if delimiter == "\t" else f"'{delimiter}'"


class InMemory:
    """A table given in memory (a pyarrow Table or a pandas DataFrame) in place of a file: what messages call
    it (``str``, ``name``), and the stem a scenario is named after."""

    suffix = ""
    stem = "imported"

    def __init__(self, what: str) -> None:
        self.name = f"the {what} table" if what != "detections" else "the table"

    def __str__(self) -> str:
        return self.name


Source = str | Path | pa.Table | Any  # a file's path, a pyarrow Table or a pandas DataFrame


def _source(source: Source, what: str, dialect: CsvDialect = CsvDialect()) -> tuple[Path | InMemory, pa.Table]:
    """The label and the table of a file (path) or of a table given in memory (pyarrow or pandas)."""
    if isinstance(source, (str, Path)):
        path = Path(source)
        return path, _read_table(path, what, dialect)
    label = InMemory(what)
    if isinstance(source, pa.Table):
        return label, _named(source, label, what)
    if type(source).__module__.split(".")[0] == "pandas" and hasattr(source, "columns"):
        try:  # pyarrow converts the DataFrame (pandas is the caller's; nnda does not import it)
            return label, pa.Table.from_pandas(source, preserve_index=False)
        except (pa.ArrowException, TypeError, ValueError) as exc:
            raise DatasetError(f"{label}: the DataFrame does not convert to columns nnda reads ({exc}); give "
                               f"each column one type") from None
    raise ConfigError(f"{what}: {type(source).__name__} is not a file path, a pyarrow Table or a pandas DataFrame")


def _read_table(path: Path, what: str, dialect: CsvDialect = CsvDialect()) -> pa.Table:
    if not path.is_file():
        raise DatasetError(f"{what} {path}: no such file")
    suffix = path.suffix.lower()
    try:
        if suffix == ".csv":
            return _read_csv(path, what, dialect)
        if suffix in (".parquet", ".pq"):
            return _named(pq.read_table(path), path, what)
    except (pa.ArrowException, OSError) as exc:
        raise DatasetError(f"{what} {path}: unreadable {suffix[1:]} file ({exc})") from None
    raise ConfigError(f"{what} {path}: unknown file type {suffix or '(no suffix)'!r}; give a .csv or .parquet file")


def _named(table: pa.Table, path: Path, what: str) -> pa.Table:
    """``table``, whose column names are text; DatasetError naming the first that is not."""
    for i in range(table.num_columns):
        try:
            _ = table.field(i).name
        except UnicodeDecodeError as exc:
            raise DatasetError(f"{what} {path}: the name of column {i + 1} is not UTF-8 text ({exc}); rename the "
                               f"column") from None
    return table


def _read_csv(path: Path, what: str, dialect: CsvDialect) -> pa.Table:
    """The CSV at ``path`` in ``dialect``; DatasetError naming the first undecodable byte's line and column, or
    the dialect the header suggests when the file does not parse in this one."""
    # only an empty cell is null: "nan" is a number (refused as not finite), "NA" text (not a number)
    convert = pacsv.ConvertOptions(null_values=[""], strings_can_be_null=True, decimal_point=dialect.decimal)
    read = pacsv.ReadOptions(encoding="utf8" if dialect.encoding == "utf-8" else dialect.encoding)
    with open(path, "rb") as f:
        start = f.read(4)
    for bom, name in ((codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
                      (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16")):
        if start.startswith(bom) and not dialect.encoding.startswith(name):
            raise DatasetError(f"{what} {path}: line 1: the file starts with a {name.upper()} byte-order mark: it is "
                               f"{name.upper()} text, not {dialect.encoding}: pass --encoding {name}")
    try:
        table = pacsv.read_csv(path, read_options=read, parse_options=pacsv.ParseOptions(delimiter=dialect.delimiter),
                               convert_options=convert)
    except UnicodeError:  # a header not in UTF-8, or any text not in the --encoding given (transcoded as read)
        raise _undecodable(path, what, dialect) from None
    except pa.ArrowInvalid as exc:
        hint = _dialect_hint(path, what, dialect)
        raise DatasetError(f"{what} {path}: unreadable csv file ({exc})" + (f"; {hint}" if hint else "")) from None
    try:
        _ = table.column_names  # pyarrow decodes the header's names when asked
    except UnicodeDecodeError:
        raise _undecodable(path, what, dialect) from None
    if any(pa.types.is_binary(f.type) or pa.types.is_large_binary(f.type) for f in table.schema):
        raise _undecodable(path, what, dialect)  # pyarrow keeps a column of invalid UTF-8 as bytes
    if table.num_columns == 1 and (hint := _dialect_hint(path, what, dialect)):
        raise DatasetError(f"{what} {path}: line 1 (the header) reads as one column, "
                           f"{table.column_names[0]!r}; {hint}")
    return table


def _dialect_hint(path: Path, what: str, dialect: CsvDialect) -> str:
    """What to pass when the header line is split by another delimiter than ``dialect``'s (and the first data
    line has decimal commas), or ""."""
    try:
        with open(path, "rb") as f:
            head = f.read(_SNIFF_BYTES).decode(dialect.encoding, errors="replace").lstrip("\ufeff")
    except (OSError, UnicodeError, LookupError):
        return ""
    lines = [s for s in re.split(r"\r\n|\r|\n", head) if s.strip()]
    if not lines or dialect.delimiter in lines[0]:
        return ""
    counts = {d: lines[0].count(d) for d in (",", ";", "\t", "|") if d != dialect.delimiter}
    likely = max(counts, key=counts.__getitem__)
    if not counts[likely]:
        return ""
    hint = f"the header line is separated by {_shown(likely)}, not {_shown(dialect.delimiter)}"
    both = " (the options read the detections and the truth file alike)" if what == "truth" else ""
    data = lines[1].split(likely) if len(lines) > 1 else []
    if likely != "," and dialect.decimal == "." and any(_DECIMAL_COMMA.fullmatch(v.strip()) for v in data):
        return hint + f", and line 2 has decimal commas: pass --delimiter {_shown(likely)} --decimal ','{both}"
    return hint + f": pass --delimiter {_shown(likely)}{both}"


def _undecodable(path: Path, what: str, dialect: CsvDialect) -> DatasetError:
    """The error for a CSV with bytes that are not text in ``dialect.encoding``: the file, the line (1-based, as
    an editor counts), the column of the first such byte, and what to do."""
    encoding = "UTF-8" if dialect.encoding == "utf-8" else dialect.encoding
    convert = (f"give the file's encoding with --encoding (e.g. --encoding latin-1, or cp1252), or convert the "
               f"file to UTF-8, e.g. iconv -f cp1252 -t utf-8 {path.name} > {path.stem}-utf8.csv")
    data = path.read_bytes()
    try:
        data.decode(dialect.encoding)
    except UnicodeDecodeError as exc:
        start, bad = exc.start, exc.object[exc.start:exc.end]
    except UnicodeError as exc:
        return DatasetError(f"{what} {path}: not readable as {encoding} text ({exc}); {convert}")
    else:  # pyarrow and Python disagree: name no position
        return DatasetError(f"{what} {path}: not readable as {encoding} text; {convert}")
    text = data[:start].decode(dialect.encoding, errors="replace")
    line = text.count("\n") + text.count("\r") - text.count("\r\n") + 1
    shown = " ".join(f"0x{b:02x}" for b in bad[:4])
    where = f"line {line}"
    try:  # the record holding the byte, parsed as pyarrow parses (blank lines skipped)
        records = [r for r in csv.reader(io.StringIO(text.lstrip("\ufeff") + "\ue000", newline=""),
                                         delimiter=dialect.delimiter, quotechar='"', doublequote=True) if r]
    except csv.Error:
        records = []
    if len(records) == 1:
        where += f" (the header), column {len(records[0])}"
    elif records:
        field, header = len(records[-1]) - 1, records[0]
        name = repr(header[field]) if field < len(header) else f"{field + 1} (beyond the header's {len(header)})"
        where = f"data row {len(records) - 1} ({where}), column {name}"
    return DatasetError(f"{what} {path}: {where}: byte {shown} is not {encoding} text; {convert}")


def _decimal(path: Path | InMemory, dialect: CsvDialect) -> str:
    """The decimal mark of text numbers in the file at ``path``: the dialect's in a CSV, a point otherwise."""
    return dialect.decimal if path.suffix.lower() == ".csv" else "."


def _where(path: Path | InMemory, row: int, column: str) -> str:
    if isinstance(path, InMemory):
        return f"{path}: row {row + 1} (1-based), column {column!r}"
    return f"{path}: data row {row + 1} (line {row + 2}), column {column!r}"


#: a number as text in a CSV: decimal point (or comma, ``{0}``), optional exponent; or nan/inf (refused later)
_NUMBER = r"\s*[+-]?(?:(?:[0-9]+(?:{0}[0-9]*)?|{0}[0-9]+)(?:[eE][+-]?[0-9]+)?|inf|infinity|nan)\s*"
_NUMBERS = {d: re.compile(_NUMBER.format(re.escape(d)), re.IGNORECASE) for d in DECIMAL_MARKS}
_DECIMAL_COMMA = re.compile(r"[+-]?[0-9]*,[0-9]+(?:[eE][+-]?[0-9]+)?")


def _not_a_number(v: Any, name: str, decimal: str) -> str:
    """Why cell value ``v`` is not a number (nnda's column ``name``), with the --decimal option that may read
    it."""
    if v is None or v == "":
        return f"an empty cell ({name} must be a number)"
    if isinstance(v, str) and decimal == "." and _DECIMAL_COMMA.fullmatch(v.strip()):
        return (f"{v!r}, not a number ({name} must be a number; for decimal commas pass --decimal ',' and a "
                f"--delimiter other than ',')")
    if isinstance(v, str) and decimal == "," and _NUMBERS["."].fullmatch(v):
        return f"{v!r}, not a number ({name} must be a number; --decimal ',' reads decimal commas only)"
    return f"{v!r}, not a number ({name} must be a number)"


def _numeric(table: pa.Table, path: Path, name: str, column: str, decimal: str = ".") -> np.ndarray:
    """Column ``column`` (nnda's ``name``) as finite float64; DatasetError at the first empty, non-numeric,
    NaN or infinite cell. Text cells are numbers written with the ``decimal`` mark."""
    col = table.column(column)
    if not len(col):
        return np.empty(0)
    if pa.types.is_decimal(col.type):
        col = pc.cast(col, pa.float64())
    if pa.types.is_string(col.type) or pa.types.is_large_string(col.type):
        number = _NUMBERS[decimal]
        values = col.to_pylist()
        a = np.empty(len(values))
        for row, v in enumerate(values):
            if v is None or not number.fullmatch(v):
                raise DatasetError(f"{_where(path, row, column)}: {_not_a_number(v, name, decimal)}")
            a[row] = float(v.replace(decimal, "."))
    elif pa.types.is_integer(col.type) or pa.types.is_floating(col.type):
        if col.null_count:
            row = int(pc.index(pc.is_null(col), True).as_py())
            raise DatasetError(f"{_where(path, row, column)}: an empty cell ({name} must be a number)")
        a = col.to_numpy().astype(np.float64, copy=False)
    else:  # booleans, dates, bytes, all-empty columns: the first cell says what it is
        v = col[0].as_py()
        raise DatasetError(f"{_where(path, 0, column)}: {_not_a_number(v, name, decimal)[:-1]}; the column holds "
                           f"{col.type})")
    bad = ~np.isfinite(a)
    if bad.any():
        row = int(np.argmax(bad))
        raise DatasetError(f"{_where(path, row, column)}: {float(a[row])!r} ({name} must be a finite number)")
    unit = {"range": "m", "x": "m", "y": "m", "vx": "m/s", "vy": "m/s", "alt": "m"}.get(name)
    if unit and (bad := np.abs(a) > MAX_MAGNITUDE).any():
        row = int(np.argmax(bad))
        raise DatasetError(f"{_where(path, row, column)}: {name} {float(a[row])!r} {unit} is beyond "
                           f"+-{MAX_MAGNITUDE:g} {unit} (another unit?)")
    return a


def _texts(table: pa.Table, path: Path, column: str) -> list:
    """Column ``column``'s values, bytes (a Parquet binary column) decoded as UTF-8; DatasetError at the first
    that is not."""
    values = table.column(column).to_pylist()
    for row, v in enumerate(values):
        if isinstance(v, bytes):
            try:
                values[row] = v.decode("utf-8")
            except UnicodeDecodeError:
                raise DatasetError(f"{_where(path, row, column)}: {v!r} is not UTF-8 text") from None
    return values


def _labels(table: pa.Table, path: Path, column: str) -> np.ndarray:
    """Column ``column`` as text labels (object array); None where the cell is empty or a negative integer
    (clutter)."""
    col = table.column(column)
    if pa.types.is_floating(col.type):
        a = col.to_numpy(zero_copy_only=False)  # an empty cell is NaN
        bad = np.isinf(a) | (np.isfinite(a) & (a != np.round(a)))
        if bad.any():
            row = int(np.argmax(bad))
            raise DatasetError(f"{_where(path, row, column)}: {float(a[row])!r} (a target id is a whole number or "
                               f"text)")
        bad = np.abs(a) > 2.0 ** 53
        if bad.any():  # read as a float, it is no longer the integer written
            row = int(np.argmax(bad))
            raise DatasetError(f"{_where(path, row, column)}: {float(a[row])!r} (a target id beyond +-2**53 is not "
                               f"read exactly; use shorter ids, or text with a letter)")
        return np.array([None if not math.isfinite(v) or v < 0 else str(int(v)) for v in a.tolist()], dtype=object)
    if pa.types.is_integer(col.type):
        return np.array([None if v is None or v < 0 else str(v) for v in col.to_pylist()], dtype=object)
    return np.array([None if v is None or str(v) == "" else str(v) for v in _texts(table, path, column)],
                    dtype=object)


def _columns(table: pa.Table, path: Path, names: Sequence[str], mapping: Mapping[str, str]) -> dict[str, str]:
    """nnda column name -> the file's column name, for the ``names`` the file has; DatasetError when one of
    them is the name of several columns."""
    present = {}
    for name in names:
        column = mapping.get(name, name)
        if column in table.column_names:
            present[name] = column
        elif name in mapping:
            raise DatasetError(f"{path}: column {column!r} (mapped to {name!r} by --column {name}={column}) is "
                               f"missing; the file has {', '.join(table.column_names)}")
    repeated = {c: [i + 1 for i, f in enumerate(table.column_names) if f == c] for c in dict.fromkeys(present.values())}
    repeated = {c: at for c, at in repeated.items() if len(at) > 1}
    if repeated:
        shown = "; ".join(f"{c!r} in columns {', '.join(map(str, at))}" for c, at in repeated.items())
        raise DatasetError(f"{path}: line 1 (the header): column name(s) repeated: {shown}; nnda cannot tell which "
                           f"to read: rename or remove the copies")
    return present


def _require(path: Path, present: Mapping[str, str], names: Sequence[str], mapping: Mapping[str, str],
             table: pa.Table, why: str) -> None:
    missing = [mapping.get(n, n) for n in names if n not in present]
    if missing:
        raise DatasetError(f"{path}: required column(s) {', '.join(map(repr, missing))} missing ({why}); the file "
                           f"has {', '.join(table.column_names) or 'no columns'} (map names with --column "
                           f"NAME=COLUMN)")


def column_mapping(pairs: Sequence[str] | Mapping[str, str] | None) -> dict[str, str]:
    """``["time=t_sec", ...]`` (or a mapping) as {nnda name: file column}; ConfigError for an unknown name."""
    if pairs is None:
        return {}
    items = pairs.items() if isinstance(pairs, Mapping) else []
    if not isinstance(pairs, Mapping):
        parsed = []
        for p in pairs:
            name, sep, column = p.partition("=")
            if not sep or not name or not column:
                raise ConfigError(f"--column {p!r}: give NAME=COLUMN, e.g. time=t_sec")
            parsed.append((name.strip(), column.strip()))
        items = parsed
    mapping: dict[str, str] = {}
    known = sorted({*DETECTION_COLUMNS, *TRUTH_COLUMNS})
    for name, column in items:
        if name not in known:
            raise ConfigError(f"--column {name}={column}: unknown column name {name!r}; nnda reads "
                              f"{', '.join(known)}")
        if name in mapping:
            raise ConfigError(f"--column: {name!r} is mapped twice")
        mapping[name] = column
    return mapping


# ----------------------------------------------------------------------------- sensors

def load_sensors(path: str | Path) -> list[dict]:
    """The ``[[sensors]]`` tables of a TOML (or JSON) file, fields as in a scenario's sensors."""
    data = read_config(path, "sensors")
    sensors = data.get("sensors")
    extra = sorted(set(data) - {"sensors"})
    if extra:
        raise ConfigError(f"{path}: unknown key(s) {', '.join(extra)}; give the sensors as [[sensors]] tables")
    if not isinstance(sensors, list) or not sensors or not all(isinstance(s, dict) for s in sensors):
        raise ConfigError(f"{path}: give one or more [[sensors]] tables (Sensor fields: name, kind, x_m, y_m, "
                          f"scan_period_s, sigma_range_m, ...)")
    return sensors


#: --sensor reports=VALUE spellings
_BOOLEANS = {"true": True, "false": False, "1": True, "0": False, "yes": True, "no": False}


def sensor_fields(pairs: Sequence[str]) -> dict[str, Any]:
    """``["scan_period_s=2", "kind=position"]`` as a Sensor field mapping (numbers parsed; validated later)."""
    fields: dict[str, Any] = {}
    for p in pairs:
        name, sep, value = p.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name:
            raise ConfigError(f"--sensor {p!r}: give FIELD=VALUE, e.g. scan_period_s=2")
        if (name not in Sensor.model_fields or name == "clutter") and name not in SITE_FIELDS:
            fields_known = ", ".join([*(f for f in Sensor.model_fields if f != "clutter"), *SITE_FIELDS])
            raise ConfigError(f"--sensor {p!r}: unknown sensor field {name!r}; choose one of {fields_known}")
        if name == "reports":
            if value.lower() not in _BOOLEANS:
                raise ConfigError(f"--sensor {p!r}: reports must be true or false")
            fields[name] = _BOOLEANS[value.lower()]
            continue
        try:
            fields[name] = float(value) if name not in ("name", "kind") else value
        except ValueError:
            raise ConfigError(f"--sensor {p!r}: {name} must be a number") from None
    return fields


def _fraction(seconds: float, what: str) -> Fraction:
    f = Fraction(seconds).limit_denominator(round(1 / TIME_RESOLUTION_S))
    if abs(float(f) - seconds) > 1e-9 * max(1.0, seconds):
        raise ConfigError(f"{what} = {seconds!r} s is not a whole number of microseconds; nnda's scan schedule "
                          f"needs periods of a common multiple")
    return f


def _lcm(periods: Sequence[Fraction]) -> Fraction:
    num, den = periods[0].numerator, periods[0].denominator
    for p in periods[1:]:
        num, den = math.lcm(num, p.numerator), math.gcd(den, p.denominator)
    return Fraction(num, den)


def _sweep_grid(sensor: Mapping[str, Any], t: np.ndarray, tol: float, time_origin: float) -> tuple[float, float]:
    """Period and offset (s, after the origin) of a sensor: as given (an offset in the file's clock), or
    inferred from its times ``t`` (after the origin, in order)."""
    starts = t[np.concatenate([[True], np.diff(t) > tol])] if t.size else t
    period = sensor.get("scan_period_s")
    if period is None:
        gaps = np.diff(starts)
        period = round(float(np.median(gaps)), 6) if gaps.size else Sensor().scan_period_s
        period = period if period > 0 else Sensor().scan_period_s
    period = float(period)
    if "scan_offset_s" in sensor:
        offset = round((float(sensor["scan_offset_s"]) - time_origin) % period, 9)
    else:
        offset = round(float(starts[0] % period), 6) if starts.size else 0.0
    if offset <= max(tol, 1e-9) or period - offset <= max(tol, 1e-9):
        offset = 0.0
    return period, offset


# ----------------------------------------------------------------------------- the import

def _check_azimuth(path: Path, column: str, az: np.ndarray, unit: str) -> None:
    bad = (az < -math.pi) | (az >= TWO_PI)
    if bad.any():
        row = int(np.argmax(bad))
        shown = az[row] / AZIMUTH_UNITS[unit]
        limits = "[-180, 360) deg" if unit == "deg" else "[-pi, 2 pi) rad"
        hint = "" if unit == "deg" or abs(shown) > 360 else " (degrees? pass --azimuth-unit deg)"
        raise DatasetError(f"{_where(path, row, column)}: azimuth {float(shown)!r} {unit} is outside {limits}{hint}")


def _sensor_index(path: Path, column: str, table: pa.Table, names: list[str], named: bool) -> np.ndarray:
    """Each row's sensor index from column ``column``: a value is a sensor's name, else (unless every sensor
    was ``named`` by the user) its index in the list; an integer column is matched as text (a sensor named
    "12", value 12)."""
    col = table.column(column)
    n = len(names)
    if pa.types.is_integer(col.type) and not col.null_count and not named and not any(s.isdigit() for s in names):
        idx = col.to_numpy().astype(np.int64)
        bad = (idx < 0) | (idx >= n)
        if bad.any():
            row = int(np.argmax(bad))
            raise DatasetError(f"{_where(path, row, column)}: unknown sensor {int(idx[row])} (sensors: "
                               f"{', '.join(f'{i} {s!r}' for i, s in enumerate(names))})")
        return idx.astype(np.int32)
    values = np.array(["" if v is None else str(v) for v in _texts(table, path, column)], dtype=object)
    uniq, inverse = np.unique(values, return_inverse=True)
    lookup = []
    for value in uniq:
        if value in names:
            lookup.append(names.index(value))
        elif not named and re.fullmatch(r"\d{1,9}", value) and int(value) < n:
            lookup.append(int(value))
        else:
            row = int(np.argmax(values == value))
            got = "an empty cell" if value == "" else f"unknown sensor {value!r}"
            raise DatasetError(f"{_where(path, row, column)}: {got} (sensors: "
                               f"{', '.join(f'{i} {s!r}' for i, s in enumerate(names))})")
    return np.asarray(lookup, dtype=np.int32)[inverse]


def _uses_polar(kind: str, polar: bool, cart: bool) -> bool:
    """Does a sensor of ``kind`` take its detections from the range/azimuth columns (else from x/y)?"""
    return polar and (kind == "polar" or not cart)


#: a label that is an integer (sorted as one)
_INTEGER_LABEL = re.compile(r"-?\d{1,30}")


def _target_order(labels: list[str]) -> list[str]:
    """Target labels in id order: numerically when every label is an integer, as text otherwise."""
    if all(_INTEGER_LABEL.fullmatch(s) for s in labels):
        return sorted(labels, key=int)
    return sorted(labels)


def _scenario_name(name: str) -> str:
    kept = "".join(c if (c.isascii() and c.isalnum()) or c in "_.-" else "_" for c in name) or "imported"
    return "_" + kept[1:] if kept.startswith(".") else kept


def read_detections(
    path: Source, *, sensors: Sequence[Mapping[str, Any] | Sensor] | None = None,
    truth: Source | None = None, columns: Sequence[str] | Mapping[str, str] | None = None,
    azimuth_unit: str = "rad", scan_tolerance: float = SCAN_TOLERANCE_S, time_origin: float | None = None,
    name: str | None = None, delimiter: str = ",", decimal: str = ".", encoding: str = "utf-8",
    origin: str | Sequence[float] | GeodeticOrigin | None = None, region: str | Path | Region | None = None,
    distance_unit: str = "m", speed_unit: str = "m/s",
) -> Dataset:
    """The detections file at ``path`` (and its ``truth`` file) as a checked `Dataset` (see the module).

    ``path`` and ``truth`` may also be tables in memory, a pyarrow Table or a
    pandas DataFrame (its index ignored), with the columns a file has;
    messages then name "the table" (or "the truth table") and its row
    (1-based) and column, and the scenario is named "imported" by default.

    ``sensors``: one mapping of Sensor fields (or a Sensor) per sensor, in
    index order (default: one radar with the default fields); fields left out
    are inferred as the module docstring says. ``columns`` maps nnda's column
    names to the file's. ``name`` names the scenario (default: the file's stem).
    ``delimiter`` (``,`` ``;`` ``|`` or a tab), ``decimal`` (``.`` or ``,``)
    and ``encoding`` (a Python codec name) say how a CSV (detections and
    truth) is written; a Parquet file ignores them. ``origin`` (``"LAT,LON[,ALT]"``, deg, deg, m) fixes
    the geodetic origin of the frame (default: chosen from the data, `nnda.data.geodetic_import`);
    ``region`` (a box or a polygon file, `nnda.data.region`) drops the reports outside it.
    ``distance_unit`` (`DISTANCE_UNITS`: m, km, nmi, ft) is the unit of the
    files' range, x, y and alt, ``speed_unit`` (`SPEED_UNITS`: m/s, kn,
    km/h) of the truth's vx, vy; the dataset holds metres and m/s (the
    sensors' fields stay in metres).
    """
    if azimuth_unit not in AZIMUTH_UNITS:
        raise ConfigError(f"--azimuth-unit {azimuth_unit!r}: unknown unit; choose one of {', '.join(AZIMUTH_UNITS)}")
    for option, unit, known in (("--distance-unit", distance_unit, DISTANCE_UNITS), ("--speed-unit", speed_unit,
                                                                                      SPEED_UNITS)):
        if unit not in known:
            raise ConfigError(f"{option} {unit!r}: unknown unit; choose one of {', '.join(known)}")
    metres = DISTANCE_UNITS[distance_unit]
    if not (math.isfinite(scan_tolerance) and scan_tolerance >= 0):
        raise ConfigError(f"--scan-tolerance {scan_tolerance!r}: must be a finite number of seconds >= 0")
    if time_origin is not None and not math.isfinite(time_origin):
        raise ConfigError(f"--time-origin {time_origin!r}: must be a finite number of seconds")
    mapping = column_mapping(columns)
    dialect = csv_dialect(delimiter, decimal, encoding)
    specs = [s.model_dump(exclude_unset=True) if isinstance(s, Sensor) else dict(s) for s in (sensors or [{}])]
    given = [dict(s) for s in specs]  # as the user gave them (names before the defaults)
    for i, s in enumerate(specs):
        s.setdefault("name", "radar" if len(specs) == 1 else f"sensor{i}")
    names = [str(s["name"]) for s in specs]
    sites = sensor_sites(specs, names)
    if isinstance(region, (str, Path)):
        region = parse_box(str(region)) or _polygon_file(Path(region), mapping, dialect)
    for j, s in enumerate(specs):  # the fields given, before anything is inferred (an offset needs its period)
        validated(Sensor, {k: v for k, v in s.items() if k != "scan_offset_s"}, f"sensor {j} ({names[j]!r})",
                  "sensor")
    path, table = _source(path, "detections", dialect)
    dec = _decimal(path, dialect)
    present = _columns(table, path, DETECTION_COLUMNS, mapping)
    _require(path, present, ["time"], mapping, table, "the time of each detection, s")
    n = table.num_rows
    tcol = present["time"]
    absolute = is_absolute(table.column(tcol))
    if absolute:
        t_ns = absolute_ns(table.column(tcol), lambda row: _where(path, row, tcol))
    else:
        time_origin = 0.0 if time_origin is None else float(time_origin)
        t = _numeric(table, path, "time", tcol, dec) - time_origin
    polar, cart = {"range", "azimuth"} <= present.keys(), {"x", "y"} <= present.keys()
    geodetic = not cart and ({"lat", "lon"} <= present.keys() or not polar and ("lat" in present or "lon" in present))
    if not (polar or cart or geodetic):
        _require(path, present, ["range", "azimuth"] if "x" not in present and "y" not in present else ["x", "y"],
                 mapping, table, "a position: range and azimuth, x and y, or lat and lon")
    lat = lon = alt = None
    if geodetic:
        _require(path, present, ["lat", "lon"], mapping, table, "a position in degrees: lat and lon")
        lat, lon, alt = (_numeric(table, path, c, present[c], dec) if c in present else None for c in SITE_FIELDS)
        alt = alt * metres if alt is not None else None
        check_geodetic(lat, lon, alt, where=lambda c, row: _where(path, row, present[c]), error=DatasetError)
    frame = choose_origin(origin, sites, names, lat, lon)
    place_sites(specs, sites, frame)
    rng = az = x = y = None
    if polar:
        rng = _numeric(table, path, "range", present["range"], dec) * metres
        az = _numeric(table, path, "azimuth", present["azimuth"], dec) * AZIMUTH_UNITS[azimuth_unit]
        _check_azimuth(path, present["azimuth"], az, azimuth_unit)
        az = wrap_azimuth(az)
        bad = ~(rng > 0)
        if bad.any():
            row = int(np.argmax(bad))
            raise DatasetError(f"{_where(path, row, present['range'])}: range {float(rng[row])!r} m must be positive")
    if cart:
        x = _numeric(table, path, "x", present["x"], dec) * metres
        y = _numeric(table, path, "y", present["y"], dec) * metres
    elif geodetic:
        x, y = local_positions(path, present, frame, lat, lon, alt)
        cart = True
    if "sensor" in present:
        sensor = _sensor_index(path, present["sensor"], table, names, all("name" in s for s in given))
    elif len(specs) > 1:
        raise DatasetError(f"{path}: {len(specs)} sensors are given but the file has no column "
                           f"{mapping.get('sensor', 'sensor')!r} saying which one made each detection")
    else:
        sensor = np.zeros(n, dtype=np.int32)
    tol = float(scan_tolerance)
    origin_ns = None
    if absolute:
        origin_ns = (_default_origin(specs, names, sensor, t_ns, tol) if time_origin is None
                     else origin_ns_of(time_origin))
        time_origin, t = origin_ns / NS, seconds_after(t_ns, origin_ns)
    bad = ~(t > 0)
    if bad.any():
        row = int(np.argmax(bad))
        raise DatasetError(f"{_where(path, row, tcol)}: time {float(t[row] + time_origin)!r} s is not after the time "
                           f"origin ({time_origin:g} s); nnda's scans lie at t > 0: pass --time-origin T with T "
                           f"below the first time (e.g. --time-origin {math.floor(t.min() + time_origin) - 1})")

    # the sweep of each row, per sensor
    sweep = np.empty(n, dtype=np.int64)
    grids: list[tuple[float, float]] = []
    needed: list[int] = []
    for j, spec in enumerate(specs):
        rows = np.flatnonzero(sensor == j)
        tj = t[rows]
        reports = bool(spec.get("reports", False))
        period, offset = (report_grid(spec, names[j], j, time_origin) if reports
                          else _sweep_grid(spec, tj, tol, time_origin))
        if tol >= period / 2 and not reports:
            raise ConfigError(f"--scan-tolerance {tol:g} s: must be below half the scan period of sensor "
                              f"{names[j]!r} ({period:g} s)")
        far = np.abs(tj - offset) > MAX_SCANS * period  # before the sweep index overflows
        if far.any():
            i = int(np.argmax(far))
            raise DatasetError(f"{_where(path, int(rows[i]), tcol)}: time {float(tj[i] + time_origin)!r} s is more "
                               f"than {MAX_SCANS:,} scan periods ({period:g} s) of sensor {names[j]!r} after t = "
                               f"{time_origin:g} s; clock times? pass --time-origin with a time just before the first")
        if reports:
            first = 1 if offset == 0 else 0  # t > 0 lies in window k >= first
            sweep[rows] = report_windows(tj, rows, period, offset, lambda row: _where(path, row, tcol),
                                         lambda time: float(time + time_origin), names[j]) - first
            grids.append((period, offset))
            needed.append(int(sweep[rows].max()) + 1 if rows.size else 1)
            continue
        k = np.round((tj - offset) / period).astype(np.int64)
        back = np.diff(k) < 0
        if back.any():
            i = int(np.argmax(back))
            raise DatasetError(f"{_where(path, int(rows[i + 1]), tcol)}: time {float(tj[i + 1] + time_origin)!r} s "
                               f"goes back from {float(tj[i] + time_origin)!r} s (data row {rows[i] + 1}, an earlier "
                               f"sweep) for sensor {names[j]!r}; each sensor's rows must be in time order")
        miss = np.abs(tj - (offset + k * period))
        first = 1 if offset == 0 else 0
        bad = (miss > tol + 1e-9 * np.maximum(1.0, np.abs(tj))) | (k < first)
        if bad.any():
            i = int(np.argmax(bad))
            nearest = offset + max(k[i], first) * period
            raise DatasetError(
                f"{_where(path, int(rows[i]), tcol)}: time {float(tj[i] + time_origin)!r} s is "
                f"{abs(tj[i] - nearest):.6g} s "
                f"from the nearest sweep of sensor {names[j]!r} ({nearest + time_origin:.6g} s; period {period:g} s, "
                f"offset {offset + time_origin:g} s), beyond the scan tolerance ({tol:g} s): give the sensor's "
                f"scan_period_s and scan_offset_s, or a larger --scan-tolerance")
        sweep[rows] = k - first
        grids.append((period, offset))
        needed.append(int(k.max()) + 1 - first if rows.size else 1)

    periods = [_fraction(p, f"sensor {names[j]!r}: scan_period_s") for j, (p, _) in enumerate(grids)]
    common = _lcm(periods)
    longest = max(Fraction(m) * p for m, p in zip(needed, periods))
    truth_rows = (_read_truth(truth, mapping, time_origin, dialect, frame, origin_ns,
                              (metres, SPEED_UNITS[speed_unit])) if truth is not None else None)
    if truth_rows is not None and truth_rows["t"].size:  # the schedule reaches the last true state too
        longest = max(longest, Fraction(float(truth_rows["t"].max())))
    duration = common * math.ceil(longest / common)
    n_scans = sum(int(duration / p) for p in periods)
    if n_scans > MAX_SCANS:
        raise DatasetError(f"{path}: column {tcol!r}: the times reach {float(longest) + time_origin:.6g} s, a "
                           f"schedule of {n_scans:,} scans from t = {time_origin:g} s (more than {MAX_SCANS:,}); "
                           f"clock times? pass --time-origin with a time just before the first")

    # sensors, with what the data implies where the user gave nothing
    built = []
    for j, spec in enumerate(specs):
        mine = sensor == j
        full = {**spec, "scan_period_s": grids[j][0], "scan_offset_s": grids[j][1]}
        full.setdefault("clutter", Clutter(law="none").model_dump())
        origin = (float(full.get("x_m", 0.0)), float(full.get("y_m", 0.0)))
        if _uses_polar(full.get("kind", "polar"), polar, cart):
            rj = rng[mine]
        else:
            rj = np.hypot(x[mine] - origin[0], y[mine] - origin[1])
        if rj.size:
            full.setdefault("min_range_m", float(min(Sensor().min_range_m, math.floor(rj.min()))))
            full.setdefault("max_range_m", float(max(Sensor().max_range_m, math.ceil(rj.max()))))
        built.append(validated(Sensor, full, f"sensor {j} ({names[j]!r})", "sensor"))

    labels = _labels(table, path, present["target_id"]) if "target_id" in present else None
    scenario_name = _scenario_name(name or path.stem)
    return _assemble(path, truth_rows, mapping, scenario_name, built, float(duration), time_origin, tol,
                     t, sweep, sensor, rng, az, x, y, labels, polar, frame, region,
                     None if origin_ns is None else utc_text(origin_ns))


def _default_origin(specs: Sequence[Mapping[str, Any]], names: list[str], sensor: np.ndarray, t_ns: np.ndarray,
                    tol: float) -> int:
    """The time origin (ns since 1970 UTC) of absolute times ``t_ns`` (`nnda.data.time_columns.default_origin_ns`):
    a report sensor's window, a sweep sensor's period given or inferred from its times."""
    firsts, periods, reports = [], [], []
    for j, spec in enumerate(specs):
        tj = t_ns[sensor == j]
        report = bool(spec.get("reports", False))
        if report:
            period = report_grid(spec, names[j], j, 0.0)[0]
        elif spec.get("scan_period_s") is not None:
            period = float(spec["scan_period_s"])
        else:  # the gaps between its times: the offset (and so the origin) does not change them
            period = _sweep_grid({}, seconds_after(tj, int(tj[0])) if tj.size else np.empty(0), tol, 0.0)[0]
        firsts.append(int(tj.min()) if tj.size else None)
        periods.append(period)
        reports.append(report)
    return default_origin_ns(firsts, periods, reports)


def _polygon_file(path: Path, mapping: Mapping[str, str], dialect: CsvDialect) -> Region:
    """The polygon of the ``--region`` file at ``path``: one vertex a row, columns x, y (m) or lat, lon (deg)."""
    table = _read_table(path, "--region", dialect)
    present = _columns(table, path, ("x", "y", "lat", "lon"), {})
    pair = ("x", "y") if {"x", "y"} <= present.keys() else ("lat", "lon")
    _require(path, present, pair, {}, table, "a polygon's vertices: x, y (m) or lat, lon (deg), one a row")
    a, b = (_numeric(table, path, c, present[c], _decimal(path, dialect)) for c in pair)
    if pair[0] == "lat":
        check_geodetic(a, b, where=lambda c, row: _where(path, row, present[c]), error=DatasetError)
    return polygon(str(path), a, b, pair[0] == "lat", path)


def _assemble(path, truth_rows, mapping, scenario_name, sensors, duration, time_origin, tol, t, sweep, sensor,
              rng, az, x, y, labels, polar, frame=None, region=None, origin_utc=None) -> Dataset:
    """The dataset from the checked columns: scans, positions in both forms, targets, truth; the reports
    outside ``region`` dropped."""
    n = t.size
    draft = Scenario(name=scenario_name, duration_s=duration, sensors=tuple(sensors),
                     targets=[_placeholder(duration)], process_noise=ProcessNoise(model="none"))
    sched_time, sched_sensor = draft.scan_schedule()
    scan = np.empty(n, dtype=np.int32)
    for j in range(len(sensors)):
        mine = sensor == j
        scans_j = np.flatnonzero(sched_sensor == j).astype(np.int32) + 1
        scan[mine] = scans_j[sweep[mine]]
    # both position forms, each row from its own sensor
    r_out, az_out, x_out, y_out = (np.empty(n) for _ in range(4))
    for j, s in enumerate(sensors):
        mine = sensor == j
        if not mine.any():
            continue
        if _uses_polar(s.kind, polar, x is not None):
            r_out[mine], az_out[mine] = rng[mine], az[mine]
            x_out[mine], y_out[mine] = polar_to_cart_at(s.position, rng[mine], az[mine])
        else:
            x_out[mine], y_out[mine] = x[mine], y[mine]
            r_out[mine], az_out[mine] = cart_to_polar_at(s.position, x[mine], y[mine])
    bad = ~(r_out > 0)
    if bad.any():
        row = int(np.argmax(bad))
        raise DatasetError(f"{_where(path, row, mapping.get('x', 'x'))}: the detection lies on sensor "
                           f"{sensors[sensor[row]].name!r} (range 0 m); nnda needs a positive range")
    keep, n_dropped = keep_in_region(region, x_out, y_out, frame)
    if keep is not None:
        scan, t, r_out, az_out, x_out, y_out, sensor = (a[keep] for a in (scan, t, r_out, az_out, x_out, y_out,
                                                                          sensor))
        labels = labels[keep] if labels is not None else None
        n = int(keep.sum())
    # targets: the truth file's, else the labels'
    truth_table = _truth_scans(truth_rows, time_origin, tol, sched_time) if truth_rows is not None else None
    truth_path = truth_rows["path"] if truth_rows is not None else None
    known = set(truth_table["label"]) if truth_table is not None else set()
    found = {v for v in labels if v is not None} if labels is not None else set()
    if truth_table is not None and found - known:
        unknown = found - known
        row = int(np.flatnonzero(np.isin(labels, list(unknown)))[0])
        raise DatasetError(f"{_where(path, row, mapping.get('target_id', 'target_id'))}: target {labels[row]!r} "
                           f"is not in the truth file {truth_path}")
    order = _target_order(sorted(known | found))
    index = {lab: i for i, lab in enumerate(order)}
    tid = (np.array([-1 if v is None else index[v] for v in labels.tolist()], dtype=np.int32)
           if labels is not None else np.full(n, -1, dtype=np.int32))
    report = np.array([s.reports for s in sensors])[sensor]
    rows = scan_order(scan, az_out, t, report) if report.any() else _scan_then_azimuth(scan, az_out)
    time = np.where(report[rows], t[rows], sched_time[scan[rows] - 1])
    det = Detections(scan=scan[rows], time=time, range=r_out[rows], azimuth=az_out[rows],
                     x=x_out[rows], y=y_out[rows], is_clutter=tid[rows] < 0, target_id=tid[rows],
                     sensor=sensor[rows].astype(np.int32))
    targets = _targets(order, truth_table, det, sched_time, duration)
    truth_rec = _truth_record(truth_table, index, det)
    what = f"{n} detections from {path.name}" + (f", truth from {truth_path.name}" if truth_path else "")
    what += f"; geodetic origin {frame}" if frame is not None else ""
    what += f"; {n_dropped} outside --region {region.text} dropped" if region is not None else ""
    scenario = Scenario(
        name=scenario_name, duration_s=duration, sensors=tuple(sensors), targets=targets,
        process_noise=ProcessNoise(model="none"),
        description=(f"imported by nnda import-detections: {what}; times less the origin "
                     f"{origin_utc or f'{time_origin:g} s'}, "
                     f"grouped into sweeps within {tol:g} s"
                     + (", a report sensor's into windows of its scan period" if report.any() else "")
                     + "; targets give each one's first true state "
                     "(a placeholder when unlabelled), the truth file its motion"))
    return Dataset(scenario, 0, 0, det, truth_rec, frame, {"--region": n_dropped} if region is not None else {},
                   origin_utc)


def _scan_then_azimuth(scan: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """``np.lexsort((azimuth, scan))`` (stable), by one sort of the key scan x 8 + azimuth (azimuth < 8), several
    times faster; exact ties the key's rounding makes are checked, and then the slow sort decides."""
    rows = np.argsort(scan * 8.0 + azimuth, kind="stable")
    s, a = scan[rows], azimuth[rows]
    if np.all((np.diff(s) > 0) | ((np.diff(s) == 0) & (np.diff(a) >= 0))):
        return rows
    return np.lexsort((azimuth, scan))


def _read_truth(path: Source, mapping: Mapping[str, str], time_origin: float, dialect: CsvDialect = CsvDialect(),
                frame: GeodeticOrigin | None = None, origin_ns: int | None = None,
                units: tuple[float, float] = (1.0, 1.0)) -> dict:
    """The truth file's checked columns: time (after the origin; absolute times, after ``origin_ns``, when the
    detections' are absolute), labels, state (positions in lat/lon placed on ``frame``'s plane); its path and
    time column. ``units``: metres per distance unit (x, y, alt), m/s per speed unit (vx, vy)."""
    path, table = _source(path, "truth", dialect)
    dec = _decimal(path, dialect)
    present = _columns(table, path, TRUTH_COLUMNS, mapping)
    position = ["lat", "lon"] if not {"x", "y"} & present.keys() and {"lat", "lon"} & present.keys() else ["x", "y"]
    _require(path, present, ["time", "target_id", *position, "vx", "vy"], mapping, table,
             "a truth file has time, target_id, x, y (or lat, lon), vx, vy")
    tcol = present["time"]
    if is_absolute(table.column(tcol)) != (origin_ns is not None):
        kinds = ("absolute times (date and time)", "seconds (numbers)")
        truth_kind, det_kind = kinds if origin_ns is None else kinds[::-1]
        raise DatasetError(f"{_where(path, 0, tcol)}: the truth file's times are {truth_kind} but the detections' "
                           f"are {det_kind}; write both files' times alike")
    if origin_ns is not None:
        t = seconds_after(absolute_ns(table.column(tcol), lambda row: _where(path, row, tcol)), origin_ns)
    else:
        t = _numeric(table, path, "time", tcol, dec) - time_origin
    values = {c: _numeric(table, path, c, present[c], dec) * units[1] for c in ("vx", "vy")}
    if position[0] == "x":
        values |= {c: _numeric(table, path, c, present[c], dec) * units[0] for c in ("x", "y")}
    else:
        lat, lon, alt = (_numeric(table, path, c, present[c], dec) if c in present else None for c in SITE_FIELDS)
        alt = alt * units[0] if alt is not None else None
        check_geodetic(lat, lon, alt, where=lambda c, row: _where(path, row, present[c]), error=DatasetError)
        values["x"], values["y"] = local_positions(path, present, frame, lat, lon, alt)
    labels = _labels(table, path, present["target_id"])
    if any(v is None for v in labels):
        row = int(np.flatnonzero(np.array([v is None for v in labels]))[0])
        raise DatasetError(f"{_where(path, row, present['target_id'])}: no target id (a truth row needs one)")
    return {"t": t, "labels": labels, "values": values, "path": path, "time_column": present["time"]}


def _truth_scans(truth: dict, time_origin: float, tol: float, sched_time: np.ndarray) -> dict:
    """The truth rows, each repeated for every scan at its time: scan, label, state, source row."""
    t, labels, values, path = truth["t"], truth["labels"], truth["values"], truth["path"]
    present = {"time": truth["time_column"]}
    times = np.unique(sched_time)
    pos = np.clip(np.searchsorted(times, t), 1, max(times.size - 1, 1))
    near = np.where(np.abs(times[pos - 1] - t) <= np.abs(times[np.minimum(pos, times.size - 1)] - t),
                    pos - 1, np.minimum(pos, times.size - 1))
    miss = np.abs(times[near] - t) > tol + 1e-9 * np.maximum(1.0, np.abs(t))
    if miss.any():
        row = int(np.argmax(miss))
        raise DatasetError(f"{_where(path, row, present['time'])}: time {float(t[row] + time_origin)!r} s is no scan's "
                           f"time (nearest {times[near[row]] + time_origin:.6g} s, tolerance {tol:g} s); truth "
                           f"rows must be at the sweeps' times")
    first_scan = np.searchsorted(sched_time, times[near], side="left")
    last_scan = np.searchsorted(sched_time, times[near], side="right")
    reps = last_scan - first_scan
    src = np.repeat(np.arange(t.size), reps)
    scan = (np.concatenate([np.arange(a, b) for a, b in zip(first_scan, last_scan)]) + 1 if t.size
            else np.empty(0, np.int64))
    return {"scan": scan.astype(np.int32), "label": labels[src].tolist(), "row": src, "path": path,
            "time_column": present["time"], "sched_time": sched_time, **{c: v[src] for c, v in values.items()}}


def _placeholder(duration: float) -> Target:
    """The one target of a scenario without labels (a scenario has at least one): at the origin, still."""
    return Target(name="unlabelled", x_m=0, y_m=0, heading_deg=0, speed_m_s=1e-6,
                  segments=[Segment(duration_s=duration)])


def _targets(order: list[str], truth: dict | None, det: Detections, sched_time: np.ndarray, duration: float
             ) -> list[Target]:
    if not order:
        return [_placeholder(duration)]
    targets = []
    labels = np.array(truth["label"], dtype=object) if truth is not None else None
    for i, name in enumerate(order):
        if labels is not None:
            rows = np.flatnonzero(labels == name)
            r0 = rows[np.argmin(truth["scan"][rows])]
            x0, y0, vx, vy = (float(truth[c][r0]) for c in ("x", "y", "vx", "vy"))
            times = sched_time[truth["scan"][rows] - 1]
        else:
            rows = np.flatnonzero(det.target_id == i)
            x0, y0, vx, vy = float(det.x[rows[0]]), float(det.y[rows[0]]), 0.0, 0.0
            times = det.time[rows]
        start, end = float(times.min()), float(times.max())
        targets.append(Target(
            name=name, x_m=x0, y_m=y0, heading_deg=math.degrees(math.atan2(vx, vy)) % 360.0,
            speed_m_s=max(math.hypot(vx, vy), 1e-6), start_time_s=start,
            segments=[Segment(duration_s=max(end - start, 1e-3))]))
    return targets


def _truth_record(truth: dict | None, index: Mapping[str, int], det: Detections) -> Truth:
    if truth is None:
        e = np.empty(0)
        return Truth(scan=np.empty(0, np.int32), time=e, target_id=np.empty(0, np.int32), x=e, y=e, vx=e, vy=e,
                     detected=np.empty(0, bool))
    tid = np.array([index[v] for v in truth["label"]], dtype=np.int32)
    scan = truth["scan"]
    n_targets = max(len(index), 1)
    key = scan.astype(np.int64) * n_targets + tid
    order = np.argsort(key, kind="stable")
    twice = np.flatnonzero(np.diff(key[order]) == 0)
    if twice.size:
        a, b = sorted(truth["row"][order[twice[0]:twice[0] + 2]])
        raise DatasetError(f"{_where(truth['path'], int(b), truth['time_column'])}: target {truth['label'][b]!r} "
                           f"has a second row at the time of data row {a + 1}; one row per target per scan")
    seen = np.zeros(0, np.int64) if not det.scan.size else np.unique(
        det.scan[~det.is_clutter].astype(np.int64) * n_targets + det.target_id[~det.is_clutter])
    k = key[order]
    return Truth(scan=scan[order], time=truth["sched_time"][scan[order] - 1], target_id=tid[order],
                 x=truth["x"][order], y=truth["y"][order], vx=truth["vx"][order], vy=truth["vy"][order],
                 detected=np.isin(k, seen))


def import_detections(path: Source, out: str | Path, overwrite: bool = False, **options) -> tuple[Path, Dataset]:
    """`read_detections` (``options`` as there), then write the dataset atomically at ``out``."""
    dataset = read_detections(path, **options)
    return write_dataset(dataset, out, overwrite), dataset


# ----------------------------------------------------------------------------- the other way

def export_detections(dataset: Dataset, path: str | Path, truth: str | Path | None = None) -> None:
    """Write ``dataset``'s detections (and truth) in the import schema, CSV or Parquet by suffix: time, sensor
    (name), range, azimuth (rad), x, y, target_id (the target's name; empty for clutter); with a geodetic
    origin also lat, lon (deg). `read_detections` with the scenario's sensors (`sensor_specs`) reads them back
    into the same scans (x, y taken before lat, lon)."""
    d, sc = dataset.detections, dataset.scenario
    names = np.array([t.name for t in sc.targets], dtype=object)
    labels = np.where(d.target_id < 0, None, names[np.maximum(d.target_id, 0)])
    _write(pa.table({"time": d.time, "sensor": np.array([s.name for s in sc.sensors], dtype=object)[d.sensor],
                     "range": d.range, "azimuth": d.azimuth, "x": d.x, "y": d.y, **_degrees(dataset, d.x, d.y),
                     "target_id": pa.array(labels.tolist(), pa.string())}), Path(path))
    if truth is not None:
        t = dataset.truth
        once = np.sort(np.unique(np.column_stack([t.time, t.target_id]), axis=0, return_index=True)[1])
        _write(pa.table({"time": t.time[once], "target_id": pa.array(names[t.target_id[once]].tolist(), pa.string()),
                         "x": t.x[once], "y": t.y[once], **_degrees(dataset, t.x[once], t.y[once]),
                         "vx": t.vx[once], "vy": t.vy[once]}), Path(truth))


def _degrees(dataset: Dataset, x: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
    """``lat``, ``lon`` (deg) of points x, y (m) at the height of the dataset's geodetic origin; {} without
    one."""
    if dataset.geodetic_origin is None:
        return {}
    lat, lon = dataset.geodetic_origin.on_surface(x, y)
    return {"lat": lat, "lon": lon}


def sensor_specs(scenario: Scenario) -> list[dict]:
    """The scenario's sensors as `read_detections` takes them (every field but clutter)."""
    return [s.model_dump(mode="json", exclude={"clutter"}) for s in scenario.sensors]


def _write(table: pa.Table, path: Path) -> None:
    with atomic_output(path, overwrite=True, directory=False) as tmp:  # a whole file, or none
        if path.suffix.lower() == ".csv":
            pacsv.write_csv(table, tmp)
        else:
            pq.write_table(table, tmp)
