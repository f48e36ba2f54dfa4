"""Small file helpers of the study and report stages: atomic writes and canonical JSON."""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from nnda.errors import DatasetError


@contextmanager
def atomic_file(path: str | Path) -> Iterator[Path]:
    """Yield a temporary sibling of ``path`` to write; it replaces ``path`` only on success."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        mask = os.umask(0)
        os.umask(mask)
        tmp.chmod(0o666 & ~mask)  # mkstemp makes it private; the result is an ordinary file
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def finite_or_none(value: float) -> float | None:
    """JSON has no NaN: undefined numbers (a hit rate with no contacts, ...) are written as null."""
    return None if value is None or not math.isfinite(value) else value


def _clean(data: Any) -> Any:
    if isinstance(data, float):
        return finite_or_none(data)
    if isinstance(data, dict):
        return {k: _clean(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [_clean(v) for v in data]
    return data


def dumps(data: Any, indent: int | None = 1) -> str:
    """Canonical JSON text: sorted keys, full float precision, NaN and infinities as null, newline-terminated."""
    return json.dumps(_clean(data), indent=indent, sort_keys=True, allow_nan=False) + "\n"


def write_json(path: str | Path, data: Any, indent: int | None = 1) -> Path:
    """Write canonical JSON atomically (``indent`` None: one line); returns the path."""
    text = dumps(data, indent)
    with atomic_file(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def read_json(path: str | Path, expected_format: str, version: int) -> dict:
    """Read a JSON document of ``expected_format`` and ``version``; DatasetError naming the file otherwise."""
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"{path}: missing")
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != expected_format:
        found = data.get("format") if isinstance(data, dict) else type(data).__name__
        raise DatasetError(f"{path}: field 'format' is {found!r}, expected {expected_format!r}")
    if data.get("format_version") != version:
        raise DatasetError(f"{path}: field 'format_version' is {data.get('format_version')!r}, "
                           f"this nnda reads version {version}")
    return data


def digest(*parts: bytes) -> str:
    """SHA-256 hex digest of the concatenated byte strings."""
    h = hashlib.sha256()
    for p in parts:
        h.update(p)
    return h.hexdigest()


def file_digest(*paths: Path) -> str:
    """SHA-256 of the files' contents, in the order given."""
    return digest(*(Path(p).read_bytes() for p in paths))
