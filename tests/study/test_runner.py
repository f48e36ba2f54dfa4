"""The study runner: every job once, same data for every tracker, identical bytes whether run at once,
resumed after a kill, on local processes or on a Dask LocalCluster."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import pyarrow.parquet as pq
import pytest

from nnda.data.dataset import write_collection
from nnda.data.generator import generate
from nnda.data.scenario import load_scenario
from nnda.errors import ConfigError
from nnda.study.compare import compare
from nnda.study.config import load_study
from nnda.study.plan import plan_study
from nnda.study.runner import JobFailed, run_jobs

#: the files that must not depend on how or when the jobs ran (timing lives in timing.*)
DETERMINISTIC = ("results.parquet", "summary.json", "trajectories.parquet", "cardinality.parquet", "classifier.json")


def saved(out):
    return {name: (out / name).read_bytes() for name in DETERMINISTIC}


@pytest.fixture(scope="module")
def reference(tmp_path_factory, write_study):
    """The small study run in this process."""
    root = tmp_path_factory.mktemp("reference")
    study_file = write_study(root, runs=3)
    result = compare(load_study(study_file), root / "out", workers=1)
    return study_file, root / "out", result


def test_every_job_once_and_the_same_data_for_every_tracker(reference):
    _, out, result = reference
    assert (result.execution.jobs_run, result.execution.executor) == (12, "in-process")
    assert len(list((out / "jobs").rglob("run-*.json"))) == 12
    res = pq.read_table(out / "results.parquet").to_pydict()
    assert list(zip(res["scenario"], res["tracker"], res["run"]))[:4] == [
        ("one", "gnn", 0), ("one", "gnn", 1), ("one", "gnn", 2), ("one", "gnn-tight", 0)]
    digests = {}
    for s, r, d in zip(res["scenario"], res["run"], res["dataset_digest"]):
        digests.setdefault((s, r), set()).add(d)
    assert all(len(d) == 1 for d in digests.values())  # both trackers saw the same data
    assert len({d.pop() for d in digests.values()}) == 6  # and every run its own
    assert all(len(g) == 20 for g in res["gospa_per_scan"])
    summary = json.loads((out / "summary.json").read_text())
    gnn = summary["scenarios"][0]["trackers"]["gnn"]
    assert gnn["runs"] == 3 and gnn["metrics"]["hits"]["n"] == 3
    assert gnn["metrics"]["hits"]["mean"] == pytest.approx(np.mean(res["hits"][:3]))
    assert gnn["series_mean"]["gospa"] == pytest.approx(np.mean(res["gospa_per_scan"][:3], axis=0).tolist())
    assert "time_per_scan" not in (out / "summary.json").read_text()
    timing = pq.read_table(out / "timing.parquet").to_pydict()
    assert all(len(t) == 20 and min(t) > 0 for t in timing["time_per_scan_s"])
    tracks = pq.read_table(out / "trajectories.parquet").to_pydict()
    assert {(s, src) for s, src in zip(tracks["scenario"], tracks["source"])} >= {
        ("one", "truth"), ("one", "gnn"), ("two", "truth"), ("two", "gnn-tight")}


def test_datasets_on_disk_give_the_results_of_the_generated_runs(reference, tmp_path):
    study_file, out, _ = reference
    scenario = load_scenario(study_file.parent / "scenarios/one.toml")
    write_collection(((f"run-{r}", generate(scenario, 5, r)) for r in range(3)), tmp_path / "data", "three runs")
    (tmp_path / "disk.toml").write_text('seed = 5\n[trackers.gnn]\nkind = "gnn"\n'
                                        '[[scenarios]]\npath = "data"\nname = "one-disk"\n')
    compare(load_study(tmp_path / "disk.toml"), tmp_path / "out", workers=1)
    disk = pq.read_table(tmp_path / "out/results.parquet").to_pydict()
    ref = pq.read_table(out / "results.parquet").to_pydict()
    assert disk["scenario"] == ["one-disk"] * 3
    for column in ("dataset_digest", "hits", "losses", "gospa", "gospa_per_scan"):
        assert disk[column] == ref[column][:3]


def test_local_processes_give_identical_bytes(reference, tmp_path):
    study_file, out, _ = reference
    result = compare(load_study(study_file), tmp_path / "out", workers=2)
    assert result.execution.executor == "local processes"
    assert saved(tmp_path / "out") == saved(out)


def test_dask_local_cluster_gives_identical_bytes(reference, tmp_path):
    pytest.importorskip("dask.distributed", reason="dask is not installed (pip install 'nnda[dask]')")
    study_file, out, _ = reference
    result = compare(load_study(study_file), tmp_path / "out", workers=2, dask="local")
    assert result.execution.executor == "dask local"
    assert saved(tmp_path / "out") == saved(out)


def test_resume_after_a_killed_study_gives_the_uninterrupted_results(tmp_path, write_study):
    study_file = write_study(tmp_path, runs=12, duration=60, clutter=40)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "nnda", "compare", "--study", str(study_file), "--out", str(out),
                             "--jobs", "1"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while not any((out / "jobs").rglob("run-*.json")) and time.monotonic() < deadline:
        time.sleep(0.005)
    proc.kill()
    assert proc.wait(timeout=30) < 0, "the study finished before it could be killed"
    done = len(list((out / "jobs").rglob("run-*.json")))
    assert 0 < done < 48 and not (out / "summary.json").exists()

    with pytest.raises(FileExistsError, match="pass --resume"):
        compare(load_study(study_file), out)
    resumed = compare(load_study(study_file), out, resume=True, workers=2)
    assert (resumed.execution.jobs_skipped, resumed.execution.jobs_run) == (done, 48 - done)
    assert not list(out.rglob("*.partial"))
    compare(load_study(study_file), tmp_path / "uninterrupted", workers=2)
    assert saved(out) == saved(tmp_path / "uninterrupted")


def test_resume_of_a_changed_study_reruns_only_what_changed_and_overwrite_replaces_it(reference, tmp_path):
    study_file, _, _ = reference
    out = tmp_path / "out"
    compare(load_study(study_file), out, workers=1)
    changed = study_file.parent / "changed.toml"
    changed.write_text(study_file.read_text().replace("gate = 6.0", "gate = 7.0"))
    resumed = compare(load_study(changed), out, resume=True, workers=1)
    assert (resumed.execution.jobs_run, resumed.execution.jobs_skipped) == (6, 6)  # gnn-tight's jobs only
    fresh = compare(load_study(changed), tmp_path / "fresh", workers=1)
    assert saved(out) == saved(tmp_path / "fresh") and fresh.summary == resumed.summary
    again = compare(load_study(changed), out, overwrite=True, workers=1)
    assert again.execution.jobs_run == 12
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine/notes.txt").write_text("keep me")
    with pytest.raises(Exception, match="not a study directory"):
        compare(load_study(study_file), tmp_path / "mine", overwrite=True, workers=1)
    assert (tmp_path / "mine/notes.txt").exists()


@pytest.mark.parametrize("workers", [1, 2])
def test_a_failing_job_is_named_and_the_finished_ones_are_kept(tmp_path, write_study, workers):
    write_study(tmp_path)
    scenario = load_scenario(tmp_path / "scenarios/one.toml")
    write_collection(((f"run-{r}", generate(scenario, 1, r)) for r in range(2)), tmp_path / "data", "two runs")
    (tmp_path / "s.toml").write_text('[trackers.gnn]\nkind = "gnn"\n[[scenarios]]\npath = "data"\n')
    plan = plan_study(load_study(tmp_path / "s.toml"))
    (tmp_path / "data/run-1/detections.parquet").write_bytes(b"not parquet")  # damaged after the checks
    with pytest.raises(JobFailed, match=r"jobs/one/gnn/run-0001.json \(gnn on one run 1\) failed: DatasetError"):
        run_jobs(plan, tmp_path / "out", workers=workers)
    assert [p.name for p in (tmp_path / "out/jobs/one/gnn").iterdir()] == ["run-0000.json"]



def test_dask_without_the_extra_names_it(reference, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # as if nnda[dask] were not installed
    study_file, _, _ = reference
    with pytest.raises(ConfigError, match=r"--dask needs the optional extra nnda\[dask\]: pip install 'nnda\[dask\]'"):
        compare(load_study(study_file), tmp_path / "out", dask="local")
    assert not (tmp_path / "out").exists()
