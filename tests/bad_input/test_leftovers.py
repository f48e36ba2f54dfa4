"""Nothing is left behind after a kill: every command that writes ``--out``, killed with SIGKILL at a random time
and run again to completion, leaves ``--out`` whole and nothing else beside it (no ``*.partial``, no lock, no
``.old``); a symbolic link at ``--out`` is refused with a true message, nothing changed.

Each try starts the command as a real process (``python -m nnda ... --overwrite``) on inputs that keep it busy
for a few seconds, kills its process group at a seeded random time between 0.3 s and its typical run time,
checks what the kill left (``--out`` absent or whole, for the commands that write it atomically), reruns it in
this process (`nnda.app.cli.main`, as ``nnda`` runs it) and checks the directory again. The default suite makes
2 tries per command; the slow variant 20, and prints the tallies.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from cli_run import Outcome, assert_one_line_error

from dataset_edits import snapshot
from nnda.data.dataset import iter_datasets, read_dataset, write_dataset
from nnda.data.detections_import import export_detections
from nnda.data.generator import generate
from nnda.data.scenario import scenario_from_dict
from nnda.models.scorer import load_model
from nnda.study.checksums import read_checked

#: two targets and 40 clutter points a scan over 200 s (100 scans): about 4,000 detections
SCENE_TOML = """name = "scene"
duration_s = 200
seed = 2
[clutter]
count = 40
[[targets]]
name = "a"
x_m = 0
y_m = 12000
heading_deg = 90
speed_m_s = 100
segments = [{duration_s = 200}]
[[targets]]
name = "b"
x_m = 5000
y_m = 15000
heading_deg = 180
speed_m_s = 80
segments = [{duration_s = 200}]
"""

STUDY_TOML = """name = "leftovers"
seed = 0
runs = 3
[trackers.gnn]
kind = "gnn"
[trackers.jpda]
kind = "jpda"
[[scenarios]]
config = "scene.toml"
"""

#: the re-entry study's table, tiny: 4 runs of 30 steps, 300 particles
REENTRY_TOML = """runs = 4
steps = 30
[[settings]]
name = "paper"
sigma_r = 200.0
sigma_eps = 0.017
particles = [300]
"""


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    """The inputs of every command, in their own directory: scene.toml, busy.toml (300 clutter points a scan),
    the dataset ``ds``, the exported detections det.csv and truth.csv (about 100,000 rows), study.toml and
    reentry.toml."""
    root = tmp_path_factory.mktemp("inputs")
    (root / "scene.toml").write_text(SCENE_TOML)
    (root / "busy.toml").write_text(SCENE_TOML.replace("count = 40", "count = 300"))
    (root / "study.toml").write_text(STUDY_TOML)
    (root / "reentry.toml").write_text(REENTRY_TOML)
    scene = scenario_from_dict({"name": "scene", "duration_s": 200, "seed": 2, "clutter": {"count": 40},
                                "targets": [{"name": "a", "x_m": 0, "y_m": 12000, "heading_deg": 90,
                                             "speed_m_s": 100, "segments": [{"duration_s": 200}]}]})
    write_dataset(generate(scene), root / "ds")
    busy = scenario_from_dict({"name": "busy", "duration_s": 1000, "seed": 3, "clutter": {"count": 200},
                               "targets": [{"name": "a", "x_m": -10000, "y_m": 12000, "heading_deg": 90,
                                            "speed_m_s": 20, "segments": [{"duration_s": 1000}]}]})
    export_detections(generate(busy), root / "det.csv", truth=root / "truth.csv")
    return root


def _tracks_whole(out: Path) -> None:
    pq.read_table(out / "tracks.parquet")
    assert "metrics" in json.loads((out / "scores.json").read_text())
    assert (out / "tracks.png").stat().st_size and (out / "tracks.html").stat().st_size


def _datasets_whole(out: Path) -> None:
    assert len(list(iter_datasets(out))) == 40


def _study_whole(out: Path) -> None:
    for name in json.loads((out / "checksums.json").read_text())["sha256"]:
        read_checked(out, name)
    assert (out / "report.html").is_file() and (out / "report.md").is_file()


@dataclass(frozen=True)
class Command:
    """A command writing ``out`` from the inputs, how long it typically runs (s, a new process on a 2-core
    machine), whether it writes ``out`` atomically (a study writes its directory as it goes, for --resume), and
    the check that ``out`` is whole (raises if not)."""

    args: Callable[[Path], list[str]]
    typical_s: float
    atomic: bool
    whole: Callable[[Path], None]


COMMANDS = {
    "track": Command(lambda i: ["track", i / "ds", "--tracker", "jpda", "--quiet"], 3.5, True, _tracks_whole),
    "generate": Command(lambda i: ["generate", "--config", i / "busy.toml", "--runs", "40"], 3.5, True,
                        _datasets_whole),
    "import-detections": Command(lambda i: ["import-detections", i / "det.csv", "--truth", i / "truth.csv",
                                            "--sensor", "scan_period_s=2"], 3.0, True, read_dataset),
    "train": Command(lambda i: ["train", "--data", i / "ds", "--method", "gd"], 6.5, True, load_model),
    "run": Command(lambda i: ["run", "--study", i / "study.toml", "--jobs", "1"], 4.5, False, _study_whole),
    "reentry": Command(lambda i: ["reentry", "--config", i / "reentry.toml", "--jobs", "1"], 4.0, False,
                       _study_whole),
}


def _leftovers(work: Path) -> list[str]:
    """What is in ``work`` besides ``out``, and nnda's temporaries or locks inside ``out``."""
    beside = sorted(p.name for p in work.iterdir() if p.name != "out")
    inside = sorted(str(p.relative_to(work)) for p in (work / "out").rglob("*")
                    if p.name.endswith((".partial", ".lock", ".old"))) if (work / "out").is_dir() else []
    return beside + inside


