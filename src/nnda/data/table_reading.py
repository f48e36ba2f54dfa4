"""Reading an imported table: a CSV (its dialect: delimiter, decimal mark, encoding) or Parquet file, or a table
in memory, and its columns as checked numbers, texts and target labels.

Every refusal is a `DatasetError` (the file's content) or a `ConfigError`
(the options) naming the file, the data row (1-based, the header not
counted) and the column (`where_in`); `nnda.data.detections_import` reads
the detections, truth and polygon files with these.
"""

from __future__ import annotations

import codecs
import csv
import io
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from nnda.errors import ConfigError, DatasetError

#: an import refuses a range, x, y (m) or velocity (m/s) of a larger magnitude (a unit error; filters square them)
MAX_MAGNITUDE = 1e12
#: --delimiter values a CSV may use (the spellings of a tab included), and the separators they stand for
DELIMITERS = {",": ",", ";": ";", "|": "|", "\t": "\t", "\\t": "\t", "tab": "\t"}
#: --decimal values: the decimal mark of the CSV's numbers
DECIMAL_MARKS = (".", ",")
#: bytes of a CSV read to guess its dialect when it does not parse
_SNIFF_BYTES = 1 << 16
#: a compressed CSV's last suffix -> pyarrow's codec (the file is read as it is decompressed) and the command-line
#: tool that tests (-t) and decompresses (-dc) such a file
COMPRESSIONS = {".gz": ("gzip", "gzip"), ".bz2": ("bz2", "bzip2"), ".zst": ("zstd", "zstd")}


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


def read_source(source: Source, what: str, dialect: CsvDialect = CsvDialect()) -> tuple[Path | InMemory, pa.Table]:
    """The label and the table of a file (path) or of a table given in memory (pyarrow or pandas)."""
    if isinstance(source, (str, Path)):
        path = Path(source)
        return path, read_table(path, what, dialect)
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


def table_kind(path: Path | InMemory) -> tuple[str, str]:
    """The table format of ``path`` by its suffixes (".csv", ".parquet", ...; lower case) and its compression
    suffix (".gz", ".bz2", ".zst"; "" for none): "plots.csv.gz" -> (".csv", ".gz")."""
    suffix = path.suffix.lower()
    if suffix in COMPRESSIONS:
        return Path(path.stem).suffix.lower(), suffix
    return suffix, ""


def table_stem(path: Path | InMemory) -> str:
    """The name of ``path`` without its table and compression suffixes: "plots.csv.gz" -> "plots"."""
    return Path(path.stem).stem if table_kind(path)[1] else path.stem


def _text_stream(path: Path) -> pa.NativeFile:
    """The bytes of the CSV at ``path``, decompressed as read when its suffix names a compression."""
    packed = table_kind(path)[1]
    return pa.input_stream(str(path), compression=COMPRESSIONS[packed][0] if packed else None)


def _to_utf8(path: Path) -> str:
    """A shell command that writes the CSV at ``path`` (decompressed), read as cp1252, as UTF-8."""
    packed, out = table_kind(path)[1], f"{table_stem(path)}-utf8.csv"
    if packed:
        return f"{COMPRESSIONS[packed][1]} -dc {path.name} | iconv -f cp1252 -t utf-8 > {out}"
    return f"iconv -f cp1252 -t utf-8 {path.name} > {out}"


