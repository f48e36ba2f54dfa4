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

A command writes its ``--out`` through `atomic_output` (a directory or one
file): it holds the lock, refuses a symbolic link at ``--out``, and names its
temporary ``.<out>.<host>-<pid>.<random>.partial``, so that the temporaries
and the lock a killed process left are removed by the next writer of that
output once their writer is gone (`sweep_stale`; `sweep_stale_within` for a
study directory, whose finished jobs stay).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import hashlib
import json
import math
import os
import re
import shutil
import signal
import socket
import sys
import tempfile
import threading
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


# ----------------------------------------------------------------------------- temporaries and their writers

def _host() -> str:
    """This host's name as it appears in a temporary's name (letters, digits, '.' and '-'; at most 32)."""
    return re.sub(r"[^A-Za-z0-9.-]", "_", socket.gethostname())[:32] or "host"


def _writer() -> str:
    """``<host>-<pid>``: who writes a temporary, encoded in its name so a later run can tell a dead writer's."""
    return f"{_host()}-{os.getpid()}"


def _temporaries(name: str | None = None, kinds: str = "partial|old") -> re.Pattern:
    """Temporaries written on this host, of output ``name`` (None: of any output):
    ``.<name>.<host>-<pid>.<random>.partial`` (or ``.old``: an earlier output being replaced); groups ``pid``
    and ``kind``."""
    named = ".+" if name is None else re.escape(name)
    return re.compile(rf"\.{named}\.{re.escape(_host())}-(?P<pid>\d+)\.[a-z0-9_]+\.(?P<kind>{kinds})")


def _temporary(path: Path, directory: bool) -> Path:
    """A new, empty temporary sibling of ``path`` (a directory, or a file), named for this writer
    (``.<name>.<host>-<pid>.<random>.partial``). OSError as raised."""
    prefix = f".{path.name}.{_writer()}."
    if directory:
        tmp = Path(tempfile.mkdtemp(prefix=prefix, suffix=".partial", dir=path.parent))
        tmp.chmod(0o777 & ~_umask())  # mkdtemp makes it private; the result is an ordinary directory
        return tmp
    fd, name = tempfile.mkstemp(prefix=prefix, suffix=".partial", dir=path.parent)
    os.close(fd)
    return Path(name)


def _put_file(tmp: Path, path: Path) -> None:
    """The finished temporary file ``tmp`` takes the place of ``path``, with an ordinary file's mode."""
    tmp.chmod(0o666 & ~_umask())  # mkstemp makes it private
    os.replace(tmp, path)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def _warn(text: str) -> None:
    """One warning line on stderr (the command line's "warning:" form)."""
    print(f"warning: {text}", file=sys.stderr, flush=True)


def _tell_removed(paths: list[Path], where: Path) -> None:
    if paths:
        shown = ", ".join(p.name for p in paths[:5]) + (f" and {len(paths) - 5} more" if len(paths) > 5 else "")
        _warn(f"removed {len(paths)} stale temporary file(s) in {where} left by nnda processes on this host "
              f"that are gone: {shown}")


def sweep_stale(out: str | Path) -> list[Path]:
    """Remove the temporaries beside output ``out`` whose writer (the pid in the name) is dead on this host;
    never a live writer's, nor another host's. An earlier output a dead writer had moved aside to replace it
    (``.old``) is put back when ``out`` is missing, and removed otherwise. Says on stderr what it removed;
    returns the paths removed."""
    out = Path(out)
    try:
        names = os.listdir(out.parent)
    except OSError:
        return []
    pattern, removed = _temporaries(out.name), []
    for name in sorted(names):
        found = pattern.fullmatch(name)
        if found is None or _alive(int(found["pid"])):
            continue
        path = out.parent / name
        if found["kind"] == "old" and not os.path.lexists(out):
            path.rename(out)
            _warn(f"restored {out} from {path.name}, which nnda process {found['pid']} on this host had moved "
                  f"aside to replace it before it was stopped")
            continue
        _remove(path)
        removed.append(path)
    _tell_removed(removed, out.parent)
    return removed


def sweep_stale_within(directory: str | Path) -> list[Path]:
    """Remove nnda's own temporaries (``.<name>.<host>-<pid>.<random>.partial``) anywhere under ``directory``
    whose writer is dead on this host: what a stopped study left in its directory. Every other file (a finished
    job's record above all) stays. Says on stderr what it removed; returns the paths removed."""
    directory = Path(directory)
    pattern = _temporaries(kinds="partial")
    removed = []
    for root, dirs, files in os.walk(directory):
        for name in [*dirs, *files]:
            found = pattern.fullmatch(name)
            if found is not None and not _alive(int(found["pid"])):
                _remove(Path(root) / name)
                removed.append(Path(root) / name)
        dirs[:] = [d for d in dirs if (Path(root) / d).exists()]
    _tell_removed(removed, directory)
    return removed