def _damaged(command: Command, out: Path) -> str | None:
    try:
        command.whole(out)
    except Exception as exc:  # any failure to read it back is damage
        return f"{type(exc).__name__}: {exc}"
    return None


def _kill_and_rerun(name: str, tries: int, inputs: Path, work_root: Path, nnda) -> dict:
    """``tries`` kills of ``name`` (each followed by a rerun) in one working directory; the tallies."""
    command = COMMANDS[name]
    work = work_root / name
    work.mkdir()
    args = [*map(str, command.args(inputs)), "--out", "out", "--overwrite"]
    tally = {"tries": 0, "killed": 0, "left_by_kill": 0, "leftovers_after_rerun": 0, "damaged": 0,
             "problems": []}
    for attempt in range(tries):
        wait = random.Random(f"{name}:{attempt}").uniform(0.3, command.typical_s)
        process = subprocess.Popen([sys.executable, "-m", "nnda", *args], cwd=work, start_new_session=True,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(wait)
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)  # the command and anything it started
            tally["killed"] += 1
        process.wait(timeout=60)
        tally["tries"] += 1
        left = [p for p in _leftovers(work) if p != "out"]
        tally["left_by_kill"] += bool(left)
        if command.atomic and (work / "out").exists():
            if (problem := _damaged(command, work / "out")) is not None:
                tally["damaged"] += 1
                tally["problems"].append(f"try {attempt}, killed at {wait:.2f} s: {problem}")
        outcome = nnda(*args, cwd=work)
        assert outcome.code == 0, (name, attempt, outcome.err)
        if after := _leftovers(work):
            tally["leftovers_after_rerun"] += 1
            tally["problems"].append(f"try {attempt}, killed at {wait:.2f} s: left {after}")
        if (problem := _damaged(command, work / "out")) is not None:
            tally["damaged"] += 1
            tally["problems"].append(f"try {attempt}, after the rerun: {problem}")
    return tally


@pytest.mark.parametrize("name", list(COMMANDS))
def test_a_killed_command_leaves_nothing_after_a_rerun(name, inputs, tmp_path, nnda):
    tally = _kill_and_rerun(name, 2, inputs, tmp_path, nnda)
    assert tally["leftovers_after_rerun"] == 0 and tally["damaged"] == 0, tally["problems"]


@pytest.mark.slow
@pytest.mark.parametrize("name", list(COMMANDS))
def test_twenty_kills_leave_nothing_after_a_rerun(name, inputs, tmp_path, nnda, capsys):
    tally = _kill_and_rerun(name, 20, inputs, tmp_path, nnda)
    with capsys.disabled():
        print(f"\n{name}: " + ", ".join(f"{k} {v}" for k, v in tally.items() if k != "problems"))
    assert tally["leftovers_after_rerun"] == 0 and tally["damaged"] == 0, tally["problems"]


# ----------------------------------------------------------------------------- a symbolic link at --out

@pytest.mark.parametrize("write", ["track", "import-detections"])
def test_a_symlinked_out_is_refused_and_nothing_changes(write, inputs, tmp_path, nnda, refused):
    args = COMMANDS[write].args(inputs)
    assert nnda(*args, "--out", "earlier", cwd=tmp_path).code == 0
    (tmp_path / "link").symlink_to("earlier")
    for more in ((), ("--overwrite",)):
        outcome = refused(tmp_path, *args, "--out", "link", *more,
                          fragments=("--out link is a symbolic link to earlier: give the target directly or "
                                     "remove the link",))
        assert "nothing was written or changed" in outcome.err
    assert (tmp_path / "link").is_symlink() and sorted(p.name for p in tmp_path.iterdir()) == ["earlier", "link"]


def test_a_dangling_symlinked_out_is_refused(inputs, tmp_path, nnda):
    (tmp_path / "link").symlink_to("nowhere")
    assert_one_line_error(nnda(*COMMANDS["track"].args(inputs), "--out", "link", cwd=tmp_path),
                          "--out link is a symbolic link to nowhere")
    assert [p.name for p in tmp_path.iterdir()] == ["link"] and os.readlink(tmp_path / "link") == "nowhere"


def test_a_symlinked_out_is_refused_in_a_new_process(inputs, tmp_path):
    (tmp_path / "earlier").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "earlier")
    before = snapshot(tmp_path)
    done = subprocess.run([sys.executable, "-m", "nnda", *map(str, COMMANDS["import-detections"].args(inputs)),
                           "--out", "link", "--overwrite"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert_one_line_error(Outcome(done.returncode, done.stdout, done.stderr),
                          f"--out link is a symbolic link to {tmp_path / 'earlier'}")
    assert snapshot(tmp_path) == before
