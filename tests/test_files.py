"""Atomic writes under faults, digests, safe names, output paths and the writer lock (nnda.files)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from nnda.errors import ConfigError, DatasetError, OutputError
from nnda.files import (
    atomic_directory,
    atomic_file,
    check_output_path,
    directory_lock,
    file_digests,
    path_component,
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
