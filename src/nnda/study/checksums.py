"""The SHA-256 of every file a study's aggregation writes, and the checked way to read one back.

    write_checksums(out, ["summary.json", "results.parquet"], fingerprint)   # out/checksums.json
    path = read_checked(out, "results.parquet")      # DatasetError if missing, unlisted or changed
    table = read_table(out, "results.parquet", columns=["scenario"])        # checked, then read

A report built from a corrupt or hand-edited file would be wrong without
saying so; every reader of a study directory goes through here instead.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from nnda.errors import DatasetError
from nnda.files import file_digest, read_json, write_json

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
    sums = read_json(out / CHECKSUMS_FILE, CHECKSUMS_FORMAT, CHECKSUMS_VERSION)
    want = sums.get("sha256", {}).get(name)
    if want is None:
        raise DatasetError(f"{path}: not among the files this study wrote ({CHECKSUMS_FILE})")
    if file_digest(path) != want:
        raise DatasetError(f"{path}: corrupt or edited (its SHA-256 differs from {CHECKSUMS_FILE}); run the study "
                           f"again with --resume to rebuild it")
    return path


def read_table(out: str | Path, name: str, columns: list[str] | None = None) -> pa.Table:
    """A checked Parquet table of a study directory (`read_checked`); DatasetError naming it if unreadable."""
    path = read_checked(out, name)
    try:
        return pq.read_table(path, columns=columns)
    except (pa.ArrowException, OSError) as exc:
        raise DatasetError(f"{path}: not a readable Parquet table ({exc})") from None
