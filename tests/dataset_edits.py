"""Helpers of the tests that damage files on purpose: edit a dataset as another writer would, flip a byte,
and take stock of a directory before and after a command."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from nnda.data.dataset import manifest_seal
from nnda.files import file_digests


def edit_manifest(directory: Path, change: Callable[[dict], None], name: str = "scenario.json",
                  reseal: bool = True) -> None:
    """Apply ``change`` to the parsed JSON manifest ``directory / name`` and write it back, sealed again as a
    writer of those values would have (``reseal``; False: a hand edit, which the seal then refuses)."""
    path = directory / name
    doc = json.loads(path.read_text())
    change(doc)
    if reseal and "manifest_sha256" in doc:
        doc["manifest_sha256"] = manifest_seal(doc)
    path.write_text(json.dumps(doc))


def as_format(version: int) -> Callable[[dict], None]:
    """An `edit_manifest` change: the manifest as a writer of format ``version`` wrote it (the fields of later
    versions gone, and the version of nnda that wrote such files: 0.2.0 and later write only format 4)."""
    def change(doc: dict) -> None:
        doc["format_version"] = version
        if version < 4:
            doc["nnda_version"] = "0.1.0"
        for field, since in (("sha256", 3), ("manifest_sha256", 4)):
            if version < since:
                doc.pop(field, None)
    return change


def rewrite_table(directory: Path, name: str, change: Callable[[pa.Table], pa.Table]) -> None:
    """Rewrite the Parquet file ``name`` of a dataset through ``change`` and record its new digest, as a
    writer that made these values would have: the dataset's checks then see the values, not a corrupt file."""
    pq.write_table(change(pq.read_table(directory / name)), directory / name)
    edit_manifest(directory, lambda m: m["sha256"].update(file_digests(directory, [name])))


def set_value(column: str, row: int, value) -> Callable[[pa.Table], pa.Table]:
    """A `rewrite_table` change: ``column[row] = value``, keeping the column's type."""
    def change(table: pa.Table) -> pa.Table:
        values = table.column(column).to_numpy().copy()
        values[row] = value
        i = table.schema.get_field_index(column)
        return table.set_column(i, column, pa.array(values, type=table.schema.field(column).type))
    return change


def flip_byte(path: Path, offset: int) -> None:
    """Invert one bit of the byte at ``offset`` of ``path`` (negative: from the end)."""
    data = bytearray(path.read_bytes())
    data[offset] ^= 0x01
    path.write_bytes(bytes(data))


def snapshot(root: Path) -> dict[str, bytes | None]:
    """Every entry under ``root``, hidden ones included: relative path -> bytes (None for a directory)."""
    return {p.relative_to(root).as_posix(): None if p.is_dir() else p.read_bytes() for p in sorted(root.rglob("*"))}
