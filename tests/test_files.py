"""Atomic writes under faults, digests, safe names, output paths and the writer lock (nnda.files)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from nnda.errors import ConfigError, DatasetError, OutputError
from nnda.files import (
    _host,
    atomic_directory,
    atomic_file,
    atomic_output,
    check_output_path,
    directory_lock,
    file_digests,
    path_component,
    sweep_stale,
    sweep_stale_within,
    verify_digests,
)


def _listing(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def test_a_full_disk_is_an_output_error_and_leaves_nothing(small_disk):
    (small_disk / "kept.txt").write_text("old")
    with pytest.raises(OutputError, match=r"big\.bin: cannot write \(No space left on device\)"):
        with atomic_file(small_disk / "big.bin") as tmp:
            tmp.write_bytes(b"x" * 2_000_000)
    with pytest.raises(OutputError, match="cannot write"):
        with atomic_directory(small_disk / "out") as tmp:
            (tmp / "data.bin").write_bytes(b"x" * 2_000_000)
    assert _listing(small_disk) == ["kept.txt"] and (small_disk / "kept.txt").read_text() == "old"


def test_a_read_only_disk_is_an_output_error(small_disk):
    (small_disk / "out").mkdir()
    subprocess.run(["mount", "-o", "remount,ro", str(small_disk)], check=True)
    with pytest.raises(OutputError, match="Read-only file system"):
        with atomic_file(small_disk / "out" / "a.json") as tmp:
            tmp.write_text("{}")
    with pytest.raises(OutputError, match="Read-only file system"):
        with atomic_directory(small_disk / "new"):
            pass
    with pytest.raises(OutputError, match="Read-only file system"):
        with directory_lock(small_disk / "out"):
            pass
    assert _listing(small_disk) == ["out"]


def test_a_directory_never_replaces_a_file(tmp_path):
    (tmp_path / "out").write_text("mine")
    with pytest.raises(OutputError, match="is a file, not a directory"):
        with atomic_directory(tmp_path / "out", overwrite=True) as tmp:
            (tmp / "x").write_text("x")
    assert _listing(tmp_path) == ["out"] and (tmp_path / "out").read_text() == "mine"


def test_digests_catch_a_flipped_byte(tmp_path):
    (tmp_path / "a.bin").write_bytes(bytes(range(256)) * 4)
    recorded = file_digests(tmp_path, ["a.bin"])
    verify_digests(tmp_path, recorded)
    data = bytearray((tmp_path / "a.bin").read_bytes())
    data[700] ^= 0x01
    (tmp_path / "a.bin").write_bytes(bytes(data))
    with pytest.raises(DatasetError, match=r"a\.bin: corrupt file: its SHA-256 is"):
        verify_digests(tmp_path, recorded)
    with pytest.raises(DatasetError, match=r"b\.bin: missing \(the manifest lists it\)"):
        verify_digests(tmp_path, {"b.bin": "0" * 64})


@pytest.mark.parametrize("name", ["..", ".", "", "a/b", "..\\up", ".hidden", "nul\0byte"])
def test_unsafe_names_are_refused(name):
    with pytest.raises(ConfigError, match="tracker label: .* cannot name a file"):
        path_component(name, "tracker label")


@pytest.mark.parametrize("name", ["S1", "nn-seed", "my.run_2", "Ω"])
def test_ordinary_names_pass(name):
    assert path_component(name, "tracker label") == name


def test_an_output_may_not_be_contain_or_sit_inside_an_input(tmp_path):
    data = tmp_path / "data"
    (data / "train").mkdir(parents=True)
    for out, relation in ((data, "is"), (tmp_path, "contains"), (data / "train" / "models", "lies inside")):
        with pytest.raises(OutputError, match=f"{relation} the input"):
            check_output_path(out, [data / "train"] if relation == "lies inside" else [data])
    check_output_path(tmp_path / "models", [data])  # a sibling is fine


def test_the_lock_refuses_a_second_writer_and_takes_over_a_stale_one(tmp_path):
    out = tmp_path / "study"
    with directory_lock(out) as lock:
        assert lock.exists()
        code = ("import sys; from nnda.files import directory_lock\n"
                "try:\n    directory_lock(sys.argv[1]).__enter__()\nexcept Exception as e:\n    print(e); sys.exit(3)")
        other = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True)
        assert other.returncode == 3 and "another nnda process" in other.stdout
    assert not lock.exists()
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    lock.write_text(f"{socket.gethostname()} {gone.stdout.strip()}\n")  # left by a process that has ended
    with directory_lock(out):
        assert lock.read_text().split()[1] == str(os.getpid())
    assert not lock.exists()


# ----------------------------------------------------------------------------- what a stopped writer leaves

def _dead_pid() -> int:
    """The pid of a process that has ended."""
    return int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                              text=True, check=True).stdout)


@pytest.fixture
def live_pid():
    """The pid of a sleeping child process (alive for the test)."""
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    yield child.pid
    child.kill()
    child.wait()


def test_a_dead_writers_temporary_is_removed_and_a_live_writers_kept(tmp_path, live_pid, capsys):
    out, host, dead = tmp_path / "out", _host(), _dead_pid()
    stale = tmp_path / f".out.{host}-{dead}.abcd1234.partial"
    (stale / "sub").mkdir(parents=True)
    (stale / "sub" / "tracks.parquet").write_bytes(b"half")
    kept = [tmp_path / f".out.{host}-{live_pid}.efgh5678.partial",     # a live writer's
            tmp_path / f".out.elsewhere-{dead}.ijkl9012.partial",       # another host's: its pid means nothing here
            tmp_path / f".other.{host}-{dead}.mnop3456.partial",        # another output's
            tmp_path / "out.partial"]                                   # not nnda's
    for path in kept:
        path.write_text("x")
    with atomic_output(out) as tmp:
        assert tmp.name.startswith(f".out.{host}-{os.getpid()}.") and tmp.name.endswith(".partial")
        (tmp / "a.txt").write_text("new")
    assert not stale.exists() and all(p.exists() for p in kept)
    assert (out / "a.txt").read_text() == "new" and not (tmp_path / ".out.lock").exists()
    err = capsys.readouterr().err
    assert err.count("warning: ") == 1 and stale.name in err and "gone" in err, err
    assert sweep_stale(out) == [] and capsys.readouterr().err == ""  # said once


def test_a_stale_lock_is_taken_over_with_a_warning(tmp_path, capsys):
    (tmp_path / ".out.lock").write_text(f"{socket.gethostname()} {_dead_pid()}\n")
    with atomic_output(tmp_path / "out", directory=False) as tmp:
        tmp.write_text("one file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"] and (tmp_path / "out").read_text() == "one file"
    assert "removed the stale lock" in capsys.readouterr().err


def test_an_output_a_dead_writer_had_moved_aside_is_put_back(tmp_path, capsys):
    aside = tmp_path / f".out.{_host()}-{_dead_pid()}.abcd1234.old"
    aside.mkdir()
    (aside / "a.txt").write_text("earlier")
    sweep_stale(tmp_path / "out")
    assert _listing(tmp_path) == ["out", "out/a.txt"] and (tmp_path / "out" / "a.txt").read_text() == "earlier"
    assert "restored" in capsys.readouterr().err


def test_a_study_keeps_its_records_and_loses_dead_writers_temporaries(tmp_path, live_pid):
    host, dead = _host(), _dead_pid()
    (tmp_path / "jobs" / "track").mkdir(parents=True)
    records = [tmp_path / "study.json", tmp_path / "jobs" / "track" / "a.json"]
    live = tmp_path / "jobs" / "track" / f".b.json.{host}-{live_pid}.efgh5678.partial"
    for path in (*records, live):
        path.write_text("{}")
    stale = [tmp_path / "jobs" / "track" / f".c.json.{host}-{dead}.abcd1234.partial",
             tmp_path / f".report.md.{host}-{dead}.ijkl9012.partial"]
    for path in stale:
        path.write_text("half")
    assert sorted(sweep_stale_within(tmp_path)) == sorted(stale)
    assert all(p.exists() for p in (*records, live)) and not any(p.exists() for p in stale)


def test_a_replaced_directory_leaves_nothing_beside_it(tmp_path):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "old.txt").write_text("old")
    with atomic_directory(tmp_path / "out", overwrite=True) as tmp:
        (tmp / "new.txt").write_text("new")
    assert _listing(tmp_path) == ["out", "out/new.txt"]


def test_an_error_or_sigterm_leaves_neither_temporary_nor_lock(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with atomic_output(tmp_path / "out") as tmp:
            (tmp / "a.txt").write_text("half")
            raise KeyboardInterrupt
    assert _listing(tmp_path) == []
    code = ("import os, signal, sys, time; from nnda.files import atomic_output\n"
            "with atomic_output(sys.argv[1]) as tmp:\n"
            "    (tmp / 'a.txt').write_text('half'); os.kill(os.getpid(), signal.SIGTERM); time.sleep(30)")
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "out")], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert _listing(tmp_path) == []


def test_what_a_killed_writer_left_goes_with_the_next_write(tmp_path, capsys):
    code = ("import sys, time; from nnda.files import atomic_output\n"
            "with atomic_output(sys.argv[1]) as tmp:\n"
            "    (tmp / 'a.txt').write_text('half'); print('writing', flush=True); time.sleep(60)")
    child = subprocess.Popen([sys.executable, "-c", code, str(tmp_path / "out")], stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline() == "writing\n"
    child.send_signal(signal.SIGKILL)
    child.wait()
    child.stdout.close()
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == [".out.lock", *[n for n in left if n.startswith(f".out.{_host()}-{child.pid}.")]] and len(left) == 2
    with atomic_output(tmp_path / "out") as tmp:
        (tmp / "a.txt").write_text("whole")
    assert _listing(tmp_path) == ["out", "out/a.txt"] and (tmp_path / "out" / "a.txt").read_text() == "whole"
    err = capsys.readouterr().err
    assert err.count("warning: ") == 2 and "stale lock" in err and left[1] in err, err


def test_a_symbolic_link_at_an_output_is_refused(tmp_path):
    (tmp_path / "earlier").mkdir()
    (tmp_path / "link").symlink_to("earlier")
    with pytest.raises(OutputError, match="--out .*link is a symbolic link to earlier: give the target directly"):
        check_output_path(tmp_path / "link", [])
    with pytest.raises(OutputError, match="link is a symbolic link to earlier"):
        with atomic_output(tmp_path / "link", overwrite=True):
            pass
    assert (tmp_path / "link").is_symlink() and _listing(tmp_path) == ["earlier", "link"]
