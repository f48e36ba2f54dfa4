"""The SHA-256 of every file a study's aggregation writes, and the checked way to read one back.

    write_checksums(out, ["summary.json", "results.parquet"], fingerprint)   # out/checksums.json
    path = read_checked(out, "results.parquet")      # DatasetError if missing, unlisted or changed
    table = read_table(out, "results.parquet", columns=["scenario"])        # checked, then read
    schema = read_schema(out, "results.parquet")                             # checked, its footer read

A report built from a corrupt or hand-edited file would be wrong without
saying so; every reader of a study directory goes through here instead.
``checksums.json`` names files of its own directory only (`listed`: plain
names, no symbolic link out of it), and a Parquet file that does not parse
is a DatasetError naming it, on one line, whatever the reader says.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from nnda.errors import DatasetError
from nnda.files import file_digest, listed_file, read_json, write_json

CHECKSUMS_FORMAT = "nnda.study-checksums"
CHECKSUMS_VERSION = 1
CHECKSUMS_FILE = "checksums.json"


def write_checksums(out: Path, names: Iterable[str], fingerprint: str) -> None:
    """``out``/checksums.json: the SHA-256 of each named file of ``out`` and the study's fingerprint."""
    write_json(out / CHECKSUMS_FILE, {"format": CHECKSUMS_FORMAT, "format_version": CHECKSUMS_VERSION,
                                      "fingerprint": fingerprint,
                                      "sha256": {n: file_digest(out / n) for n in sorted(names)}})


def read_checked(out: str | Path, name: str) -> Path:
    """The path of study file ``name`` in ``out`` once its SHA-256 matches ``checksums.json``; DatasetError
    naming the file when it is missing, not listed, or changed since the study wrote it."""
    out = Path(out)
    path = out / name
    if not path.is_file():
        raise DatasetError(f"{path}: missing (run the study to completion first)")
    want = listed(out).get(name)
    if want is None:
        raise DatasetError(f"{path}: not among the files this study wrote ({CHECKSUMS_FILE})")
    if file_digest(path) != want:
        raise DatasetError(f"{path}: corrupt or edited (its SHA-256 differs from {CHECKSUMS_FILE}); run the study "
                           f"again with --resume to rebuild it")
    return path


def listed(out: str | Path) -> dict[str, str]:
    """``checksums.json`` of study directory ``out``: file name -> SHA-256, each name a file of ``out`` itself
    (`nnda.files.listed_file`); DatasetError naming the file and the entry otherwise."""
    out = Path(out)
    where = out / CHECKSUMS_FILE
    sums = read_json(where, CHECKSUMS_FORMAT, CHECKSUMS_VERSION)
    recorded = sums.get("sha256")
    if not isinstance(recorded, dict) or not all(isinstance(v, str) for v in recorded.values()):
        raise DatasetError(f"{where}: field 'sha256' must map each file's name to its SHA-256, got "
                           f"{type(recorded).__name__}; run the study again with --resume to rebuild it")
    for name in recorded:
        listed_file(out, name, where)
    return recorded


#: what a Parquet reader raises on a damaged file (ArrowInvalid and ArrowIOError are ValueError and OSError)
_UNREADABLE = (pa.ArrowException, OSError, ValueError)


def _unreadable(path: Path, exc: Exception) -> DatasetError:
    reason = " ".join(str(exc).split())  # one line, whatever the reader said
    return DatasetError(f"{path}: not a readable Parquet table ({reason}); run the study again with --resume to "
                        f"rebuild it")


def read_table(out: str | Path, name: str, columns: list[str] | None = None) -> pa.Table:
    """A checked Parquet table of a study directory (`read_checked`); DatasetError naming it if unreadable."""
    path = read_checked(out, name)
    try:
        return pq.read_table(path, columns=columns)
    except _UNREADABLE as exc:
        raise _unreadable(path, exc) from None


def read_schema(out: str | Path, name: str) -> pa.Schema:
    """The schema of a checked Parquet table of a study directory (its footer only: cheap);
    DatasetError naming it if unreadable."""
    path = read_checked(out, name)
    try:
        return pq.read_schema(path)
    except _UNREADABLE as exc:
        raise _unreadable(path, exc) from None