@contextmanager
def _termination_unwinds() -> Iterator[None]:
    """While the body runs, SIGTERM raises SystemExit(143) in the main thread (when nothing else handles it),
    so the ``finally`` clauses that remove temporaries and the lock run; a second SIGTERM meanwhile is ignored."""
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        yield
        return

    def stop(signum, _frame):
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # cleaning up: a second SIGTERM must not cut it short
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


# ----------------------------------------------------------------------------- atomic outputs

def refuse_symlink(out: str | Path, what: str = "--out") -> None:
    """OutputError if ``out`` itself is a symbolic link: renaming a new output into place would replace the
    link, not what it points to."""
    out = Path(out)
    if out.is_symlink():
        target = os.readlink(out)
        raise OutputError(f"{what} {out} is a symbolic link to {target}: give the target directly or remove the "
                          f"link; nothing was written or changed")


@contextmanager
def atomic_file(path: str | Path) -> Iterator[Path]:
    """Yield a temporary sibling of ``path`` to write; it replaces ``path`` only on success.

    For a file inside an output (a command's ``--out`` itself, file or
    directory, goes through `atomic_output`, which also holds the lock and
    removes what stopped writers left). The temporary is
    ``.<name>.<host>-<pid>.<random>.partial``, removed on any error; one a
    killed process left inside a study directory is removed by the next run
    of the study (`sweep_stale_within`). An OSError while writing (full or
    read-only disk) becomes an `OutputError`; ``path`` is untouched.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = _temporary(path, directory=False)
    except OSError as exc:
        raise _unwritable(path, exc) from None
    try:
        yield tmp
        _put_file(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, NndaError):
            raise
        raise _unwritable(path, exc) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Swap ``a`` and ``b`` in one step (Linux ``renameat2`` with RENAME_EXCHANGE); False where unsupported."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _replace_directory(tmp: Path, out: Path) -> None:
    """Put the finished directory ``tmp`` at ``out`` (replacing an earlier one) and remove the earlier one."""
    if not os.path.lexists(out):
        tmp.rename(out)
        return
    if _exchange(tmp, out):
        old = tmp  # the earlier output now sits at the temporary's name
    else:  # two renames; a writer stopped between them leaves .old, which the next writer puts back
        old = out.with_name(tmp.name.removesuffix(".partial") + ".old")
        out.rename(old)
        try:
            tmp.rename(out)
        except OSError:
            old.rename(out)
            raise
    shutil.rmtree(old, ignore_errors=True)
    if old.exists():
        _warn(f"replaced {out}, but could not remove the earlier output at {old}; remove it by hand")


@contextmanager
def atomic_output(out: str | Path, overwrite: bool = False, *, directory: bool = True,
                  locked: bool = False) -> Iterator[Path]:
    """Write the output ``out`` of a command (a directory, or a file with ``directory`` false): yield a
    temporary sibling to fill; it takes the place of ``out`` only when the body succeeds.

    * A symbolic link at ``out`` is refused (`refuse_symlink`), as is an
      existing ``out`` without ``overwrite`` (FileExistsError) or of the
      other kind (a file where a directory goes, or the reverse).
    * The lock ``.<name>.lock`` is held meanwhile (`directory_lock`;
      ``locked``: the caller holds it already), and taking it removes the
      temporaries of writers that are gone (`sweep_stale`).
    * The temporary (``.<name>.<host>-<pid>.<random>.partial``) and the lock
      are removed on every exit this process controls: an error, Ctrl-C,
      SIGTERM. An earlier directory is swapped with the new one in one step
      where the file system can (Linux), so ``out`` is never missing.
    * An OSError while writing (full or read-only disk) becomes an
      `OutputError`; ``out`` is then untouched.
    """
    out = Path(out)

    def check() -> None:
        refuse_symlink(out, "output")
        if out.exists() and not overwrite:
            raise FileExistsError(f"{out}: already exists (pass overwrite to replace it)")
        if directory and out.exists() and not out.is_dir():
            raise OutputError(f"{out}: is a file, not a directory; refusing to replace it with one")
        if not directory and out.is_dir():
            raise OutputError(f"{out}: is a directory, not a file; refusing to replace it with one")

    check()
    with contextlib.ExitStack() as stack:
        if not locked:
            stack.enter_context(directory_lock(out))
            check()  # the sweep may have put back an output a stopped writer had moved aside
        stack.enter_context(_termination_unwinds())
        try:
            tmp = _temporary(out, directory)
        except OSError as exc:
            raise _unwritable(out, exc) from None
        try:
            yield tmp
            if directory:
                _replace_directory(tmp, out)
            else:
                _put_file(tmp, out)
        except OSError as exc:
            _remove(tmp)
            if isinstance(exc, NndaError):  # a nested write's error: name the output, not its temporary copy
                raise type(exc)(str(exc).replace(str(tmp), str(out))) from None
            raise _unwritable(out, exc) from None
        except BaseException:
            _remove(tmp)
            raise


def atomic_directory(out: str | Path, overwrite: bool = False):
    """`atomic_output` of a directory (the name earlier versions had)."""
    return atomic_output(out, overwrite)


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
    """Raise OutputError if ``out`` is a symbolic link (`refuse_symlink`), or is, contains or lies inside one of
    ``inputs`` (paths resolved)."""
    refuse_symlink(out, what)
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


def _create_lock(lock: Path, out: Path, content: str) -> bool:
    """Create ``lock`` holding ``content`` in one step (a hard link of a finished temporary, so no reader ever
    sees it empty); False if it exists."""
    fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.{_writer()}.", suffix=".partial", dir=lock.parent)
    try:
        with os.fdopen(fd, "w") as f:
            f.write(content)
        os.chmod(tmp, 0o644)
        try:
            os.link(tmp, lock)
        except FileExistsError:
            return False
        except OSError as exc:
            if exc.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EXDEV):
                raise
            try:  # a file system without hard links: create it exclusively, then write
                fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                return False
            with os.fdopen(fd, "w") as f:
                f.write(content)
        return True
    finally:
        Path(tmp).unlink(missing_ok=True)


@contextmanager
def directory_lock(out: str | Path) -> Iterator[Path]:
    """Hold a lock on output ``out`` (a sibling file ``.<name>.lock`` naming this host and pid) while the body
    writes it.

    A second writer is refused with an OutputError naming the holder; a lock
    left by a process that is gone (same host) is taken over, with a warning.
    Once it is held, the temporaries beside ``out`` of writers that are gone
    are removed (`sweep_stale`). The lock is removed on every exit this
    process controls, SIGTERM included.
    """
    out = Path(out)
    lock = out.with_name(f".{out.name}.lock")
    me = f"{socket.gethostname()} {os.getpid()}\n"
    with _termination_unwinds():
        try:
            lock.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise _unwritable(out, exc) from None
        for _ in range(3):
            try:
                if _create_lock(lock, out, me):
                    break
                holder = lock.read_text()
            except FileNotFoundError:
                continue  # released meanwhile: try again
            except OSError as exc:
                raise _unwritable(out, exc) from None
            host, _, pid = holder.strip().partition(" ")
            if host == socket.gethostname() and pid.isdigit() and not _alive(int(pid)):
                lock.unlink(missing_ok=True)  # its writer is gone: take it over
                _warn(f"removed the stale lock {lock} of nnda process {pid} on this host, which is gone")
                continue
            raise OutputError(f"{out}: another nnda process ({host} pid {pid}) is writing it; wait for it to "
                              f"finish, or remove {lock} if that process is gone")
        else:
            raise OutputError(f"{out}: could not take the lock {lock}; try again")
        try:
            sweep_stale(out)
            yield lock
        finally:
            try:
                if lock.read_text() == me:
                    lock.unlink()
            except FileNotFoundError:
                pass


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


def listed_file(directory: str | Path, name: Any, manifest: str | Path, what: str = "file",
                error: type[NndaError] = DatasetError) -> Path:
    """``directory / name`` for an entry ``name`` that ``manifest`` lists: a plain file or directory name
    (`path_component`: no absolute path, no separator, no '..' or leading dot) whose resolved path, symbolic
    links followed, lies inside ``directory``; ``error`` naming the manifest and the entry otherwise. A
    manifest only ever names the files beside it, so nothing it says can steer a read elsewhere."""
    directory = Path(directory)
    if not isinstance(name, str):
        raise error(f"{manifest}: lists the {what} {name!r}, which is not a file name; restore the manifest or "
                    f"regenerate its directory")
    try:
        path_component(name, "")
    except ConfigError:
        raise error(f"{manifest}: lists the {what} {name!r}, which is not a plain name in {directory} (absolute "
                    f"paths, '..', path separators and leading dots are refused: a manifest names files in its "
                    f"own directory only); restore the manifest or regenerate its directory") from None
    path = directory / name
    try:
        inside = path.resolve().is_relative_to(directory.resolve())
    except (OSError, RuntimeError):  # a symbolic-link loop
        inside = False
    if not inside:
        raise error(f"{manifest}: its {what} {name!r} is a symbolic link that leads outside {directory}; a "
                    f"manifest names files in its own directory only: replace the link by the file itself")
    return path
