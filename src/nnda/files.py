"""File helpers every stage shares: atomic files and directories, canonical JSON, manifests, digests.

Whatever nnda writes appears whole or not at all: it is written to a
temporary sibling and renamed into place, and a failed write (full or
read-only disk) is an `OutputError` that leaves nothing behind. Manifests
are JSON documents with a ``format`` and a ``format_version``; `read_json`
refuses any other with an error that names the file and the field. A
manifest records the SHA-256 of each data file beside it (`file_digests`),
checked on read (`verify_digests`), so a flipped byte is a "corrupt file"
error rather than data. Names that become path components pass
`path_component`; an output path passes `check_output_path` against the
inputs (`check_output_location` also keeps it off the working directory);
`directory_lock` keeps a second writer off one output. A document that
guards itself (a model file) records `content_digest` of its other fields.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import socket
import tempfile
import tomllib
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from nnda.errors import ConfigError, DatasetError, NndaError, OutputError
from nnda.version import __version__


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _unwritable(path: Path, exc: OSError) -> OutputError:
    """The error for a write that failed at ``path`` (full or read-only disk, no permission, ...)."""
    return OutputError(f"{path}: cannot write ({exc.strerror or exc}); nothing was written or changed there")


@contextmanager
def atomic_file(path: str | Path) -> Iterator[Path]:
    """Yield a temporary sibling of ``path`` to write; it replaces ``path`` only on success.

    An OSError while writing (full or read-only disk) becomes an `OutputError`; ``path`` is untouched.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent)
    except OSError as exc:
        raise _unwritable(path, exc) from None
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        tmp.chmod(0o666 & ~_umask())  # mkstemp makes it private; the result is an ordinary file
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, NndaError):
            raise
        raise _unwritable(path, exc) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


