"""File helpers every stage shares: atomic files and directories, canonical JSON, manifests, digests.

Whatever nnda writes appears whole or not at all: it is written to a
temporary sibling and renamed into place. Manifests are JSON documents with
a ``format`` and a ``format_version``; `read_json` refuses any other with an
error that names the file and the field.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import tempfile
import tomllib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import nnda
from nnda.errors import ConfigError, DatasetError, NndaError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


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
        tmp.chmod(0o666 & ~_umask())  # mkstemp makes it private; the result is an ordinary file
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


@contextmanager
def atomic_directory(out: str | Path, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary sibling of ``out`` to fill; rename it to ``out`` on success.

    On any error the temporary directory is removed and ``out`` is untouched.
    An existing ``out`` is refused unless ``overwrite`` is true.
    """
    out = Path(out)
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out}: already exists (pass overwrite to replace it)")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".partial", dir=out.parent))
    tmp.chmod(0o777 & ~_umask())  # mkdtemp makes it private; the result is an ordinary directory
    try:
        yield tmp
        if out.exists():
            old = out.with_name(f".{out.name}.{os.getpid()}.old")
            out.rename(old)
            tmp.rename(out)
            shutil.rmtree(old)
        else:
            tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
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


def read_json(path: str | Path, expected_format: str, version: int | tuple[int, ...],
              error: type[NndaError] = DatasetError) -> dict:
    """Read a JSON document of ``expected_format`` and ``version`` (or one of several); ``error`` naming the
    file otherwise."""
    path = Path(path)
    if not path.is_file():
        raise error(f"{path}: missing")
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise error(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != expected_format:
        found = data.get("format") if isinstance(data, dict) else type(data).__name__
        raise error(f"{path}: field 'format' is {found!r}, expected {expected_format!r}")
    versions = (version,) if isinstance(version, int) else version
    if data.get("format_version") not in versions:
        raise error(f"{path}: field 'format_version' is {data.get('format_version')!r}; this nnda "
                    f"({nnda.__version__}) reads version {' or '.join(map(str, versions))} only")
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


def read_config(path: str | Path, what: str) -> dict:
    """The mapping in a ``.toml`` or ``.json`` config file; ConfigError naming the file otherwise."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such {what} file")
    try:
        if path.suffix == ".toml":
            return tomllib.loads(path.read_text())
        if path.suffix == ".json":
            data = json.loads(path.read_text())
            if not isinstance(data, dict):
                raise ConfigError(f"{path}: a {what} must be a JSON object, got {type(data).__name__}")
            return data
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: not valid {path.suffix[1:].upper()}: {exc}") from None
    raise ConfigError(f"{path}: unknown {what} file type {path.suffix!r} (use .toml or .json)")
