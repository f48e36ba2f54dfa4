"""Full and read-only disks under `nnda generate`, `nnda train`, `nnda evaluate`, `nnda plot-scenario` and
`nnda import-stonesoup`: an OutputError naming the output and the cause, no traceback, nothing left on the
disk, and an existing output untouched.

The disk is a 1 MiB tmpfs (`small_disk`, root only; skipped otherwise), filled
up to a few KiB by a filler file, or remounted read-only.
"""

from __future__ import annotations

import os
import shutil
import subprocess

import numpy as np
import pytest
from cli_run import TINY_TOML, assert_one_line_error, nnda_process

from dataset_edits import snapshot
from nnda.data.dataset import write_dataset
from nnda.data.generator import generate
from nnda.data.presets import preset
from nnda.models.mlp import MLPWeights, n_weights
from nnda.models.preprocessing import Normaliser
from nnda.models.scorer import Scorer, save_model

FULL = "No space left on device"
READ_ONLY = "Read-only file system"


def fill(disk, leave: int) -> None:
    """Fill ``disk`` with a file ``filler`` until about ``leave`` bytes are free."""
    st = os.statvfs(disk)
    (disk / "filler").write_bytes(b"\0" * max(0, st.f_bavail * st.f_frsize - leave))


def read_only(disk) -> None:
    subprocess.run(["mount", "-o", "remount,ro", str(disk)], check=True)


@pytest.fixture(scope="module")
def train01(tmp_path_factory):
    return write_dataset(generate(preset("train01"), seed=0), tmp_path_factory.mktemp("train01") / "ds")


@pytest.fixture
def root(tmp_path, small_disk, train01):
    """``tmp_path`` with the scenario ``tiny.toml``, the dataset ``ds`` (train01), the model ``m`` and the small
    disk at ``disk``."""
    (tmp_path / "tiny.toml").write_text(TINY_TOML)
    shutil.copytree(train01, tmp_path / "ds")
    weights = MLPWeights.from_vector(np.linspace(-1, 1, n_weights(3, 2)), 3, 2)
    save_model(Scorer(weights, Normaliser(np.array([90.0, 0.1, 4.0]), np.array([100.0, 28.0, 2.4]))),
               tmp_path / "m" / "model.json")
    return tmp_path


def _refused_on_disk(nnda, root, args, *fragments) -> None:
    before, disk_before = snapshot(root / "ds"), snapshot(root / "disk")
    outcome = nnda(*args, cwd=root)
    assert_one_line_error(outcome, *fragments)
    assert snapshot(root / "disk") == disk_before  # no temporary left, nothing changed
    assert snapshot(root / "ds") == before


@pytest.mark.parametrize("args, leave", [
    (("generate", "--preset", "S1", "--out", "disk/S1"), 64 << 10),  # about 0.4 MB of Parquet
    (("generate", "--config", "tiny.toml", "--runs", "40", "--out", "disk/mc"), 64 << 10),
    (("plot-scenario", "ds", "--out", "disk/s.png"), 16 << 10),
    (("train", "--data", "ds", "--hidden", "2", "--out", "disk/lm"), 16 << 10),
    (("evaluate", "m", "--data", "ds", "--out", "disk/ev"), 8 << 10),
])
def test_a_full_disk_is_an_output_error_and_leaves_nothing(root, nnda, args, leave):
    fill(root / "disk", leave)
    _refused_on_disk(nnda, root, args, f"{args[-1]}: cannot write (", FULL)


def test_a_full_disk_keeps_the_dataset_it_was_to_replace(root, nnda):
    assert nnda("generate", "--config", "tiny.toml", "--out", "disk/d", cwd=root).code == 0
    fill(root / "disk", 16 << 10)
    _refused_on_disk(nnda, root, ("generate", "--preset", "S1", "--out", "disk/d", "--overwrite"),
                     "disk/d: cannot write (", FULL)


def test_a_full_disk_keeps_the_plot_it_was_to_replace(root, nnda):
    (root / "disk" / "s.png").write_bytes(b"old picture")
    fill(root / "disk", 16 << 10)
    _refused_on_disk(nnda, root, ("plot-scenario", "ds", "--out", "disk/s.png", "--overwrite"),
                     "disk/s.png: cannot write (", FULL)


@pytest.mark.parametrize("args", [
    ("generate", "--config", "tiny.toml", "--out", "disk/d"),
    ("generate", "--config", "tiny.toml", "--out", "disk/old", "--overwrite"),
    ("generate", "--config", "tiny.toml", "--runs", "2", "--out", "disk/mc"),
    ("plot-scenario", "ds", "--out", "disk/s.png"),
    ("train", "--data", "ds", "--out", "disk/lm"),
    ("train", "--data", "ds", "--ablation", "--repeats", "2", "--out", "disk/abl"),
    ("evaluate", "m", "--data", "ds", "--out", "disk/ev"),
    ("import-stonesoup", "--scans", "3", "--out", "disk/ss"),
])
def test_a_read_only_disk_is_an_output_error_before_any_work(root, nnda, args):
    (root / "disk" / "old").mkdir()
    (root / "disk" / "old" / "kept.txt").write_text("mine")
    read_only(root / "disk")
    _refused_on_disk(nnda, root, args, f"{args[args.index('--out') + 1]}: cannot write ({READ_ONLY})")


def test_a_read_only_disk_as_a_user_meets_it(root):
    read_only(root / "disk")
    outcome = nnda_process("generate", "--config", "tiny.toml", "--out", "disk/d", cwd=root)
    assert_one_line_error(outcome, f"disk/d: cannot write ({READ_ONLY})")
    assert snapshot(root / "disk") == {}