def read_table(path: Path, what: str, dialect: CsvDialect = CsvDialect()) -> pa.Table:
    """The table of the CSV (plain, .gz, .bz2 or .zst) or Parquet file at ``path`` (``what`` names it in
    messages); DatasetError when it cannot be read, ConfigError for another kind of file."""
    if not path.is_file():
        raise DatasetError(f"{what} {path}: no such file")
    suffix, packed = table_kind(path)
    try:
        if suffix == ".csv":
            return _read_csv(path, what, dialect)
        if suffix in (".parquet", ".pq") and not packed:
            return _named(pq.read_table(path), path, what)
    except (pa.ArrowException, OSError) as exc:
        if packed:  # a damaged or mislabelled compressed file fails as it is decompressed
            codec, tool = COMPRESSIONS[packed]
            raise DatasetError(f"{what} {path}: not readable as {codec}-compressed CSV ({exc}); the file is damaged "
                               f"or not {codec} data: check it with {tool} -t {path.name}, or give the CSV "
                               f"uncompressed") from None
        raise DatasetError(f"{what} {path}: unreadable {suffix[1:]} file ({exc})") from None
    if packed and suffix in (".parquet", ".pq"):
        raise ConfigError(f"{what} {path}: a compressed Parquet file is not read (Parquet compresses its columns "
                          f"itself); give the {suffix} file uncompressed")
    shown = suffix + packed or "(no suffix)"
    raise ConfigError(f"{what} {path}: unknown file type {shown!r}; give a .csv (or .csv.gz, .csv.bz2, .csv.zst) "
                      f"or .parquet file")


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
    """The CSV at ``path`` (decompressed as read when compressed) in ``dialect``; DatasetError naming the first
    undecodable byte's line and column, or the dialect the header suggests when the file does not parse in this
    one. OSError when a compressed file does not decompress."""
    # only an empty cell is null: "nan" is a number (refused as not finite), "NA" text (not a number)
    convert = pacsv.ConvertOptions(null_values=[""], strings_can_be_null=True, decimal_point=dialect.decimal)
    read = pacsv.ReadOptions(encoding="utf8" if dialect.encoding == "utf-8" else dialect.encoding)
    with _text_stream(path) as f:
        start = f.read(4)
    for bom, name in ((codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
                      (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16")):
        if start.startswith(bom) and not dialect.encoding.startswith(name):
            raise DatasetError(f"{what} {path}: line 1: the file starts with a {name.upper()} byte-order mark: it is "
                               f"{name.upper()} text, not {dialect.encoding}: pass --encoding {name}")
    try:
        with _text_stream(path) as f:
            table = pacsv.read_csv(f, read_options=read, convert_options=convert,
                                   parse_options=pacsv.ParseOptions(delimiter=dialect.delimiter))
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
        with _text_stream(path) as f:
            head = f.read(_SNIFF_BYTES).decode(dialect.encoding, errors="replace").lstrip("\ufeff")
    except (OSError, UnicodeError, LookupError, pa.ArrowException):
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
               f"file to UTF-8, e.g. {_to_utf8(path)}")
    with _text_stream(path) as f:
        data = f.read()
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


def decimal_mark(path: Path | InMemory, dialect: CsvDialect) -> str:
    """The decimal mark of text numbers in the file at ``path``: the dialect's in a CSV, a point otherwise."""
    return dialect.decimal if table_kind(path)[0] == ".csv" else "."


def where_in(path: Path | InMemory, row: int, column: str) -> str:
    """A cell for a message: the file, its data row (``row`` 0-based; the line in a CSV) and column."""
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


def numbers_of(table: pa.Table, path: Path, name: str, column: str, decimal: str = ".") -> np.ndarray:
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
                raise DatasetError(f"{where_in(path, row, column)}: {_not_a_number(v, name, decimal)}")
            a[row] = float(v.replace(decimal, "."))
    elif pa.types.is_integer(col.type) or pa.types.is_floating(col.type):
        if col.null_count:
            row = int(pc.index(pc.is_null(col), True).as_py())
            raise DatasetError(f"{where_in(path, row, column)}: an empty cell ({name} must be a number)")
        a = col.to_numpy().astype(np.float64, copy=False)
    else:  # booleans, dates, bytes, all-empty columns: the first cell says what it is
        v = col[0].as_py()
        raise DatasetError(f"{where_in(path, 0, column)}: {_not_a_number(v, name, decimal)[:-1]}; the column holds "
                           f"{col.type})")
    bad = ~np.isfinite(a)
    if bad.any():
        row = int(np.argmax(bad))
        raise DatasetError(f"{where_in(path, row, column)}: {float(a[row])!r} ({name} must be a finite number)")
    unit = {"range": "m", "x": "m", "y": "m", "vx": "m/s", "vy": "m/s", "alt": "m"}.get(name)
    if unit and (bad := np.abs(a) > MAX_MAGNITUDE).any():
        row = int(np.argmax(bad))
        raise DatasetError(f"{where_in(path, row, column)}: {name} {float(a[row])!r} {unit} is beyond "
                           f"+-{MAX_MAGNITUDE:g} {unit} (another unit?)")
    return a


def texts_of(table: pa.Table, path: Path, column: str) -> list:
    """Column ``column``'s values, bytes (a Parquet binary column) decoded as UTF-8; DatasetError at the first
    that is not."""
    values = table.column(column).to_pylist()
    for row, v in enumerate(values):
        if isinstance(v, bytes):
            try:
                values[row] = v.decode("utf-8")
            except UnicodeDecodeError:
                raise DatasetError(f"{where_in(path, row, column)}: {v!r} is not UTF-8 text") from None
    return values


def labels_of(table: pa.Table, path: Path, column: str) -> np.ndarray:
    """Column ``column`` as text labels (object array); None where the cell is empty or a negative integer
    (clutter)."""
    col = table.column(column)
    if pa.types.is_floating(col.type):
        a = col.to_numpy(zero_copy_only=False)  # an empty cell is NaN
        bad = np.isinf(a) | (np.isfinite(a) & (a != np.round(a)))
        if bad.any():
            row = int(np.argmax(bad))
            raise DatasetError(f"{where_in(path, row, column)}: {float(a[row])!r} (a target id is a whole number or "
                               f"text)")
        bad = np.abs(a) > 2.0 ** 53
        if bad.any():  # read as a float, it is no longer the integer written
            row = int(np.argmax(bad))
            raise DatasetError(f"{where_in(path, row, column)}: {float(a[row])!r} (a target id beyond +-2**53 is not "
                               f"read exactly; use shorter ids, or text with a letter)")
        return np.array([None if not math.isfinite(v) or v < 0 else str(int(v)) for v in a.tolist()], dtype=object)
    if pa.types.is_integer(col.type):
        return np.array([None if v is None or v < 0 else str(v) for v in col.to_pylist()], dtype=object)
    return np.array([None if v is None or str(v) == "" else str(v) for v in texts_of(table, path, column)],
                    dtype=object)


def find_columns(table: pa.Table, path: Path, names: Sequence[str], mapping: Mapping[str, str]) -> dict[str, str]:
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


def require_columns(path: Path, present: Mapping[str, str], names: Sequence[str], mapping: Mapping[str, str],
                    table: pa.Table, why: str) -> None:
    """DatasetError naming the ``names`` (nnda's) not ``present`` in ``path``'s table, the file's columns,
    and ``why`` they are needed."""
    missing = [mapping.get(n, n) for n in names if n not in present]
    if missing:
        raise DatasetError(f"{path}: required column(s) {', '.join(map(repr, missing))} missing ({why}); the file "
                           f"has {', '.join(table.column_names) or 'no columns'} (map names with --column "
                           f"NAME=COLUMN)")