@contextmanager
def atomic_directory(out: str | Path, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary sibling of ``out`` to fill; rename it to ``out`` on success.

    On any error the temporary directory is removed and ``out`` is untouched;
    an OSError while writing (full or read-only disk) becomes an `OutputError`.
    An existing ``out`` is refused unless ``overwrite`` is true, and a file
    (not a directory) at ``out`` is never replaced.
    """
    out = Path(out)
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out}: already exists (pass overwrite to replace it)")
    if out.exists() and not out.is_dir():
        raise OutputError(f"{out}: is a file, not a directory; refusing to replace it with one")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".partial", dir=out.parent))
    except OSError as exc:
        raise _unwritable(out, exc) from None
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
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, NndaError):  # a nested write's error: name the output, not its temporary copy
            raise type(exc)(str(exc).replace(str(tmp), str(out))) from None
        raise _unwritable(out, exc) from None
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
                    f"({__version__}) reads version {' or '.join(map(str, versions))} only")
    return data


def canonical(data: Any) -> bytes:
    """The canonical JSON bytes of ``data`` (sorted keys, no spaces, other types by ``str``): the input of a
    digest that must not depend on key order or formatting (job keys, scene digests)."""
    return json.dumps(data, sort_keys=True, separators=(",", ":"), default=str).encode()


def digest(*parts: bytes) -> str:
    """SHA-256 hex digest of the concatenated byte strings."""
    h = hashlib.sha256()
    for p in parts:
        h.update(p)
    return h.hexdigest()


def content_digest(doc: dict, field: str) -> str:
    """SHA-256 of ``doc``'s canonical one-line JSON (`dumps`) without its key ``field``: the digest a
    document records of itself, so a hand edit of any other value is caught on read."""
    return digest(dumps({k: v for k, v in doc.items() if k != field}, indent=None).encode())


def with_content_digest(doc: dict, field: str) -> dict:
    """``doc`` as it reads back from JSON (tuples as lists, NaN as null, keys as strings) with its
    `content_digest` under ``field``."""
    doc = json.loads(dumps(doc))
    doc[field] = content_digest(doc, field)
    return doc


def file_digest(*paths: Path) -> str:
    """SHA-256 of the files' contents, in the order given."""
    return digest(*(Path(p).read_bytes() for p in paths))


def file_digests(directory: Path, names: Iterable[str]) -> dict[str, str]:
    """SHA-256 of each named file in ``directory``, by name: what a manifest records of its data files."""
    digests = {}
    for name in names:
        with open(directory / name, "rb") as f:
            digests[name] = hashlib.file_digest(f, "sha256").hexdigest()
    return digests


def verify_digests(directory: Path, recorded: dict[str, str], error: type[NndaError] = DatasetError) -> None:
    """Raise ``error`` naming the first file of ``recorded`` (name -> SHA-256) whose content differs."""
    for name, want in recorded.items():
        path = directory / name
        if not path.is_file():
            raise error(f"{path}: missing (the manifest lists it)")
        got = file_digests(directory, [name])[name]
        if got != want:
            raise error(f"{path}: corrupt file: its SHA-256 is {got[:16]}..., the manifest recorded "
                        f"{want[:16]}...; regenerate it or restore a good copy")


def path_component(name: str, what: str) -> str:
    """``name`` if it is safe as one file or directory name (no separator, not empty, '.' or '..',
    no leading dot or NUL); ConfigError naming ``what`` otherwise."""
    if not name or name.startswith(".") or any(c in name for c in ("/", "\\", "\0")):
        raise ConfigError(f"{what}: {name!r} cannot name a file (no path separators, no leading dot, "
                          f"not '.' or '..')")
    return name


def check_output_path(out: str | Path, inputs: Iterable[str | Path], what: str = "--out") -> None:
    """Raise OutputError if ``out`` is, contains or lies inside one of ``inputs`` (paths resolved)."""
    target = Path(out).resolve()
    for given in inputs:
        source = Path(given).resolve()
        if target == source or source.is_relative_to(target) or target.is_relative_to(source):
            relation = ("is" if target == source else "contains" if source.is_relative_to(target)
                        else "lies inside")
            raise OutputError(f"{what} {out} {relation} the input {given}; write the output elsewhere")


def check_output_location(out: str | Path, inputs: Iterable[str | Path] = (), what: str = "--out") -> None:
    """`check_output_path` against ``inputs``, and an OutputError if ``out`` is the working directory or
    contains it (replacing it would remove the directory the command runs in)."""
    here = Path.cwd().resolve()
    target = Path(out).resolve()
    if here.is_relative_to(target):
        relation = "is" if here == target else "contains"
        raise OutputError(f"{what} {out} {relation} the current directory {here}; name a new directory for the "
                          f"output")
    check_output_path(out, inputs, what)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@contextmanager
def directory_lock(out: str | Path) -> Iterator[Path]:
    """Hold a lock on output ``out`` (a sibling file ``.<name>.lock``) while the body writes it.

    A second writer is refused with an OutputError naming the holder; a lock
    left by a process that is gone (same host) is taken over.
    """
    out = Path(out)
    lock = out.with_name(f".{out.name}.lock")
    me = f"{socket.gethostname()} {os.getpid()}\n"
    try:
        lock.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _unwritable(out, exc) from None
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            host, _, pid = lock.read_text().strip().partition(" ")
            if host == socket.gethostname() and pid.isdigit() and not _alive(int(pid)):
                lock.unlink(missing_ok=True)  # its writer is gone: take it over
                continue
            raise OutputError(f"{out}: another nnda process ({host} pid {pid}) is writing it; wait for it to "
                              f"finish, or remove {lock} if that process is gone") from None
        except OSError as exc:
            raise _unwritable(out, exc) from None
        with os.fdopen(fd, "w") as f:
            f.write(me)
        break
    else:
        raise OutputError(f"{out}: could not take the lock {lock}")
    try:
        yield lock
    finally:
        if lock.exists() and lock.read_text() == me:
            lock.unlink()


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
