"""Bad studies and faults around a study directory: each a clear error naming what and where (exit code 2
from the command line), nothing left behind, no existing output changed."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from nnda.data.dataset import write_dataset
from nnda.data.generator import generate
from nnda.data.scenario import load_scenario
from nnda.errors import ConfigError, OutputError
from nnda.files import directory_lock
from nnda.study.compare import compare
from nnda.study.config import load_study
from nnda.study.plan import plan_study

SCENARIO = """name = "{name}"
duration_s = 12
seed = 3
[clutter]
count = 5
[[targets]]
name = "a"
x_m = -10000
y_m = 10000
heading_deg = 90
speed_m_s = 100
segments = [{{duration_s = 12}}]
"""
STUDY = """name = "tiny"
runs = 2
[trackers.gnn]
kind = "gnn"
[[scenarios]]
config = "one.toml"
"""


def _tiny(root: Path, study: str = STUDY, name: str = "one") -> Path:
    root.mkdir(parents=True, exist_ok=True)
    (root / "one.toml").write_text(SCENARIO.format(name=name))
    (root / "study.toml").write_text(study)
    return root / "study.toml"


def _snapshot(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` (hidden ones included) with its bytes."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _nnda(*args, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nnda", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=300)


@pytest.mark.parametrize("study, message", [
    (STUDY.replace("[trackers.gnn]", '[trackers.".."]'),
     r"study\.toml: invalid study.*trackers\.\.\.\.\[key\]: String should match pattern"),
    (STUDY.replace("[trackers.gnn]", '[trackers."a/b"]'),
     r"study\.toml: invalid study.*trackers\.a/b\.\[key\]: String should match pattern"),
])
def test_labels_that_would_escape_the_study_directory_are_refused(tmp_path, study, message):
    with pytest.raises(ConfigError, match=re.compile(message, re.S)):
        load_study(_tiny(tmp_path, study))


def test_a_scenario_named_dot_dot_cannot_name_a_job_directory(tmp_path):
    with pytest.raises(ConfigError, match=r"scenario name: '\.\.' cannot name a file"):
        plan_study(load_study(_tiny(tmp_path, name="..")))


@pytest.mark.parametrize("out", [".", "one.toml", "sub/../one.toml"])
def test_the_output_may_not_be_an_input(tmp_path, out):
    study_file = _tiny(tmp_path)
    before = _snapshot(tmp_path)
    done = _nnda("compare", "--study", study_file, "--out", out, cwd=tmp_path)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "--out" in done.stderr and "the input" in done.stderr
    assert _snapshot(tmp_path) == before


def test_a_second_writer_is_refused(tmp_path):
    study_file = _tiny(tmp_path)
    with directory_lock(tmp_path / "out"):
        with pytest.raises(OutputError, match=r"out: another nnda process .* is writing it"):
            compare(load_study(study_file), tmp_path / "out", workers=1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.toml", "study.toml"]


def test_an_edited_job_file_is_run_again_on_resume(tmp_path):
    study_file = _tiny(tmp_path)
    compare(load_study(study_file), tmp_path / "out", workers=1)
    summary = (tmp_path / "out" / "summary.json").read_bytes()
    job = tmp_path / "out" / "jobs" / "one" / "gnn" / "run-0001.json"
    record = json.loads(job.read_text())
    record["metrics"]["hits"] = 10_000  # a hand-edited metric must not reach the summary
    job.write_text(json.dumps(record))
    resumed = compare(load_study(study_file), tmp_path / "out", resume=True, workers=1)
    assert resumed.execution.jobs_run == 1
    assert (tmp_path / "out" / "summary.json").read_bytes() == summary


def test_overwrite_with_a_failing_study_leaves_the_earlier_one_whole(tmp_path):
    study_file = _tiny(tmp_path)
    compare(load_study(study_file), tmp_path / "out", workers=1)
    before = _snapshot(tmp_path / "out")
    data = tmp_path / "data"
    (tmp_path / "bad.toml").write_text(STUDY.replace('config = "one.toml"', 'path = "data"'))
    write_dataset(generate(load_scenario(tmp_path / "one.toml"), 1), data)
    plan_ok = load_study(tmp_path / "bad.toml")
    (data / "detections.parquet").write_bytes(b"damaged after the checks")
    with pytest.raises(Exception, match="run-0000|detections"):
        compare(plan_ok, tmp_path / "out", overwrite=True, workers=1)
    assert _snapshot(tmp_path / "out") == before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no partial directory, no lock


def test_results_do_not_depend_on_where_the_study_lives(tmp_path):
    for place in ("a", "b/deeper"):
        compare(load_study(_tiny(tmp_path / place)), tmp_path / place / "out", workers=1)
    for name in ("summary.json", "results.parquet", "trajectories.parquet"):
        assert (tmp_path / "a/out" / name).read_bytes() == (tmp_path / "b/deeper/out" / name).read_bytes(), name
    source = json.loads((tmp_path / "a/out/summary.json").read_text())["scenarios"][0]["source"]
    assert source == "config one.toml"


def test_a_scenario_generation_would_refuse_fails_at_planning(tmp_path):
    study_file = _tiny(tmp_path)
    text = (tmp_path / "one.toml").read_text().replace("count = 5", "count = 5\ncentre_m = [500000.0, 0.0]")
    (tmp_path / "one.toml").write_text(text)  # the clutter square lies far outside the radar's coverage
    with pytest.raises(ConfigError, match=r"scenario 'one': .*clutter"):
        plan_study(load_study(study_file))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.toml", "study.toml"]
